//! `imitate learch` with its nonlinear learner, dilated loss and early stopping, as a user
//! runs it.

mod common;

use common::*;

/// The prepared workspace with features `fr`: the layers and a regional feature (a
/// blur over 6 cells), which the trees' stages hold back, so that LEARCH trains its two
/// members.
fn workspace_with_regional_features() -> tempfile::TempDir {
    let ws = prepared_workspace();
    let mut args = vec!["features", "--dataset", "ds", "--out", "fr"];
    for layer in ["elevation", "vegetation", "water", "road"] {
        args.extend(["--layer", layer]);
    }
    args.extend(["--op", r#"{"op":"blur","layer":"elevation","cells":[6]}"#]);
    let out = imitate(ws.path(), &args);
    assert!(out.status.success(), "{}", stderr(&out));
    ws
}

#[test]
fn tree_learch_with_early_stopping_writes_what_it_kept() {
    let ws = workspace_with_regional_features();
    let run = |args: &[&str]| imitate(ws.path(), args);
    let out = run(&[
        "learch",
        "--dataset",
        "ds",
        "--features",
        "fr",
        "--weak-learner",
        "tree",
        "--loss-kind",
        "dilated",
        "--holdout",
        "0.25",
        "--validation",
        "0.25",
        "--patience",
        "3",
        "--rounds",
        "20",
        "--out",
        "c",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let metrics: serde_json::Value =
        serde_json::from_slice(&std::fs::read(ws.path().join("c/metrics.json")).unwrap()).unwrap();
    // Two members by default, each stopped on its own.
    let members = metrics["members"].as_array().unwrap();
    assert_eq!(members.len(), 2);
    let rounds = metrics["rounds"].as_array().unwrap();
    let member_rounds = |m: usize| -> Vec<&serde_json::Value> {
        let m = m as u64;
        rounds
            .iter()
            .filter(|r| r["member"].as_u64().unwrap_or(0) == m)
            .collect()
    };
    for (m, member) in members.iter().enumerate() {
        let kept = member["kept_round"].as_u64().unwrap() as usize;
        let ran = member["rounds"].as_u64().unwrap() as usize;
        assert_eq!(member_rounds(m).len(), ran);
        assert!(kept >= 1 && kept <= ran && ran <= 20, "{member}");
    }
    assert_eq!(metrics["validation"]["summary"]["examples"], 12);
    assert_eq!(metrics["holdout"]["summary"]["examples"], 16);
    let model: serde_json::Value =
        serde_json::from_slice(&std::fs::read(ws.path().join("c/model.json")).unwrap()).unwrap();
    let learners = model["cost"]["learners"].as_array().unwrap();
    assert!(
        learners
            .iter()
            .all(|l| l["kind"] == "tree" && l["tree"].is_object())
    );
    // Each member's kept learners, member after member, take the contrast chosen on
    // the training paths times the steps their rounds record, halved: the geometric
    // mean of the two members' costs.
    let mut learners = learners.iter();
    for (m, member) in members.iter().enumerate() {
        let kept = member["kept_round"].as_u64().unwrap() as usize;
        let contrast = member["contrast"].as_f64().unwrap();
        assert!([1.0, 1.25, 1.5, 2.0].contains(&contrast), "{contrast}");
        for round in &member_rounds(m)[..kept] {
            let kept_step = learners.next().unwrap()["step"].as_f64().unwrap();
            let round_step = round["step"].as_f64().unwrap();
            assert!((kept_step - contrast * round_step / 2.0).abs() < 1e-12);
        }
    }
    assert!(learners.next().is_none());

    // Early stopping needs a validation split, and the other way round.
    let out = run(&[
        "learch",
        "--dataset",
        "ds",
        "--features",
        "fs",
        "--patience",
        "3",
        "--out",
        "d",
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("patience and validation"),
        "{}",
        stderr(&out)
    );
    assert!(!ws.path().join("d").exists());
}

const LONG_RUN: [&str; 10] = [
    "learch",
    "--dataset",
    "ds",
    "--features",
    "fr",
    "--rounds",
    "60",
    "--weak-learner",
    "tree",
    "--out",
];

fn digest(output: &std::process::Output) -> String {
    assert!(output.status.success(), "{}", stderr(output));
    stdout(output)
        .split('\t')
        .nth(2)
        .unwrap()
        .trim()
        .to_string()
}

#[test]
fn a_killed_run_resumes_from_its_checkpoint_to_the_same_artifact() {
    let uninterrupted = workspace_with_regional_features();
    let expected = digest(&imitate(
        uninterrupted.path(),
        &[&LONG_RUN[..], &["c"]].concat(),
    ));
    // The checkpoint is gone once the artifact is in place.
    let checkpoints = uninterrupted.path().join(".imitate/checkpoints");
    assert_eq!(
        std::fs::read_dir(&checkpoints)
            .map(|d| d.count())
            .unwrap_or(0),
        0
    );

    // Into the second member's rounds (60 each), so that the resumed run picks up the
    // first member's finished model too.
    let ws = workspace_with_regional_features();
    kill_once_checkpointed(&ws, &[&LONG_RUN[..], &["c"]].concat(), ".json", 65, 120);
    let resumed = imitate(
        ws.path(),
        &[&LONG_RUN[..], &["c", "--resume", "-v"]].concat(),
    );
    assert_eq!(digest(&resumed), expected);
}

/// Runs `imitate ARGS` (writing `c`) in `ws` and kills it once a checkpoint whose
/// name ends in `suffix` holds `rounds` rounds (or the run ends, having run `all`).
fn kill_once_checkpointed(
    ws: &tempfile::TempDir,
    args: &[&str],
    suffix: &str,
    rounds: usize,
    all: usize,
) {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_imitate"))
        .current_dir(ws.path())
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let rounds_done = || -> usize {
        let dir = ws.path().join(".imitate/checkpoints");
        let Ok(files) = std::fs::read_dir(&dir) else {
            return 0;
        };
        files
            .flatten()
            .filter(|f| f.file_name().to_string_lossy().ends_with(suffix))
            .filter_map(|f| std::fs::read(f.path()).ok())
            .filter_map(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
            .filter_map(|v| v["rounds"].as_array().map(|r| r.len()))
            .max()
            .unwrap_or(0)
    };
    let started = std::time::Instant::now();
    while rounds_done() < rounds && child.try_wait().unwrap().is_none() {
        assert!(started.elapsed().as_secs() < 240, "no checkpoint appeared");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let _ = child.kill();
    let _ = child.wait();
    let done = rounds_done();
    assert!(done >= rounds, "{done} rounds checkpointed");
    assert!(!ws.path().join("c/manifest.json").exists() || done == all);
}

/// `--corridor auto` killed in its retrain resumes both trainings from their
/// checkpoints: the first to its end (the same choice), the retrain where it stopped.
#[test]
fn a_killed_auto_corridor_run_resumes_to_the_same_artifact() {
    let run: [&str; 12] = [
        "learch",
        "--dataset",
        "dw",
        "--features",
        "fw",
        "--rounds",
        "40",
        "--members",
        "1",
        "--corridor",
        "auto",
        "--out",
    ];
    let uninterrupted = workspace_with_wobbling_tracks();
    let expected = digest(&imitate(uninterrupted.path(), &[&run[..], &["c"]].concat()));
    let checkpoints = uninterrupted.path().join(".imitate/checkpoints");
    assert_eq!(std::fs::read_dir(&checkpoints).unwrap().count(), 0);
    let ws = workspace_with_wobbling_tracks();
    kill_once_checkpointed(&ws, &[&run[..], &["c"]].concat(), "-corridor-1.json", 5, 40);
    let resumed = imitate(ws.path(), &[&run[..], &["c", "--resume", "-v"]].concat());
    assert_eq!(digest(&resumed), expected);
}

#[test]
fn the_round_benchmark_runs_on_small_maps() {
    let dir = tempfile::tempdir().unwrap();
    let out = imitate(
        dir.path(),
        &[
            "bench",
            "learch",
            "--size",
            "48",
            "--examples",
            "8",
            "--repeat",
            "1",
            "--json",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(report["examples"], 8);
    assert_eq!(report["features"], 16);
    let first = &report["timings"][0];
    assert_eq!(first["threads"], 1);
    let share = first["planning_share"].as_f64().unwrap();
    assert!(share > 0.0, "{report}");
}

#[test]
fn learch_trains_on_every_demonstration_unless_some_are_held_out() {
    let ws = prepared_workspace();
    let run = |args: &[&str]| imitate(ws.path(), args);
    let out = run(&[
        "learch",
        "--dataset",
        "ds",
        "--features",
        "fs",
        "--rounds",
        "3",
        "--members",
        "1",
        "--out",
        "c",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    // The summary says the figures are the training paths', not held-out ones.
    assert!(
        stderr(&out).contains("64 training / 0 held-out demonstrations; none held out"),
        "{}",
        stderr(&out)
    );
    let metrics: serde_json::Value =
        serde_json::from_slice(&std::fs::read(ws.path().join("c/metrics.json")).unwrap()).unwrap();
    assert_eq!(metrics["training"]["summary"]["examples"], 64);
    assert_eq!(metrics["holdout"]["summary"]["examples"], 0);
    assert!(metrics["rounds"][0]["holdout"].is_null());

    // The report gives the empty held-out set no figures.
    let out = run(&["report", "c", "--out", "r"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report = std::fs::read_to_string(ws.path().join("r/report.md")).unwrap();
    assert!(report.contains("| held out | 0 | – | – | – |"), "{report}");
    assert!(
        report.contains("no demonstrations were held out"),
        "{report}"
    );
}

/// A track that wanders a cell around the teacher's route (the world's demonstrations
/// with a smooth wobble of 1 m, its cells): LEARCH asked to make every wobble optimal
/// learns dear ground as cheap, and `--corridor 1` (each demonstration taken as the
/// cheapest path within a cell of it) plans the teacher's clean paths far closer to
/// their true cost. `--corridor auto` sees the wobble and keeps the corridor's model;
/// on the clean demonstrations it keeps the model learned without one.
/// The prepared workspace with the world's demonstrations wobbling a cell around the
/// teacher's routes: dataset `dw`, features `fw`.
fn workspace_with_wobbling_tracks() -> tempfile::TempDir {
    let ws = prepared_workspace();
    let demos = imitate::io::demo_tables::read_demonstrations(
        &repo().join("testdata/world/demonstrations.parquet"),
    )
    .unwrap();
    let wobbling: Vec<imitate::grid::Demonstration> = demos
        .iter()
        .enumerate()
        .map(|(e, d)| {
            let mut d = d.clone();
            for p in &mut d.poses {
                p.x = (p.x + (0.7 * p.t + e as f64).sin()).clamp(0.01, 63.99);
                p.y = (p.y + (0.45 * p.t + 2.0 * e as f64).cos()).clamp(0.01, 63.99);
            }
            d
        })
        .collect();
    imitate::io::tables::write_demonstrations(&ws.path().join("wobbling.parquet"), &wobbling)
        .unwrap();
    let maps: Vec<String> = (0..4)
        .map(|i| format!("testdata/world/maps/terrain-00{i}.parquet"))
        .collect();
    let mut ingest = vec![
        "ingest",
        "--demonstrations",
        "wobbling.parquet",
        "--out",
        "dw",
    ];
    for map in &maps {
        ingest.extend(["--map", map.as_str()]);
    }
    for args in [&ingest[..], &["features", "--dataset", "dw", "--out", "fw"]] {
        let out = imitate(ws.path(), args);
        assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    }
    ws
}

#[test]
fn a_corridor_learns_the_route_a_wobbling_track_was_driven_along() {
    let ws = workspace_with_wobbling_tracks();
    let run = |args: &[&str]| {
        let out = imitate(ws.path(), args);
        assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    };
    let truth: Vec<String> = (0..4)
        .map(|i| format!("testdata/world/truth/terrain-00{i}.parquet"))
        .collect();
    let learch = |dataset: &str, features: &str, corridor: &str, costmap: &str| {
        run(&[
            "learch",
            "--dataset",
            dataset,
            "--features",
            features,
            "--rounds",
            "40",
            "--members",
            "1",
            "--corridor",
            corridor,
            "--out",
            costmap,
        ]);
    };
    let mut scores = Vec::new();
    for corridor in ["0", "1"] {
        let costmap = format!("c{corridor}");
        learch("dw", "fw", corridor, &costmap);
        // Scored on the teacher's own paths (the clean dataset) under the true costs.
        let evaluation = format!("e{corridor}");
        let mut evaluate = vec![
            "evaluate",
            &costmap,
            "--dataset",
            "ds",
            "--out",
            &evaluation,
        ];
        for t in &truth {
            evaluate.extend(["--reference", t.as_str()]);
        }
        run(&evaluate);
        let summary: serde_json::Value = serde_json::from_slice(
            &std::fs::read(ws.path().join(&evaluation).join("evaluation.json")).unwrap(),
        )
        .unwrap();
        let ratio = summary["summary"]["mean_reference_cost_ratio"]
            .as_f64()
            .unwrap();
        scores.push(ratio);
        let lineage =
            std::fs::read_to_string(ws.path().join(&costmap).join("manifest.json")).unwrap();
        assert!(
            lineage.contains(&format!("\"corridor\": {corridor}")),
            "{lineage}"
        );
    }
    assert!(
        scores[1] < 1.06 && scores[0] > scores[1] + 0.05,
        "mean true-cost ratios without and with the corridor: {scores:?}"
    );
    let read = |costmap: &str, file: &str| std::fs::read(ws.path().join(costmap).join(file));
    let corridor_of = |costmap: &str| -> serde_json::Value {
        let metrics: serde_json::Value =
            serde_json::from_slice(&read(costmap, "metrics.json").unwrap()).unwrap();
        metrics["corridor"].clone()
    };
    let costmap = "costmaps/terrain-000.parquet";
    learch("dw", "fw", "auto", "wobbling-auto");
    let chosen = corridor_of("wobbling-auto");
    assert_eq!(
        (&chosen["requested"], &chosen["cells"]),
        (&"auto".into(), &1.into())
    );
    let share = chosen["plans_as_long"].as_f64().unwrap();
    assert!(
        share < chosen["retrains_below"].as_f64().unwrap(),
        "{chosen}"
    );
    assert_eq!(
        read("wobbling-auto", costmap).unwrap(),
        read("c1", costmap).unwrap()
    );
    learch("ds", "fs", "auto", "clean-auto");
    learch("ds", "fs", "0", "clean-0");
    let chosen = corridor_of("clean-auto");
    assert_eq!(chosen["cells"], 0, "{chosen}");
    assert!(chosen["plans_as_long"].as_f64().unwrap() > 0.5, "{chosen}");
    assert_eq!(
        read("clean-auto", costmap).unwrap(),
        read("clean-0", costmap).unwrap()
    );
    assert_eq!(corridor_of("clean-0")["requested"], 0);
}
