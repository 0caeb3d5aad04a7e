//! `imitate ingest` from other people's tables: renamed columns, list elements, integer
//! episode ids, LeRobot v2 and v3 dataset folders.

mod common;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow::array::{
    ArrayRef, FixedSizeListArray, Float32Array, Float64Array, Int64Array, RecordBatch,
};
use arrow::datatypes::{DataType, Field, Schema};
use common::*;
use imitate::grid::Demonstration;

/// terrain-000's teacher episodes from the committed world.
fn terrain_000() -> Vec<Demonstration> {
    imitate::io::demo_tables::read_demonstrations(
        &repo().join("testdata/world/demonstrations.parquet"),
    )
    .unwrap()
    .into_iter()
    .filter(|d| d.map == "terrain-000")
    .collect()
}

fn write_parquet(path: &Path, batch: &RecordBatch) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let file = std::fs::File::create(path).unwrap();
    let mut writer = parquet::arrow::ArrowWriter::try_new(file, batch.schema(), None).unwrap();
    writer.write(batch).unwrap();
    writer.close().unwrap();
}

/// LeRobot-style rows: episode_index, frame_index, timestamp, observation.state [x, y, yaw].
fn lerobot_rows(demos: &[(i64, &Demonstration)]) -> RecordBatch {
    let rows: Vec<(i64, usize, &imitate::grid::Pose)> = demos
        .iter()
        .flat_map(|(i, d)| d.poses.iter().enumerate().map(move |(k, p)| (*i, k, p)))
        .collect();
    let state: Vec<f32> = rows
        .iter()
        .flat_map(|(_, _, p)| [p.x as f32, p.y as f32, p.yaw.unwrap_or(0.0) as f32])
        .collect();
    let item = Arc::new(Field::new("item", DataType::Float32, true));
    let state = FixedSizeListArray::new(item.clone(), 3, Arc::new(Float32Array::from(state)), None);
    let schema = Schema::new(vec![
        Field::new("observation.state", DataType::FixedSizeList(item, 3), false),
        Field::new("timestamp", DataType::Float32, false),
        Field::new("frame_index", DataType::Int64, false),
        Field::new("episode_index", DataType::Int64, false),
    ]);
    let columns: Vec<ArrayRef> = vec![
        Arc::new(state),
        Arc::new(Float32Array::from_iter_values(
            rows.iter().map(|r| r.2.t as f32),
        )),
        Arc::new(Int64Array::from_iter_values(
            rows.iter().map(|r| r.1 as i64),
        )),
        Arc::new(Int64Array::from_iter_values(rows.iter().map(|r| r.0))),
    ];
    RecordBatch::try_new(Arc::new(schema), columns).unwrap()
}

fn write_info(dir: &Path, version: &str) {
    let info = serde_json::json!({
        "codebase_version": version,
        "fps": 1,
        "features": {
            "observation.state": {"dtype": "float32", "shape": [3], "names": ["x", "y", "yaw"]},
            "timestamp": {"dtype": "float32", "shape": [1], "names": null},
        },
    });
    std::fs::create_dir_all(dir.join("meta")).unwrap();
    std::fs::write(dir.join("meta/info.json"), info.to_string()).unwrap();
}

/// The cell paths of an ingested dataset, in episode order.
fn cells(dataset: &Path) -> Vec<Vec<imitate::grid::Cell>> {
    imitate::io::tables::read_paths(&dataset.join("paths.parquet"))
        .unwrap()
        .into_iter()
        .map(|p| p.cells.to_vec())
        .collect()
}

fn ingest(dir: &Path, args: &[&str]) -> std::process::Output {
    let map = repo().join("testdata/world/maps/terrain-000.parquet");
    let mut all = vec!["ingest", "--map", map.to_str().unwrap()];
    all.extend_from_slice(args);
    imitate(dir, &all)
}

#[test]
fn lerobot_v2_and_v3_datasets_ingest_like_the_original_table() {
    let dir = tempfile::tempdir().unwrap();
    let demos = terrain_000();
    let indexed: Vec<(i64, &Demonstration)> = demos
        .iter()
        .enumerate()
        .map(|(i, d)| (i as i64, d))
        .collect();

    let v2 = dir.path().join("drive_v2");
    write_info(&v2, "v2.1");
    for (i, demo) in &indexed {
        write_parquet(
            &v2.join(format!("data/chunk-000/episode_{i:06}.parquet")),
            &lerobot_rows(&[(*i, *demo)]),
        );
    }
    let v3 = dir.path().join("drive_v3");
    write_info(&v3, "v3.0");
    let (first, second) = indexed.split_at(7);
    write_parquet(
        &v3.join("data/chunk-000/file-000.parquet"),
        &lerobot_rows(first),
    );
    write_parquet(
        &v3.join("data/chunk-000/file-001.parquet"),
        &lerobot_rows(second),
    );

    let table = dir.path().join("table");
    let out = ingest(
        dir.path(),
        &[
            "--demonstrations",
            repo()
                .join("testdata/world/demonstrations.parquet")
                .to_str()
                .unwrap(),
            "--default-map",
            "terrain-000",
            "--out",
            table.to_str().unwrap(),
        ],
    );
    // The world's table holds other maps' episodes too: they are refused by name.
    assert_input_error(&out, &["terrain-001", "not among the maps given"]);

    let one_map = dir.path().join("one_map.parquet");
    imitate::io::tables::write_demonstrations(&one_map, &demos).unwrap();
    let out = ingest(
        dir.path(),
        &[
            "--demonstrations",
            one_map.to_str().unwrap(),
            "--out",
            table.to_str().unwrap(),
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));

    for (name, folder) in [("v2", &v2), ("v3", &v3)] {
        let dataset = dir.path().join(format!("from_{name}"));
        let out = ingest(
            dir.path(),
            &[
                "--lerobot",
                folder.to_str().unwrap(),
                "--out",
                dataset.to_str().unwrap(),
            ],
        );
        assert!(out.status.success(), "{name}: {}", stderr(&out));
        assert_eq!(cells(&dataset), cells(&table), "{name}");
        let names: Vec<String> =
            imitate::io::demo_tables::read_demonstrations(&dataset.join("demonstrations.parquet"))
                .unwrap()
                .into_iter()
                .map(|d| d.episode)
                .collect();
        assert_eq!(names[3], format!("drive_{name}-episode-3"));
    }
}

#[test]
fn renamed_columns_and_a_default_map_read_other_peoples_tables() {
    let dir = tempfile::tempdir().unwrap();
    let demos = terrain_000();
    let rows: Vec<(i64, &imitate::grid::Pose)> = demos
        .iter()
        .enumerate()
        .flat_map(|(i, d)| d.poses.iter().map(move |p| (i as i64, p)))
        .collect();
    let schema = Schema::new(vec![
        Field::new("trajectory", DataType::Int64, false),
        Field::new("time_s", DataType::Float64, false),
        Field::new("px", DataType::Float64, false),
        Field::new("py", DataType::Float64, false),
    ]);
    let columns: Vec<ArrayRef> = vec![
        Arc::new(Int64Array::from_iter_values(rows.iter().map(|r| r.0))),
        Arc::new(Float64Array::from_iter_values(rows.iter().map(|r| r.1.t))),
        Arc::new(Float64Array::from_iter_values(rows.iter().map(|r| r.1.x))),
        Arc::new(Float64Array::from_iter_values(rows.iter().map(|r| r.1.y))),
    ];
    let table = dir.path().join("theirs.parquet");
    write_parquet(
        &table,
        &RecordBatch::try_new(Arc::new(schema), columns).unwrap(),
    );
    let table = table.to_str().unwrap();

    let out = ingest(dir.path(), &["--demonstrations", table, "--out", "ds"]);
    assert_input_error(
        &out,
        &[
            "theirs.parquet",
            "no column 't'",
            "trajectory, time_s, px, py",
        ],
    );
    // Without an episode column the table is one episode: its trajectories' times
    // restart, and the error says which column to name.
    let out = ingest(
        dir.path(),
        &[
            "--demonstrations",
            table,
            "--column",
            "t=time_s",
            "--column",
            "x=px",
            "--column",
            "y=py",
            "--out",
            "ds",
        ],
    );
    assert_input_error(
        &out,
        &[
            "theirs.parquet",
            "goes back in time",
            "--column episode=COLUMN",
        ],
    );

    let renamed = [
        "--column",
        "episode=trajectory",
        "--column",
        "t=time_s",
        "--column",
        "x=px",
        "--column",
        "y=py",
    ];
    let out = ingest(
        dir.path(),
        &[&["--demonstrations", table, "--out", "ds"], &renamed[..]].concat(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("1 maps, 16 demonstrations"),
        "{}",
        stderr(&out)
    );

    let list_of_px = [&renamed[..6], &["--column", "x=px[0]"]].concat();
    let out = ingest(
        dir.path(),
        &[
            &["--demonstrations", table, "--out", "ds2"],
            &list_of_px[..],
        ]
        .concat(),
    );
    assert_input_error(&out, &["theirs.parquet", "needs a list column"]);
    let out = ingest(
        dir.path(),
        &[
            "--demonstrations",
            table,
            "--column",
            "speed=v",
            "--out",
            "ds2",
        ],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("unknown column role 'speed'"),
        "{}",
        stderr(&out)
    );
}

/// `--cells` and `--cell-size` coarsen every map by whole blocks before the
/// demonstrations are laid on it: the same dataset either way, block means of the
/// layers, paths on the coarse grid, and a stack that learns.
#[test]
fn maps_coarsened_at_ingest_carry_the_demonstrations_on_their_cells() {
    let dir = tempfile::tempdir().unwrap();
    let world = repo().join("testdata/world");
    let maps: Vec<String> = (0..4)
        .map(|i| world.join(format!("maps/terrain-{i:03}.parquet")))
        .map(|p| p.to_str().unwrap().to_string())
        .collect();
    let table = world.join("demonstrations.parquet");
    let run = |out: &str, extra: &[&str]| {
        let mut args = vec!["ingest", "--map"];
        args.extend(maps.iter().map(String::as_str));
        args.extend(["--demonstrations", table.to_str().unwrap(), "--out", out]);
        args.extend_from_slice(extra);
        imitate(dir.path(), &args)
    };
    let out = run("by-cells", &["--cells", "16"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let out = run("by-metres", &["--cell-size", "4.3"]);
    assert!(out.status.success(), "{}", stderr(&out));
    for file in ["maps/terrain-000.parquet", "paths.parquet"] {
        let read = |ds: &str| std::fs::read(dir.path().join(ds).join(file)).unwrap();
        assert_eq!(read("by-cells"), read("by-metres"), "{file}");
    }

    let fine = imitate::io::tables::read_map(&world.join("maps/terrain-000.parquet")).unwrap();
    let coarse =
        imitate::io::tables::read_map(&dir.path().join("by-cells/maps/terrain-000.parquet"))
            .unwrap();
    assert_eq!((coarse.geo.width, coarse.geo.height), (16, 16));
    assert_eq!(coarse.geo.cell_size(), [4.0, 4.0]);
    assert_eq!(coarse.geo.origin, fine.geo.origin);
    let (layer, coarse_layer) = (&fine.layers[0], &coarse.layers[0]);
    if layer.classes().is_none() {
        let mean: f64 = (0..4)
            .flat_map(|r| (0..4).map(move |c| r * 64 + c))
            .map(|i| f64::from(layer.values[i]))
            .sum::<f64>()
            / 16.0;
        assert!((f64::from(coarse_layer.values[0]) - mean).abs() < 1e-4);
    }
    let demos = imitate::io::demo_tables::read_demonstrations(&table).unwrap();
    let first = demos.iter().find(|d| d.map == "terrain-000").unwrap();
    let expected = imitate::grid::rasterize(&coarse.geo, &first.xy()).unwrap();
    let paths =
        imitate::io::tables::read_paths(&dir.path().join("by-cells/paths.parquet")).unwrap();
    let path = paths.iter().find(|p| p.episode == first.episode).unwrap();
    assert_eq!(path.cells.to_vec(), expected.to_vec());

    let features = imitate(
        dir.path(),
        &[
            "features",
            "--dataset",
            "by-cells",
            "--bank",
            "auto",
            "--out",
            "fs",
        ],
    );
    assert!(features.status.success(), "{}", stderr(&features));
    let learned = imitate(
        dir.path(),
        &[
            "learch",
            "--dataset",
            "by-cells",
            "--features",
            "fs",
            "--rounds",
            "4",
            "--out",
            "cm",
        ],
    );
    assert!(learned.status.success(), "{}", stderr(&learned));

    for (flags, needle) in [
        (
            &["--cell-size", "0"][..],
            "cell_size must be a positive number of metres",
        ),
        (
            &["--cell-size=-2"][..],
            "cell_size must be a positive number of metres",
        ),
        (
            &["--cells", "8", "--cell-size", "4"][..],
            "cannot be used with",
        ),
    ] {
        let out = run("bad", flags);
        assert_eq!(out.status.code(), Some(2), "{flags:?}");
        assert!(stderr(&out).contains(needle), "{flags:?}: {}", stderr(&out));
        assert!(!dir.path().join("bad").exists());
    }
}

/// A track logged many times a cell (as a robot's pose topic is, at 10–50 Hz) crosses
/// a cell's row and column edges one pose apart on every diagonal drive. Ingest reads
/// it as the drive the planner would take, not as a staircase of orthogonal steps: the
/// world's teacher episodes, logged ten times between each of their poses, give paths
/// about as long as the sparse poses joined by lines, where the staircase is longer by
/// a tenth or more.
#[test]
fn a_densely_logged_track_is_read_without_its_staircase() {
    let dir = tempfile::tempdir().unwrap();
    let world = repo().join("testdata/world");
    let sparse = terrain_000();
    let dense: Vec<Demonstration> = sparse
        .iter()
        .map(|d| {
            let mut dense = d.clone();
            dense.poses = d
                .poses
                .windows(2)
                .flat_map(|w| {
                    (0..10).map(move |k| {
                        let s = f64::from(k) / 10.0;
                        imitate::grid::Pose {
                            t: w[0].t + s * (w[1].t - w[0].t),
                            x: w[0].x + s * (w[1].x - w[0].x),
                            y: w[0].y + s * (w[1].y - w[0].y),
                            yaw: None,
                        }
                    })
                })
                .chain(d.poses.last().cloned())
                .collect();
            dense
        })
        .collect();
    imitate::io::tables::write_demonstrations(&dir.path().join("dense.parquet"), &dense).unwrap();
    let map = world.join("maps/terrain-000.parquet");
    let out = imitate(
        dir.path(),
        &[
            "ingest",
            "--map",
            map.to_str().unwrap(),
            "--demonstrations",
            "dense.parquet",
            "--out",
            "ds",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let geo = imitate::io::tables::read_map(&map).unwrap().geo;
    let paths = imitate::io::tables::read_paths(&dir.path().join("ds/paths.parquet")).unwrap();
    let (mut read, mut joined, mut staircase) = (0, 0, 0);
    for d in &dense {
        let path = paths.iter().find(|p| p.episode == d.episode).unwrap();
        assert!(imitate::grid::is_connected8(&path.cells), "{}", d.episode);
        read += path.cells.len();
        let original = sparse.iter().find(|s| s.episode == d.episode).unwrap();
        joined += imitate::grid::rasterize(&geo, &original.xy())
            .unwrap()
            .len();
        staircase += imitate::grid::rasterize_polyline(&geo, &d.xy())
            .unwrap()
            .len();
    }
    let (read, joined, staircase) = (read as f64, joined as f64, staircase as f64);
    assert!(
        read <= 1.02 * joined && staircase >= 1.1 * joined,
        "cells read {read}, sparse poses joined {joined}, the staircase {staircase}"
    );
}

/// A hiker's GPS tracks as their apps export them (GPX 1.1 with repeated one-second
/// stamps and a lone fix, GPX 1.0 with course and speed and no times, both by gpxpy) on a
/// DEM in UTM: every segment of two fixes or more is an episode, its fixes moved from
/// longitude and latitude onto the cells rasterio's PROJ puts them in.
#[test]
fn gps_tracks_in_gpx_files_land_on_a_utm_dem() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("gpx_tracks.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    let text = |value: &serde_json::Value| value.as_str().unwrap().to_string();
    let raster = text(&info["raster"]);
    let gpx: Vec<String> = info["gpx"].as_array().unwrap().iter().map(text).collect();
    let mut args = vec!["ingest", "--map", &raster, "--gpx"];
    args.extend(gpx.iter().map(String::as_str));
    args.extend(["--out", "ds"]);
    let out = imitate(dir.path(), &args);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(!stderr(&out).contains("wander"), "{}", stderr(&out));
    let paths = imitate::io::tables::read_paths(&dir.path().join("ds/paths.parquet")).unwrap();
    let ends = info["ends"].as_object().unwrap();
    let names: Vec<&str> = paths.iter().map(|p| p.episode.as_str()).collect();
    assert_eq!(
        names,
        ["ridge-track-000", "ridge-track-001-000", "valley-track-000"]
    );
    for path in &paths {
        let cell = |c: &imitate::grid::Cell| serde_json::json!([c.row, c.col]);
        let (first, last) = (&path.cells[0], &path.cells[path.cells.len() - 1]);
        assert_eq!(
            serde_json::json!([cell(first), cell(last)]),
            ends[&path.episode],
            "{}",
            path.episode
        );
    }
    let demos = imitate::io::demo_tables::read_demonstrations(
        &dir.path().join("ds/demonstrations.parquet"),
    )
    .unwrap();
    let times: Vec<f64> = demos[0].poses.iter().take(4).map(|p| p.t).collect();
    assert_eq!(times, [0.0, 0.5, 1.0, 2.0]);

    // On 1 m cells the fixes' few metres of error span several: a warning says so.
    let fine = text(&info["fine"]);
    let out = imitate(
        dir.path(),
        &["ingest", "--map", &fine, "--gpx", &gpx[0], "--out", "fine"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("cells of 1.00 m: GPS fixes"),
        "{}",
        stderr(&out)
    );

    // Tracks on a map with no CRS cannot be placed; a file that is not GPX is named.
    let out = ingest(dir.path(), &["--gpx", &gpx[0], "--out", "nowhere"]);
    assert_input_error(
        &out,
        &["GPX tracks (WGS84)", "terrain-000", "names no EPSG code"],
    );
    let kml = dir.path().join("track.kml");
    std::fs::write(&kml, "<kml><Document/></kml>").unwrap();
    let out = ingest(
        dir.path(),
        &["--gpx", kml.to_str().unwrap(), "--out", "nowhere"],
    );
    assert_input_error(&out, &["track.kml", "root element is <kml>"]);
    assert!(!dir.path().join("nowhere").exists());
}

/// Routes an expert drew over a map in QGIS, saved as GeoJSON by GDAL's OGR: in the
/// layer's UTM CRS (a legacy crs member) and as RFC 7946 longitude and latitude, a
/// MultiLineString among them; as GeoPackage line layers (QGIS's default), in UTM
/// and in WGS 84, with Z; and as KML and KMZ from GDAL's KML and LIBKML drivers. All
/// give the same episodes on the same cells.
#[test]
fn routes_drawn_in_qgis_as_geojson_are_demonstrations() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("drawn_paths.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    let text = |key: &str| info[key].as_str().unwrap().to_string();
    let raster = text("raster");
    for kind in ["utm", "wgs84"] {
        let file = text(kind);
        let out = imitate(
            dir.path(),
            &[
                "ingest",
                "--map",
                &raster,
                "--geojson",
                &file,
                "--out",
                kind,
            ],
        );
        assert!(out.status.success(), "{kind}: {}", stderr(&out));
    }
    // The same routes as GeoPackage line layers (with Z), in UTM and in WGS 84.
    for kind in ["gpkg_utm", "gpkg_wgs84"] {
        let file = text(kind);
        let out = imitate(
            dir.path(),
            &["ingest", "--map", &raster, "--gpkg", &file, "--out", kind],
        );
        assert!(out.status.success(), "{kind}: {}", stderr(&out));
    }
    // And as Google Earth keeps them: KML from GDAL's two drivers, and a KMZ.
    for kind in ["kml", "libkml", "kmz"] {
        let file = text(kind);
        let out = imitate(
            dir.path(),
            &["ingest", "--map", &raster, "--kml", &file, "--out", kind],
        );
        assert!(out.status.success(), "{kind}: {}", stderr(&out));
    }
    let paths = |kind: &str| std::fs::read(dir.path().join(kind).join("paths.parquet")).unwrap();
    for kind in ["wgs84", "gpkg_utm", "gpkg_wgs84", "kml", "libkml", "kmz"] {
        assert_eq!(paths("utm"), paths(kind), "{kind}");
    }
    let read = imitate::io::tables::read_paths(&dir.path().join("utm/paths.parquet")).unwrap();
    // The first two routes as a recorded track's points (GDAL's GeoJSON of a GPX
    // file's track_points): tracks named by their track_fid, on the same cells.
    let out = imitate(
        dir.path(),
        &[
            "ingest",
            "--map",
            &raster,
            "--geojson",
            &text("track_points"),
            "--out",
            "track_points",
        ],
    );
    assert!(out.status.success(), "track points: {}", stderr(&out));
    let tracks =
        imitate::io::tables::read_paths(&dir.path().join("track_points/paths.parquet")).unwrap();
    let names: Vec<&str> = tracks.iter().map(|p| p.episode.as_str()).collect();
    assert_eq!(names, ["track_points-track-000", "track_points-track-001"]);
    assert_eq!(tracks[0].cells, read[0].cells);
    assert_eq!(tracks[1].cells, read[1].cells);
    let timed = imitate::io::demo_tables::read_demonstrations(
        &dir.path().join("track_points/demonstrations.parquet"),
    )
    .unwrap();
    let times: Vec<f64> = timed[0].poses.iter().map(|p| p.t).collect();
    assert_eq!(times, [0.0, 3.0, 6.0], "timed by the fixes' time");
    let names: Vec<&str> = read.iter().map(|p| p.episode.as_str()).collect();
    let episodes: Vec<String> = serde_json::from_value(info["episodes"].clone()).unwrap();
    assert_eq!(names, episodes);
    // The first route's first and last vertices, in cells (rows from the south edge).
    let first = &read[0].cells;
    assert_eq!(
        (first[0], first[first.len() - 1]),
        (
            imitate::grid::Cell::new(47, 3),
            imitate::grid::Cell::new(24, 60)
        )
    );
    // LEARCH takes them as routes of sparse vertices, re-planned between them.
    for command in [
        "features --dataset utm --bank auto --out fs",
        "learch --dataset utm --features fs --out costmap --rounds 4",
    ] {
        let out = imitate(dir.path(), &command.split(' ').collect::<Vec<_>>());
        assert!(out.status.success(), "{command}: {}", stderr(&out));
    }
    let metrics = std::fs::read_to_string(dir.path().join("costmap/metrics.json")).unwrap();
    let metrics: serde_json::Value = serde_json::from_str(&metrics).unwrap();
    assert_eq!(metrics["drawn_routes"], 4);

    // A file with no lines, and a crs member that names no EPSG code, are named.
    let points = dir.path().join("points.geojson");
    std::fs::write(
        &points,
        r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":[7.7,46.58]}}]}"#,
    )
    .unwrap();
    let odd = dir.path().join("odd.geojson");
    std::fs::write(
        &odd,
        r#"{"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"my local grid"}},"features":[]}"#,
    )
    .unwrap();
    let points_gpkg = PathBuf::from(text("points_gpkg"));
    for (flag, file, says) in [
        ("--geojson", &points, "has 1 point(s); a path needs 2"),
        ("--geojson", &odd, "names 'my local grid', not an EPSG code"),
        (
            "--gpkg",
            &points_gpkg,
            "holds no LineString or MultiLineString",
        ),
        ("--gpkg", &PathBuf::from(&raster), "not a GeoPackage"),
        ("--kml", &points, "not KML"),
    ] {
        let out = imitate(
            dir.path(),
            &[
                "ingest",
                "--map",
                &raster,
                flag,
                file.to_str().unwrap(),
                "--out",
                "bad",
            ],
        );
        assert_input_error(&out, &[file.file_name().unwrap().to_str().unwrap(), says]);
    }
    assert!(!dir.path().join("bad").exists());
}
