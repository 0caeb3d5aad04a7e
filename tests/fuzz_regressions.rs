//! Inputs the fuzzers (`fuzz/`) found crashing a reader, kept as regression tests: each
//! must now be refused with an error (exit code 2 from the CLI), never a panic.
//! `tests/fuzz_regressions/<target>/` holds them as the fuzzer wrote them.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use imitate::io::demo_tables::{Columns, read_demonstrations_table};
use imitate::io::geotiff::read_geotiff;
use imitate::io::mcap::inspect::{Source, inspect};
use imitate::io::tables::{read_costmap, read_features, read_map, read_paths};

fn inputs(target: &str) -> Vec<PathBuf> {
    let dir = repo().join("tests/fuzz_regressions").join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|entries| entries.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    files.sort();
    files
}

/// A copy of `input` named `name` in `dir`, since the CLI chooses readers by extension.
fn as_file(dir: &Path, input: &Path, name: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::copy(input, &path).unwrap();
    path
}

#[test]
fn damaged_parquet_files_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    for input in inputs("tables") {
        let path = as_file(dir.path(), &input, "damaged.parquet");
        assert!(read_map(&path).is_err(), "{}", input.display());
        assert!(read_features(&path).is_err());
        assert!(read_costmap(&path).is_err());
        assert!(read_paths(&path).is_err());
        assert!(read_demonstrations_table(&path, &Columns::default(), Some("map")).is_err());
        let out = imitate(
            dir.path(),
            &[
                "ingest",
                "--map",
                "damaged.parquet",
                "--demonstrations",
                "damaged.parquet",
                "--out",
                "ds",
            ],
        );
        assert_input_error(&out, &["damaged.parquet"]);
    }
}

#[test]
fn damaged_mcap_files_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    for input in inputs("mcap") {
        let path = as_file(dir.path(), &input, "damaged.mcap");
        let _ = inspect(&path, Source::VerifiedSummary, true);
        let _ = inspect(&path, Source::Scan, false);
        for command in [&["cat", "damaged.mcap"][..], &["inspect", "damaged.mcap"]] {
            let out = imitate(dir.path(), command);
            let err = stderr(&out);
            assert!(!err.contains("panicked"), "{}: {err}", input.display());
            assert!(matches!(out.status.code(), Some(0 | 2)), "{err}");
        }
    }
}

#[test]
fn damaged_geotiffs_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let inputs = inputs("geotiff");
    assert!(!inputs.is_empty());
    for input in inputs {
        let path = as_file(dir.path(), &input, "damaged.tif");
        let error = read_geotiff(&path, "m").expect_err(&input.display().to_string());
        assert!(error.to_string().contains("damaged.tif"), "{error}");
        let out = imitate(
            dir.path(),
            &[
                "plan",
                "damaged.tif",
                "--cells",
                "--start",
                "0,0",
                "--goal",
                "0,1",
            ],
        );
        assert_input_error(&out, &["damaged.tif"]);
    }
}
