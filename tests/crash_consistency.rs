//! Kills at seeded moments: a pipeline run and DAgger appends killed with SIGKILL
//! anywhere leave no half-written artifact, the next run gives the digests of a clean
//! run, sweeps every leftover, and `imitate verify` finds nothing wrong.

#![cfg(unix)]

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::*;

const KILLS: u64 = 20;

/// A small pipeline (ingest, features, a few LEARCH rounds), so that each kill and
/// rerun takes a moment.
const PIPELINE: &str = "schema: 1
stages:
  ingest:
    uses: ingest
    with:
      maps: [testdata/world/maps/terrain-000.parquet, testdata/world/maps/terrain-001.parquet, testdata/world/maps/terrain-002.parquet, testdata/world/maps/terrain-003.parquet]
      demonstrations: testdata/world/demonstrations.parquet
      out: out/dataset
  features:
    uses: features
    with:
      dataset: out/dataset
      out: out/features
  learch:
    uses: learch
    with:
      dataset: out/dataset
      features: out/features
      rounds: 4
      out: out/costmap
";

/// Deterministic moments in [0, span): a 64-bit LCG, so every run of the test kills at
/// the same times.
fn moments(seed: u64, span: Duration) -> Vec<Duration> {
    let mut state = seed;
    (0..KILLS)
        .map(|_| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            span.mul_f64((state >> 11) as f64 / (1u64 << 53) as f64)
        })
        .collect()
}

/// Starts `imitate ARGS` in `dir` and kills it with SIGKILL after `after` (if it is
/// still running).
fn kill_after(dir: &Path, args: &[&str], after: Duration) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_imitate"))
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while started.elapsed() < after {
        if child.try_wait().unwrap().is_some() {
            return;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let _ = child.kill();
    let _ = child.wait();
}

/// Every name under `dir` that a killed run may leave behind.
fn leftovers(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return found;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if name.starts_with(".imitate-") || name.starts_with(".round-") {
            found.push(entry.path().display().to_string());
        }
        if entry.file_type().unwrap().is_dir() {
            found.extend(leftovers(&entry.path()));
        }
    }
    found
}

/// The manifest digests of the outputs, as `run` prints them.
fn digests(stdout: &str) -> Vec<String> {
    let mut lines: Vec<String> = stdout.lines().map(str::to_string).collect();
    lines.sort();
    lines
}

#[test]
fn a_pipeline_killed_anywhere_reruns_to_the_clean_digests() {
    let clean_ws = quickstart_workspace();
    std::fs::write(clean_ws.path().join("imitate.yaml"), PIPELINE).unwrap();
    let started = Instant::now();
    let clean = imitate(clean_ws.path(), &["run"]);
    let span = started.elapsed();
    assert!(clean.status.success(), "{}", stderr(&clean));
    let clean = digests(&stdout(&clean));

    let ws = quickstart_workspace();
    std::fs::write(ws.path().join("imitate.yaml"), PIPELINE).unwrap();
    for (i, moment) in moments(7, span).into_iter().enumerate() {
        // Every fourth kill starts from scratch, the others from what the last left.
        if i % 4 == 0 {
            let _ = std::fs::remove_dir_all(ws.path().join("out"));
            let _ = std::fs::remove_dir_all(ws.path().join(".imitate"));
            let _ = std::fs::remove_file(ws.path().join("imitate.lock"));
        }
        kill_after(ws.path(), &["run"], moment);
        // Whatever was killed, every output that exists is whole.
        for out in ["out/dataset", "out/features", "out/costmap"] {
            let dir = ws.path().join(out);
            if dir.exists() {
                let verified = imitate(ws.path(), &["verify", out]);
                assert!(
                    verified.status.success(),
                    "kill {i} at {moment:?}: {}",
                    stdout(&verified)
                );
            }
        }
        let rerun = imitate(ws.path(), &["run"]);
        assert!(rerun.status.success(), "kill {i}: {}", stderr(&rerun));
        assert_eq!(
            digests(&stdout(&rerun)),
            clean,
            "kill {i} at {moment:?}: digests differ from a clean run's"
        );
        assert_eq!(leftovers(ws.path()), Vec::<String>::new(), "kill {i}");
    }
}

#[test]
fn dagger_appends_killed_anywhere_leave_a_dataset_that_verifies() {
    let clean_dir = tempfile::tempdir().unwrap();
    let run_in = |dir: &Path, args: &[&str]| imitate(dir, args);
    assert!(
        run_in(clean_dir.path(), &["dagger", "init", "ds"])
            .status
            .success()
    );
    let started = Instant::now();
    let added = run_in(clean_dir.path(), &["dagger", "add", "ds", "--seed", "1"]);
    let span = started.elapsed();
    assert!(added.status.success(), "{}", stderr(&added));
    let clean_manifest = std::fs::read(clean_dir.path().join("ds/manifest.json")).unwrap();

    let dir = tempfile::tempdir().unwrap();
    assert!(
        run_in(dir.path(), &["dagger", "init", "ds"])
            .status
            .success()
    );
    let pristine = std::fs::read(dir.path().join("ds/manifest.json")).unwrap();
    for (i, moment) in moments(11, span).into_iter().enumerate() {
        kill_after(dir.path(), &["dagger", "add", "ds", "--seed", "1"], moment);
        let verified = run_in(dir.path(), &["verify", "ds"]);
        assert!(
            verified.status.success(),
            "kill {i} at {moment:?}: {}",
            stdout(&verified)
        );
        let manifest = std::fs::read(dir.path().join("ds/manifest.json")).unwrap();
        assert!(
            manifest == pristine || manifest == clean_manifest,
            "kill {i}: the dataset holds neither no round nor the whole round"
        );
        // The same round again completes (or is a no-op if it had landed).
        let again = run_in(dir.path(), &["dagger", "add", "ds", "--seed", "1"]);
        assert!(again.status.success(), "kill {i}: {}", stderr(&again));
        assert_eq!(
            std::fs::read(dir.path().join("ds/manifest.json")).unwrap(),
            clean_manifest,
            "kill {i}"
        );
        assert_eq!(
            leftovers(&dir.path().join("ds")),
            Vec::<String>::new(),
            "kill {i}"
        );
        assert!(run_in(dir.path(), &["verify", "ds"]).status.success());
        // Back to no round for the next kill.
        std::fs::remove_dir_all(dir.path().join("ds")).unwrap();
        assert!(
            run_in(dir.path(), &["dagger", "init", "ds"])
                .status
                .success()
        );
    }
}
