//! `imitate diff`, `report` and `export` on quickstart artifacts, as a user runs them,
//! with the pictures checked by pixel statistics.

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::*;
use imitate::io::png::{Rgb, read_png};

/// A workspace with a dataset (`ds`), features (`fs`) and two costmaps: `costmap-40` (40 rounds),
/// `costmap-3` (3 rounds), and `costmap-40-copy`, identical to the first.
fn workspace() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = prepared_workspace();
        let run = |args: &[&str]| {
            let out = imitate(dir.path(), args);
            assert!(out.status.success(), "{args:?}: {}", stderr(&out));
        };
        for rounds in ["40", "3"] {
            let out = format!("costmap-{rounds}");
            run(&[
                "learch",
                "--dataset",
                "ds",
                "--features",
                "fs",
                "--rounds",
                rounds,
                "--holdout",
                "0.25",
                "--out",
                &out,
            ]);
        }
        copy_dir(
            &dir.path().join("costmap-40"),
            &dir.path().join("costmap-40-copy"),
        );
        dir
    })
    .path()
}

fn diff(args: &[&str]) -> std::process::Output {
    imitate(workspace(), &[&["diff"], args].concat())
}

fn json(output: &std::process::Output) -> serde_json::Value {
    serde_json::from_str(&stdout(output)).expect("JSON on stdout")
}

#[test]
fn different_training_changes_paths_and_thresholds_decide_the_exit_code() {
    let out = diff(&["costmap-40", "costmap-3", "--format", "json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report = json(&out);
    let summary = &report["summary"];
    assert!(
        summary["changed_paths"].as_f64().unwrap() >= 1.0,
        "{summary}"
    );
    assert!(
        summary["max_abs_log_cost"].as_f64().unwrap() > 0.1,
        "{summary}"
    );
    assert_eq!(summary["reference_paths"], 16.0);
    assert_eq!(report["costmaps"]["maps"].as_array().unwrap().len(), 4);

    let tight = diff(&["costmap-40", "costmap-3", "--fail-if", "changed_paths > 0"]);
    assert_eq!(tight.status.code(), Some(1), "{}", stderr(&tight));
    assert!(
        stderr(&tight).contains("changed_paths"),
        "{}",
        stderr(&tight)
    );
    let loose = diff(&[
        "costmap-40",
        "costmap-3",
        "--fail-if",
        "max_abs_log_cost > 50",
    ]);
    assert_eq!(loose.status.code(), Some(0), "{}", stderr(&loose));
    assert!(stdout(&loose).contains("changed"), "{}", stdout(&loose));
}

#[test]
fn identical_artifacts_show_no_change() {
    let out = diff(&[
        "costmap-40",
        "costmap-40-copy",
        "--format",
        "json",
        "--fail-if",
        "max_abs_log_cost > 0",
        "--fail-if",
        "changed_paths > 0",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let summary = json(&out)["summary"].clone();
    assert_eq!(summary["files_changed"], 0.0);
    assert_eq!(summary["changed_paths"], 0.0);
    assert_eq!(summary["min_rank_correlation"], 1.0);
}

fn colourful(picture: &Rgb, x0: u32, x1: u32) -> (usize, usize, usize) {
    let (mut red, mut blue, mut white) = (0, 0, 0);
    for y in 0..picture.height {
        for x in x0..x1 {
            match picture.get(x, y) {
                [255, 255, 255] => white += 1,
                [255, g, b] if g == b && g < 255 => red += 1,
                [r, _, 255] if r < 255 => blue += 1,
                _ => {}
            }
        }
    }
    (red, blue, white)
}

#[test]
fn markdown_diffs_carry_side_by_side_pictures() {
    let images = workspace().join("images-changed");
    let out = diff(&[
        "costmap-40",
        "costmap-3",
        "--format",
        "markdown",
        "--images",
        images.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let md = stdout(&out);
    assert!(md.contains("| map |") && md.contains("changed"), "{md}");
    assert!(
        md.contains(&format!("({})", images.join("terrain-002.png").display())),
        "{md}"
    );
    let picture = read_png(&images.join("terrain-002.png")).unwrap();
    // Three 256-pixel panels and the histogram of the change per cell, 8 pixels apart.
    assert_eq!((picture.width, picture.height), (3 * 256 + 360 + 24, 256));
    let (red, blue, _) = colourful(&picture, 2 * 264, 3 * 264);
    assert!(
        red > 100 && blue > 100,
        "difference panel: {red} red, {blue} blue"
    );
    // The histogram is a chart: title, tick labels and axis descriptions in dark text.
    let text = (0..picture.height)
        .flat_map(|y| (3 * 264..picture.width).map(move |x| (x, y)))
        .filter(|&(x, y)| picture.get(x, y).iter().all(|&v| v < 80))
        .count();
    assert!(text > 500, "{text} dark pixels in the histogram");
    // The old and new panels are costmaps, not blank: many distinct colours.
    let mut colours = std::collections::BTreeSet::new();
    for y in 0..256 {
        for x in 0..256 {
            colours.insert(picture.get(x, y));
        }
    }
    assert!(colours.len() > 50, "{} colours", colours.len());

    let same = workspace().join("images-same");
    let out = diff(&[
        "costmap-40",
        "costmap-40-copy",
        "--format",
        "markdown",
        "--images",
        same.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let picture = read_png(&same.join("terrain-000.png")).unwrap();
    let (red, blue, white) = colourful(&picture, 2 * 264, 2 * 264 + 256);
    assert_eq!(
        (red, blue, white),
        (0, 0, 256 * 256),
        "no change: a white difference panel"
    );
}

#[test]
fn diffing_incompatible_things_is_an_input_error() {
    let out = diff(&["costmap-40", "ds"]);
    assert_input_error(&out, &["cannot diff", "costmap", "dataset"]);
    let out = diff(&["costmap-40", "no-such-folder"]);
    assert_input_error(&out, &["no-such-folder"]);
    let out = diff(&["costmap-40", "deadbeef"]);
    assert_input_error(&out, &["deadbeef", "stored version"]);

    let future = workspace().join("costmap-future");
    if !future.exists() {
        copy_dir(&workspace().join("costmap-40"), &future);
        let manifest = future.join("manifest.json");
        let text = std::fs::read_to_string(&manifest).unwrap();
        std::fs::write(
            &manifest,
            text.replace(
                "\"schema_version\": \"1.0.0\"",
                "\"schema_version\": \"2.0.0\"",
            ),
        )
        .unwrap();
    }
    let out = diff(&["costmap-40", "costmap-future"]);
    assert_input_error(&out, &["incompatible schemas", "2.0.0"]);
}

fn exported(dir: &str) -> PathBuf {
    let out_dir = workspace().join(dir);
    if !out_dir.exists() {
        let out = imitate(
            workspace(),
            &["export", "costmap-40", "--out", dir, "--map", "terrain-001"],
        );
        assert!(out.status.success(), "{}", stderr(&out));
        // An artifact: its manifest lists the three files.
        assert!(stdout(&out).starts_with("export\t"), "{}", stdout(&out));
        let manifest =
            std::fs::read_to_string(workspace().join(dir).join("manifest.json")).unwrap();
        for file in ["terrain-001.png", "terrain-001.tif", "terrain-001.mcap"] {
            assert!(manifest.contains(file), "{manifest}");
        }
    }
    out_dir
}

#[test]
fn exports_read_back_through_our_readers() {
    let dir = exported("export");
    let (_, costs) = imitate::io::tables::read_costmap(
        &workspace().join("costmap-40/costmaps/terrain-001.parquet"),
    )
    .unwrap();

    let tiff = imitate::io::geotiff::read_geotiff(&dir.join("terrain-001.tif"), "t").unwrap();
    assert_eq!(tiff.geo.width, costs.geo.width);
    assert_eq!(tiff.geo.origin, costs.geo.origin);
    assert_eq!(tiff.layers[0].values, costs.data);

    // The PNG: costmap, then a colour bar, costly (yellow) at the top, labelled on its
    // right (8-pixel margins, a 14-pixel bar, 74 pixels of labels, 36 under the map
    // for the scale bar).
    let png = read_png(&dir.join("terrain-001.png")).unwrap();
    let bar = png.width - 8 - 74 - 7;
    let (top, bottom) = (8, png.height - 36 - 1);
    assert!(png.get(bar, top)[1] > png.get(bar, bottom)[1] + 100);
    let dark = |x0: u32, x1: u32, y0: u32, y1: u32| {
        (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .filter(|&(x, y)| png.get(x, y).iter().all(|&v| v < 90))
            .count()
    };
    assert!(
        dark(png.width - 82, png.width, 0, png.height) > 100,
        "cost labels"
    );
    assert!(
        dark(0, png.width / 2, bottom + 1, png.height) > 50,
        "scale bar"
    );

    // The MCAP: the foxglove.Grid holds the exact costs, the paths the demonstrations.
    let log = dir.join("terrain-001.mcap");
    let mut grid = None;
    let mut grid_map = None;
    let mut demonstrations = Vec::new();
    let decoders = imitate::io::mcap::Decoders::default();
    imitate::io::mcap::scan(&log, |event| {
        if let imitate::io::mcap::Event::Message { channel, data, .. } = event {
            let value = decoders.get(channel).unwrap().decode(data).unwrap();
            match channel.topic.as_str() {
                "/costmap" => {
                    grid =
                        Some(imitate::io::mcap::ros2::grid("foxglove.Grid", &value, "g").unwrap())
                }
                "/grid_map" => {
                    grid_map = Some(
                        imitate::io::mcap::ros2::grid("grid_map_msgs/msg/GridMap", &value, "g")
                            .unwrap(),
                    )
                }
                "/demonstrations" => demonstrations
                    .push(imitate::io::mcap::ros2::poses("nav_msgs/msg/Path", &value, 0).unwrap()),
                _ => {}
            }
        }
        Ok(())
    })
    .unwrap();
    let grid = grid.expect("a /costmap message");
    assert_eq!(grid.geo, costs.geo);
    assert_eq!(grid.layers[0].name, "cost");
    assert_eq!(grid.layers[0].values, costs.data);
    // grid_map_msgs/GridMap, the layer format of ROS navigation stacks: the same costs.
    let grid_map = grid_map.expect("a /grid_map message");
    assert_eq!(grid_map.geo.origin, costs.geo.origin);
    assert_eq!(grid_map.layers[0].name, "cost");
    let finite: Vec<f32> = costs
        .data
        .iter()
        .map(|&c| if c.is_finite() { c } else { f32::NAN })
        .collect();
    assert!(
        grid_map.layers[0]
            .values
            .iter()
            .zip(&finite)
            .all(|(a, b)| a == b || (a.is_nan() && b.is_nan()))
    );
    let paths =
        imitate::io::tables::read_paths(&workspace().join("costmap-40/paths.parquet")).unwrap();
    let on_map: Vec<_> = paths.iter().filter(|p| p.map == "terrain-001").collect();
    assert_eq!(demonstrations.len(), on_map.len());
    for (poses, path) in demonstrations.iter().zip(&on_map) {
        let cells: Vec<_> = poses
            .iter()
            .map(|p| costs.geo.cell_of(p.x, p.y).unwrap())
            .collect();
        assert_eq!(cells, path.cells.to_vec());
    }
}

/// A costmap as a Nav2 map: the YAML and PGM map_server reads, read back by our reader
/// (as `ingest --map F.yaml` does) on the costmap's grid, occupancy rising with cost.
#[test]
fn costmaps_export_as_nav2_maps_that_read_back() {
    let out = imitate(
        workspace(),
        &[
            "export",
            "costmap-40",
            "--out",
            "nav2",
            "--map",
            "terrain-001",
            "--format",
            "nav2",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let dir = workspace().join("nav2");
    assert!(dir.join("terrain-001.pgm").exists());
    let yaml = std::fs::read_to_string(dir.join("terrain-001.yaml")).unwrap();
    assert!(
        yaml.contains("mode: scale") && yaml.contains("image: terrain-001.pgm"),
        "{yaml}"
    );
    let (_, costs) = imitate::io::tables::read_costmap(
        &workspace().join("costmap-40/costmaps/terrain-001.parquet"),
    )
    .unwrap();
    let map = imitate::io::nav2::read_nav2_map(&dir.join("terrain-001.yaml"), "t").unwrap();
    assert_eq!(
        (map.geo.width, map.geo.height),
        (costs.geo.width, costs.geo.height)
    );
    assert_eq!(map.geo.origin, costs.geo.origin);
    assert_eq!(map.geo.resolution, costs.geo.resolution);
    let occupancy = &map.layers[0].values;
    let mut order: Vec<usize> = (0..occupancy.len()).collect();
    order.sort_by(|&a, &b| costs.data[a].total_cmp(&costs.data[b]));
    let (cheap, dear) = (order[0], order[order.len() - 1]);
    assert!(
        occupancy[cheap] < occupancy[dear],
        "{} vs {}",
        occupancy[cheap],
        occupancy[dear]
    );
    assert!(occupancy.iter().all(|v| (0.0..=100.0).contains(v)));
}

#[test]
fn exported_logs_read_in_python() {
    let probe = std::process::Command::new("python3")
        .args(["-c", "import mcap, mcap_ros2"])
        .output();
    if !probe.is_ok_and(|o| o.status.success()) {
        eprintln!("skipped: Python's mcap and mcap-ros2-support are not installed");
        return;
    }
    let log = exported("export-python").join("terrain-001.mcap");
    let script = r#"
import sys
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
reader = make_reader(open(sys.argv[1], "rb"), decoder_factories=[DecoderFactory()])
counts = {}
for schema, channel, message, decoded in reader.iter_decoded_messages(topics=["/map", "/demonstrations", "/plans"]):
    counts[channel.topic] = counts.get(channel.topic, 0) + 1
    if channel.topic == "/map":
        assert decoded.info.width == 64 and len(decoded.data) == 64 * 64
        assert all(0 <= v <= 100 for v in decoded.data)
print(counts["/map"], counts["/demonstrations"], counts["/plans"])
"#;
    let out = std::process::Command::new("python3")
        .args(["-c", script, log.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let counts: Vec<u32> = stdout(&out)
        .split_whitespace()
        .map(|n| n.parse().unwrap())
        .collect();
    assert_eq!(counts[0], 1);
    assert!(counts[1] > 0 && counts[1] == counts[2], "{counts:?}");
}

#[test]
fn reports_have_pictures_and_metrics() {
    let out = imitate(workspace(), &["report", "costmap-40", "--out", "report"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let dir = workspace().join("report");
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(md.contains("| held out | 16 |"), "{md}");
    // The exact quickstart demonstrations: `--corridor auto` kept the first model.
    assert!(md.contains("Corridor: none (`auto`)."), "{md}");
    for line in md.lines().filter(|l| l.starts_with("![")) {
        let file = line.split('(').nth(1).unwrap().trim_end_matches(')');
        assert!(dir.join(file).is_file(), "{file}");
    }
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert_eq!(html.matches("data:image/png;base64,").count(), 5);
    // The learning curves are drawn: red and blue lines on white.
    let curves = read_png(&dir.join("learning-curves.png")).unwrap();
    let mut red = 0;
    let mut blue = 0;
    for y in 0..curves.height {
        for x in 0..curves.width {
            match curves.get(x, y) {
                [200, 40, 40] => red += 1,
                [40, 90, 200] => blue += 1,
                _ => {}
            }
        }
    }
    assert!(red > 200 && blue > 200, "{red} red, {blue} blue pixels");
}
