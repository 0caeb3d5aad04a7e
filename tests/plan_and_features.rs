//! `imitate plan` and `imitate features --op ...` as a user runs them.

mod common;

use common::*;
use imitate::grid::{GeoRef, Grid};
use imitate::io::geotiff::write_geotiff;
use imitate::io::tables::write_costmap;
use std::path::{Path, PathBuf};

/// A 5 x 4 costmap of ones with a wall in column 2, open only in the top row.
fn walled(dir: &std::path::Path) -> std::path::PathBuf {
    let geo = GeoRef::square(5, 4, 2.0, [10.0, 20.0], "map");
    let mut costs = Grid::filled(geo, 1.0f32);
    for row in 0..3 {
        costs.set(imitate::grid::Cell::new(row, 2), f32::INFINITY);
    }
    let path = dir.join("walled.parquet");
    write_costmap(&path, "walled", &costs).unwrap();
    path
}

fn plan(dir: &std::path::Path, args: &[&str]) -> std::process::Output {
    let mut all = vec!["plan", "walled.parquet"];
    all.extend_from_slice(args);
    imitate(dir, &all)
}

#[test]
fn plans_around_a_wall_in_cells_and_in_metres() {
    let dir = tempfile::tempdir().unwrap();
    walled(dir.path());
    let out = plan(
        dir.path(),
        &[
            "--cells", "--start", "0,0", "--goal", "0,4", "--png", "plan.png",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(json["schema"], "imitate.plan/1");
    let cells = json["cells"].as_array().unwrap();
    assert_eq!(cells.first().unwrap(), &serde_json::json!([0, 0]));
    assert!(
        cells.contains(&serde_json::json!([3, 2])),
        "through the gap in the top row"
    );
    // Up to the gap at (3, 2) and down again: each leg 2 diagonals and 1 straight step,
    // at 2 m per cell.
    let cost = json["cost"].as_f64().unwrap();
    assert!(
        (cost - 2.0 * (2.0 + 4.0 * 2f64.sqrt())).abs() < 1e-9,
        "{cost}"
    );
    let picture = imitate::io::png::read_png(&dir.path().join("plan.png")).unwrap();
    // The 20 x 16 pixel map (4 pixels a cell) with its colour bar and scale bar.
    assert_eq!(
        (picture.width, picture.height),
        (8 + 20 + 10 + 14 + 74 + 8, 8 + 16 + 36)
    );
    // The same query in world coordinates (cell centres at 11 m, 21 m and 19 m, 21 m).
    let world = plan(
        dir.path(),
        &["--start", "11,21", "--goal", "19,21", "--no-corner-cutting"],
    );
    assert!(world.status.success(), "{}", stderr(&world));
    let json: serde_json::Value = serde_json::from_str(&stdout(&world)).unwrap();
    assert!(
        json["cost"].as_f64().unwrap() >= cost,
        "no corner cutting is never cheaper"
    );
}

#[test]
fn bad_plan_requests_are_explained() {
    let dir = tempfile::tempdir().unwrap();
    walled(dir.path());
    let out = plan(dir.path(), &["--start", "0,0", "--goal", "19,21"]);
    assert_input_error(
        &out,
        &["walled.parquet", "--start 0,0 lies outside map 'walled'"],
    );
    let out = plan(dir.path(), &["--cells", "--start", "0,2", "--goal", "0,4"]);
    assert_input_error(&out, &["--start 0,2 is on a blocked cell"]);
    let out = plan(
        dir.path(),
        &[
            "--cells",
            "--start",
            "0,0",
            "--goal",
            "0,4",
            "--connectivity",
            "four",
            "--start",
            "x",
        ],
    );
    assert_eq!(out.status.code(), Some(2));
    let out = plan(
        dir.path(),
        &[
            "--cells",
            "--start",
            "0,0",
            "--goal",
            "0,4",
            "--connectivity",
            "four",
        ],
    );
    assert!(out.status.success(), "4-connected also finds the gap");
}

/// Runs `imitate ARGS` in `dir` with its stdout closed before it prints anything, as
/// `imitate ... | head -c 10` does once head has had enough.
fn into_closed_pipe(dir: &std::path::Path, args: &[&str]) -> std::process::Output {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_imitate"))
        .current_dir(dir)
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    child.wait_with_output().unwrap()
}

#[test]
fn output_into_a_closed_pipe_ends_quietly() {
    let dir = tempfile::tempdir().unwrap();
    walled(dir.path());
    let log = repo().join("testdata/world/logs/terrain-000.mcap");
    for args in [
        vec![
            "plan",
            "walled.parquet",
            "--cells",
            "--start",
            "0,0",
            "--goal",
            "0,4",
        ],
        vec!["cat", log.to_str().unwrap()],
    ] {
        let out = into_closed_pipe(dir.path(), &args);
        assert_eq!(out.status.code(), Some(0), "{args:?}: {}", stderr(&out));
        assert!(stderr(&out).is_empty(), "{args:?}: {}", stderr(&out));
    }
}

#[test]
fn unreachable_goals_fail_with_exit_code_1() {
    let dir = tempfile::tempdir().unwrap();
    let geo = GeoRef::unit(3, 1);
    let costs = Grid::from_vec(geo, vec![1.0, f32::INFINITY, 1.0]);
    write_costmap(&dir.path().join("walled.parquet"), "cut", &costs).unwrap();
    let out = plan(dir.path(), &["--cells", "--start", "0,0", "--goal", "0,2"]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(stderr(&out).contains("no path"));
}

/// The cost and cells of a successful `imitate plan` run.
fn planned(out: &std::process::Output) -> (f64, serde_json::Value) {
    assert!(out.status.success(), "{}", stderr(out));
    let json: serde_json::Value = serde_json::from_str(&stdout(out)).unwrap();
    (json["cost"].as_f64().unwrap(), json["cells"].clone())
}

#[test]
fn plans_on_a_geotiff_and_an_ascii_grid_as_on_the_same_table() {
    let dir = tempfile::tempdir().unwrap();
    let table = walled(dir.path());
    let (_, costs) = imitate::io::tables::read_costmap(&table).unwrap();
    // The wall as nodata (NaN): blocked, as ∞ is in the table.
    let values: Vec<f32> = costs
        .data
        .iter()
        .map(|&c| if c.is_finite() { c } else { f32::NAN })
        .collect();
    write_geotiff(&dir.path().join("walled.tif"), &costs.geo, &values).unwrap();
    let query = ["--cells", "--start", "0,0", "--goal", "0,4"];
    let from_table = planned(&plan(dir.path(), &query));
    let mut args = vec!["plan", "walled.tif"];
    args.extend_from_slice(&query);
    assert_eq!(planned(&imitate(dir.path(), &args)), from_table);
    // The same costs as an Esri ASCII grid (rows from the north, the wall as nodata).
    let geo = &costs.geo;
    let mut grid = format!(
        "ncols {}\nnrows {}\nxllcorner {}\nyllcorner {}\ncellsize {}\nNODATA_value -9999\n",
        geo.width, geo.height, geo.origin[0], geo.origin[1], geo.resolution
    );
    for row in (0..geo.height as usize).rev() {
        let line = &values[row * geo.width as usize..][..geo.width as usize];
        for v in line {
            grid.push_str(&if v.is_nan() {
                "-9999 ".into()
            } else {
                format!("{v} ")
            });
        }
        grid.push('\n');
    }
    std::fs::write(dir.path().join("walled.asc"), grid).unwrap();
    let mut ascii = vec!["plan", "walled.asc"];
    ascii.extend_from_slice(&query);
    assert_eq!(planned(&imitate(dir.path(), &ascii)), from_table);
    // A grid with no CRS has no longitude: its route cannot be GeoJSON.
    ascii.extend_from_slice(&["--geojson", "route.geojson"]);
    let out = imitate(dir.path(), &ascii);
    assert_input_error(&out, &["walled.asc", "RFC 7946", "names no EPSG code"]);
    assert!(!dir.path().join("route.geojson").exists());

    let mut negative = values.clone();
    negative[1] = -1.0;
    write_geotiff(&dir.path().join("negative.tif"), &costs.geo, &negative).unwrap();
    args[1] = "negative.tif";
    let out = imitate(dir.path(), &args);
    assert_input_error(
        &out,
        &[
            "negative.tif",
            "band 'band1', cell (row 0, col 1): cost -1 is negative",
        ],
    );
    args[1] = "walled.tif";
    args.extend_from_slice(&["--map", "band2"]);
    let out = imitate(dir.path(), &args);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("has no band 'band2' (it has: band1)"));
}

#[test]
fn plans_on_real_rasters_and_movingai_maps() {
    let Some(movingai) = shared_data("movingai") else {
        return;
    };
    let map = movingai.join("arena.map");
    let grid = imitate::io::movingai::read_map(&map).unwrap();
    let scenarios =
        imitate::io::movingai::read_scenarios(&movingai.join("arena.map.scen"), &grid.geo).unwrap();
    let dir = tempfile::tempdir().unwrap();
    for scenario in scenarios.iter().step_by(40) {
        let (start, goal) = (scenario.start, scenario.goal);
        let out = imitate(
            dir.path(),
            &[
                "plan",
                map.to_str().unwrap(),
                "--cells",
                "--start",
                &format!("{},{}", start.row, start.col),
                "--goal",
                &format!("{},{}", goal.row, goal.col),
                "--no-corner-cutting",
            ],
        );
        let (cost, _) = planned(&out);
        let optimal = scenario.optimal_length;
        assert!(
            (cost - optimal).abs() <= 1e-4 * optimal,
            "{cost} vs {optimal}"
        );
    }

    let Some(raster) = shared_data("raster") else {
        return;
    };
    // Real GeoTIFFs are read, and what makes them unusable as costs is named: a
    // hillshade that is nodata (255) or 0 everywhere, and a float raster with negatives.
    let shade = raster.join("rasterio_shade.tif");
    let query = ["--cells", "--start", "100,100", "--goal", "900,900"];
    let mut args = vec!["plan", shade.to_str().unwrap()];
    args.extend_from_slice(&query);
    let out = imitate(dir.path(), &args);
    assert_input_error(
        &out,
        &["rasterio_shade.tif", "--start 100,100 is on a blocked cell"],
    );
    let floats = raster.join("rasterio_float_nan.tif");
    args[1] = floats.to_str().unwrap();
    let out = imitate(dir.path(), &args);
    assert_input_error(
        &out,
        &[
            "rasterio_float_nan.tif",
            // Its transformation matrix has a positive y scale: stored south-up, so
            // the second stored row is row 1.
            "band 'band1', cell (row 1, col 1): cost -0.23 is negative",
        ],
    );
}

#[test]
fn features_with_operators_from_the_command_line() {
    let ws = quickstart_workspace();
    let map = "testdata/world/maps/terrain-000.parquet";
    let out = imitate(
        ws.path(),
        &[
            "ingest",
            "--map",
            map,
            "--demonstrations",
            "testdata/world/demonstrations.parquet",
            "--out",
            "ds",
        ],
    );
    // The demonstrations name four maps; only one is given.
    assert_input_error(&out, &["refers to map 'terrain-001'"]);
    let maps: Vec<String> = (0..4)
        .map(|m| format!("testdata/world/maps/terrain-00{m}.parquet"))
        .collect();
    let mut args = vec!["ingest"];
    for m in &maps {
        args.extend(["--map", m.as_str()]);
    }
    args.extend([
        "--demonstrations",
        "testdata/world/demonstrations.parquet",
        "--out",
        "ds",
    ]);
    assert!(imitate(ws.path(), &args).status.success());
    let out = imitate(
        ws.path(),
        &[
            "features",
            "--dataset",
            "ds",
            "--out",
            "fs",
            "--layer",
            "road",
            "--op",
            r#"{"op":"slope","layer":"elevation"}"#,
            "--op",
            r#"{"op":"distance","layer":"water","above":0.5}"#,
            "--op",
            r#"{"op":"classes","layer":"road","classes":[1],"shares":[3]}"#,
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(ws.path().join("fs/manifest.json")).unwrap())
            .unwrap();
    assert_eq!(
        manifest["metrics"]["features"],
        serde_json::json!([
            "road",
            "elevation/slope_deg",
            "water/distance_to_above_0.5_m",
            "road/class_1",
            "road/class_1/share_3c",
            "road/distance_to_class_1_m",
            "bias"
        ])
    );
    let out = imitate(
        ws.path(),
        &[
            "features",
            "--dataset",
            "ds",
            "--out",
            "fs2",
            "--op",
            r#"{"op":"blurr"}"#,
        ],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("not a feature operator"),
        "{}",
        stderr(&out)
    );
    let out = imitate(
        ws.path(),
        &[
            "features",
            "--dataset",
            "ds",
            "--out",
            "fs2",
            "--op",
            r#"{"op":"slope","layer":"height"}"#,
        ],
    );
    assert_input_error(&out, &["terrain-000.parquet", "no layer 'height'"]);
    assert!(!ws.path().join("fs2").exists());
    // A bank: the elevation layer by its name, imagery operators on the others.
    let out = imitate(
        ws.path(),
        &[
            "features",
            "--dataset",
            "ds",
            "--out",
            "fs3",
            "--bank",
            "auto",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    // The world's 0/1 layers look like classes: the bank says which operator would
    // give them per-class features.
    assert!(
        stderr(&out).contains(r#"--op '{"op":"classes","layer":"#),
        "{}",
        stderr(&out)
    );
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(ws.path().join("fs3/manifest.json")).unwrap())
            .unwrap();
    let names: Vec<&str> = manifest["metrics"]["features"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    for expected in [
        "elevation/slope_deg",
        "elevation/relief_16c",
        "vegetation/blur_3c",
        "nd(vegetation,water)",
        "road/above_q90",
        "brightness",
        "brightness/distance_to_above_q90_m",
        "bias",
    ] {
        assert!(names.contains(&expected), "{expected} in {names:?}");
    }
    assert!(!names.iter().any(|n| n.starts_with("vegetation/slope")));
}

#[test]
fn bench_terrain_runs_the_hidden_teacher_protocol_on_a_real_raster() {
    let Some(rasters) = common::shared_data("raster") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let spot = rasters.join("osgeo_spot_chicago_utm.tif");
    let out = imitate(
        dir.path(),
        &[
            "bench",
            "terrain",
            spot.to_str().unwrap(),
            "--teacher",
            "threshold",
            "--teacher",
            "texture",
            "--method",
            "learch-tree",
            "--cells",
            "60",
            "--paths",
            "16",
            "--rounds",
            "8",
            "--json",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["schema"], "imitate.bench-terrain/2");
    let results = report["results"].as_array().unwrap();
    let by = |method: &str, teacher: &str| {
        results
            .iter()
            .find(|r| {
                r["method"] == method
                    && r["terrain"] == format!("osgeo_spot_chicago_utm/{teacher}").as_str()
            })
            .unwrap_or_else(|| panic!("{method} on {teacher} in {results:?}"))
    };
    let (uniform, tree) = (by("uniform", "threshold"), by("learch-tree", "threshold"));
    assert_eq!(tree["held_out"], 4);
    assert_eq!(tree["rounds"], 8, "--rounds overrides the method's default");
    // Two models averaged, each of the rounds asked for.
    assert_eq!(tree["models"], 2);
    // The same figures on the training paths, to tell overfitting from underfitting.
    let training = tree["training_mean_cost_ratio"].as_f64().unwrap();
    assert!(training >= 1.0 - 1e-9, "{tree}");
    assert!(
        tree["training_within_radius"].as_f64().unwrap() > 0.0,
        "{tree}"
    );
    // Even a short run learns more than planning on a uniform cost.
    let ratio = |r: &serde_json::Value| r["mean_cost_ratio"].as_f64().unwrap();
    assert!(ratio(tree) < ratio(uniform), "{tree} vs {uniform}");
    // The texture teacher (rough ground over a window drawn from the seed) too.
    let (uniform, tree) = (by("uniform", "texture"), by("learch-tree", "texture"));
    assert!(ratio(tree) < ratio(uniform), "{tree} vs {uniform}");
    let bad = imitate(
        dir.path(),
        &[
            "bench",
            "terrain",
            spot.to_str().unwrap(),
            "--method",
            "nope",
        ],
    );
    assert_eq!(bad.status.code(), Some(2));
}

/// A raster whose content leaves the protocol nothing to do (one cell: no two cells
/// half the map apart) is an input error naming it, not a failure of the run.
#[test]
fn bench_terrain_names_a_raster_it_cannot_use() {
    let dir = tempfile::tempdir().unwrap();
    let raster = dir.path().join("one-cell.tif");
    write_geotiff(
        &raster,
        &GeoRef::square(1, 1, 30.0, [0.0, 0.0], "map"),
        &[1.0],
    )
    .unwrap();
    let out = imitate(
        dir.path(),
        &[
            "bench",
            "terrain",
            raster.to_str().unwrap(),
            "--method",
            "learch-tree",
        ],
    );
    assert_input_error(&out, &["one-cell.tif", "no 60 pairs of cells", "1 × 1"]);
}

/// A raster with nothing on it (every cell the same value) leaves every teacher a
/// uniform cost: every method learns a cost of one level (its features are constant),
/// whose plans cost exactly the teacher's, and none fails on the features' zero spread.
#[test]
fn bench_terrain_on_a_constant_raster_plans_at_the_teachers_cost() {
    let dir = tempfile::tempdir().unwrap();
    let raster = dir.path().join("flat.tif");
    write_geotiff(
        &raster,
        &GeoRef::square(24, 20, 30.0, [0.0, 0.0], "map"),
        &[7.0; 24 * 20],
    )
    .unwrap();
    let mut args = vec!["bench", "terrain", raster.to_str().unwrap()];
    for teacher in ["threshold", "texture"] {
        args.extend(["--teacher", teacher]);
    }
    for method in ["learch-alternate", "learch-ridge", "mmp", "maxent"] {
        args.extend(["--method", method]);
    }
    args.extend(["--rounds", "3", "--paths", "16", "--json"]);
    let out = imitate(dir.path(), &args);
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let results = report["results"].as_array().unwrap();
    // Both teachers, the uniform baseline and the four methods.
    assert_eq!(results.len(), 2 * 5, "{report}");
    for result in results {
        for figure in ["mean_cost_ratio", "max_cost_ratio"] {
            let ratio = result[figure].as_f64().unwrap();
            assert!((ratio - 1.0).abs() < 1e-9, "{figure} {ratio} in {result}");
        }
    }
}

/// A 48 × 40 GeoTIFF of 30 m cells in `dir`: crossed waves on a slope, a terrain
/// that `bench terrain` runs on in seconds.
fn waves_raster(dir: &Path) -> PathBuf {
    let raster = dir.join("waves.tif");
    let (width, height) = (48u32, 40u32);
    let values: Vec<f32> = (0..width * height)
        .map(|i| {
            let (x, y) = (f64::from(i % width), f64::from(i / width));
            (100.0 + 40.0 * (x / 5.0).sin() * (y / 7.0).cos() + x) as f32
        })
        .collect();
    write_geotiff(
        &raster,
        &GeoRef::square(width, height, 30.0, [0.0, 0.0], "map"),
        &values,
    )
    .unwrap();
    raster
}

/// MaxEnt's horizon reaches the learner from the command line, and one shorter than
/// the demonstrations (which no path of theirs would fit) is refused by name.
#[test]
fn bench_terrain_takes_maxents_horizon_and_refuses_one_below_a_demonstration() {
    let dir = tempfile::tempdir().unwrap();
    let raster = waves_raster(dir.path());
    let run = |factor: &str| {
        imitate(
            dir.path(),
            &[
                "bench",
                "terrain",
                raster.to_str().unwrap(),
                "--teacher",
                "slope",
                "--method",
                "maxent",
                "--rounds",
                "3",
                "--paths",
                "16",
                "--horizon-factor",
                factor,
                "--json",
            ],
        )
    };
    let ratios: Vec<f64> = ["1", "3"]
        .iter()
        .map(|factor| {
            let out = run(factor);
            assert!(out.status.success(), "{}", stderr(&out));
            let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            let maxent = report["results"]
                .as_array()
                .unwrap()
                .iter()
                .find(|r| r["method"] == "maxent")
                .cloned()
                .unwrap();
            assert_eq!(maxent["rounds"], 3, "{maxent}");
            maxent["training_mean_cost_ratio"].as_f64().unwrap()
        })
        .collect();
    // Paths three times the demonstrations' length spread the visits: another cost.
    assert_ne!(ratios[0], ratios[1], "the horizon did not reach MaxEnt");
    let out = run("0.9");
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("--horizon-factor"),
        "{}",
        stderr(&out)
    );
}

/// `--hidden-cost-off-by` plans the held-out pairs on the hidden cost itself, off by a
/// smooth random factor: at 0 it is the teacher's own cost and plans its paths; with
/// `--method uniform` no learner runs.
#[test]
fn bench_terrain_plans_on_the_hidden_cost_off_by_a_smooth_factor() {
    let dir = tempfile::tempdir().unwrap();
    let raster = waves_raster(dir.path());
    let raster = raster.to_str().unwrap();
    let args = |off: &[&'static str]| {
        let mut args = vec![
            "bench",
            "terrain",
            raster,
            "--teacher",
            "threshold",
            "--method",
            "uniform",
            "--paths",
            "16",
            "--json",
        ];
        for epsilon in off {
            args.extend(["--hidden-cost-off-by", epsilon]);
        }
        args
    };
    let out = imitate(dir.path(), &args(&["0", "0.3"]));
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let results = report["results"].as_array().unwrap();
    let methods: Vec<&str> = results
        .iter()
        .map(|r| r["method"].as_str().unwrap())
        .collect();
    assert_eq!(
        methods,
        ["uniform", "hidden-cost-off-by", "hidden-cost-off-by"]
    );
    let (exact, off) = (&results[1], &results[2]);
    assert_eq!(exact["off_by"]["epsilon"], 0.0);
    assert_eq!(off["off_by"]["epsilon"], 0.3);
    assert_eq!(off["off_by"]["cells"], 4.0);
    assert_eq!(exact["held_out"], 4);
    assert_eq!(exact["within_radius"], 1.0, "{exact}");
    assert_eq!(exact["mean_cost_ratio"], 1.0, "{exact}");
    let ratio = off["mean_cost_ratio"].as_f64().unwrap();
    assert!(ratio >= 1.0, "{off}");
    let mut negative = args(&[]);
    negative.push("--hidden-cost-off-by=-1");
    let bad = imitate(dir.path(), &negative);
    assert_eq!(bad.status.code(), Some(2), "{}", stderr(&bad));
    assert!(
        stderr(&bad).contains("--hidden-cost-off-by"),
        "{}",
        stderr(&bad)
    );
}

/// `--features oracle` gives the learners the teacher's hidden cost itself: the
/// ceiling that tells a learner's shortfall from the features'. On the SPOT image's
/// step teacher, trees on it plan within a hair of the teacher's cost.
#[test]
fn bench_terrain_measures_the_learners_ceiling_on_the_hidden_cost() {
    let Some(rasters) = common::shared_data("raster") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let spot = rasters.join("osgeo_spot_chicago_utm.tif");
    let out = imitate(
        dir.path(),
        &[
            "bench",
            "terrain",
            spot.to_str().unwrap(),
            "--teacher",
            "threshold",
            "--method",
            "learch-tree",
            "--features",
            "oracle",
            "--cells",
            "80",
            "--paths",
            "24",
            "--json",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["features"], "oracle");
    let tree = method_result(&report, "learch-tree");
    let ratio = tree["mean_cost_ratio"].as_f64().unwrap();
    assert!((1.0 - 1e-9..1.02).contains(&ratio), "{tree}");
}

/// The quickstart maps with a land-cover layer: elevation cut into classes coded as
/// NLCD's, the last map without the highest class.
#[test]
fn a_land_cover_layer_gets_the_same_class_indicators_on_every_map() {
    use imitate::grid::Layer;
    use imitate::io::tables::{read_map, write_map};
    let ws = quickstart_workspace();
    const CODES: [f32; 5] = [11.0, 21.0, 41.0, 82.0, 90.0];
    let mut args: Vec<String> = vec!["ingest".into()];
    for m in 0..4 {
        let from = ws
            .path()
            .join(format!("testdata/world/maps/terrain-00{m}.parquet"));
        let mut map = read_map(&from).unwrap();
        let elevation = &map.layer("elevation").unwrap().values;
        let (lo, hi) = elevation
            .iter()
            .fold((f32::MAX, f32::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        let classes = if m == 3 { 4 } else { 5 };
        let values = elevation
            .iter()
            .map(|&v| {
                let k = ((v - lo) / (hi - lo) * classes as f32) as usize;
                CODES[k.min(classes - 1)]
            })
            .collect();
        map.layers.push(Layer::new("landcover", values));
        let to = ws.path().join(format!("terrain-00{m}.parquet"));
        write_map(&to, &map).unwrap();
        args.extend(["--map".into(), to.display().to_string()]);
    }
    args.extend(
        [
            "--demonstrations",
            "testdata/world/demonstrations.parquet",
            "--out",
            "ds",
        ]
        .map(String::from),
    );
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = imitate(ws.path(), &args);
    assert!(out.status.success(), "{}", stderr(&out));
    let out = imitate(
        ws.path(),
        &[
            "features",
            "--dataset",
            "ds",
            "--out",
            "fs",
            "--bank",
            "auto",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    // The 0/1 layers still get a hint; the land cover, which the bank now reads per
    // class, none.
    assert!(stderr(&out).contains("classes"), "{}", stderr(&out));
    assert!(!stderr(&out).contains("'landcover'"), "{}", stderr(&out));
    let features = ws.path().join("fs/features");
    let mut stacks = 0;
    for entry in std::fs::read_dir(&features).unwrap() {
        let path = entry.unwrap().path();
        let (_, stack, _) = imitate::io::tables::read_features(&path).unwrap();
        let indicators: Vec<&String> = stack
            .names
            .iter()
            .filter(|n| n.starts_with("landcover/class_"))
            .collect();
        let expected: Vec<String> = CODES
            .iter()
            .map(|c| format!("landcover/class_{c}"))
            .collect();
        assert_eq!(
            indicators,
            expected.iter().collect::<Vec<_>>(),
            "{}",
            path.display()
        );
        stacks += 1;
    }
    assert_eq!(stacks, 4);
}

/// A land cover as CORINE ships it, written by rasterio: 44 codes under a colour table.
/// The colour table declares them classes, so the bank indicates every one, past the 32
/// codes after which an undeclared integer layer is read as values. The same codes
/// without the table get none, and a hint with the operator that reads them as classes;
/// with GDAL's sidecar naming the classes, the indicators again.
#[test]
fn a_palette_land_cover_gets_an_indicator_per_class_past_32_codes() {
    use imitate::grid::LayerKind;
    let dir = tempfile::tempdir().unwrap();
    let Some(_) = python_script("land_cover.py", &[dir.path()]) else {
        return;
    };
    let ingest = |raster: &str| -> LayerKind {
        let ds = format!("{raster}-ds");
        let out = imitate(
            dir.path(),
            &[
                "ingest",
                "--map",
                &format!("{raster}.tif"),
                "--demonstrations",
                "demonstrations.parquet",
                "--out",
                &ds,
            ],
        );
        assert!(out.status.success(), "{}", stderr(&out));
        let map_path = dir.path().join(format!("{ds}/maps/{raster}.parquet"));
        imitate::io::tables::read_map(&map_path).unwrap().layers[0].kind
    };
    // The features of `raster`'s dataset with the bank and `ops`: how many class
    // indicators, and what the run said.
    let features = |raster: &str, out: &str, ops: &[&str]| -> (usize, String) {
        let ds = format!("{raster}-ds");
        let mut args = vec!["features", "--dataset", &ds, "--out", out, "--bank", "auto"];
        for op in ops {
            args.extend(["--op", op]);
        }
        let run = imitate(dir.path(), &args);
        assert!(run.status.success(), "{}", stderr(&run));
        let stack = dir.path().join(format!("{out}/features/{raster}.parquet"));
        let (_, stack, _) = imitate::io::tables::read_features(&stack).unwrap();
        let classes = stack
            .names
            .iter()
            .filter(|n| n.starts_with("band1/class_"))
            .count();
        (classes, stderr(&run))
    };
    assert_eq!(ingest("corine"), LayerKind::Classes);
    let (classes, said) = features("corine", "corine-fs", &[]);
    assert_eq!(classes, 44);
    assert!(!said.contains("integer codes"), "{said}");

    assert_eq!(ingest("codes"), LayerKind::Values);
    let (classes, said) = features("codes", "codes-fs", &[]);
    assert_eq!(classes, 0);
    assert!(
        said.contains("layer 'band1' holds 44 integer codes"),
        "{said}"
    );
    // The hint's operator, as the user would paste it, gives the indicators.
    let op = said
        .split_once("--op '")
        .and_then(|(_, rest)| rest.split_once('\''))
        .map(|(op, _)| op)
        .unwrap_or_else(|| panic!("{said}"));
    let (classes, said) = features("codes", "codes-hinted-fs", &[op]);
    assert_eq!(classes, 44);
    assert!(!said.contains("integer codes"), "{said}");

    // GDAL's sidecar declares them too where its attribute table names each class, not
    // where it only counts the values (as ArcGIS's table of any integer raster does).
    assert_eq!(ingest("labelled"), LayerKind::Classes);
    assert_eq!(features("labelled", "labelled-fs", &[]).0, 44);
    assert_eq!(ingest("counted"), LayerKind::Values);
    // The sidecar is an input: without it the dataset is stale and made again.
    std::fs::remove_file(dir.path().join("labelled.tif.aux.xml")).unwrap();
    assert_eq!(ingest("labelled"), LayerKind::Values);
}

/// `--wander`: the training demonstrations as tracks that drift around the teacher's
/// paths, which `--corridor auto` (the default) sees and retrains for; the report says
/// how far they wander and what was chosen.
#[test]
fn bench_terrain_trains_on_wandering_tracks_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let raster = waves_raster(dir.path());
    let run = |extra: &[&str]| {
        let mut args = vec!["bench", "terrain", raster.to_str().unwrap()];
        args.extend(["--teacher", "threshold", "--method", "learch-tree"]);
        args.extend(["--rounds", "20", "--paths", "16", "--json"]);
        args.extend(extra);
        imitate(dir.path(), &args)
    };
    let out = run(&["--wander", "1"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["wander"], 1.0, "{report}");
    let tree = method_result(&report, "learch-tree");
    let corridor = &tree["corridor"];
    assert_eq!(corridor["requested"], "auto", "{tree}");
    let share = corridor["plans_as_long"].as_f64().unwrap();
    let below = corridor["retrains_below"].as_f64().unwrap();
    assert_eq!(corridor["cells"], u64::from(share < below), "{tree}");
    assert!(share < 0.5, "tracks a cell off are rarely retraced: {tree}");
    // Exact paths report no wander.
    let out = run(&[]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(report.get("wander").is_none(), "{report}");
    let bad = run(&["--wander", "NaN"]);
    assert_eq!(bad.status.code(), Some(2), "{}", stderr(&bad));
    assert!(stderr(&bad).contains("--wander"), "{}", stderr(&bad));
}

/// The result of `method` in a `bench terrain --json` report (its first terrain).
fn method_result<'a>(report: &'a serde_json::Value, method: &str) -> &'a serde_json::Value {
    let results = report["results"].as_array().unwrap();
    (results.iter().find(|r| r["method"] == method))
        .unwrap_or_else(|| panic!("{method} in {report}"))
}

#[test]
fn inspect_shows_a_raster_as_imitate_reads_it_in_ground_metres() {
    // An Esri ASCII grid in degrees at 60° N (its CRS in the .prj beside it): a cell of
    // 0.01° spans about 558 m east and 1117 m north on the ground.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("north.asc"),
        "ncols 4\nnrows 2\nxllcorner 10\nyllcorner 59.99\ncellsize 0.01\n\
         NODATA_value -9999\n1.5 2 3 -9999\n4 5 6 7\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("north.prj"),
        r#"GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433],AUTHORITY["EPSG","4326"]]"#,
    )
    .unwrap();
    let out = imitate(dir.path(), &["inspect", "north.asc", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        (report["width"].as_u64(), report["height"].as_u64()),
        (Some(4), Some(2))
    );
    assert_eq!(report["units"], "degrees");
    let [east, north] = imitate::grid::metres_per_degree(60.0).map(|m| 0.01 * m);
    let metres = &report["cell_metres"];
    assert!((metres[0].as_f64().unwrap() - east).abs() < 0.5, "{metres}");
    assert!(
        (metres[1].as_f64().unwrap() - north).abs() < 0.5,
        "{metres}"
    );
    let layer = &report["layers"][0];
    assert_eq!(
        (layer["cells"].as_u64(), layer["nodata"].as_u64()),
        (Some(7), Some(1))
    );
    assert_eq!(
        (layer["min"].as_f64(), layer["max"].as_f64()),
        (Some(1.5), Some(7.0))
    );
    assert_eq!(layer["kind"], "values", "1.5 is not a class code");
    // As text, the same facts; a file that is not a raster is exit 2, named.
    let text = imitate(dir.path(), &["inspect", "north.asc"]);
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(
        text.contains("4 × 2 cells") && text.contains("degrees"),
        "{text}"
    );
    std::fs::write(dir.path().join("broken.tif"), b"II*\0junk").unwrap();
    let out = imitate(dir.path(), &["inspect", "broken.tif"]);
    assert_input_error(&out, &["broken.tif"]);
}
