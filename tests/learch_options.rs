//! `imitate learch` with its nonlinear learner, dilated loss and early stopping, as a user
//! runs it.

mod common;

use common::*;

#[test]
fn tree_learch_with_early_stopping_writes_what_it_kept() {
    let ws = prepared_workspace();
    let run = |args: &[&str]| imitate(ws.path(), args);
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
    // The kept learners take the contrast chosen on the training paths times the
    // steps their rounds record.
    let contrast = metrics["contrast"].as_f64().unwrap();
    assert!([1.0, 1.25, 1.5, 2.0].contains(&contrast), "{contrast}");
    for (learner, round) in learners.iter().zip(rounds) {
        let (kept_step, round_step) = (
            learner["step"].as_f64().unwrap(),
            round["step"].as_f64().unwrap(),
        );
        assert!((kept_step - contrast * round_step).abs() < 1e-12);
    }

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
    "fs",
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
    let uninterrupted = prepared_workspace();
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

    let ws = prepared_workspace();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_imitate"))
        .current_dir(ws.path())
        .args([&LONG_RUN[..], &["c"]].concat())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Kill it once a few rounds are checkpointed.
    let rounds_done = || -> usize {
        let dir = ws.path().join(".imitate/checkpoints");
        let Some(file) = std::fs::read_dir(&dir).ok().and_then(|mut d| d.next()) else {
            return 0;
        };
        std::fs::read(file.unwrap().path())
            .ok()
            .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
            .and_then(|v| v["rounds"].as_array().map(|r| r.len()))
            .unwrap_or(0)
    };
    let started = std::time::Instant::now();
    while rounds_done() < 5 && child.try_wait().unwrap().is_none() {
        assert!(started.elapsed().as_secs() < 120, "no checkpoint appeared");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let _ = child.kill();
    let _ = child.wait();
    let done = rounds_done();
    assert!(done >= 5, "{done} rounds checkpointed");
    assert!(!ws.path().join("c/manifest.json").exists() || done == 60);

    let resumed = imitate(
        ws.path(),
        &[&LONG_RUN[..], &["c", "--resume", "-v"]].concat(),
    );
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
