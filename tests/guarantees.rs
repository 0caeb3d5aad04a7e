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
