//! `imitate dagger` as a user runs it: a dataset grows by rounds the teacher and then
//! the learner drive, policies are trained from it and rolled out.

mod common;

use common::*;

fn json(out: &std::process::Output) -> serde_json::Value {
    assert!(out.status.success(), "{}", stderr(out));
    serde_json::from_str(&stdout(out)).unwrap()
}

#[test]
fn rounds_grow_the_dataset_and_train_policies() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| imitate(dir.path(), args);
    assert!(run(&["dagger", "init", "ds"]).status.success());
    let first = run(&["dagger", "add", "ds", "--seed", "1"]);
    assert!(first.status.success(), "{}", stderr(&first));
    let manifest = std::fs::read(dir.path().join("ds/manifest.json")).unwrap();
    // The same lap again is a no-op.
    let again = run(&["dagger", "add", "ds", "--seed", "1"]);
    assert!(
        stdout(&again).contains("already holds"),
        "{}",
        stdout(&again)
    );
    assert_eq!(
        std::fs::read(dir.path().join("ds/manifest.json")).unwrap(),
        manifest
    );

    let trained = run(&["dagger", "train", "ds", "--out", "p0"]);
    assert!(trained.status.success(), "{}", stderr(&trained));
    let policy: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("p0/policy.json")).unwrap()).unwrap();
    assert_eq!(policy["kind"], "linear");
    let rollout = json(&run(&["dagger", "rollout", "p0", "--laps", "1", "--json"]));
    assert_eq!(rollout["teacher_falls_per_lap"], 0.0);
    assert!(rollout["falls_per_lap"].as_f64().unwrap() >= 0.0);

    // A round the learner drives, labelled by the teacher.
    let second = run(&["dagger", "add", "ds", "--policy", "p0", "--seed", "2"]);
    assert!(second.status.success(), "{}", stderr(&second));
    let rounds = json(&run(&["dagger", "status", "ds", "--json"]));
    let rounds = rounds.as_array().unwrap();
    assert_eq!(rounds.len(), 2);
    assert_eq!(rounds[0]["learner_steps"], 0);
    assert_eq!(rounds[1]["learner_steps"], rounds[1]["steps"]);
    assert_eq!(rounds[1]["beta"], 0.0);
    assert!(
        dir.path()
            .join("ds/data/round=001/part-000.parquet")
            .is_file()
    );
    let tree = run(&["dagger", "train", "ds", "--out", "p1", "--learner", "tree"]);
    assert!(tree.status.success(), "{}", stderr(&tree));
}

#[test]
fn bad_dagger_input_exits_2_and_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| imitate(dir.path(), args);
    let missing = run(&["dagger", "add", "nowhere"]);
    assert_eq!(missing.status.code(), Some(2), "{}", stderr(&missing));
    assert!(
        stderr(&missing).contains("not a DAgger dataset"),
        "{}",
        stderr(&missing)
    );
    assert!(run(&["dagger", "init", "ds"]).status.success());
    let twice = run(&["dagger", "init", "ds"]);
    assert_eq!(twice.status.code(), Some(2), "{}", stderr(&twice));
    let empty = run(&["dagger", "train", "ds", "--out", "p"]);
    assert_eq!(empty.status.code(), Some(2), "{}", stderr(&empty));
    assert!(!dir.path().join("p").exists());
    let beta = run(&["dagger", "add", "ds", "--beta", "2"]);
    assert_eq!(beta.status.code(), Some(2), "{}", stderr(&beta));
    let no_policy = run(&["dagger", "add", "ds", "--policy", "nothing"]);
    assert_eq!(no_policy.status.code(), Some(2), "{}", stderr(&no_policy));
    let rounds = json(&run(&["dagger", "status", "ds", "--json"]));
    assert_eq!(rounds.as_array().unwrap().len(), 0);
}

#[test]
fn bench_dagger_scale_builds_appends_and_retrains() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| imitate(dir.path(), args);
    let report = json(&run(&[
        "bench",
        "dagger-scale",
        "--dataset",
        "big",
        "--steps",
        "2000",
        "--round-steps",
        "500",
        "--json",
    ]));
    assert_eq!(report["rounds"], 5);
    assert_eq!(report["steps"], 2500);
    // A second run reuses the dataset and appends one more round.
    let again = json(&run(&[
        "bench",
        "dagger-scale",
        "--dataset",
        "big",
        "--steps",
        "2000",
        "--round-steps",
        "500",
        "--json",
    ]));
    assert_eq!(again["rounds"], 6);
    assert!(again["build_seconds"].is_null());
    let status = json(&run(&["dagger", "status", "big", "--json"]));
    assert_eq!(status.as_array().unwrap().len(), 6);
}
