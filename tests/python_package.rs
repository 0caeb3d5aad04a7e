//! The Python package (`python/`, built by `scripts/python-package.sh`) against the
//! command line: the same artifacts, plans and errors, arrays that hold what the files
//! hold, DAgger rounds from in-memory tables, a policy that acts as its ONNX export;
//! and on a local multi-node Ray cluster, LEARCH writing the single-machine artifact and
//! logs ingested one task each, DAgger rounds rolled out as tasks in gymnasium's
//! Pendulum, and a whole pipeline run with its stages as tasks.

mod common;

use common::*;

/// Whether `scripts/python-package.sh` built the package; outside CI its tests skip,
/// saying so, when it did not.
fn package_built() -> bool {
    let built = repo().join("target/python-package/imitate").is_dir();
    if !built {
        assert!(
            std::env::var_os("CI").is_none(),
            "the Python package is not built in CI (scripts/test.sh builds it)"
        );
        eprintln!("skipped: the Python package is not built (run scripts/python-package.sh)");
    }
    built
}

#[test]
fn the_python_package_does_what_the_command_line_does() {
    if !package_built() {
        return;
    }
    let ws = quickstart_workspace();
    let out = imitate(ws.path(), &["run", "pipelines/quickstart.yaml"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let binary = std::path::PathBuf::from(env!("CARGO_BIN_EXE_imitate"));
    let Some(checks) = python_script("package_api.py", &[ws.path(), &binary]) else {
        return;
    };
    let names: Vec<&str> = checks.iter().filter_map(|c| c["check"].as_str()).collect();
    assert_eq!(
        names,
        [
            "run_stage",
            "run_pipeline",
            "read_costmap",
            "plan",
            "features",
            "errors",
            "append_round",
            "policy"
        ]
    );
}

#[test]
fn learch_on_a_local_ray_cluster_writes_the_single_machine_artifact() {
    if !package_built() {
        return;
    }
    let ws = prepared_workspace();
    let binary = std::path::PathBuf::from(env!("CARGO_BIN_EXE_imitate"));
    let args = [ws.path(), &binary, "ds".as_ref(), "fs".as_ref()];
    let Some(runs) = python_script("ray_learch.py", &args) else {
        return;
    };
    let digests: Vec<&str> = runs.iter().filter_map(|r| r["digest"].as_str()).collect();
    assert_eq!(digests.len(), 7, "{runs:?}");
    // One machine, 1, 3 and 5 actors, one killed; then a corridor of 1 on one machine
    // and on 3 actors: another model, the same on both.
    let (plain, corridor) = digests.split_at(5);
    assert!(plain.iter().all(|d| *d == plain[0]), "{runs:?}");
    assert!(
        corridor[0] == corridor[1] && corridor[0] != plain[0],
        "{runs:?}"
    );
}

#[test]
fn dagger_rounds_rolled_out_on_ray_are_the_rounds_made_here() {
    if !package_built() {
        return;
    }
    let ws = tempfile::tempdir().unwrap();
    let binary = std::path::PathBuf::from(env!("CARGO_BIN_EXE_imitate"));
    let Some(rounds) = python_script("ray_dagger.py", &[ws.path(), &binary]) else {
        return;
    };
    let steps: Vec<u64> = rounds.iter().filter_map(|r| r["steps"].as_u64()).collect();
    assert_eq!(steps, [240, 240], "{rounds:?}");
}

#[test]
fn logs_ingested_on_ray_give_the_dataset_ingested_here() {
    if !package_built() {
        return;
    }
    let ws = tempfile::tempdir().unwrap();
    let binary = std::path::PathBuf::from(env!("CARGO_BIN_EXE_imitate"));
    let repository = repo();
    let Some(runs) = python_script("ray_ingest.py", &[ws.path(), &binary, &repository]) else {
        return;
    };
    let digests: Vec<&str> = runs.iter().filter_map(|r| r["digest"].as_str()).collect();
    assert_eq!(digests.len(), 3, "{runs:?}");
    assert!(digests.iter().all(|d| *d == digests[0]), "{runs:?}");
}

#[test]
fn a_pipeline_run_on_ray_gives_the_digests_of_imitate_run() {
    if !package_built() {
        return;
    }
    let here = quickstart_workspace();
    let out = imitate(here.path(), &["run", "pipelines/quickstart.yaml"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let expected: Vec<(String, String)> = stdout(&out)
        .lines()
        .map(|l| {
            let fields: Vec<&str> = l.split('\t').collect();
            (fields[0].to_string(), fields[2].to_string())
        })
        .collect();
    let cluster = quickstart_workspace();
    let pipeline = std::path::Path::new("pipelines/quickstart.yaml");
    let Some(runs) = python_script("ray_pipeline.py", &[cluster.path(), pipeline]) else {
        return;
    };
    assert_eq!(runs.len(), 3, "{runs:?}");
    for run in &runs {
        let stages: Vec<(String, String)> = run["stages"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| {
                (
                    s["name"].as_str().unwrap().into(),
                    s["digest"].as_str().unwrap().into(),
                )
            })
            .collect();
        assert_eq!(stages, expected, "{run:?}");
    }
    let ran = |i: usize| runs[i]["ran"].as_array().unwrap().len();
    assert_eq!(ran(0), expected.len(), "{runs:?}");
    assert_eq!(ran(1), 0, "the second run reruns nothing: {runs:?}");
    assert_eq!(
        ran(2),
        expected.len(),
        "forced, every stage reruns: {runs:?}"
    );
}
