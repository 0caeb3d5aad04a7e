//! `imitate bench movingai` on the real MovingAI benchmark files in ../shared/data.

mod common;

use std::path::PathBuf;

use common::*;

fn data() -> Option<PathBuf> {
    shared_data("movingai")
}

fn report(args: &[&str]) -> serde_json::Value {
    let out = imitate(&repo(), args);
    assert!(out.status.success(), "{}", stderr(&out));
    serde_json::from_str(&stdout(&out)).unwrap()
}

#[test]
fn every_arena_scenario_matches_its_optimal_length() {
    let Some(dir) = data() else { return };
    for planner in ["astar", "dijkstra"] {
        let r = report(&[
            "bench",
            "movingai",
            dir.join("arena.map").to_str().unwrap(),
            dir.join("arena.map.scen").to_str().unwrap(),
            "--planner",
            planner,
            "--json",
        ]);
        assert_eq!(r["schema"], "imitate.bench.movingai/1");
        assert_eq!(r["scenarios"], 160);
        assert_eq!(r["mismatches"], 0, "{r}");
    }
}

#[test]
fn maze_scenarios_match_their_optimal_lengths() {
    let Some(dir) = data() else { return };
    // The first 300 of 8010 scenarios keep a debug-build test short; the release
    // benchmark in BENCHMARKS.md runs them all.
    let text = std::fs::read_to_string(dir.join("maze512-32-9.map.scen")).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let scen = tmp.path().join("maze.scen");
    std::fs::write(&scen, text.lines().take(301).collect::<Vec<_>>().join("\n")).unwrap();
    let r = report(&[
        "bench",
        "movingai",
        dir.join("maze512-32-9.map").to_str().unwrap(),
        scen.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(r["scenarios"], 300);
    assert_eq!(r["mismatches"], 0, "{r}");
}

#[test]
fn a_scenario_for_another_map_is_refused() {
    let Some(dir) = data() else { return };
    let out = imitate(
        &repo(),
        &[
            "bench",
            "movingai",
            dir.join("arena.map").to_str().unwrap(),
            dir.join("maze512-32-9.map.scen").to_str().unwrap(),
        ],
    );
    assert_input_error(
        &out,
        &["maze512-32-9.map.scen", "line 2", "512x512", "49x49"],
    );
}
