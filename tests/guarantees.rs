//! What imitate guarantees about the user's files: an output replaces only an artifact
//! imitate wrote, names from data never leave the output folder, and a pipeline never
//! writes outside its workspace without being told to. Each test is a user's mistake
//! that once cost them a folder.

mod common;

use std::path::Path;

use common::*;
use imitate::io::tables::{read_map, write_map};

/// A folder of the user's with a file in it, and a check that it is still whole.
fn user_folder(at: &Path) -> impl Fn() + use<> {
    std::fs::create_dir_all(at).unwrap();
    std::fs::write(at.join("notes.txt"), b"three years of field notes").unwrap();
    let at = at.to_path_buf();
    move || {
        assert_eq!(
            std::fs::read(at.join("notes.txt")).unwrap(),
            b"three years of field notes",
            "{} was touched",
            at.display()
        );
    }
}

#[test]
fn a_user_folder_named_as_output_is_refused_before_any_work() {
    let ws = prepared_workspace();
    let intact = user_folder(&ws.path().join("notes"));
    for args in [
        vec!["features", "--dataset", "ds", "--out", "notes"],
        vec![
            "learch",
            "--dataset",
            "ds",
            "--features",
            "fs",
            "--out",
            "notes",
        ],
        vec![
            "ingest",
            "--demonstrations",
            "testdata/world/demonstrations.parquet",
            "--map",
            "testdata/world/maps/terrain-000.parquet",
            "--out",
            "notes",
        ],
    ] {
        let out = imitate(ws.path(), &args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        let err = stderr(&out);
        assert!(
            err.contains("notes") && err.contains("not an artifact"),
            "{err}"
        );
        intact();
    }
    // An artifact imitate wrote is replaced as before.
    let out = imitate(ws.path(), &["features", "--dataset", "ds", "--out", "fs"]);
    assert!(out.status.success(), "{}", stderr(&out));
    // Nothing was left beside the refused output.
    let names: Vec<String> = std::fs::read_dir(ws.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        names.iter().all(|n| !n.starts_with(".imitate-")),
        "{names:?}"
    );
}

#[test]
fn a_dagger_dataset_is_never_created_among_user_files() {
    let dir = tempfile::tempdir().unwrap();
    let intact = user_folder(&dir.path().join("notes"));
    let out = imitate(dir.path(), &["dagger", "init", "notes", "--env", "track"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("no DAgger dataset"),
        "{}",
        stderr(&out)
    );
    intact();
    assert!(!dir.path().join("notes/manifest.json").exists());
}

/// Writes `stages` (YAML lines under `stages:`) as the workspace's pipeline.
fn pipeline(ws: &Path, stages: &str) {
    std::fs::write(
        ws.join("imitate.yaml"),
        format!("schema: 1\nstages:\n{stages}"),
    )
    .unwrap();
}

fn features_stage(out: &str) -> String {
    format!(
        "  ingest:\n    uses: ingest\n    with:\n      maps: [testdata/world/maps/terrain-000.parquet, testdata/world/maps/terrain-001.parquet, testdata/world/maps/terrain-002.parquet, testdata/world/maps/terrain-003.parquet]\n      demonstrations: testdata/world/demonstrations.parquet\n      out: out/dataset\n  features:\n    uses: features\n    with:\n      dataset: out/dataset\n      out: {out}\n"
    )
}

#[test]
fn a_pipeline_never_replaces_source_trees_git_or_its_cache() {
    let ws = quickstart_workspace();
    let src = user_folder(&ws.path().join("src"));
    let git = user_folder(&ws.path().join(".git"));
    for (out, expected) in [
        ("src", "not an artifact"),
        (".git", "not an artifact"),
        (".imitate/cache", "inside .imitate"),
        (".", "the workspace itself"),
        ("''", "`out` is empty"),
    ] {
        pipeline(ws.path(), &features_stage(out));
        for command in ["run", "status"] {
            let out_ = imitate(ws.path(), &[command]);
            let err = stderr(&out_);
            assert_eq!(out_.status.code(), Some(2), "{out}: {err}");
            assert!(err.contains(expected), "{out}: {err}");
            // The error points at the stage's `out` line.
            assert!(err.contains("line 13 column 7"), "{out}: {err}");
            // Refused before the first stage ran.
            assert!(!ws.path().join("out/dataset").exists(), "{out}: ingest ran");
        }
        src();
        git();
    }
}

#[test]
fn map_names_from_data_never_become_paths_outside() {
    let ws = quickstart_workspace();
    let source = ws.path().join("testdata/world/maps/terrain-000.parquet");
    let mut map = read_map(&source).unwrap();
    for name in ["../../../evil", "sub/dir", ".hidden"] {
        map.name = name.into();
        write_map(&ws.path().join("evil.parquet"), &map).unwrap();
        let out = imitate(
            ws.path(),
            &[
                "ingest",
                "--demonstrations",
                "testdata/world/demonstrations.parquet",
                "--map",
                "evil.parquet",
                "--default-map",
                name,
                "--out",
                "out/ds",
            ],
        );
        assert_input_error(&out, &["evil.parquet", "cannot be a file name"]);
        assert!(!ws.path().join("out/ds").exists());
        assert!(!ws.path().join("evil.parquet.parquet").exists());
    }
    assert!(!ws.path().parent().unwrap().join("evil.parquet").exists());
}

#[test]
fn a_map_listed_twice_is_refused_before_loading() {
    let ws = quickstart_workspace();
    let mut args = vec![
        "ingest",
        "--demonstrations",
        "testdata/world/demonstrations.parquet",
    ];
    for _ in 0..2000 {
        args.extend(["--map", "testdata/world/maps/terrain-000.parquet"]);
    }
    args.extend(["--out", "ds"]);
    let out = imitate(ws.path(), &args);
    assert_input_error(&out, &["terrain-000.parquet", "is given twice as a map"]);
}

#[cfg(unix)]
#[test]
fn a_symlinked_output_folder_does_not_carry_a_pipeline_outside() {
    let ws = quickstart_workspace();
    let elsewhere = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(elsewhere.path(), ws.path().join("out")).unwrap();
    pipeline(ws.path(), &features_stage("out/features"));
    let out = imitate(ws.path(), &["run"]);
    assert_input_error(
        &out,
        &["outside the workspace", "--allow-outside-workspace"],
    );
    assert_eq!(std::fs::read_dir(elsewhere.path()).unwrap().count(), 0);
    // The user who means it says so.
    let out = imitate(ws.path(), &["run", "--allow-outside-workspace"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(elsewhere.path().join("features/manifest.json").is_file());
}

/// Flips one byte in the middle of `file`.
fn flip_a_byte(file: &Path) {
    let mut bytes = std::fs::read(file).unwrap();
    let at = bytes.len() / 2;
    bytes[at] ^= 0x20;
    std::fs::write(file, bytes).unwrap();
}

#[test]
fn a_flipped_byte_in_a_dagger_round_is_refused_by_every_reader() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| imitate(dir.path(), args);
    assert!(run(&["dagger", "init", "ds"]).status.success());
    for seed in ["1", "2"] {
        let added = run(&["dagger", "add", "ds", "--seed", seed]);
        assert!(added.status.success(), "{}", stderr(&added));
    }
    copy_dir(&dir.path().join("ds"), &dir.path().join("original"));
    let verified = run(&["verify", "ds"]);
    assert!(verified.status.success(), "{}", stderr(&verified));
    assert!(
        stdout(&verified).contains("ds: ok (dagger-dataset"),
        "{}",
        stdout(&verified)
    );

    flip_a_byte(&dir.path().join("ds/data/round=001/part-000.parquet"));
    let round_file = "round=001/part-000.parquet";
    for args in [
        vec!["dagger", "train", "ds", "--out", "p"],
        vec!["dagger", "status", "ds"],
        vec!["verify", "ds"],
        vec!["diff", "original", "ds"],
        vec!["inspect", "ds"],
    ] {
        let out = run(&args);
        assert_input_error(&out, &[round_file]);
        assert!(!dir.path().join("p").exists());
    }
    let out = run(&["dagger", "train", "ds", "--out", "p"]);
    assert!(stderr(&out).contains("round 1"), "{}", stderr(&out));
    let out = run(&["verify", "ds"]);
    assert!(stdout(&out).contains("DAMAGED"), "{}", stdout(&out));
}

#[test]
fn a_flipped_byte_in_an_artifact_is_refused_by_the_next_stage() {
    let ws = prepared_workspace();
    flip_a_byte(&ws.path().join("fs/features/terrain-002.parquet"));
    let out = imitate(
        ws.path(),
        &[
            "learch",
            "--dataset",
            "ds",
            "--features",
            "fs",
            "--out",
            "c",
        ],
    );
    assert_input_error(&out, &["terrain-002.parquet", "digest"]);
    assert!(!ws.path().join("c").exists());
    let out = imitate(ws.path(), &["verify", "ds", "fs"]);
    assert_input_error(
        &out,
        &["fs/features/terrain-002.parquet", "1 damaged file(s)"],
    );
    assert!(stdout(&out).contains("ds: ok (dataset"), "{}", stdout(&out));
}

#[test]
fn the_output_cache_reports_its_size_and_is_bounded_by_gc() {
    let ws = quickstart_workspace();
    pipeline(ws.path(), &features_stage("out/features"));
    let ran = imitate(ws.path(), &["run"]);
    assert!(ran.status.success(), "{}", stderr(&ran));
    let status: serde_json::Value =
        serde_json::from_str(&stdout(&imitate(ws.path(), &["cache", "status", "--json"]))).unwrap();
    let outputs = status["outputs"].as_array().unwrap();
    assert_eq!(outputs.len(), 2, "{status}");
    assert!(status["bytes"].as_u64().unwrap() > 0);
    let kinds: Vec<&str> = outputs
        .iter()
        .map(|o| o["kind"].as_str().unwrap())
        .collect();
    assert!(
        kinds.contains(&"dataset") && kinds.contains(&"features"),
        "{kinds:?}"
    );

    let refused = imitate(ws.path(), &["cache", "gc"]);
    assert_eq!(refused.status.code(), Some(2));
    let gc = imitate(ws.path(), &["cache", "gc", "--max-size", "0"]);
    assert!(gc.status.success(), "{}", stderr(&gc));
    assert_eq!(stdout(&gc).lines().count(), 2, "{}", stdout(&gc));
    let text = stdout(&imitate(ws.path(), &["cache", "status"]));
    assert!(text.contains("0 outputs, 0 B"), "{text}");
    // The workspace's outputs are untouched, and a run is still up to date.
    let verified = imitate(ws.path(), &["verify", "out/dataset", "out/features"]);
    assert!(verified.status.success(), "{}", stdout(&verified));
    let again = imitate(ws.path(), &["run"]);
    assert!(
        stderr(&again).contains("features: up to date"),
        "{}",
        stderr(&again)
    );
}

#[test]
fn a_nan_cell_in_one_map_gives_every_map_the_same_features() {
    let ws = quickstart_workspace();
    let file = ws.path().join("testdata/world/maps/terrain-001.parquet");
    let mut map = read_map(&file).unwrap();
    map.layers[0].values[5] = f32::NAN;
    write_map(&file, &map).unwrap();
    pipeline(ws.path(), &features_stage("out/features"));
    let learch = "  learch:\n    uses: learch\n    with:\n      dataset: out/dataset\n      features: out/features\n      rounds: 2\n      out: out/costmap\n";
    let yaml = std::fs::read_to_string(ws.path().join("imitate.yaml")).unwrap() + learch;
    std::fs::write(ws.path().join("imitate.yaml"), yaml).unwrap();
    let out = imitate(ws.path(), &["run"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let manifest: serde_json::Value = serde_json::from_slice(
        &std::fs::read(ws.path().join("out/features/manifest.json")).unwrap(),
    )
    .unwrap();
    let features = manifest["metrics"]["features"].to_string();
    assert!(features.contains("elevation/nodata"), "{features}");
}
