//! Make-style reruns: only what is stale runs, with a reason a person can read.

mod common;

use std::path::Path;

use common::*;

const PIPELINE: &str = "pipelines/quickstart.yaml";

fn run(ws: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["run", PIPELINE];
    args.extend_from_slice(extra);
    let out = imitate(ws, &args);
    assert!(out.status.success(), "{}", stderr(&out));
    out
}

/// stderr line of each stage, in order.
fn lines(out: &std::process::Output) -> Vec<String> {
    stderr(out)
        .lines()
        .filter(|l| !l.starts_with(' '))
        .map(String::from)
        .collect()
}

fn edit(ws: &Path, from: &str, to: &str) {
    let path = ws.join(PIPELINE);
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains(from));
    std::fs::write(&path, text.replacen(from, to, 1)).unwrap();
}

#[test]
fn only_stale_stages_rerun_and_say_why() {
    let ws = quickstart_workspace();
    let first = run(ws.path(), &[]);
    assert!(ws.path().join("pipelines/quickstart.lock").is_file());
    let digests = stdout(&first);

    // Nothing changed: nothing runs, the same outputs are reported.
    let again = run(ws.path(), &[]);
    assert_eq!(
        lines(&again),
        [
            "ingest: up to date",
            "features: up to date",
            "learch: up to date",
            "export: up to date",
            "report: up to date"
        ]
    );
    assert_eq!(stdout(&again), digests);

    // Touching an input without changing it changes nothing.
    let demos = ws.path().join("testdata/world/demonstrations.parquet");
    let bytes = std::fs::read(&demos).unwrap();
    std::fs::write(&demos, &bytes).unwrap();
    let touched = imitate(ws.path(), &["status", PIPELINE, "--exit-code"]);
    assert_eq!(touched.status.code(), Some(0), "{}", stdout(&touched));

    // One parameter: only that stage is stale, and the reason names it.
    edit(ws.path(), "rounds: 160", "rounds: 5");
    let status = imitate(ws.path(), &["status", PIPELINE, "--exit-code"]);
    assert_eq!(status.status.code(), Some(1));
    assert_eq!(
        stdout(&status).lines().collect::<Vec<_>>(),
        [
            "ingest: up to date",
            "features: up to date",
            "learch: stale: param changed: learch.rounds 160 → 5",
            "export: stale: input will be remade: out/quickstart/costmap",
            "report: stale: input will be remade: out/quickstart/costmap"
        ]
    );
    let dry = imitate(ws.path(), &["run", PIPELINE, "--dry-run"]);
    assert!(stdout(&dry).contains(
        "learch\tout/quickstart/costmap\twould run: param changed: learch.rounds 160 → 5"
    ));
    let rerun = run(ws.path(), &[]);
    let rerun_lines = lines(&rerun);
    assert_eq!(
        rerun_lines[..2],
        ["ingest: up to date", "features: up to date"]
    );
    assert!(
        rerun_lines[2].starts_with("learch: 5 rounds"),
        "{rerun_lines:?}"
    );
    // What follows LEARCH reruns because its costmap changed.
    for (line, stage) in rerun_lines[3..].iter().zip(["export", "report"]) {
        assert!(
            line.starts_with(stage) && line.ends_with("(input changed: out/quickstart/costmap)"),
            "{rerun_lines:?}"
        );
    }

    // Reverting restores the first run's artifact from the cache, without training.
    edit(ws.path(), "rounds: 5", "rounds: 160");
    let reverted = run(ws.path(), &[]);
    assert_eq!(stdout(&reverted), digests);
    assert_eq!(
        lines(&reverted)[2],
        "learch: restored from the output cache (param changed: learch.rounds 5 → 160)"
    );
    let status = imitate(ws.path(), &["status", PIPELINE, "--exit-code"]);
    assert_eq!(status.status.code(), Some(0), "{}", stdout(&status));
}

#[test]
fn a_deleted_output_reruns_its_stage_and_identical_outputs_cut_off_downstream() {
    let ws = quickstart_workspace();
    run(ws.path(), &[]);
    std::fs::remove_dir_all(ws.path().join("out/quickstart/features")).unwrap();
    let status = imitate(ws.path(), &["status", PIPELINE, "--json"]);
    let json: serde_json::Value = serde_json::from_str(&stdout(&status)).unwrap();
    assert_eq!(json["schema"], "imitate.status/1");
    assert_eq!(
        json["stale"], 4,
        "features, and learch, export and report whose inputs will be remade"
    );
    assert_eq!(
        json["stages"][1]["reasons"][0],
        "output missing: out/quickstart/features"
    );
    // The cache has it.
    let restored = run(ws.path(), &[]);
    assert_eq!(
        lines(&restored)[1..],
        [
            "features: restored from the output cache (output missing: out/quickstart/features)",
            "learch: up to date",
            "export: up to date",
            "report: up to date"
        ]
    );
    // Without the cache the stage runs, remakes the features byte for byte, and so
    // learch stays up to date.
    std::fs::remove_dir_all(ws.path().join("out/quickstart/features")).unwrap();
    std::fs::remove_dir_all(ws.path().join(".imitate")).unwrap();
    let rerun = run(ws.path(), &[]);
    let stages = lines(&rerun);
    assert!(stages[1].starts_with("features: 4 maps"), "{stages:?}");
    assert_eq!(stages[2], "learch: up to date");
}

#[test]
fn force_and_single_stage_runs() {
    let ws = quickstart_workspace();
    run(ws.path(), &[]);
    let forced = run(ws.path(), &["--force", "--stage", "features"]);
    let stages = lines(&forced);
    assert_eq!(stages.len(), 1, "{stages:?}");
    assert!(
        stages[0].starts_with("features: ") && stages[0].ends_with("(forced)"),
        "{stages:?}"
    );
    let out = imitate(ws.path(), &["run", PIPELINE, "--stage", "nope"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("no stage 'nope'"), "{}", stderr(&out));
}

#[test]
fn impossible_pipelines_are_refused_before_anything_runs() {
    let ws = quickstart_workspace();
    let cases = [
        (
            "stages:\n  a:\n    uses: features\n    with: {dataset: d, out: ../elsewhere}\n",
            "outside the workspace",
        ),
        (
            "stages:\n  a:\n    uses: features\n    with: {dataset: d, out: /tmp/x}\n",
            "outside the workspace",
        ),
        (
            "stages:\n  a:\n    uses: features\n    with: {dataset: d, out: out/f}\n  b:\n    uses: features\n    with: {dataset: d, out: out/f}\n",
            "stages 'a' and 'b' both write out/f",
        ),
        (
            "stages:\n  a:\n    uses: features\n    with: {dataset: out/d, out: out/f}\n  b:\n    uses: features\n    with: {dataset: out/f, out: out/d}\n",
            "stages a, b read each other's outputs in a cycle",
        ),
        (
            "stages:\n  a:\n    uses: features\n    with: {dataset: out/f, out: out/f}\n",
            "which it writes itself",
        ),
    ];
    for (stages, expected) in cases {
        std::fs::write(ws.path().join("bad.yaml"), format!("schema: 1\n{stages}")).unwrap();
        let out = imitate(ws.path(), &["run", "bad.yaml"]);
        assert_input_error(&out, &["bad.yaml", expected]);
        assert!(!ws.path().join("out").exists());
    }
}

/// Every output folder that exists is complete: its manifest lists files that are all
/// there with the sizes and digests it names.
fn assert_outputs_complete(ws: &Path) {
    for stage in ["dataset", "features", "costmap"] {
        let dir = ws.join("out/quickstart").join(stage);
        if !dir.exists() {
            continue;
        }
        let manifest: serde_json::Value = serde_json::from_slice(
            &std::fs::read(dir.join("manifest.json")).expect("an output folder has its manifest"),
        )
        .unwrap();
        for file in manifest["files"].as_array().unwrap() {
            let path = dir.join(file["path"].as_str().unwrap());
            let bytes = std::fs::read(&path)
                .unwrap_or_else(|_| panic!("{} is listed but missing", path.display()));
            assert_eq!(
                bytes.len() as u64,
                file["size"].as_u64().unwrap(),
                "{}",
                path.display()
            );
            assert_eq!(
                format!("blake3:{}", blake3::hash(&bytes).to_hex()),
                file["digest"].as_str().unwrap()
            );
        }
    }
}

#[test]
fn runs_killed_at_any_moment_leave_no_half_outputs_and_finish_the_same() {
    let reference = quickstart_workspace();
    let expected = stdout(&run(reference.path(), &[]));
    let ws = quickstart_workspace();
    // Kill moments drawn at random (seeded, so a failure can be replayed) over the
    // length of a debug-build quickstart run.
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2026);
    let mut delays: Vec<u64> = (0..12).map(|_| rng.random_range(0..4000)).collect();
    delays.sort_unstable();
    for delay_ms in delays {
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_imitate"))
            .current_dir(ws.path())
            .args(["run", PIPELINE])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(delay_ms));
        let _ = child.kill(); // SIGKILL on Unix
        let _ = child.wait();
        assert_outputs_complete(ws.path());
        // Start over from nothing but what the killed run left, now and then.
        if delay_ms % 3 == 0 {
            let _ = std::fs::remove_dir_all(ws.path().join(".imitate"));
        }
    }
    assert_eq!(
        stdout(&run(ws.path(), &[])),
        expected,
        "the run after the kills ends where an uninterrupted one does"
    );
    assert_outputs_complete(ws.path());
}

#[test]
fn foreach_over_a_glob_and_downstream_runs() {
    let ws = quickstart_workspace();
    let yaml = "schema: 1
stages:
  ingest:
    foreach: {glob: \"testdata/world/maps/terrain-00[01].parquet\"}
    uses: ingest
    with: {maps: [\"${item}\"], demonstrations: demos.parquet, out: \"out/${item_stem}/dataset\"}
  features:
    foreach: [terrain-000, terrain-001]
    uses: features
    with: {dataset: \"out/${item}/dataset\", out: \"out/${item}/features\"}
";
    std::fs::write(ws.path().join("fan.yaml"), yaml).unwrap();
    // One demonstrations file for both ingests, holding terrain-000's episodes only.
    let demos = imitate::io::demo_tables::read_demonstrations(
        &ws.path().join("testdata/world/demonstrations.parquet"),
    )
    .unwrap();
    let one_map: Vec<_> = demos
        .into_iter()
        .filter(|d| d.map == "terrain-000")
        .collect();
    imitate::io::tables::write_demonstrations(&ws.path().join("demos.parquet"), &one_map).unwrap();
    let out = imitate(ws.path(), &["run", "fan.yaml"]);
    // terrain-001's ingest gets demonstrations on terrain-000 only: a clear input error.
    assert_input_error(&out, &["demos.parquet", "refers to map 'terrain-000'"]);
    let yaml = yaml
        .replace("terrain-00[01]", "terrain-000")
        .replace("[terrain-000, terrain-001]", "[terrain-000]");
    std::fs::write(ws.path().join("fan.yaml"), yaml).unwrap();
    let out = imitate(ws.path(), &["run", "fan.yaml"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let names: Vec<String> = stdout(&out)
        .lines()
        .map(|l| l.split('\t').next().unwrap().to_string())
        .collect();
    assert_eq!(
        names,
        [
            "ingest@testdata/world/maps/terrain-000.parquet",
            "features@terrain-000"
        ]
    );
    let forced = imitate(
        ws.path(),
        &[
            "run",
            "fan.yaml",
            "--force",
            "--stage",
            "ingest@testdata/world/maps/terrain-000.parquet",
            "--downstream",
        ],
    );
    assert_eq!(
        lines(&forced).len(),
        2,
        "the stage and the one downstream of it: {}",
        stderr(&forced)
    );
}

#[test]
fn a_second_run_in_the_same_workspace_is_refused_while_one_works() {
    let ws = quickstart_workspace();
    std::fs::create_dir_all(ws.path().join(".imitate")).unwrap();
    let held = std::fs::File::create(ws.path().join(".imitate/run.lock")).unwrap();
    held.lock().unwrap();
    let out = imitate(ws.path(), &["run", PIPELINE]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("another `imitate run` is working in this workspace"),
        "{}",
        stderr(&out)
    );
    assert!(!ws.path().join("out").exists());
    // Looking is always allowed.
    assert!(imitate(ws.path(), &["status", PIPELINE]).status.success());
    held.unlock().unwrap();
    run(ws.path(), &[]);
}

#[test]
fn independent_stages_run_at_once_with_the_same_results() {
    let yaml = std::fs::read_to_string(repo().join(PIPELINE)).unwrap()
        + "  learch-seed-1:
    uses: learch
    with:
      dataset: out/quickstart/dataset
      features: out/quickstart/features
      rounds: 10
      seed: 1
      out: out/quickstart/costmap-seed-1
";
    let run_with = |jobs: &str| {
        let ws = quickstart_workspace();
        std::fs::write(ws.path().join(PIPELINE), &yaml).unwrap();
        let out = imitate(ws.path(), &["run", PIPELINE, "--jobs", jobs]);
        assert!(out.status.success(), "{}", stderr(&out));
        (ws, stdout(&out))
    };
    let (_a, one) = run_with("1");
    let (_b, two) = run_with("2");
    assert_eq!(one, two, "same outputs, reported in the same order");
    assert_eq!(one.lines().count(), 6);
}

#[test]
fn log_lists_the_stored_versions_with_their_changes() {
    let ws = quickstart_workspace();
    run(ws.path(), &[]);
    edit(ws.path(), "rounds: 160", "rounds: 3");
    run(ws.path(), &[]);
    let out = imitate(ws.path(), &["log", "out/quickstart/costmap", "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    let versions = json["versions"].as_array().unwrap();
    assert_eq!(versions.len(), 2);
    assert_eq!(versions[0]["changes"][0], "first version");
    assert_eq!(
        versions[1]["changes"][0],
        "param changed: learch.rounds 160 → 3"
    );
    assert_eq!(versions[1]["current"], true);
    let text = imitate(ws.path(), &["log", "out/quickstart/costmap"]);
    assert!(
        stdout(&text).contains("(current): param changed: learch.rounds 160 → 3"),
        "{}",
        stdout(&text)
    );
    let none = imitate(ws.path(), &["log", "out/nothing"]);
    assert_input_error(&none, &["out/nothing", "no stored versions"]);
}

#[test]
fn declared_deps_join_the_lineage_and_declared_outs_are_checked() {
    let ws = quickstart_workspace();
    std::fs::write(ws.path().join("notes.txt"), "tuning notes v1").unwrap();
    edit(
        ws.path(),
        "  learch:\n    uses: learch\n",
        "  learch:\n    uses: learch\n    deps: [notes.txt]\n    outs: [out/quickstart/costmap]\n",
    );
    run(ws.path(), &[]);
    let manifest: serde_json::Value = serde_json::from_slice(
        &std::fs::read(ws.path().join("out/quickstart/costmap/manifest.json")).unwrap(),
    )
    .unwrap();
    let inputs: Vec<&str> = manifest["lineage"]["inputs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["path"].as_str().unwrap())
        .collect();
    assert!(inputs.contains(&"notes.txt"), "{inputs:?}");
    assert!(stdout(&imitate(ws.path(), &["status", PIPELINE])).contains("learch: up to date"));
    std::fs::write(ws.path().join("notes.txt"), "tuning notes v2").unwrap();
    let status = stdout(&imitate(ws.path(), &["status", PIPELINE]));
    assert!(
        status.contains("learch: stale: input changed: notes.txt"),
        "{status}"
    );
    assert!(status.contains("features: up to date"), "{status}");

    edit(
        ws.path(),
        "outs: [out/quickstart/costmap]",
        "outs: [out/elsewhere]",
    );
    let out = imitate(ws.path(), &["run", PIPELINE]);
    assert_input_error(
        &out,
        &[
            "quickstart.yaml",
            "outs lists out/elsewhere, but its parameters write out/quickstart/costmap",
        ],
    );
}

#[test]
fn the_quickstart_ends_with_an_export_and_a_report_as_stages() {
    let ws = quickstart_workspace();
    let first = run(ws.path(), &[]);
    let export = ws.path().join("out/quickstart/export");
    for file in [
        "terrain-000.tif",
        "terrain-003.tif",
        "terrain-000.yaml",
        "terrain-000.pgm",
        "manifest.json",
    ] {
        assert!(export.join(file).is_file(), "{file}: {}", stderr(&first));
    }
    let report = ws.path().join("out/quickstart/report");
    assert!(report.join("report.html").is_file());
    // The learning curves have labelled axes: text drawn left of each plot (the y
    // axis's ticks and description) and below it (the x axis's).
    let curves = imitate::io::png::read_png(&report.join("learning-curves.png")).unwrap();
    let dark = |x: std::ops::Range<u32>, y: std::ops::Range<u32>| {
        y.flat_map(|row| x.clone().map(move |col| (col, row)))
            .filter(|&(col, row)| {
                let i = (row as usize * curves.width as usize + col as usize) * 3;
                curves.pixels[i..i + 3]
                    .iter()
                    .map(|&v| u32::from(v))
                    .sum::<u32>()
                    < 330
            })
            .count()
    };
    assert_eq!((curves.width, curves.height), (852, 280));
    for left in [0, 432] {
        assert!(
            dark(left..left + 55, 30..230) > 150,
            "y axis text at {left}"
        );
        assert!(
            dark(left + 70..left + 410, 240..280) > 150,
            "x axis text at {left}"
        );
    }
    let again = run(ws.path(), &[]);
    for stage in ["export", "report"] {
        let line = format!("{stage}: up to date");
        assert!(lines(&again).contains(&line), "{}", stderr(&again));
    }
}

#[test]
fn evaluate_scores_a_costmap_on_a_fixed_set_as_a_command_and_as_a_stage() {
    let yaml = std::fs::read_to_string(repo().join(PIPELINE)).unwrap()
        + "  evaluate:
    uses: evaluate
    with:
      artifact: out/quickstart/costmap
      dataset: out/quickstart/dataset
      references:
        - testdata/world/truth/terrain-000.parquet
        - testdata/world/truth/terrain-001.parquet
        - testdata/world/truth/terrain-002.parquet
        - testdata/world/truth/terrain-003.parquet
      out: out/quickstart/evaluation
";
    let ws = quickstart_workspace();
    std::fs::write(ws.path().join(PIPELINE), &yaml).unwrap();
    let first = run(ws.path(), &[]);
    let read = |dir: &str| -> serde_json::Value {
        let bytes = std::fs::read(ws.path().join(dir).join("evaluation.json")).unwrap();
        serde_json::from_slice(&bytes).unwrap()
    };
    let evaluation = read("out/quickstart/evaluation");
    let summary = &evaluation["summary"];
    // Every demonstration of the world, training ones included: plans on the learned
    // costmap stay near them and cost little more than the optimum under the truth.
    assert_eq!(summary["examples"], 64, "{}", stderr(&first));
    assert!(
        summary["within_radius"].as_f64().unwrap() > 0.9,
        "{summary}"
    );
    let optimal = summary["mean_optimal_cost_ratio"].as_f64().unwrap();
    assert!((1.0..1.05).contains(&optimal), "{summary}");
    assert_eq!(evaluation["paths"].as_array().unwrap().len(), 64);
    let again = run(ws.path(), &[]);
    assert!(lines(&again).contains(&"evaluate: up to date".to_string()));

    // The command writes the same artifact; a map without its reference is refused.
    let out = imitate(
        ws.path(),
        &[
            "evaluate",
            "out/quickstart/costmap",
            "--dataset",
            "out/quickstart/dataset",
            "--reference",
            "testdata/world/truth/terrain-000.parquet",
            "--out",
            "out/partial",
        ],
    );
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("no reference costmap for map 'terrain-001'"));
    assert!(!ws.path().join("out/partial").exists());
    let plain = imitate(
        ws.path(),
        &[
            "evaluate",
            "out/quickstart/costmap",
            "--dataset",
            "out/quickstart/dataset",
            "--out",
            "out/plain",
        ],
    );
    assert!(plain.status.success(), "{}", stderr(&plain));
    let plain = read("out/plain");
    assert_eq!(plain["summary"]["within_radius"], summary["within_radius"]);
    assert!(plain["summary"].get("mean_optimal_cost_ratio").is_none());

    // The true costs as GeoTIFF cost rasters, as a teacher's costs come: named after
    // their maps they score the plans exactly as the tables do; under names of their
    // own, four of the same grid cannot say which map each is for.
    let mut named = Vec::new();
    let mut unnamed = Vec::new();
    for k in 0..4 {
        let table = ws
            .path()
            .join(format!("testdata/world/truth/terrain-00{k}.parquet"));
        let (_, truth) = imitate::io::tables::read_costmap(&table).unwrap();
        for (file, list) in [
            (format!("terrain-00{k}.tif"), &mut named),
            (format!("teacher-{k}.tif"), &mut unnamed),
        ] {
            imitate::io::geotiff::write_geotiff(&ws.path().join(&file), &truth.geo, &truth.data)
                .unwrap();
            list.push(file);
        }
    }
    let evaluate_with = |references: &[String], out: &str| {
        let mut args = vec![
            "evaluate",
            "out/quickstart/costmap",
            "--dataset",
            "out/quickstart/dataset",
            "--out",
            out,
        ];
        for r in references {
            args.extend(["--reference", r.as_str()]);
        }
        imitate(ws.path(), &args)
    };
    let out = evaluate_with(&named, "out/rasters");
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(read("out/rasters")["summary"], evaluation["summary"]);
    let out = evaluate_with(&unnamed, "out/unnamed");
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("map 'terrain-000' has several references of its grid"),
        "{}",
        stderr(&out)
    );
    assert!(!ws.path().join("out/unnamed").exists());
}

#[test]
fn a_diff_stage_keeps_the_comparison_of_two_costmaps_as_an_artifact() {
    let yaml = std::fs::read_to_string(repo().join(PIPELINE)).unwrap()
        + "  learch-short:
    uses: learch
    with:
      dataset: out/quickstart/dataset
      features: out/quickstart/features
      rounds: 5
      out: out/quickstart/costmap-short
  diff:
    uses: diff
    with:
      old: out/quickstart/costmap-short
      new: out/quickstart/costmap
      fail_if: ['max_abs_log_cost > 0.001', 'changed_paths > 1000']
      out: out/quickstart/diff
";
    let ws = quickstart_workspace();
    std::fs::write(ws.path().join(PIPELINE), &yaml).unwrap();
    let first = run(ws.path(), &[]);
    let dir = ws.path().join("out/quickstart/diff");
    let diff: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("diff.json")).unwrap()).unwrap();
    assert_eq!(diff["kind"], "costmap", "{}", stderr(&first));
    // 5 rounds against 80: the costmaps differ, so the first threshold is crossed and
    // recorded; the second is not.
    let failed = diff["failed"].as_array().unwrap();
    assert_eq!(failed.len(), 1, "{diff}");
    assert!(failed[0].as_str().unwrap().contains("max_abs_log_cost"));
    let markdown = std::fs::read_to_string(dir.join("diff.md")).unwrap();
    assert!(markdown.contains("](terrain-000.png)"), "{markdown}");
    for map in ["terrain-000", "terrain-003"] {
        assert!(dir.join(format!("{map}.png")).is_file());
    }
    let again = run(ws.path(), &[]);
    assert!(lines(&again).contains(&"diff: up to date".to_string()));
    // A threshold that names no figure is refused before anything is written.
    edit(ws.path(), "changed_paths > 1000", "no_such_figure > 1");
    std::fs::remove_dir_all(&dir).unwrap();
    let out = imitate(ws.path(), &["run", PIPELINE]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("no_such_figure"), "{}", stderr(&out));
    assert!(!dir.exists());
}

/// The first Chromium on the PATH (`scripts/browser-deps.sh` installs Debian's).
fn browser() -> Option<&'static str> {
    ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|name| {
            std::process::Command::new(name)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        })
}

#[test]
fn the_report_renders_in_a_headless_browser_with_its_pictures() {
    let Some(browser) = browser() else {
        eprintln!("skipped: no Chromium on the PATH (scripts/browser-deps.sh installs it)");
        return;
    };
    let ws = quickstart_workspace();
    run(ws.path(), &[]);
    let html = ws.path().join("out/quickstart/report/report.html");
    // Kept after the run as the test's artifact: target/tmp/report-screenshot.png.
    let shot = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report-screenshot.png");
    let _ = std::fs::remove_file(&shot);
    let profile = tempfile::tempdir().unwrap();
    let out = std::process::Command::new("timeout")
        .arg("120")
        .arg(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--window-size=1200,2600",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}", html.display()))
        .output()
        .unwrap();
    assert!(shot.is_file(), "no screenshot: {}", stderr(&out));
    let picture = imitate::io::png::read_png(&shot).unwrap();
    assert_eq!((picture.width, picture.height), (1200, 2600));
    // The pictures loaded: a broken image shows an icon and its alt text, not the
    // costmaps' viridis ends, the demonstrations' red or the loss curve's.
    let near = |target: [u8; 3]| {
        picture
            .pixels
            .chunks_exact(3)
            .filter(|p| {
                p.iter()
                    .zip(target)
                    .all(|(&a, b)| (i32::from(a) - i32::from(b)).abs() <= 25)
            })
            .count()
    };
    let purple = near([68, 1, 84]);
    let yellow = near([253, 231, 37]);
    let red = near(imitate::report::COLOUR_DEMONSTRATION);
    assert!(
        purple > 2_000 && yellow > 2_000 && red > 1_000,
        "costmap colours on the page: purple {purple}, yellow {yellow}, red {red}"
    );
    // And the text rendered: a good share of the page is dark glyphs on white.
    let dark = picture
        .pixels
        .chunks_exact(3)
        .filter(|p| p.iter().all(|&v| v < 60))
        .count();
    assert!(dark > 20_000, "{dark} dark pixels");
}
