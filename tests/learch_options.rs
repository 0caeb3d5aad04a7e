//! `imitate learch` with its nonlinear learner, dilated loss and early stopping, as a user
//! runs it.

mod common;

use common::*;

#[test]
fn tree_learch_with_early_stopping_writes_what_it_kept() {
    let ws = quickstart_workspace();
    let run = |args: &[&str]| imitate(ws.path(), args);
    let mut ingest = vec![
        "ingest",
        "--demonstrations",
        "testdata/world/demonstrations.parquet",
    ];
    let maps: Vec<String> = (0..4)
        .map(|i| format!("testdata/world/maps/terrain-00{i}.parquet"))
        .collect();
    for map in &maps {
        ingest.extend(["--map", map.as_str()]);
    }
    ingest.extend(["--out", "ds"]);
    assert!(run(&ingest).status.success());
    assert!(
        run(&["features", "--dataset", "ds", "--out", "fs"])
            .status
            .success()
    );

    let out = run(&[
        "learch",
        "--dataset",
        "ds",
        "--features",
        "fs",
        "--weak-learner",
        "tree",
        "--loss-kind",
        "dilated",
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
    let kept = metrics["kept_round"].as_u64().unwrap() as usize;
    let rounds = metrics["rounds"].as_array().unwrap();
    assert!(kept >= 1 && kept <= rounds.len() && rounds.len() <= 20);
    assert_eq!(metrics["validation"]["summary"]["examples"], 12);
    assert_eq!(metrics["holdout"]["summary"]["examples"], 16);
    let model: serde_json::Value =
        serde_json::from_slice(&std::fs::read(ws.path().join("c/model.json")).unwrap()).unwrap();
    let learners = model["cost"]["learners"].as_array().unwrap();
    assert_eq!(learners.len(), kept);
    assert!(
        learners
            .iter()
            .all(|l| l["kind"] == "tree" && l["tree"].is_object())
    );

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
