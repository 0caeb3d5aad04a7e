//! The quickstart as a user runs it, and the reproducibility of what it makes.

mod common;

use common::*;

fn json(path: &std::path::Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

#[test]
fn quickstart_learns_a_costmap_that_imitates_the_teacher() {
    let ws = quickstart_workspace();
    let out = imitate(ws.path(), &["run", "pipelines/quickstart.yaml"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let lines: Vec<String> = stdout(&out).lines().map(String::from).collect();
    assert_eq!(lines.len(), 5, "one line per stage: {lines:?}");
    assert!(
        lines[2].starts_with("learch\tout/quickstart/costmap\tblake3:"),
        "{lines:?}"
    );

    let artifact = ws.path().join("out/quickstart/costmap");
    let manifest = json(&artifact.join("manifest.json"));
    assert_eq!(manifest["kind"], "costmap");
    assert_eq!(manifest["lineage"]["stage"], "learch");
    for file in manifest["files"].as_array().unwrap() {
        let path = artifact.join(file["path"].as_str().unwrap());
        assert_eq!(
            std::fs::metadata(&path).unwrap().len(),
            file["size"].as_u64().unwrap()
        );
    }
    for map in ["terrain-000", "terrain-001", "terrain-002", "terrain-003"] {
        assert!(artifact.join(format!("costmaps/{map}.parquet")).is_file());
        let png = artifact.join(format!("previews/{map}.png"));
        let picture = imitate::io::png::read_png(&png).unwrap();
        // 64 cells at 4 pixels, with 8-pixel margins, the colour bar (10 + 14 pixels)
        // and its labels (74) on the right, and the scale bar (36) under the map.
        assert_eq!(
            (picture.width, picture.height),
            (8 + 256 + 10 + 14 + 74 + 8, 8 + 256 + 36)
        );
    }

    // The bar: on held-out start/goal pairs, >= 90% of planned cells within 2 cells
    // of the teacher's path, and planned cost under the true cost within 5% of the teacher's.
    let metrics = json(&artifact.join("metrics.json"));
    let holdout = &metrics["holdout"]["summary"];
    assert!(holdout["examples"].as_u64().unwrap() >= 10, "{holdout}");
    assert!(
        holdout["within_radius"].as_f64().unwrap() >= 0.90,
        "{holdout}"
    );
    assert!(
        holdout["mean_reference_cost_ratio"].as_f64().unwrap() <= 1.05,
        "{holdout}"
    );
    let rounds = metrics["rounds"].as_array().unwrap();
    assert_eq!(rounds.len(), 160);
    let first = rounds[0]["training_loss"].as_f64().unwrap();
    let last = rounds[159]["training_loss"].as_f64().unwrap();
    assert!(last < first, "training loss {first} -> {last}");
}

/// Digests of every stage's output, as printed on stdout.
fn digests(output: &std::process::Output) -> Vec<String> {
    assert!(output.status.success(), "{}", stderr(output));
    stdout(output)
        .lines()
        .map(|l| l.split('\t').nth(2).unwrap().to_string())
        .collect()
}

#[test]
fn artifacts_are_identical_across_thread_counts_runs_and_checkouts() {
    let a = quickstart_workspace();
    let b = quickstart_workspace();
    let args = ["run", "pipelines/quickstart.yaml"];
    let one_thread = digests(&imitate_env(a.path(), &args, &[("RAYON_NUM_THREADS", "1")]));
    let two_threads = digests(&imitate_env(b.path(), &args, &[("RAYON_NUM_THREADS", "2")]));
    // --force: the lock file would otherwise (rightly) skip every stage.
    let forced = ["run", "pipelines/quickstart.yaml", "--force"];
    let again = digests(&imitate_env(
        a.path(),
        &forced,
        &[("RAYON_NUM_THREADS", "2")],
    ));
    assert_eq!(one_thread, two_threads);
    assert_eq!(one_thread, again);
    let manifest = |ws: &std::path::Path| {
        std::fs::read(ws.join("out/quickstart/costmap/manifest.json")).unwrap()
    };
    assert_eq!(
        manifest(a.path()),
        manifest(b.path()),
        "byte-identical manifests"
    );
}

#[test]
fn the_committed_test_world_is_what_the_generator_makes() {
    let dir = tempfile::tempdir().unwrap();
    let out = imitate(dir.path(), &["testdata", "world", "--out", "world"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let committed = repo().join("testdata/world");
    for sub in [
        "world.json",
        "demonstrations.parquet",
        "maps/terrain-000.parquet",
        "truth/terrain-003.parquet",
        "logs/terrain-002.mcap",
    ] {
        assert_eq!(
            std::fs::read(dir.path().join("world").join(sub)).unwrap(),
            std::fs::read(committed.join(sub)).unwrap(),
            "{sub} differs: regenerate testdata/world as testdata/README.md says"
        );
    }
}
