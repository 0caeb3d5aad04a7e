//! Helpers for the CLI tests: run the real binary as a user would.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Runs `imitate ARGS` in `dir` with extra environment variables.
pub fn imitate_env(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_imitate"));
    command.current_dir(dir).args(args).env_remove("RUST_LOG");
    for (k, v) in env {
        command.env(k, v);
    }
    command.output().expect("the imitate binary runs")
}

/// A folder of the real third-party data in ../shared/data, or `None` (with a message
/// saying the test is skipped) when this checkout has none.
pub fn shared_data(folder: &str) -> Option<PathBuf> {
    let dir = repo().join("../shared/data").join(folder);
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipped: {} is absent", dir.display());
        None
    }
}

pub fn imitate(dir: &Path, args: &[&str]) -> Output {
    imitate_env(dir, args, &[])
}

pub fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

pub fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// Asserts a run ended as a user error: exit code 2, a message naming `needles`, no panic.
pub fn assert_input_error(output: &Output, needles: &[&str]) {
    let err = stderr(output);
    assert_eq!(output.status.code(), Some(2), "stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for needle in needles {
        assert!(err.contains(needle), "expected {needle:?} in: {err}");
    }
}

pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

/// A fresh workspace holding the quickstart pipeline and its test data.
pub fn quickstart_workspace() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(
        &repo().join("testdata/world"),
        &dir.path().join("testdata/world"),
    );
    std::fs::create_dir_all(dir.path().join("pipelines")).unwrap();
    std::fs::copy(
        repo().join("pipelines/quickstart.yaml"),
        dir.path().join("pipelines/quickstart.yaml"),
    )
    .unwrap();
    dir
}

/// A quickstart workspace with the dataset (`ds`) and features (`fs`) made by the CLI,
/// for tests of what comes after them.
pub fn prepared_workspace() -> tempfile::TempDir {
    let ws = quickstart_workspace();
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
    let out = imitate(ws.path(), &ingest);
    assert!(out.status.success(), "{}", stderr(&out));
    let out = imitate(ws.path(), &["features", "--dataset", "ds", "--out", "fs"]);
    assert!(out.status.success(), "{}", stderr(&out));
    ws
}

/// Runs `tests/python/SCRIPT ARGS` (real tools writing or reading files) with the
/// packages `scripts/python-deps.sh` installs (and our own Python package, where
/// `scripts/python-package.sh` built it), and parses its stdout as one JSON value
/// per line. `None` (the test is skipped, with a
/// message) where they are not installed, except in CI, where that is a failure.
pub fn python_script(script: &str, args: &[&Path]) -> Option<Vec<serde_json::Value>> {
    let run = Command::new("python3")
        .arg(repo().join("tests/python").join(script))
        .args(args)
        .env(
            "PYTHONPATH",
            std::env::join_paths([
                repo().join("target/python-package"),
                repo().join("target/python-deps"),
            ])
            .unwrap(),
        )
        .output();
    match run {
        Ok(o) if o.status.success() => Some(
            String::from_utf8_lossy(&o.stdout)
                .lines()
                .map(|l| serde_json::from_str(l).unwrap())
                .collect(),
        ),
        other => {
            let why = match other {
                Ok(o) => String::from_utf8_lossy(&o.stderr).into_owned(),
                Err(e) => e.to_string(),
            };
            assert!(
                std::env::var_os("CI").is_none(),
                "{script} failed in CI (scripts/python-deps.sh installs its packages): {why}"
            );
            eprintln!("skipped: {script} cannot run (run scripts/python-deps.sh): {why}");
            None
        }
    }
}
