//! GeoTIFFs as GDAL writes them (through rasterio): every layout and compression of one
//! raster reads to the same grid, and rasters that cannot be used are refused by name.
//! The files are written by `tests/python/geotiff_variants.py` from the real rasters in
//! ../shared/data/raster; rasterio comes from `scripts/python-deps.sh`.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use common::{assert_input_error, imitate, python_script, shared_data, stderr, stdout};
use imitate::features::{Bank, FeatureSpec, Op, compute};
use imitate::grid::{
    Demonstration, Edges, GroundScale, LayerKind, Map, Pose, Reprojection, coarsened,
};
use imitate::io::geotiff::{read_geotiff, write_geotiff};
use imitate::io::tables::write_demonstrations;

/// Writes the variants into `out` with rasterio (see [`python_script`]).
fn write_variants(out: &Path) -> Option<Vec<serde_json::Value>> {
    let rasters = shared_data("raster")?;
    python_script("geotiff_variants.py", &[&rasters, out])
}

fn same_values(a: &Map, b: &Map) -> bool {
    a.layers.len() == b.layers.len()
        && a.layers.iter().zip(&b.layers).all(|(x, y)| {
            x.name == y.name
                && x.values.len() == y.values.len()
                && x.values
                    .iter()
                    .zip(&y.values)
                    .all(|(p, q)| p == q || (p.is_nan() && q.is_nan()))
        })
}

#[test]
fn every_gdal_variant_reads_to_the_same_grid() {
    let dir = tempfile::tempdir().unwrap();
    let Some(files) = write_variants(dir.path()) else {
        return;
    };
    let path = |name: &str| -> PathBuf { dir.path().join(format!("{name}.tif")) };
    let mut references: BTreeMap<String, Map> = BTreeMap::new();
    for source in ["aerial", "spot"] {
        references.insert(
            source.into(),
            read_geotiff(&path(&format!("{source}--none")), "m").unwrap(),
        );
        references.insert(
            format!("{source}-float"),
            read_geotiff(&path(&format!("{source}--float-pred3")), "m").unwrap(),
        );
    }
    for source in ["rgb8", "rgba8"] {
        references.insert(
            source.into(),
            read_geotiff(&path(&format!("{source}--none")), "m").unwrap(),
        );
    }
    let aerial = &references["aerial"];
    // rasterio's aerial image: about 1.380 × 1.379 m cells, kept as they are.
    let [x, y] = aerial.geo.cell_size();
    assert!(
        (x - 1.37998).abs() < 1e-5 && (y - 1.37934).abs() < 1e-5,
        "{x} × {y}"
    );
    assert!(!aerial.geo.is_square());
    assert_eq!(aerial.layers.len(), 4);
    let mut checked = 0;
    for file in &files {
        let name = file["name"].as_str().unwrap();
        let source = file["source"].as_str().unwrap();
        if source == "bad"
            || source == "units"
            || source == "kinds"
            || source == "sidecars"
            || source == "pam-first"
            || source == "pam-compound"
            || source == "pam-esri"
            || source == "registry"
            || source == "coarse"
            || name.ends_with("--none")
            || name.ends_with("--float-pred3")
        {
            continue;
        }
        let float = name.contains("--float-");
        let reference = &references[&if float {
            format!("{source}-float")
        } else {
            source.to_string()
        }];
        let map = read_geotiff(&path(name), "m").unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(map.geo, reference.geo, "{name}");
        if file["lossless"].as_bool().unwrap() {
            assert!(same_values(&map, reference), "{name}: values differ");
        } else {
            // JPEG or lossy WebP: what GDAL decodes from the same file, within the
            // rounding of two decoders, in every band.
            let codec = name.rsplit("--").next().unwrap();
            let gdal =
                read_geotiff(&path(&format!("gdal-decoded--{source}-{codec}")), "m").unwrap();
            assert_within_decoder_rounding(name, &map, &gdal);
        }
        checked += 1;
    }
    assert!(checked >= 44, "only {checked} variants checked");
    // The float copy keeps the NaN block in the file's north-west corner (our top rows).
    let float = &references["aerial-float"];
    let (w, h) = (float.geo.width as usize, float.geo.height as usize);
    assert!(float.layers[0].values[(h - 1) * w].is_nan());
    assert!(!float.layers[0].values[0].is_nan());
}

/// Asserts that a lossy file reads as another decoder (GDAL's, libjxl's) decodes it,
/// within the rounding of two decoders, in every band.
fn assert_within_decoder_rounding(name: &str, map: &Map, theirs: &Map) {
    assert_eq!(map.layers.len(), theirs.layers.len(), "{name}");
    for (ours, theirs) in map.layers.iter().zip(&theirs.layers) {
        let (a, b) = (&ours.values, &theirs.values);
        let largest = a
            .iter()
            .zip(b)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f32::max);
        let mean = a.iter().zip(b).map(|(p, q)| (p - q).abs()).sum::<f32>() / a.len() as f32;
        assert!(
            largest <= 2.0 && mean < 0.5,
            "{name} {}: largest {largest}, mean {mean}",
            ours.name
        );
    }
}

/// JPEG XL-compressed GeoTIFFs (tifffile and libjxl write them: rasterio's GDAL has no
/// JPEG XL codec) read to their uncompressed baselines: grey, RGB with extra channels
/// and band-interleaved, 8 and 16 bits and floats with NaN, tiles and strips, GDAL's
/// and DNG's codes; a lossy one as libjxl decodes it.
#[test]
fn jpeg_xl_variants_read_as_their_baselines() {
    let dir = tempfile::tempdir().unwrap();
    let Some(rasters) = shared_data("raster") else {
        return;
    };
    let Some(files) = python_script("jpeg_xl.py", &[&rasters, dir.path()]) else {
        return;
    };
    assert_eq!(files.len(), 8);
    let read = |name: &str| {
        read_geotiff(&dir.path().join(format!("{name}.tif")), "m")
            .unwrap_or_else(|e| panic!("{name}: {e}"))
    };
    for file in &files {
        let name = file["name"].as_str().unwrap();
        let (map, reference) = (read(name), read(file["reference"].as_str().unwrap()));
        assert_eq!(map.geo, reference.geo, "{name}");
        if file["lossless"].as_bool().unwrap() {
            assert!(same_values(&map, &reference), "{name}: values differ");
        } else {
            assert_within_decoder_rounding(name, &map, &reference);
        }
    }
    // The float raster's NaN block, in the file's north-west corner, is nodata.
    let heights = read("heights--jxl-tiles");
    let (w, h) = (heights.geo.width as usize, heights.geo.height as usize);
    assert!(heights.layers[0].values[(h - 1) * w].is_nan());
    assert_eq!(heights.layers.len(), 1);
    assert_eq!(read("five--jxl-strips").layers.len(), 5);
    assert!(damage_each(dir.path(), &files) >= 36);
}

#[test]
fn projected_units_in_feet_keep_their_coordinates_measured_in_metres() {
    let dir = tempfile::tempdir().unwrap();
    if write_variants(dir.path()).is_none() {
        return;
    }
    let feet = read_geotiff(&dir.path().join("units--us-feet.tif"), "m").unwrap();
    let spot = read_geotiff(&dir.path().join("spot--none.tif"), "m").unwrap();
    assert_eq!(feet.geo.frame, "EPSG:2263");
    // The CRS's own coordinates (the SPOT image's numbers, read as feet), as the user's
    // demonstrations in that CRS are given...
    assert_eq!(feet.geo.cell_size(), spot.geo.cell_size());
    assert_eq!(feet.geo.origin, spot.geo.origin);
    // ... measured on the ground in metres: a foot times the State Plane's scale, far
    // from 1 where the SPOT image's grid lies, far north of New York's zone.
    let foot = 1200.0 / 3937.0;
    let [gx, gy] = feet.geo.ground_scale.unwrap().per_axis();
    assert!((gx / foot - 1.0).abs() > 0.01 && (gy / foot - 1.0).abs() > 0.01);
    let ([mx, my], [fx, fy]) = (feet.geo.cell_metres(), feet.geo.cell_size());
    assert!((mx - fx * gx).abs() < 1e-9 && (my - fy * gy).abs() < 1e-9);
}

/// A user whose DEM is in New York State Plane (US survey feet) gives their tracks in
/// that CRS, as every GIS tool has them: ingest takes the poses in feet, plans are asked
/// and answered in feet and priced in ground metres, and the costmap comes back as a
/// GeoTIFF on the DEM's very grid and CRS.
#[test]
fn a_raster_in_feet_takes_poses_in_feet_and_plans_in_ground_metres() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("feet_raster.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    let text = |key: &str| info[key].as_str().unwrap().to_string();
    let point = |key: &str| {
        let p: Vec<f64> = serde_json::from_value(info[key].clone()).unwrap();
        format!("{},{}", p[0], p[1])
    };
    let (raster, walks) = (text("raster"), text("demonstrations"));
    let run = |args: &[&str]| {
        let out = imitate(dir.path(), args);
        assert!(out.status.success(), "{args:?}: {}", stderr(&out));
        out
    };
    run(&[
        "ingest",
        "--map",
        &raster,
        "--demonstrations",
        &walks,
        "--out",
        "ds",
    ]);
    // The same walks as a GPS logs them, in longitude and latitude: refused with the way
    // out, then moved into the map's feet onto the very same cells.
    let gps = text("gps");
    let out = imitate(
        dir.path(),
        &[
            "ingest",
            "--map",
            &raster,
            "--demonstrations",
            &gps,
            "--out",
            "gps",
        ],
    );
    assert_input_error(
        &out,
        &[
            "walks_gps.parquet",
            "lies outside the map 'feet'",
            "look like longitude and latitude",
            "--demonstrations-crs EPSG:4326",
        ],
    );
    assert!(!dir.path().join("gps").exists());
    run(&[
        "ingest",
        "--map",
        &raster,
        "--demonstrations",
        &gps,
        "--demonstrations-crs",
        "EPSG:4326",
        "--out",
        "gps",
    ]);
    let cells = |dataset: &str| std::fs::read(dir.path().join(dataset).join("paths.parquet"));
    assert_eq!(cells("gps").unwrap(), cells("ds").unwrap());
    for command in [
        "features --dataset ds --bank auto --out fs",
        "learch --dataset ds --features fs --out costmap --rounds 10",
    ] {
        run(&command.split(' ').collect::<Vec<_>>());
    }
    let (start, goal) = (point("start"), point("goal"));
    let planned = run(&["plan", "costmap", "--start", &start, "--goal", &goal]);
    let json: serde_json::Value = serde_json::from_str(&stdout(&planned)).unwrap();
    let world = json["world"].as_array().unwrap();
    let bounds: Vec<f64> = serde_json::from_value(info["bounds"].clone()).unwrap();
    assert_eq!(world[0], info["start"]);
    assert_eq!(world[world.len() - 1], info["goal"]);
    for p in world {
        let (x, y) = (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
        assert!(
            x > bounds[0] && x < bounds[2] && y > bounds[1] && y < bounds[3],
            "{p}"
        );
    }
    // The same ends as GPS fixes: the same route, its points answered in longitude and
    // latitude (the ends' within a micro-degree of PROJ's), and a fix given without
    // --crs is refused with the way out.
    let (start_gps, goal_gps) = (point("start_gps"), point("goal_gps"));
    let gps = |args: &[&str]| {
        let mut all = vec![
            "plan", "costmap", "--start", &start_gps, "--goal", &goal_gps,
        ];
        all.extend(args);
        imitate(dir.path(), &all)
    };
    let by_gps = gps(&["--crs", "EPSG:4326"]);
    assert!(by_gps.status.success(), "{}", stderr(&by_gps));
    let gps_json: serde_json::Value = serde_json::from_str(&stdout(&by_gps)).unwrap();
    assert_eq!(gps_json["cells"], json["cells"]);
    assert_eq!(gps_json["crs"], "EPSG:4326");
    assert_eq!(json["crs"], "EPSG:2263");
    let gps_world = gps_json["world"].as_array().unwrap();
    let near = |p: &serde_json::Value, q: &serde_json::Value| {
        (0..2).all(|i| (p[i].as_f64().unwrap() - q[i].as_f64().unwrap()).abs() < 1e-6)
    };
    assert!(near(&gps_world[0], &info["start_gps"]), "{}", gps_world[0]);
    assert!(near(&gps_world[gps_world.len() - 1], &info["goal_gps"]));
    assert_input_error(
        &gps(&[]),
        &[
            "lies outside map 'feet'",
            "looks like longitude and latitude",
            "--crs EPSG:4326",
        ],
    );
    assert_eq!(
        gps(&["--crs", "EPSG:4326", "--cells"]).status.code(),
        Some(2)
    );
    run(&[
        "forecast",
        "costmap",
        "--observed",
        &start_gps,
        "--destination",
        &goal_gps,
        "--crs",
        "EPSG:4326",
        "--out",
        "forecast",
    ]);
    let forecast = std::fs::read_to_string(dir.path().join("forecast/forecast.json")).unwrap();
    let forecast: serde_json::Value = serde_json::from_str(&forecast).unwrap();
    assert_eq!(forecast["crs"], "EPSG:4326");
    let destination = &forecast["destinations"][0];
    assert_eq!(destination["cell"], gps_world_cell(&gps_json));
    assert!(
        near(&destination["world"], &info["goal_gps"]),
        "{destination}"
    );
    // Ten straight 50-foot steps on the raster's cheap cells (cost 10): 152.4 ground
    // metres at 10 a metre (New York's zone is true to scale there).
    let straight = run(&[
        "plan",
        &raster,
        "--start",
        "980175,199875",
        "--goal",
        "980675,199875",
    ]);
    let json: serde_json::Value = serde_json::from_str(&stdout(&straight)).unwrap();
    let cost = json["cost"].as_f64().unwrap();
    assert!(
        (cost - 10.0 * 500.0 * 1200.0 / 3937.0).abs() < 1e-6,
        "{cost}"
    );
    // Poses converted to metres are off the map, which says where it is.
    let out = imitate(
        dir.path(),
        &["plan", &raster, "--start", "298760,60920", "--goal", &goal],
    );
    assert_input_error(
        &out,
        &["--start 298760,60920 lies outside map", "x 980000..982000"],
    );
    run(&[
        "export", "costmap", "--format", "geotiff", "--format", "geojson", "--out", "export",
    ]);
    // The paths as GeoJSON for QGIS: in longitude and latitude, the demonstrations
    // through the very fixes of the GPS table (their cells' centres), a plan beside each.
    let geojson = std::fs::read_to_string(dir.path().join("export/feet.geojson")).unwrap();
    let geojson: serde_json::Value = serde_json::from_str(&geojson).unwrap();
    let features = geojson["features"].as_array().unwrap();
    let kinds: Vec<&str> = features
        .iter()
        .map(|f| f["properties"]["kind"].as_str().unwrap())
        .collect();
    assert_eq!(kinds, ["demonstration", "plan"].repeat(3));
    let fixes = imitate::io::demo_tables::read_demonstrations(Path::new(&text("gps"))).unwrap();
    let first = &features[0]["geometry"]["coordinates"][0];
    let fix = fixes[0].poses[0];
    assert!(
        near(first, &serde_json::json!([fix.x, fix.y])),
        "{first} {fix:?}"
    );
    assert_eq!(features[0]["properties"]["episode"], "walk-0");
    // A route's own GeoJSON goes through the points the plan answers in longitude and
    // latitude.
    run(&[
        "plan",
        "costmap",
        "--start",
        &start,
        "--goal",
        &goal,
        "--geojson",
        "route.geojson",
    ]);
    let route = std::fs::read_to_string(dir.path().join("route.geojson")).unwrap();
    let route: serde_json::Value = serde_json::from_str(&route).unwrap();
    assert_eq!(
        route["features"][0]["geometry"]["coordinates"],
        gps_json["world"]
    );
    let exported = dir.path().join("export/feet.tif");
    let Some(checked) = python_script("same_crs.py", &[Path::new(&raster), &exported]) else {
        return;
    };
    let pair = &checked[0];
    assert_eq!(pair["same_crs"], true, "{pair}");
    assert_eq!(pair["bounds"], pair["written_bounds"], "{pair}");
    assert_eq!(pair["res"], pair["written_res"], "{pair}");
}

/// The last cell of a plan's answer.
fn gps_world_cell(plan: &serde_json::Value) -> serde_json::Value {
    let cells = plan["cells"].as_array().unwrap();
    cells[cells.len() - 1].clone()
}

#[test]
fn rasters_written_back_keep_the_crs_they_were_read_with() {
    let dir = tempfile::tempdir().unwrap();
    if write_variants(dir.path()).is_none() {
        return;
    }
    // A CRS in US survey feet (read in feet), projections GDAL writes by their
    // parameters (Albers, LAEA, LCC), an EPSG code, and degrees.
    let names = [
        "units--us-feet",
        "units--albers-plane",
        "units--laea-plane",
        "units--lcc-plane",
        "units--conus-albers-plane",
        "spot--none",
    ];
    let mut pairs = Vec::new();
    for name in names {
        let source = dir.path().join(format!("{name}.tif"));
        let map = read_geotiff(&source, "m").unwrap();
        let written = dir.path().join(format!("{name}--written.tif"));
        write_geotiff(&written, &map.geo, &map.layers[0].values).unwrap();
        // And read back by us: the same grid.
        assert_eq!(read_geotiff(&written, "m").unwrap().geo, map.geo, "{name}");
        pairs.extend([source, written]);
    }
    let pairs: Vec<&Path> = pairs.iter().map(PathBuf::as_path).collect();
    let Some(checked) = python_script("same_crs.py", &pairs) else {
        return;
    };
    assert_eq!(checked.len(), names.len());
    for pair in &checked {
        assert_eq!(pair["same_crs"], true, "{pair}");
        for (ours, theirs) in [("bounds", "written_bounds"), ("res", "written_res")] {
            let (a, b) = (
                pair[ours].as_array().unwrap(),
                pair[theirs].as_array().unwrap(),
            );
            for (x, y) in a.iter().zip(b) {
                let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
                assert!((x - y).abs() <= 1e-9 * x.abs().max(1.0), "{pair}");
            }
        }
    }
}

#[test]
fn rotation_terms_of_float_noise_are_not_a_rotation() {
    let dir = tempfile::tempdir().unwrap();
    if write_variants(dir.path()).is_none() {
        return;
    }
    // 1e-13 m per cell on 10 m cells (the SPOT image's grid, a ModelTransformation).
    let noise = read_geotiff(&dir.path().join("units--rotation-noise.tif"), "m").unwrap();
    let spot = read_geotiff(&dir.path().join("spot--none.tif"), "m").unwrap();
    assert_eq!(noise.geo, spot.geo);
    assert!(same_values(&noise, &spot));
}

/// The median slope (degrees) over the cells of `map` at least `margin` cells inside its
/// edges and from its nodata (GDAL's warp leaves a resampled border).
fn median_slope(map: &Map, margin: usize) -> f64 {
    let inner = inner_slopes(map, margin);
    inner[inner.len() / 2]
}

/// The slopes (degrees, sorted) of the cells of `map` at least `margin` cells inside its
/// edges and from its nodata.
fn inner_slopes(map: &Map, margin: usize) -> Vec<f64> {
    let spec = FeatureSpec {
        layers: Some(Vec::new()),
        ops: vec![Op::Slope {
            layer: "band1".into(),
        }],
        bias: false,
        nodata_fill: 0.0,
        bank: None,
    };
    let stack = imitate::features::compute(map, &spec).unwrap();
    let (w, h) = (map.geo.width as usize, map.geo.height as usize);
    let values = &map.layers[0].values;
    let clear = |r: usize, c: usize| {
        (r - margin..=r + margin)
            .all(|rr| (c - margin..=c + margin).all(|cc| !values[rr * w + cc].is_nan()))
    };
    let mut inner: Vec<f64> = (margin..h - margin)
        .flat_map(|r| (margin..w - margin).map(move |c| (r, c)))
        .filter(|&(r, c)| clear(r, c))
        .map(|(r, c)| f64::from(stack.plane(0)[r * w + c]))
        .collect();
    inner.sort_by(f64::total_cmp);
    inner
}

#[test]
fn web_mercator_cells_are_measured_on_the_ground() {
    let dir = tempfile::tempdir().unwrap();
    if write_variants(dir.path()).is_none() {
        return;
    }
    // A plane of slope atan √0.05 = 12.6° in UTM at 60° N, and GDAL's warp of it into
    // Web Mercator, whose 59.9 "metre" cells span about 30 m on the ground there.
    let utm = read_geotiff(&dir.path().join("units--utm-plane.tif"), "m").unwrap();
    let mercator = read_geotiff(&dir.path().join("units--web-mercator-plane.tif"), "m").unwrap();
    assert!(mercator.geo.web_mercator && !utm.geo.web_mercator);
    let [east, north] = mercator.geo.cell_metres();
    assert!((mercator.geo.resolution - 59.95).abs() < 0.01);
    assert!(
        (east - 30.0).abs() < 0.2 && (north - 30.0).abs() < 0.2,
        "{east} × {north}"
    );
    let truth = 0.05f64.sqrt().atan().to_degrees();
    let (flat, warped) = (median_slope(&utm, 2), median_slope(&mercator, 4));
    assert!((flat - truth).abs() < 0.01, "UTM: {flat} against {truth}");
    // Read as frame metres the warped plane would slope atan(√0.05 / 2) = 6.4°.
    assert!(
        (warped - truth).abs() < 0.2,
        "Web Mercator: {warped} against {truth}"
    );
}

#[test]
fn polar_stereographic_cells_are_measured_on_the_ground() {
    let dir = tempfile::tempdir().unwrap();
    if write_variants(dir.path()).is_none() {
        return;
    }
    // The same plane warped into NSIDC's Arctic grid (EPSG:3413): read in its nominal
    // metres it would slope atan(tan 12.6° / 1.04) = 12.1°.
    let polar = read_geotiff(
        &dir.path().join("units--polar-stereographic-plane.tif"),
        "m",
    )
    .unwrap();
    let scale = polar.geo.ground_scale.unwrap();
    assert_eq!(scale, GroundScale::Uniform(scale.per_axis()[0]));
    assert!((scale.per_axis()[0] - 0.962).abs() < 0.002, "{scale:?}");
    let truth = 0.05f64.sqrt().atan().to_degrees();
    let slope = median_slope(&polar, 4);
    assert!((slope - truth).abs() < 0.1, "{slope} against {truth}");
}

#[test]
fn transverse_mercator_cells_far_outside_their_zone_are_measured_on_the_ground() {
    let dir = tempfile::tempdir().unwrap();
    if write_variants(dir.path()).is_none() {
        return;
    }
    // The plane warped into UTM 14N and into a Transverse Mercator grid by its
    // parameters, 24° east of it (PROJ's scales at the centre: 0.9795 and 0.9791).
    // Read in nominal metres it would slope atan(tan 12.6° · 0.98) = 12.4°.
    let truth = 0.05f64.sqrt().atan().to_degrees();
    for (name, expected) in [
        ("units--utm-far-plane", 0.9795),
        ("units--tmerc-far-plane", 0.9791),
    ] {
        let map = read_geotiff(&dir.path().join(format!("{name}.tif")), "m").unwrap();
        let scale = map.geo.ground_scale.unwrap();
        assert_eq!(scale, GroundScale::Uniform(scale.per_axis()[0]));
        assert!(
            (scale.per_axis()[0] - expected).abs() < 5e-4,
            "{name}: {scale:?}"
        );
        let slope = median_slope(&map, 4);
        assert!(
            (slope - truth).abs() < 0.1,
            "{name}: {slope} against {truth}"
        );
    }
    // Inside its zone a UTM metre is read as a ground metre, as gdalinfo's cell size.
    let utm = read_geotiff(&dir.path().join("units--utm-plane.tif"), "m").unwrap();
    assert_eq!(utm.geo.ground_scale, None);
}

#[test]
fn equal_area_and_conic_cells_are_measured_on_the_ground_per_axis() {
    let dir = tempfile::tempdir().unwrap();
    if write_variants(dir.path()).is_none() {
        return;
    }
    let truth = 0.05f64.sqrt().atan().to_degrees();
    // The plane warped into an Albers cone and a polar LAEA on its meridian (GeoKeys
    // with the projections' parameters), and into Conus Albers (EPSG:5070, by code).
    for (name, expected, on_meridian) in [
        ("units--albers-plane", [0.902, 1.108], true),
        ("units--laea-plane", [0.966, 1.035], true),
        ("units--conus-albers-plane", [0.920, 1.093], false),
        // And a Lambert conformal cone by its parameters: the same scale both ways.
        ("units--lcc-plane", [0.936, 0.936], true),
        // The world grids, 123° W of their meridian but for EASE-Grid 2.0, which is
        // cylindrical (PROJ's inverses at the centre ± 10 m, as chords on WGS 84):
        // axes sheared 62°, 50° and 32° apart, so no slope is checked on them.
        ("units--modis-sinusoidal-plane", [1.0036, 2.1182], false),
        ("units--ease2-plane", [0.5781, 1.7299], true),
        ("units--mollweide-plane", [0.8602, 1.8113], false),
        ("units--equal-earth-plane", [0.7721, 1.5191], false),
        // World maps on a sphere measured through their own inverse: Eckert IV,
        // Van der Grinten, Winkel Tripel, Goode's homolosine (in its northern lobe on
        // 100° W) and Kavrayskiy VII (from the PROJ string in GDAL's sidecar).
        ("units--eckert-iv-plane", [0.7596, 1.5257], false),
        ("units--van-der-grinten-plane", [0.5382, 0.5487], false),
        ("units--winkel-tripel-plane", [0.8235, 1.2015], false),
        ("units--goode-plane", [0.8602, 1.1948], false),
        ("units--kavrayskiy-plane", [0.7087, 1.1250], false),
    ] {
        let map = read_geotiff(&dir.path().join(format!("{name}.tif")), "m").unwrap();
        let [sx, sy] = map.geo.ground_scale.unwrap().per_axis();
        assert!(
            (sx - expected[0]).abs() < 0.003 && (sy - expected[1]).abs() < 0.003,
            "{name}: {sx} × {sy}"
        );
        if on_meridian {
            // Read in nominal metres the Albers plane would slope 13.5° (its gradient
            // is mostly north, where a metre spans 1.108 ground metres). GDAL's warp
            // leaves a ripple in the north gradient of its rows (0.217 and 0.23 per
            // metre about 0.2215): the mean over the cells, not the median.
            let slopes = inner_slopes(&map, 4);
            let slope = slopes.iter().sum::<f64>() / slopes.len() as f64;
            assert!(
                (slope - truth).abs() < 0.05,
                "{name}: {slope} against {truth}"
            );
        }
    }
}

/// Reads the UTM plane in metres and `name`, the same plane stored another way, and
/// checks that they hold the same heights (within `tolerance` metres) and slopes.
fn reads_to_the_plane_in_metres(name: &str, tolerance: f32) {
    let dir = tempfile::tempdir().unwrap();
    if write_variants(dir.path()).is_none() {
        return;
    }
    let metres = read_geotiff(&dir.path().join("units--utm-plane.tif"), "m").unwrap();
    let other = read_geotiff(&dir.path().join(format!("{name}.tif")), "m").unwrap();
    let (a, b) = (&metres.layers[0].values, &other.layers[0].values);
    let largest = a
        .iter()
        .zip(b)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f32::max);
    assert!(
        largest <= tolerance,
        "{name}: largest difference {largest} m"
    );
    assert!((median_slope(&metres, 2) - median_slope(&other, 2)).abs() < 0.01);
}

#[test]
fn gdal_scales_and_offsets_give_physical_values() {
    // Stored as int16 decimetres above 100 m with GDAL's scale 0.1 and offset 100: the
    // same metres to the stored rounding.
    reads_to_the_plane_in_metres("units--utm-plane-decimetres", 0.051);
}

#[test]
fn band_descriptions_name_the_layers_and_choose_the_bank() {
    let dir = tempfile::tempdir().unwrap();
    if write_variants(dir.path()).is_none() {
        return;
    }
    let plane = read_geotiff(&dir.path().join("units--utm-plane.tif"), "m").unwrap();
    let map = read_geotiff(&dir.path().join("units--utm-plane-described.tif"), "m").unwrap();
    assert_eq!(map.layer_names(), ["Elevation (m)", "Near infrared & more"]);
    assert_eq!(map.layers[0].values, plane.layers[0].values);
    // The numbered name still finds the band.
    assert_eq!(map.layer_index("band2"), Some(1));
    // `--bank auto` takes the described elevation band for elevation, the other for
    // imagery.
    let spec = FeatureSpec {
        layers: None,
        ops: Vec::new(),
        bias: true,
        nodata_fill: 0.0,
        bank: Some(Bank::Auto),
    };
    let names = compute(&map, &spec).unwrap().names;
    for expected in ["Elevation (m)/slope_deg", "Near infrared & more/blur_8c"] {
        assert!(
            names.iter().any(|n| n == expected),
            "{expected} in {names:?}"
        );
    }
    assert!(!names.iter().any(|n| n == "Near infrared & more/slope_deg"));
}

#[test]
fn infinite_cells_read_as_nodata() {
    let dir = tempfile::tempdir().unwrap();
    if write_variants(dir.path()).is_none() {
        return;
    }
    let map = read_geotiff(&dir.path().join("units--utm-plane-infinities.tif"), "m").unwrap();
    let values = &map.layers[0].values;
    assert_eq!(
        values.iter().filter(|v| v.is_nan()).count(),
        10 * 200 + 3 * 5
    );
    assert!(values.iter().all(|v| !v.is_infinite()));
}

#[test]
fn heights_in_feet_become_metres() {
    // Heights in US survey feet, CRS EPSG:32610+6360 (NAVD88 height, ftUS).
    reads_to_the_plane_in_metres("units--utm-plane-feet-navd88", 0.001);
    // The same, said by the band's unit (rasterio's `units`) alone.
    reads_to_the_plane_in_metres("units--utm-plane-feet-unittype", 0.001);
}

#[test]
fn rasters_that_cannot_be_used_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    if write_variants(dir.path()).is_none() {
        return;
    }
    for (name, needles) in [
        ("bad--rotated", vec!["bad--rotated.tif", "rotated"]),
        ("bad--all-nodata", vec!["bad--all-nodata.tif", "nodata"]),
        (
            "bad--complex",
            vec!["bad--complex.tif", "tag SampleFormat = 6", "complex"],
        ),
        (
            "bad--gcps",
            vec!["bad--gcps.tif", "3 ground control points", "gdalwarp"],
        ),
    ] {
        let out = dir.path().join(format!("out-{name}.png"));
        let map = dir.path().join(format!("{name}.tif"));
        let output = imitate(
            dir.path(),
            &[
                "plan",
                map.to_str().unwrap(),
                "--start",
                "0,0",
                "--goal",
                "1,1",
                "--png",
                out.to_str().unwrap(),
            ],
        );
        assert_input_error(&output, &needles);
        assert!(!out.exists(), "{name}: nothing is written");
    }
}

/// The largest and mean absolute difference between two layers, over the cells where
/// both hold data; and whether exactly the same cells are nodata.
fn differences(a: &[f32], b: &[f32]) -> (f32, f32, bool) {
    let same_nodata = a.iter().zip(b).all(|(p, q)| p.is_nan() == q.is_nan());
    let diffs: Vec<f32> = a
        .iter()
        .zip(b)
        .filter(|(p, q)| !p.is_nan() && !q.is_nan())
        .map(|(p, q)| (p - q).abs())
        .collect();
    let largest = diffs.iter().copied().fold(0.0, f32::max);
    (
        largest,
        diffs.iter().sum::<f32>() / diffs.len().max(1) as f32,
        same_nodata,
    )
}

#[test]
fn rasters_as_data_comes_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(files) = write_variants(dir.path()) else {
        return;
    };
    let read = |name: &str| read_geotiff(&dir.path().join(format!("{name}.tif")), "m");
    let mut checked = Vec::new();
    for file in files.iter().filter(|f| f["source"] == "kinds") {
        let name = file["name"].as_str().unwrap();
        let ours = read(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        let gdal = read(&format!("expected--{name}")).unwrap();
        assert_eq!(ours.geo, gdal.geo, "{name}");
        assert_eq!(ours.layers.len(), gdal.layers.len(), "{name}");
        for (a, b) in ours.layers.iter().zip(&gdal.layers) {
            let (largest, mean, same_nodata) = differences(&a.values, &b.values);
            assert!(same_nodata, "{name} {}: other cells are nodata", a.name);
            if file["lossless"].as_bool().unwrap() {
                assert_eq!(largest, 0.0, "{name} {}: values differ", a.name);
            } else {
                // YCbCr JPEG: two decoders upsample chroma their own way, so measure
                // both against the colours before compression.
                let source = read(&format!("source--{name}")).unwrap();
                let band = source.layers.iter().find(|l| l.name == a.name).unwrap();
                let (_, ours_error, _) = differences(&a.values, &band.values);
                let (_, gdal_error, _) = differences(&b.values, &band.values);
                assert!(
                    mean < 6.0 && ours_error < 1.1 * gdal_error + 0.5,
                    "{name} {}: off GDAL by {mean} on average; from the source: ours \
                     {ours_error}, GDAL's {gdal_error}",
                    a.name
                );
            }
        }
        checked.push(name.to_string());
    }
    assert_eq!(checked.len(), 27, "{checked:?}");
    // The land-cover palette reads as its class codes, the 1-bit mask as 0 and 1, and
    // the internal mask takes a third of the image and a block away.
    let codes = read("kinds--palette").unwrap();
    assert_eq!(
        codes.layers[0].kind,
        LayerKind::Classes,
        "the colour table says so"
    );
    assert!(
        codes.layers[0]
            .values
            .iter()
            .all(|&v| v.fract() == 0.0 && (0.0..=5.0).contains(&v))
    );
    let bits = read("kinds--bits1").unwrap();
    assert!(bits.layers[0].values.iter().all(|&v| v == 0.0 || v == 1.0));
    assert_eq!(bits.layers[0].kind, LayerKind::Values);
    // The 12-bit bands were written as v and 4095 − v (GDAL's reading would agree on
    // a file read as zeros too).
    let twelve = read("kinds--bits12-tiled-deflate").unwrap();
    let (a, b) = (&twelve.layers[0].values, &twelve.layers[1].values);
    assert!(a.iter().zip(b).all(|(x, y)| x + y == 4095.0));
    assert!(a.iter().copied().fold(0.0, f32::max) > 3000.0);
    let masked = read("kinds--masked-deflate").unwrap();
    let empty = masked.layers[0]
        .values
        .iter()
        .filter(|v| v.is_nan())
        .count();
    let (w, h) = (masked.geo.width as usize, masked.geo.height as usize);
    assert_eq!(empty, h * (w / 3) + 60 * 120);
    // The same mask on a float raster in LZW strips (1-bit, as GDAL writes masks).
    let float_masked = read("kinds--masked-float-lzw").unwrap();
    let masked_floats = float_masked.layers[0]
        .values
        .iter()
        .filter(|v| v.is_nan())
        .count();
    assert_eq!(masked_floats, empty);
    // Transparent cells of an RGBA orthomosaic (alpha 0) are nodata in the colour
    // bands; the alpha band keeps its zeros, as in GDAL.
    let rgba = read("kinds--rgba-alpha").unwrap();
    let nodata = |band: usize| {
        rgba.layers[band]
            .values
            .iter()
            .filter(|v| v.is_nan())
            .count()
    };
    let transparent = h * (w / 4) + 50 * (w - w / 4);
    assert_eq!(
        [nodata(0), nodata(1), nodata(2), nodata(3)],
        [transparent, transparent, transparent, 0]
    );
}

/// Seeded damage to every variant GDAL wrote (bytes overwritten in the header and
/// directories or anywhere, fields set to 0 or all ones, the file cut short): each
/// read is a map or an error naming the file, never a panic.
#[test]
fn damaged_variants_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let Some(files) = write_variants(dir.path()) else {
        return;
    };
    let reads = damage_each(dir.path(), &files);
    assert!(reads > 300, "{reads}");
}

/// Reads seeded damages of each file of `files` (JSON lines with its `name` in `dir`)
/// under 400 kB, as [`damage_files`] does.
fn damage_each(dir: &Path, files: &[serde_json::Value]) -> usize {
    let paths: Vec<PathBuf> = files
        .iter()
        .map(|f| dir.join(format!("{}.tif", f["name"].as_str().unwrap())))
        .collect();
    damage_files(&paths, &dir.join("damaged.tif"), 12)
}

/// Reads `per_file` seeded damages of each of `files` under 400 kB (`IMITATE_DAMAGES`
/// sets another count, for a longer campaign), written to `damaged` (whose extension
/// picks the reader): bytes changed in its header or anywhere, cut short, offsets and
/// counts set to 0 or 0xFFFFFFFF. Each must read, or fail naming the file, never panic.
/// Returns how many damaged files were read.
fn damage_files(files: &[PathBuf], damaged: &Path, per_file: usize) -> usize {
    let damaged_name = damaged.file_name().unwrap().to_str().unwrap();
    damage_with(files, per_file, |bytes| {
        std::fs::write(damaged, bytes).unwrap();
        (damaged.to_path_buf(), damaged_name.to_string())
    })
}

/// As [`damage_files`], each file of the Zarr store (or other folder) `store` damaged
/// where it lies and the whole store read, the file restored after: errors must name
/// the store.
fn damage_store(store: &Path, per_file: usize) -> usize {
    let mut files = Vec::new();
    let mut folders = vec![store.to_path_buf()];
    while let Some(folder) = folders.pop() {
        for entry in std::fs::read_dir(folder)
            .unwrap()
            .map(|e| e.unwrap().path())
        {
            if entry.is_dir() {
                folders.push(entry);
            } else {
                files.push(entry);
            }
        }
    }
    files.sort();
    let store_name = store.file_name().unwrap().to_str().unwrap().to_string();
    let mut reads = 0;
    for file in &files {
        let original = std::fs::read(file).unwrap();
        reads += damage_with(std::slice::from_ref(file), per_file, |bytes| {
            std::fs::write(file, bytes).unwrap();
            (store.to_path_buf(), store_name.clone())
        });
        std::fs::write(file, original).unwrap();
    }
    reads
}

/// The damages of [`damage_files`]: `place` puts each damaged copy where it is read
/// and says what to read and the name its errors must hold.
fn damage_with(
    files: &[PathBuf],
    per_file: usize,
    mut place: impl FnMut(&[u8]) -> (PathBuf, String),
) -> usize {
    let per_file = std::env::var("IMITATE_DAMAGES")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(per_file);
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut reads = 0;
    for file in files {
        let name = file.display();
        let original = std::fs::read(file).unwrap();
        if original.len() > 400_000 || original.is_empty() {
            continue;
        }
        let n = original.len() as u64;
        for kind in 0..per_file {
            let mut bytes = original.clone();
            match kind % 4 {
                0 => {
                    for _ in 0..1 + next() % 4 {
                        bytes[(next() % n.min(1024)) as usize] = next() as u8;
                    }
                }
                1 => {
                    for _ in 0..1 + next() % 8 {
                        bytes[(next() % n) as usize] = next() as u8;
                    }
                }
                2 => bytes.truncate((next() % n) as usize),
                _ if n >= 4 => {
                    let at = (next() % n.min(2048).saturating_sub(4).max(1)) as usize;
                    let field = [[0xFF; 4], [0; 4]][(next() % 2) as usize];
                    bytes[at..at + 4].copy_from_slice(&field);
                }
                _ => bytes.clear(),
            }
            let (read_path, needle) = place(&bytes);
            let read = std::panic::catch_unwind(|| imitate::io::read_raster(&read_path, "m"));
            match read {
                Ok(Ok(_)) => {}
                Ok(Err(e)) => assert!(e.to_string().contains(&needle), "{name}: {e}"),
                Err(_) => panic!("{name}, damage {kind}: the reader panicked"),
            }
            reads += 1;
        }
    }
    reads
}

/// GDAL's order of georeferences: the PAM sidecar's geotransform and CRS before the
/// TIFF's own tags, and a CRS in US survey feet given as WKT 2 (its unit in its axes)
/// read in feet and measured on the ground in metres, each read to where GDAL
/// (rasterio) puts the raster.
#[test]
fn sidecars_georeference_before_the_tiff_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(files) = write_variants(dir.path()) else {
        return;
    };
    let pam_first: Vec<_> = files
        .iter()
        .filter(|f| f["source"] == "pam-first")
        .collect();
    assert_eq!(pam_first.len(), 2);
    for file in pam_first {
        let name = file["name"].as_str().unwrap();
        let map = read_geotiff(&dir.path().join(format!("{name}.tif")), "m").unwrap();
        let gdal = &file["gdal"];
        let t: Vec<f64> = serde_json::from_value(gdal["transform"].clone()).unwrap();
        let metres = gdal["metres_per_unit"].as_f64().unwrap();
        let [a, c, e, f] = [t[0], t[2], t[4], t[5]];
        let west = c;
        let south = f + e * f64::from(map.geo.height);
        let [x, y] = map.geo.cell_size();
        let close = |p: f64, q: f64| (p - q).abs() <= 1e-6 * q.abs().max(1.0);
        assert!(
            close(map.geo.origin[0], west) && close(map.geo.origin[1], south),
            "{name}: origin {:?}, GDAL's {west} {south}",
            map.geo.origin
        );
        assert!(close(x, a) && close(y, e.abs()), "{name}: {x} × {y}");
        // Ground metres: the unit's, times the projection's scale where it is far
        // from 1.
        let ground = map.geo.ground_scale.map_or([1.0; 2], GroundScale::per_axis);
        if metres != 1.0 {
            assert!(
                ground.iter().all(|g| (g / metres - 1.0).abs() < 0.2),
                "{name}: {ground:?}"
            );
        } else {
            assert_eq!(map.geo.ground_scale, None, "{name}");
        }
        assert_eq!(map.geo.frame, format!("EPSG:{}", gdal["epsg"]), "{name}");
    }
}

/// A DEM whose sidecar gives a compound CRS (GDAL's COMPD_CS for EPSG:2263+6360): cells
/// and heights in US survey feet; the cells keep the CRS's coordinates and are measured
/// in metres, the heights are read in metres.
#[test]
fn a_sidecars_compound_crs_gives_cells_and_heights_in_metres() {
    let dir = tempfile::tempdir().unwrap();
    let Some(files) = write_variants(dir.path()) else {
        return;
    };
    let file = files
        .iter()
        .find(|f| f["source"] == "pam-compound")
        .unwrap();
    let map = read_geotiff(&dir.path().join("dem--pam-compound-feet.tif"), "m").unwrap();
    let gdal = &file["gdal"];
    let foot = gdal["metres_per_unit"].as_f64().unwrap();
    assert!((foot - 1200.0 / 3937.0).abs() < 1e-12, "{foot}");
    assert_eq!(map.geo.cell_size(), [10.0, 10.0]);
    // Inside New York's zone: true to scale within 0.1 %, a foot on the ground.
    let [x, y] = map.geo.cell_metres();
    assert!(
        (x - 10.0 * foot).abs() < 1e-9 && (y - 10.0 * foot).abs() < 1e-9,
        "{x} × {y} m"
    );
    assert_eq!(map.geo.frame, "EPSG:2263");
    let first = gdal["first_value"].as_f64().unwrap();
    let read = f64::from(map.layers[0].values[0]);
    assert!(
        (read - first * foot).abs() < 1e-3,
        "the first height {read} m, GDAL's {first} ft"
    );
}

/// Grids whose EPSG codes the reader knows from the EPSG registry alone, named by the
/// code without ProjLinearUnits: cells in the unit GDAL reads (US survey and
/// international feet), measured on the ground within 0.15 % of what GDAL's
/// transformations give (the reader takes a grid within 0.1 % of true scale as true).
#[test]
fn grids_known_from_the_registry_read_in_its_units_and_ground_metres() {
    let dir = tempfile::tempdir().unwrap();
    let Some(files) = write_variants(dir.path()) else {
        return;
    };
    let grids: Vec<_> = files.iter().filter(|f| f["source"] == "registry").collect();
    assert_eq!(grids.len(), 12);
    for file in grids {
        let name = file["name"].as_str().unwrap();
        let map = read_geotiff(&dir.path().join(format!("{name}.tif")), "m").unwrap();
        let gdal = &file["gdal"];
        let cell = gdal["cell_units"].as_f64().unwrap();
        let per_unit = gdal["metres_per_unit"].as_f64().unwrap();
        let [x, y] = map.geo.cell_size();
        assert!(
            (x - cell).abs() < 1e-9 && (y - cell).abs() < 1e-9,
            "{name}: {x} × {y}, GDAL's {cell} (a unit of {per_unit} m)"
        );
        let south_west: Vec<f64> =
            serde_json::from_value(gdal["south_west_units"].clone()).unwrap();
        for (ours, theirs) in map.geo.origin.iter().zip(&south_west) {
            assert!(
                (ours - theirs).abs() < 1e-6,
                "{name}: origin {ours} (a unit of {per_unit} m)"
            );
        }
        assert_eq!(map.geo.frame, name.replace("registry--", "EPSG:"));
        let ground: Vec<f64> =
            serde_json::from_value(gdal["ground_metres_per_unit"].clone()).unwrap();
        let metres = map.geo.cell_metres();
        for (ours, theirs) in metres.iter().zip(&ground) {
            let theirs = cell * theirs;
            assert!(
                (ours / theirs - 1.0).abs() < 1.5e-3,
                "{name}: {metres:?} on the ground, GDAL's {ground:?} per unit"
            );
        }
    }
}

/// Sidecars that give the CRS with no EPSG code, in ESRI's WKT (ArcGIS's `.aux.xml`) or
/// in WKT 2 by its parameters alone:
/// the UTM zone is known by its name, and every one reads to the cells (in ground
/// metres) and origin of the same grid with the CRS's EPSG code in its GeoKeys.
#[test]
fn sidecars_with_no_epsg_code_read_as_their_crs_by_code() {
    let dir = tempfile::tempdir().unwrap();
    let Some(files) = write_variants(dir.path()) else {
        return;
    };
    let read = |name: &str| read_geotiff(&dir.path().join(format!("{name}.tif")), "m").unwrap();
    let esri: Vec<_> = files.iter().filter(|f| f["source"] == "pam-esri").collect();
    assert_eq!(esri.len(), 4);
    for file in esri {
        let name = file["name"].as_str().unwrap();
        let map = read(name);
        let reference = read(&format!(
            "spot--esri-{}-reference",
            name.trim_start_matches("spot--pam-esri-")
        ));
        let gdal = &file["gdal"];
        let per_unit = gdal["metres_per_unit"].as_f64().unwrap();
        let transform: Vec<f64> = serde_json::from_value(gdal["transform"].clone()).unwrap();
        let [x, y] = map.geo.cell_size();
        assert!(
            (x - transform[0]).abs() < 1e-9 && (y + transform[4]).abs() < 1e-9,
            "{name}: {x} × {y} against GDAL's {transform:?} (a unit of {per_unit} m)"
        );
        let (ours, theirs) = (map.geo.cell_metres(), reference.geo.cell_metres());
        assert!(
            (ours[0] / theirs[0] - 1.0).abs() < 1e-9 && (ours[1] / theirs[1] - 1.0).abs() < 1e-9,
            "{name}: {ours:?} against {theirs:?} by EPSG code"
        );
        assert!(
            (map.geo.origin[0] - reference.geo.origin[0]).abs() < 1e-6,
            "{name}"
        );
        assert!(
            (map.geo.origin[1] - reference.geo.origin[1]).abs() < 1e-6,
            "{name}"
        );
        if name.ends_with("albers") {
            // Far north of the cone's parallels: measured on the ground, not as grid metres.
            assert!(
                (ours[1] / y - 1.0).abs() > 0.01,
                "{name}: {ours:?} from {y}"
            );
        }
        let frame = if name.ends_with("utm") {
            "EPSG:32616"
        } else {
            "map"
        };
        assert_eq!(map.geo.frame, frame, "{name}");
    }
}

/// TIFFs georeferenced outside themselves, as GDAL writes them: a baseline TIFF's CRS and
/// geotransform in its `.aux.xml` read as the GeoTIFF tags would be (UTM metres, world
/// degrees), and a world file alone gives the grid with no CRS (frame `map`).
#[test]
fn baseline_tiffs_are_georeferenced_by_their_sidecars() {
    let dir = tempfile::tempdir().unwrap();
    let Some(files) = write_variants(dir.path()) else {
        return;
    };
    let read = |name: &str| read_geotiff(&dir.path().join(format!("{name}.tif")), "m").unwrap();
    let sidecars = files.iter().filter(|f| f["source"] == "sidecars").count();
    assert_eq!(sidecars, 6);
    for source in ["spot", "world"] {
        let reference = read(&format!("{source}--reference"));
        for variant in ["baseline-pam", "baseline-tfw"] {
            let name = format!("{source}--{variant}");
            let map = read(&name);
            let (a, b) = (&map.geo, &reference.geo);
            assert_eq!(
                (a.width, a.height, a.cell_size(), a.origin),
                (b.width, b.height, b.cell_size(), b.origin),
                "{name}"
            );
            if variant == "baseline-pam" {
                assert_eq!((&a.frame, a.degrees), (&b.frame, b.degrees), "{name}");
                assert_eq!(a.cell_metres(), b.cell_metres(), "{name}");
            } else {
                assert_eq!(a.frame, "map", "{name}: a world file has no CRS");
            }
            assert!(same_values(&map, &reference), "{name}: values differ");
        }
    }
    assert!(read("world--baseline-pam").geo.degrees);
    assert_eq!(read("spot--baseline-pam").geo.frame, "EPSG:26716");
    // Without its sidecars the TIFF has no georeference, and says where it looked.
    std::fs::remove_file(dir.path().join("spot--baseline-pam.tif.aux.xml")).unwrap();
    let err = read_geotiff(&dir.path().join("spot--baseline-pam.tif"), "m")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("no georeference") && err.contains("world file"),
        "{err}"
    );
}

/// Coarsened maps (`imitate ingest --cells`, `--cell-size`) are GDAL's: rasterio's
/// `reproject` to the transform scaled by the factor, `average` on imagery and `mode`
/// on a raster of two values, read to the same grid (clipped blocks along the south
/// and east edges included) and the same values on every whole block to float rounding.
#[test]
fn coarsened_maps_are_gdals_average_over_whole_blocks() {
    let dir = tempfile::tempdir().unwrap();
    let (Some(files), Some(rasters)) = (write_variants(dir.path()), shared_data("raster")) else {
        return;
    };
    let mut checked = 0;
    for file in files.iter().filter(|f| f["source"] == "coarse") {
        let name = file["name"].as_str().unwrap();
        let factor = file["factor"].as_u64().unwrap() as usize;
        let source = read_geotiff(&rasters.join(file["raster"].as_str().unwrap()), "m").unwrap();
        let (w, h) = (source.geo.width as usize, source.geo.height as usize);
        assert!(
            w % factor != 0 || h % factor != 0,
            "{name}: no clipped block"
        );
        let ours = coarsened(source, factor, Edges::Kept);
        let gdal = read_geotiff(&dir.path().join(format!("{name}.tif")), "m").unwrap();
        assert_eq!(
            (ours.geo.width, ours.geo.height),
            (gdal.geo.width, gdal.geo.height),
            "{name}"
        );
        let ([ox, oy], [gx, gy]) = (ours.geo.origin, gdal.geo.origin);
        let [sx, sy] = gdal.geo.cell_size();
        assert!(
            (ox - gx).abs() < 1e-6 * sx && (oy - gy).abs() < 1e-6 * sy,
            "{name}"
        );
        let ([ax, ay], [bx, by]) = (ours.geo.cell_size(), gdal.geo.cell_size());
        assert!(
            (ax - bx).abs() < 1e-9 * bx && (ay - by).abs() < 1e-9 * by,
            "{name}"
        );
        // Whole blocks only: GDAL's warper fills a clipped block's cells past the
        // raster from elsewhere (on the SPOT image's east edge it reads 486 / 16 for
        // twelve cells of mean 38.5); ours are the mean of the cells they hold (the
        // unit tests of `grid::coarsen`).
        let (pw, ph) = (ours.geo.width as usize, ours.geo.height as usize);
        let clipped_row = usize::from(h % factor != 0);
        let whole = |i: usize| i % pw < w / factor && i / pw >= clipped_row;
        for (a, b) in ours.layers.iter().zip(&gdal.layers) {
            let worst = (0..pw * ph)
                .filter(|&i| whole(i))
                .map(|i| (a.values[i] - b.values[i]).abs())
                .fold(0.0f32, f32::max);
            assert!(worst <= 1e-3, "{name} {}: differs by {worst}", a.name);
            assert!(a.values.iter().all(|v| v.is_finite()), "{name}");
        }
        checked += 1;
    }
    assert_eq!(checked, 3);
}

/// A site's rasters as they come (a DEM, a finer image in its CRS, a coarser band, an
/// image in degrees) stacked into one map on the DEM's grid: each layer as GDAL's warp
/// lays it (`average` from finer cells, `bilinear` from coarser, through the CRSs), and a
/// costmap learned on all of them.
#[test]
fn rasters_of_one_site_stack_into_one_map_as_gdal_warps_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("stack_rasters.py", &[Path::new("write"), dir.path()]) else {
        return;
    };
    let file = |key: &str| written[0][key].as_str().unwrap().to_string();
    let stack = format!(
        "site={},{},{},{}",
        file("dem"),
        file("ortho"),
        file("coarse"),
        file("gps_ortho")
    );
    // Two walks across the DEM, in its UTM metres.
    let walks = dir.path().join("walks.parquet");
    let poses = |episode: &str, ends: [(f64, f64); 2]| Demonstration {
        episode: episode.into(),
        map: "site".into(),
        poses: ends
            .iter()
            .enumerate()
            .map(|(t, &(x, y))| Pose {
                t: t as f64,
                x,
                y,
                yaw: None,
            })
            .collect(),
    };
    write_demonstrations(
        &walks,
        &[
            poses("a", [(500_100.0, 4_998_600.0), (501_500.0, 4_999_500.0)]),
            poses("b", [(500_050.0, 4_999_900.0), (501_700.0, 4_998_700.0)]),
        ],
    )
    .unwrap();
    let walks = walks.to_str().unwrap();
    let run = |args: &[&str]| {
        let out = imitate(dir.path(), args);
        assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    };
    run(&[
        "ingest",
        "--stack",
        &stack,
        "--demonstrations",
        walks,
        "--out",
        "ds",
    ]);
    let map = dir.path().join("ds/maps/site.parquet");
    let Some(checks) = python_script("stack_rasters.py", &[Path::new("check"), dir.path(), &map])
    else {
        return;
    };
    assert_eq!(checks.len(), 6, "{checks:?}");
    for check in &checks {
        let difference = check["max_difference"].as_f64().unwrap();
        let range = check["range"].as_f64().unwrap();
        // Aligned blocks and bilinear weights are GDAL's to float precision; through
        // the CRSs, its partial cells weigh in: within 0.5 % of the layer's range.
        assert!(difference <= 0.005 * range, "{check}");
        assert_eq!(check["data_disagree"], 0.0, "{check}");
    }
    for command in [
        "features --dataset ds --bank auto --out fs",
        "learch --dataset ds --features fs --out costmap --rounds 5",
    ] {
        run(&command.split(' ').collect::<Vec<_>>());
    }
    // Two layers of one name are refused, naming the file.
    let out = imitate(
        dir.path(),
        &[
            "ingest",
            "--stack",
            &format!("site={},{}", file("dem"), file("dem")),
            "--demonstrations",
            walks,
            "--out",
            "twice",
        ],
    );
    assert_input_error(
        &out,
        &["dem.tif", "a second layer named 'dem' in the stack 'site'"],
    );
    assert!(!dir.path().join("twice").exists());
}

/// CRSs with no EPSG code, as GDAL writes them from PROJ strings (the method and its
/// parameters in user-defined GeoKeys): longitude and latitude are moved into each as
/// PROJ moves them, feet and all.
#[test]
fn crss_defined_by_their_parameters_take_points_as_proj_moves_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(rasters) = python_script("custom_crs.py", &[dir.path()]) else {
        return;
    };
    assert_eq!(rasters.len(), 7);
    for raster in &rasters {
        let name = raster["name"].as_str().unwrap();
        let map = read_geotiff(Path::new(raster["file"].as_str().unwrap()), name).unwrap();
        assert_eq!(map.geo.frame, "map", "{name}: GDAL wrote no EPSG code");
        let reprojection =
            Reprojection::new("EPSG:4326", &map.geo).unwrap_or_else(|why| panic!("{name}: {why}"));
        for point in raster["points"].as_array().unwrap() {
            let p: Vec<f64> = serde_json::from_value(point.clone()).unwrap();
            let (x, y) = reprojection.point(p[0], p[1]).unwrap();
            assert!(
                (x - p[2]).abs() < 1e-3 && (y - p[3]).abs() < 1e-3,
                "{name}: ({x}, {y}) against PROJ's ({}, {})",
                p[2],
                p[3]
            );
        }
    }
}

/// DEMs as they are handed out in other formats than GeoTIFF, written by GDAL from
/// GeoTIFFs it also wrote: each reads to its GeoTIFF twin's grid, CRS and values (an
/// Esri ASCII grid in UTM with its .prj, one in degrees with non-square cells, an SRTM
/// tile, the tile zipped as NASA hands it out, DTED tiles of levels 0 and 1), and
/// ingest takes them as maps.
#[test]
fn ascii_grids_and_srtm_tiles_read_as_their_geotiff_twins() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("dem_formats.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    for pair in info["pairs"].as_array().unwrap() {
        let (tif, twin) = (
            PathBuf::from(pair[0].as_str().unwrap()),
            PathBuf::from(pair[1].as_str().unwrap()),
        );
        let (a, b) = (
            imitate::io::read_raster(&tif, "a").unwrap(),
            imitate::io::read_raster(&twin, "a").unwrap(),
        );
        let what = twin.display();
        assert_eq!(a.geo.frame, b.geo.frame, "{what}");
        assert_eq!((a.geo.width, a.geo.height), (b.geo.width, b.geo.height));
        for (x, y) in a.geo.bounds().into_iter().zip(b.geo.bounds()) {
            assert!((x - y).abs() <= 1e-9 * x.abs().max(1.0), "{what}: {x} {y}");
        }
        let ([ax, ay], [bx, by]) = (a.geo.cell_metres(), b.geo.cell_metres());
        assert!(
            (ax - bx).abs() < 1e-9 * ax && (ay - by).abs() < 1e-9 * ay,
            "{what}"
        );
        let (va, vb) = (&a.layers[0].values, &b.layers[0].values);
        assert!(va.iter().any(|v| v.is_nan()) || !twin.ends_with("dem.asc"));
        let same = va
            .iter()
            .zip(vb)
            .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()));
        assert!(same, "{what}: values differ from {}", tif.display());
    }
    let asc = info["pairs"][0][1].as_str().unwrap();
    let hgt = info["pairs"][2][1].as_str().unwrap();
    let zipped = info["pairs"][3][1].as_str().unwrap();
    let walks = info["demonstrations"].as_str().unwrap();
    let out = imitate(
        dir.path(),
        &[
            "ingest",
            "--map",
            asc,
            hgt,
            zipped,
            "--demonstrations",
            walks,
            "--out",
            "ds",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    for map in ["dem", "N46E007", "N46E007.SRTMGL3"] {
        assert!(dir.path().join(format!("ds/maps/{map}.parquet")).is_file());
    }
}

/// Mosaics and band stacks as gdalbuildvrt writes them (GDAL's own GDALBuildVRT): each
/// VRT reads to the grid and values GDAL reads it to (tiles that overlap with voids, a
/// missing tile, SRTM tiles, bands of three types, a coarser cell, a VRT of a VRT), as
/// do raw bands of a hand-written VRT, and ingest takes one as a map. A VRT that points at nothing readable is refused by name.
#[test]
fn gdal_virtual_rasters_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("vrt_mosaic.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    for pair in info["pairs"].as_array().unwrap() {
        let (tif, vrt) = (
            PathBuf::from(pair[0].as_str().unwrap()),
            PathBuf::from(pair[1].as_str().unwrap()),
        );
        let what = vrt.display();
        // GDAL's averages differ from ours in a float's last bits (sums in another order).
        let tolerance = pair[2].as_f64().unwrap() as f32;
        let gdal = imitate::io::read_raster(&tif, "a").unwrap();
        let ours = imitate::io::read_raster(&vrt, "a").unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(gdal.geo.frame, ours.geo.frame, "{what}");
        assert_eq!(
            (gdal.geo.width, gdal.geo.height),
            (ours.geo.width, ours.geo.height),
            "{what}"
        );
        for (x, y) in gdal.geo.bounds().into_iter().zip(ours.geo.bounds()) {
            assert!((x - y).abs() <= 1e-9 * x.abs().max(1.0), "{what}: {x} {y}");
        }
        assert_eq!(gdal.layers.len(), ours.layers.len(), "{what}");
        for (a, b) in gdal.layers.iter().zip(&ours.layers) {
            let differ = a
                .values
                .iter()
                .zip(&b.values)
                .filter(|&(x, y)| {
                    !((x - y).abs() <= tolerance * x.abs().max(1.0) || (x.is_nan() && y.is_nan()))
                })
                .count();
            assert_eq!(differ, 0, "{what} {}: cells differ from GDAL's", b.name);
        }
    }
    // The mosaic has voids and a tile's worth of nodata; the SRTM pair is one grid.
    let mosaic = imitate::io::read_raster(&dir.path().join("mosaic.vrt"), "m").unwrap();
    let voids = mosaic.layers[0]
        .values
        .iter()
        .filter(|v| v.is_nan())
        .count();
    assert!(voids > 60 * 50, "{voids}");
    let srtm = imitate::io::read_raster(&dir.path().join("srtm.vrt"), "s").unwrap();
    assert_eq!((srtm.geo.width, srtm.geo.height), (2401, 1201));
    assert!(srtm.geo.degrees);
    // What reading a VRT of a VRT depends on, so that a changed tile makes it stale.
    let inputs = imitate::io::raster_sidecars(&dir.path().join("nested.vrt"));
    for file in [
        "mosaic.vrt",
        "tiles/dem0.tif",
        "tiles/dem1.tif",
        "tiles/dem2.tif",
    ] {
        assert!(
            inputs.contains(&dir.path().join(file)),
            "{file}: {inputs:?}"
        );
    }

    // A route across the tiles' seam at 8° E.
    std::fs::write(
        dir.path().join("route.geojson"),
        r#"{"type": "FeatureCollection", "features": [{"type": "Feature",
            "properties": {"name": "across-the-seam"}, "geometry": {"type": "LineString",
            "coordinates": [[7.9, 46.5], [8.0, 46.52], [8.1, 46.5]]}}]}"#,
    )
    .unwrap();
    let out = imitate(
        dir.path(),
        &[
            "ingest",
            "--map",
            "srtm.vrt",
            "--geojson",
            "route.geojson",
            "--out",
            "ds",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(dir.path().join("ds/maps/srtm.parquet").is_file());

    // A source that is not there, one in a GDAL virtual file system, a warped VRT.
    let tiles = dir.path().join("tiles");
    let mosaic_xml = std::fs::read_to_string(dir.path().join("mosaic.vrt")).unwrap();
    std::fs::write(
        dir.path().join("gone.vrt"),
        mosaic_xml.replace("tiles/dem1.tif", "tiles/dem9.tif"),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("zipped.vrt"),
        mosaic_xml.replace(
            "<SourceFilename relativeToVRT=\"1\">tiles/dem1.tif",
            "<SourceFilename relativeToVRT=\"0\">/vsizip/tiles.zip/dem1.tif",
        ),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("warped.vrt"),
        mosaic_xml.replace("<VRTDataset ", "<VRTDataset subClass=\"VRTWarpedDataset\" "),
    )
    .unwrap();
    for (vrt, needles) in [
        (
            "gone.vrt",
            &["gone.vrt", "band 1: source 2", "dem9.tif"][..],
        ),
        (
            "zipped.vrt",
            &["zipped.vrt", "source 2", "/vsizip/", "virtual file system"],
        ),
        (
            "warped.vrt",
            &["warped.vrt", "VRTWarpedDataset", "gdalwarp"],
        ),
    ] {
        let out = imitate(
            dir.path(),
            &[
                "ingest",
                "--map",
                vrt,
                "--geojson",
                "route.geojson",
                "--out",
                "bad",
            ],
        );
        assert_input_error(&out, needles);
        assert!(!dir.path().join("bad").exists(), "{vrt}");
    }
    assert!(
        tiles.join("dem0.tif").is_file(),
        "the tiles are the user's: left as they were"
    );
}

/// JPEG 2000 rasters as GDAL writes them (JP2OpenJPEG): each reads to the grid, CRS,
/// band names, values and nodata GDAL reads it to (its sidecar's too), georeferenced by its GeoJP2 or its GMLJP2 box (degrees
/// latitude first in GML), tiled with several resolutions as Sentinel-2's bands are;
/// a lossy one within a unit of OpenJPEG's decoding. A bare codestream with no
/// georeference is refused by name.
#[test]
fn jpeg2000_rasters_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("jpeg2000.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    let lossy = strings(&info["lossy"]);
    for pair in info["pairs"].as_array().unwrap() {
        let (jp2, gdal, ours) = read_twins(pair);
        let jp2 = jp2.as_str();
        let tolerance = if lossy.contains(&jp2) { 1.0 } else { 0.0 };
        for (a, b) in gdal.layers.iter().zip(&ours.layers) {
            let (worst, _) = differences_from_gdal(jp2, a, b);
            assert!(worst <= tolerance, "{jp2} {}: off by {worst}", b.name);
        }
    }
    let out = imitate(
        dir.path(),
        &["bench", "terrain", "bare.j2k", "--method", "uniform"],
    );
    assert_input_error(&out, &["bare.j2k", "no georeference", "GeoJP2", "GMLJP2"]);
}

/// Georeferenced PNG and JPEG images as GDAL writes them: each reads to the grid, CRS,
/// band names, values and nodata GDAL reads it to, nodata where GDAL's mask says so (an
/// alpha band, a transparent grey or colour, a palette's clear entry, the mask GDAL
/// appends to a JPEG), georeferenced by the sidecar or by a world file alone; a
/// palette PNG's indices are declared classes; a JPEG as close to GDAL's libjpeg as
/// libjpeg-turbo is. An image with no georeference is refused by name.
#[test]
fn georeferenced_png_and_jpeg_images_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("pictures.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    let classes = strings(&info["classes"]);
    let lossy = info["lossy"].as_object().unwrap();
    for pair in info["pairs"].as_array().unwrap() {
        let (picture, gdal, ours) = read_twins(pair);
        let picture = picture.as_str();
        for (a, b) in gdal.layers.iter().zip(&ours.layers) {
            let (worst, mean) = differences_from_gdal(picture, a, b);
            match lossy.get(picture) {
                // Two libjpegs differ from each other on a photo's colours: ours is
                // as close to GDAL's as libjpeg-turbo is, give or take a level.
                Some(peer) => {
                    let (peer_worst, peer_mean) = (
                        peer[0].as_f64().unwrap() as f32,
                        peer[1].as_f64().unwrap() as f32,
                    );
                    assert!(
                        worst <= peer_worst.max(1.0) + 1.0 && mean <= peer_mean * 1.25 + 0.05,
                        "{picture} {}: off by {worst}, {mean} on average; libjpeg-turbo by \
                         {peer_worst}, {peer_mean}",
                        b.name
                    );
                }
                None => assert_eq!(worst, 0.0, "{picture} {}", b.name),
            }
            let declared = b.kind == LayerKind::Classes;
            assert_eq!(declared, classes.contains(&picture), "{picture}");
        }
    }
    let out = imitate(
        dir.path(),
        &["bench", "terrain", "bare.png", "--method", "uniform"],
    );
    assert_input_error(
        &out,
        &["bare.png", "no georeference", ".aux.xml", "world file"],
    );
}

/// A pair of files a Python script wrote (a GeoTIFF twin of what GDAL reads a file to,
/// and the file): the file's path, the twin read and the file read, once the two are
/// checked to have the same grid, CRS (the GeoKeys' citations aside) and layer count.
fn read_twins(pair: &serde_json::Value) -> (String, imitate::grid::Map, imitate::grid::Map) {
    let (tif, file) = (pair[0].as_str().unwrap(), pair[1].as_str().unwrap());
    let gdal = imitate::io::read_raster(Path::new(tif), "a").unwrap();
    let ours =
        imitate::io::read_raster(Path::new(file), "a").unwrap_or_else(|e| panic!("{file}: {e}"));
    let grid = |geo: &imitate::grid::GeoRef| imitate::grid::GeoRef {
        tiff_crs: None,
        ..geo.clone()
    };
    assert_eq!(grid(&gdal.geo), grid(&ours.geo), "{file}");
    assert_eq!(gdal.layers.len(), ours.layers.len(), "{file}");
    (file.to_string(), gdal, ours)
}

/// As [`read_twins`], for grids whose transform a reader computes from coordinate
/// arrays (netCDF, Zarr): the same size, CRS and degrees, the cell size, origin and
/// ground scale within GDAL's own float noise.
fn read_twins_nearly(pair: &serde_json::Value) -> (String, imitate::grid::Map, imitate::grid::Map) {
    let (tif, file) = (pair[0].as_str().unwrap(), pair[1].as_str().unwrap());
    let gdal = imitate::io::read_raster(Path::new(tif), "a").unwrap();
    let ours =
        imitate::io::read_raster(Path::new(file), "a").unwrap_or_else(|e| panic!("{file}: {e}"));
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(1.0);
    let (g, o) = (&gdal.geo, &ours.geo);
    assert_eq!(
        (g.width, g.height, &g.frame, g.degrees),
        (o.width, o.height, &o.frame, o.degrees),
        "{file}"
    );
    assert!(near(g.resolution, o.resolution), "{file}: {g:?} {o:?}");
    assert!(
        near(
            g.resolution_y.unwrap_or(g.resolution),
            o.resolution_y.unwrap_or(o.resolution)
        ),
        "{file}: {g:?} {o:?}"
    );
    assert!(
        near(g.origin[0], o.origin[0]) && near(g.origin[1], o.origin[1]),
        "{file}: {g:?} {o:?}"
    );
    let scales = |geo: &imitate::grid::GeoRef| geo.ground_scale.map(|s| s.per_axis());
    match (scales(g), scales(o)) {
        (Some(a), Some(b)) => assert!(
            (0..2).all(|i| (a[i] - b[i]).abs() <= 1e-6 * a[i]),
            "{file}: {a:?} {b:?}"
        ),
        (a, b) => assert_eq!(a, b, "{file}"),
    }
    (file.to_string(), gdal, ours)
}

/// Holds each pair's file to its twin: the grid and CRS ([`read_twins`]), and every
/// band's name, values and nodata cells exactly.
fn assert_read_exactly_as_twins(pairs: &[serde_json::Value]) {
    for pair in pairs {
        let (file, gdal, ours) = read_twins(pair);
        for (a, b) in gdal.layers.iter().zip(&ours.layers) {
            let (worst, _) = differences_from_gdal(&file, a, b);
            assert_eq!(worst, 0.0, "{file} {}", b.name);
        }
    }
}

/// Holds each pair's file to its twin on nearly its grid ([`read_twins_nearly`]) and
/// its bands to the twin's ([`assert_layers_near`]).
fn assert_read_nearly_as_twins(pairs: &[serde_json::Value], worst_allowed: f32, same_names: bool) {
    for pair in pairs {
        let (file, gdal, ours) = read_twins_nearly(pair);
        let ours: Vec<_> = ours.layers.iter().collect();
        assert_layers_near(&file, &gdal.layers, &ours, worst_allowed, same_names);
    }
}

/// As many layers as GDAL's, each's values within `worst_allowed` and its nodata cells
/// the same; their names too where `same_names` (else GDAL's are taken as ours: a twin
/// that numbers its bands, or a variable's steps).
fn assert_layers_near(
    file: &str,
    gdal: &[imitate::grid::Layer],
    ours: &[&imitate::grid::Layer],
    worst_allowed: f32,
    same_names: bool,
) {
    assert_eq!(gdal.len(), ours.len(), "{file}");
    for (a, b) in gdal.iter().zip(ours) {
        let named = imitate::grid::Layer {
            name: if same_names {
                a.name.clone()
            } else {
                b.name.clone()
            },
            ..a.clone()
        };
        let (worst, _) = differences_from_gdal(file, &named, b);
        assert!(worst <= worst_allowed, "{file} {}: {worst}", b.name);
    }
}

/// Holds our reading of `file` to GDAL's: the same values, or for lossy tiles
/// (`peer`: the largest and mean difference of libjpeg-turbo's or libwebp's decoding
/// from GDAL's, over every band) as close to GDAL's as that other decoder is, within a
/// quarter, give or take a level.
fn assert_decoded_as_gdal_or_peer(
    file: &str,
    gdal: &imitate::grid::Map,
    ours: &imitate::grid::Map,
    peer: Option<&serde_json::Value>,
) {
    let differences: Vec<(f32, f32)> = gdal
        .layers
        .iter()
        .zip(&ours.layers)
        .map(|(a, b)| differences_from_gdal(file, a, b))
        .collect();
    let worst = differences.iter().map(|d| d.0).fold(0.0, f32::max);
    let Some(peer) = peer else {
        assert_eq!(worst, 0.0, "{file}: {differences:?}");
        return;
    };
    let mean = differences.iter().map(|d| d.1).sum::<f32>() / differences.len() as f32;
    let peer_worst = peer[0].as_f64().unwrap() as f32;
    let peer_mean = peer[1].as_f64().unwrap() as f32;
    assert!(
        worst <= peer_worst.max(1.0) * 1.25 + 1.0 && mean <= peer_mean * 1.25 + 0.05,
        "{file}: off by {worst}, {mean} on average; the peer by {peer_worst}, {peer_mean}"
    );
}

/// Plans across `file` (a one-band raster read as costs) from cell `start` to `goal`, as
/// a user would, and checks the plan joins them at a finite cost.
fn plans_across(dir: &Path, file: &str, start: &str, goal: &str) {
    let out = imitate(
        dir,
        &["plan", file, "--cells", "--start", start, "--goal", goal],
    );
    assert!(out.status.success(), "{file}: {}", stderr(&out));
    let plan: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    let cells = plan["cells"].as_array().unwrap();
    let joined = |cell: &serde_json::Value| format!("{},{}", cell[0], cell[1]);
    assert_eq!(joined(&cells[0]), start, "{file}");
    assert_eq!(joined(cells.last().unwrap()), goal, "{file}");
    assert!(plan["cost"].as_f64().unwrap().is_finite(), "{plan}");
}

/// Runs `imitate bench terrain` on each file `refused` names by key, as a user would,
/// and checks each ends as an input error naming its needles.
fn assert_refused(dir: &Path, refused: &serde_json::Value, refusals: &[(&str, &[&str])]) {
    for (key, needles) in refusals {
        let file = Path::new(refused[key].as_str().unwrap());
        let name = file.file_name().unwrap().to_str().unwrap();
        let out = imitate(dir, &["bench", "terrain", name, "--method", "uniform"]);
        assert_input_error(&out, needles);
    }
}

#[test]
fn tiffs_the_rust_tiff_crates_test_on_read_as_gdal_reads_them() {
    let crate_tiffs = common::repo().join("target/crate-tiffs");
    if !crate_tiffs.join(".complete").is_file() {
        eprintln!("skipped: the TIFF crates' test files not fetched (run scripts/sample-data.sh)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("crate_tiffs.py", &[&crate_tiffs, dir.path()]) else {
        return;
    };
    let info = &written[0];
    let pairs = info["pairs"].as_array().unwrap();
    assert!(pairs.len() >= 50, "{}", pairs.len());
    assert_read_nearly_as_twins(pairs, 0.0, true);
    // JPEG tiles: another decoder's rounding and chroma upsampling, no more.
    for pair in info["lossy"].as_array().unwrap() {
        let (file, gdal, ours) = read_twins_nearly(pair);
        for (a, b) in gdal.layers.iter().zip(&ours.layers) {
            let (_, mean, same_nodata) = differences(&a.values, &b.values);
            assert!(same_nodata && mean < 1.5, "{file} {}: {mean}", b.name);
        }
    }
    // A user-defined Mercator GDAL names no CRS for, measured as PROJ measures it.
    let (merc, proj_ground) = (&info["mercator"][0], info["mercator"][1].as_f64().unwrap());
    let map = imitate::io::read_raster(Path::new(merc.as_str().unwrap()), "a").unwrap();
    let ground = map.geo.ground_scale.expect("measured").per_axis();
    assert!(
        ground.iter().all(|g| (g / proj_ground - 1.0).abs() < 1e-5),
        "{ground:?} against PROJ's {proj_ground}"
    );
    let refusals: [(&str, &[&str]); 3] = [
        ("control points", &["ground control points"]),
        ("no georeference", &["no georeference"]),
        ("photometric", &["photometric"]),
    ];
    assert_refused(dir.path(), &info["refused"], &refusals);
    // Damaged copies of those read through the paths added for them (CMYK, min-is-white,
    // old-style LZW) and of a few others: errors naming the file, never a panic. The
    // damaged copy has a world file beside it, as its plain original had.
    std::fs::write(dir.path().join("damaged.tfw"), "1\n0\n0\n-1\n0.5\n1000.5\n").unwrap();
    let damaged: Vec<PathBuf> = [
        "tiled-cmyk-i8.tif",
        "cmyk-3c-8b.tiff",
        "miniswhite-1c-1b.tiff",
        "quad-lzw-compat.tiff",
        "random-fp16-pred3.tiff",
        "BigTIFFMotorola.tif",
        "palette-1c-4b.tiff",
    ]
    .iter()
    .map(|name| dir.path().join(name))
    .collect();
    assert!(damage_files(&damaged, &dir.path().join("damaged.tif"), 40) >= 40);
}

#[test]
fn projections_with_no_formula_here_are_measured_as_proj_measures_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("projected_scales.py", &[dir.path()]) else {
        return;
    };
    let grids = written[0].as_array().unwrap();
    assert_eq!(grids.len(), 8);
    for grid in grids {
        let file = grid[0].as_str().unwrap();
        let map = imitate::io::read_raster(Path::new(file), "a").unwrap();
        let ours = map.geo.cell_metres().map(|m| m / 100.0);
        for (axis, ours) in ours.iter().enumerate() {
            let proj = grid[1][axis].as_f64().unwrap();
            // Far from true scale (2 % to 30 %), so being right is being measured.
            assert!(
                (ours / proj - 1.0).abs() < 1e-4,
                "{file} axis {axis}: {ours} against PROJ's {proj}"
            );
        }
    }
}

/// `damage_files` on the second file of each pair the Python writers print.
fn damage_pairs(pairs: &[serde_json::Value], damaged: &Path, per_file: usize) -> usize {
    let files: Vec<PathBuf> = pairs
        .iter()
        .map(|pair| PathBuf::from(pair[1].as_str().unwrap()))
        .collect();
    damage_files(&files, damaged, per_file)
}

/// Read, never written: SQLite left no journal, write-ahead log or lock file in `dir`.
fn assert_nothing_beside(dir: &Path) {
    let leftovers: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with("-journal") || n.ends_with("-wal") || n.ends_with("-shm"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// The strings of a JSON array the Python writers print.
fn strings(list: &serde_json::Value) -> Vec<&str> {
    list.as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect()
}

/// The largest and the mean difference of our layer's values from GDAL's, once the two
/// are checked to have one name and the same nodata cells.
fn differences_from_gdal(
    file: &str,
    gdal: &imitate::grid::Layer,
    ours: &imitate::grid::Layer,
) -> (f32, f32) {
    assert_eq!(gdal.name, ours.name, "{file}");
    let same_nodata = gdal
        .values
        .iter()
        .zip(&ours.values)
        .all(|(x, y)| x.is_nan() == y.is_nan());
    assert!(same_nodata, "{file} {}: nodata cells differ", ours.name);
    let differences: Vec<f32> = gdal
        .values
        .iter()
        .zip(&ours.values)
        .filter(|(x, _)| !x.is_nan())
        .map(|(x, y)| (x - y).abs())
        .collect();
    let worst = differences.iter().copied().fold(0f32, f32::max);
    let mean = differences.iter().sum::<f32>() / differences.len().max(1) as f32;
    (worst, mean)
}

/// Raw rasters with an ESRI header as GDAL writes them (EHdr) and as the USGS hands
/// them out (GridFloat): an SRTM-like int16 `.bil` in degrees with nodata, a float32
/// `.flt`, a 3-band image by line, by pixel and by band (big-endian), and a GridFloat
/// with the USGS's lowercase header; each reads to the grid, CRS, values and nodata
/// GDAL reads it to. A `.bil` without its header is refused, naming the header.
#[test]
fn raw_rasters_with_an_esri_header_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("ehdr_rasters.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    assert_read_exactly_as_twins(info["pairs"].as_array().unwrap());
    let out = imitate(
        dir.path(),
        &["bench", "terrain", "headless.bil", "--method", "uniform"],
    );
    assert_input_error(&out, &["headless.bil", "headless.hdr", "header"]);
}

/// ENVI rasters as GDAL's ENVI driver writes them (`.img`, `.bil`, `.dat`; band-sequential,
/// by line and by pixel; 16 to 64-bit integers, 32 and 64-bit floats; nodata and band
/// names) and as ENVI writes a scene by hand (big-endian after a header offset, the
/// header named `x.bsq.hdr`, the reference pixel at a cell's centre, a UTM zone south
/// named by `map info` alone): each reads to the grid, CRS, names, values and nodata GDAL
/// reads it to. A complex one is refused, naming the file and its data type.
#[test]
fn envi_rasters_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("envi_rasters.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    assert_read_exactly_as_twins(info["pairs"].as_array().unwrap());
    let out = imitate(
        dir.path(),
        &["bench", "terrain", "complex.img", "--method", "uniform"],
    );
    assert_input_error(&out, &["complex.img", "complex.hdr", "data type 6"]);
}

/// R raster grids as GDAL writes them (every sample type, by line, band and pixel, band
/// names and nodata) and as R's `raster` package writes them (big-endian, a PROJ string
/// and no WKT: geographic, equal-area, oblique stereographic, Mercator, polar): each
/// reads to the grid, CRS, ground scale, names, values and nodata GDAL reads it to,
/// beside Surfer and netCDF grids of the same extension. A grid without its samples, an
/// INT8S one and one in a projection not read from PROJ strings are refused, naming
/// the problem.
#[test]
fn r_raster_grids_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("rraster_rasters.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    assert_read_exactly_as_twins(info["pairs"].as_array().unwrap());
    plans_across(dir.path(), "r_dem.grd", "2,2", "50,70");
    assert_refused(
        dir.path(),
        &info["refused"],
        &[
            (
                "headless",
                &["no_samples.grd", "no_samples.gri", "missing"][..],
            ),
            ("int8", &["int8.grd", "INT8S"]),
            ("proj", &["robin.grd", "+proj=robin", ".prj"]),
        ],
    );
}

/// Rasters whose columns run west (a negative x step: GeoTIFFs north-up and south-up, a
/// tiled 2-band one with nodata, an Imagine file, a BIL, a PNG beside its world file and
/// GDAL's VRT of one) read to the grid and cells of GDAL's reading turned east by
/// NumPy, every value and nodata cell the same.
#[test]
fn rasters_whose_columns_run_west_read_as_gdal_reads_them_turned_east() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("westward_rasters.py", &[dir.path()]) else {
        return;
    };
    let pairs = written[0]["pairs"].as_array().unwrap();
    assert_eq!(pairs.len(), 7);
    assert_read_exactly_as_twins(pairs);
    plans_across(dir.path(), "west.tif", "2,2", "45,65");
}

/// ER Mapper rasters as GDAL's ERS driver writes them (each CRS family ER Mapper names,
/// and CRSs it has none for as GDAL's `EPSG:n`; every sample type) and as ER Mapper
/// writes them (big-endian, registered in degrees at a cell's centre, a `DataFile` and a
/// header offset) read as GDAL reads them; degrees on GDA94, which GDAL reads with no
/// CRS, are read on EPSG:4283; a rotation, a projection not read here and missing
/// samples are refused by name.
#[test]
fn er_mapper_rasters_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("ers_rasters.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    assert_read_exactly_as_twins(info["pairs"].as_array().unwrap());
    let gda94 =
        imitate::io::read_raster(Path::new(info["gda94_degrees"].as_str().unwrap()), "m").unwrap();
    assert_eq!(gda94.geo.frame, "EPSG:4283");
    assert!(gda94.geo.degrees);
    plans_across(dir.path(), "ermapper.ers", "2,2", "50,70");
    assert_refused(
        dir.path(),
        &info["refused"],
        &[
            ("rotated", &["rotated.ers", "rotated"][..]),
            ("projection", &["tmamg.ers", "TMAMG"]),
            ("headless", &["no_samples.ers", "no_samples", "data file"]),
        ],
    );
}

/// The example rasters R users load (R's raster, terra, stars and rgdal packages, as
/// Debian ships them: `scripts/sample-data.sh`): R-written grids whose CRS is a PROJ
/// string (the Dutch RD grid, Mercator), GeoTIFFs (a Landsat 7 scene, DEMs, a land
/// cover, State Plane in feet), an ASCII grid, an ENVI `.envi`, a VRT of raw bands, and
/// netCDF variables (a Lambert grid in km, longitudes from 0–360° cut across
/// Greenwich, sea-surface temperatures, climate projections; xarray-spatial's
/// Sentinel-2 bands as legacy xarray wrote them) read as GDAL reads them, and NASA's
/// TRMM subset, lying (lon, lat), as its values transposed;
/// a rotated GeoTIFF, stations and a grid of 2-D latitudes and longitudes are refused,
/// naming the problem.
#[test]
fn example_rasters_of_r_and_python_packages_read_as_gdal_reads_them() {
    let samples = common::repo().join("target/sample-data");
    if !samples.join(".complete").is_file() {
        eprintln!("skipped: R's example rasters not fetched (run scripts/sample-data.sh)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("r_samples.py", &[&samples, dir.path()]) else {
        return;
    };
    let info = &written[0];
    assert_read_nearly_as_twins(info["pairs"].as_array().unwrap(), 0.0, true);
    for variable in info["variables"].as_array().unwrap() {
        let (file, gdal, ours) = read_twins_nearly(variable);
        let name = variable[2].as_str().unwrap();
        // GDAL numbers a variable's steps as bands; ours are named by the variable.
        let ours: Vec<_> = ours
            .layers
            .iter()
            .filter(|l| l.name == name || l.name.starts_with(&format!("{name}_")))
            .collect();
        assert_layers_near(&file, &gdal.layers, &ours, 0.0, false);
    }
    // A Debian release may lack one of the packages: only what was fetched is held.
    if dir.path().join("test.grd").is_file() {
        plans_across(dir.path(), "test.grd", "20,20", "90,60");
    }
    let refusals: [(&str, &[&str]); 3] = [
        ("rotated", &["geomatrix.tif", "rotated"]),
        ("stations", &["timeseries.nc", "station"]),
        (
            "curvilinear",
            &["test_stageiv_xyt.nc", "no coordinate variables"],
        ),
    ];
    let fetched: Vec<_> = refusals
        .into_iter()
        .filter(|(key, _)| info["refused"].get(key).is_some())
        .collect();
    assert_refused(dir.path(), &info["refused"], &fetched);
}

/// USGS ASCII DEMs as GDAL's USGSDEM driver writes them (degrees on NAD83 with voids,
/// UTM on NAD83, UTM on WGS 84 in tenths of a metre) and a GTOPO30-style `.dem` beside
/// its `.hdr`: each reads to the grid, CRS, values and voids GDAL reads it to; damaged,
/// each is read or refused naming the file, never a panic. A `.dem` that is neither is
/// refused, naming the file.
#[test]
fn usgs_dems_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("usgs_dems.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    assert_read_nearly_as_twins(info["pairs"].as_array().unwrap(), 1e-4, false);
    plans_across(dir.path(), "utm.dem", "5,5", "50,40");
    let pairs = info["pairs"].as_array().unwrap();
    assert!(damage_pairs(&pairs[..3], &dir.path().join("damaged.dem"), 60) >= 60);
    assert_refused(
        dir.path(),
        &info["refused"],
        &[("neither", &["grid.dem", ".hdr"][..])],
    );
}

/// Zarr stores as xarray writes them: version 2 (zarr's default Blosc with LZ4 and byte
/// shuffle, Blosc's Zstandard, zlib and BloscLZ, Blosc with bit shuffle, Zstandard,
/// zlib and gzip alone, uncompressed, `/` between chunk indices) read as GDAL reads them, and
/// version 3 (Zstandard, gzip with a checksum, Blosc; degrees with latitudes from the
/// south, also bit-shuffled; bands first beside a second variable; shards of 2 × 2
/// chunks) read as xarray reads them: partial edge chunks, a chunk never written,
/// `_FillValue` voids and rioxarray's grid mapping.
/// A store without coordinates is refused, naming the problem;
/// damaged stores are read or refused, never a panic.
#[test]
fn zarr_stores_read_as_gdal_and_xarray_read_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("zarr_rasters.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    assert_read_nearly_as_twins(info["pairs"].as_array().unwrap(), 0.0, true);
    plans_across(dir.path(), "v2_default.zarr", "30,2", "2,60");
    assert_refused(
        dir.path(),
        &info["refused"],
        &[("bare", &["bare.zarr", "no gridded array"])],
    );
    for store in ["v2_default.zarr", "v3_gzip.zarr", "v3_sharded.zarr"] {
        assert!(damage_store(&dir.path().join(store), 8) >= 100);
    }
    // Our own decoders' streams: BloscLZ's matches, bit-shuffled blocks.
    for store in ["v2_blosclz_far.zarr", "v2_bitshuffle.zarr"] {
        assert!(damage_store(&dir.path().join(store), 8) >= 40);
    }
}

/// SAGA grids as GDAL writes them (every sample type it writes, named by the `.sdat` or
/// the `.sgrd`), as SAGA 7 writes a header, and as SAGA's compressed `.sg-grd-z`: each
/// reads to the grid, CRS, values and nodata GDAL reads it to. Where GDAL departs from
/// SAGA (rows from the top, a z factor and offset, a nodata range, a data file offset),
/// each reads to the values SAGA reads. Bits, text samples, a missing header and samples
/// cut short are refused, naming the file and the problem; damaged archives are read or
/// refused, never a panic.
#[test]
fn saga_grids_read_as_gdal_and_saga_read_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("saga_rasters.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    let pairs = info["pairs"].as_array().unwrap();
    assert_read_exactly_as_twins(pairs);
    assert_read_exactly_as_twins(info["saga_pairs"].as_array().unwrap());
    plans_across(dir.path(), "dem.sgrd", "5,5", "60,80");
    assert_refused(
        dir.path(),
        &info["refused"],
        &[
            ("bits", &["bits.sdat", "bits.sgrd", "DATAFORMAT BIT"][..]),
            ("text", &["text.sdat", "DATAFORMAT ASCII"]),
            (
                "headless",
                &["headless.sdat", "headless.sgrd", "cannot be read"],
            ),
            ("short", &["short.sdat", "holds 1000 bytes"]),
        ],
    );
    let zipped: Vec<_> = pairs
        .iter()
        .filter(|pair| pair[1].as_str().unwrap().ends_with(".sg-grd-z"))
        .cloned()
        .collect();
    assert!(damage_pairs(&zipped, &dir.path().join("damaged.sg-grd-z"), 200) >= 20);
}

/// netCDF rasters as GDAL, netCDF4-python and xarray write them (classic and netCDF-4,
/// Deflate, latitudes either way, time steps, packed integers with fill and missing
/// values, `_Unsigned` bytes, a `spatial_ref` WKT, heights in kilometres): each reads to
/// the grid, values, nodata and names GDAL reads it to; CRSs that only CF's grid-mapping
/// parameters give (polar stereographic, Lambert conformal on a sphere) are measured on
/// the ground as GDAL's CRS for them is (its twin a user-defined GeoTIFF CRS); a variable
/// with `flag_values` holds classes, longitudes running west and packed coordinates read
/// as the same grid running east, damaged files are errors, never panics, and files that cannot be a map
/// are refused naming the file and why.
#[test]
fn netcdf_rasters_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("netcdf_rasters.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    let classes = strings(&info["classes"]);
    // GDAL's transform from coordinate variables carries its own float noise.
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(1.0);
    for pair in info["pairs"].as_array().unwrap() {
        let (file, gdal, ours) = read_twins_nearly(pair);
        let file = file.as_str();
        assert_eq!(gdal.layers.len(), ours.layers.len(), "{file}");
        for (a, b) in gdal.layers.iter().zip(&ours.layers) {
            let (worst, _) = differences_from_gdal(file, a, b);
            assert!(
                worst <= 1e-6 * a.values.iter().fold(1f32, |m, v| m.max(v.abs())),
                "{file} {}: {worst}",
                b.name
            );
            let declared = b.kind == LayerKind::Classes;
            assert_eq!(
                declared,
                classes.contains(&file) && b.name == "land_cover",
                "{file} {}",
                b.name
            );
        }
    }
    let read =
        |key: &str| imitate::io::read_raster(Path::new(info[key].as_str().unwrap()), "a").unwrap();
    let (east, west, packed) = (read("east"), read("west"), read("packed"));
    assert_eq!(east.geo, west.geo);
    assert_eq!(east.layers[0].values, west.layers[0].values);
    assert!(near(east.geo.resolution, packed.geo.resolution));
    assert!((0..2).all(|i| near(east.geo.origin[i], packed.geo.origin[i])));
    assert_eq!(east.layers[0].values, packed.layers[0].values);
    // A variable lying (lon, lat) reads as its (lat, lon) twin.
    let (lat_lon, lon_lat) = (read("lat_lon"), read("lon_lat"));
    assert_eq!(lat_lon.geo, lon_lat.geo);
    assert_eq!(lat_lon.layers[0].values, lon_lat.layers[0].values);
    // h5netcdf's file named .h5 reads as the same file named .nc.
    let (h5, h5_twin) = (read("h5"), read("h5_twin"));
    assert_eq!(h5.geo, h5_twin.geo);
    assert_eq!(h5.layers, h5_twin.layers);
    let refusals = [
        ("uneven", "not evenly spaced"),
        ("no_wkt", "gives no WKT"),
        ("points", "no gridded variable"),
        ("neither", "not a netCDF file"),
    ];
    let files: Vec<PathBuf> = info["pairs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|pair| PathBuf::from(pair[1].as_str().unwrap()))
        .collect();
    assert!(damage_files(&files, &dir.path().join("damaged.nc"), 60) >= 400);
    for (key, why) in refusals {
        let file = Path::new(info["refused"][key].as_str().unwrap());
        let name = file.file_name().unwrap().to_str().unwrap();
        let out = imitate(
            dir.path(),
            &["bench", "terrain", name, "--method", "uniform"],
        );
        assert_input_error(&out, &[name, why]);
    }
}

/// Surfer grids as GDAL writes them (ASCII, Surfer 6 and Surfer 7 binary): each reads to
/// the grid, CRS, values and blanked nodes GDAL reads it to; damaged, each is read or
/// refused naming the file, never a panic.
#[test]
fn surfer_grids_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("surfer_grids.py", &[dir.path()]) else {
        return;
    };
    let pairs = written[0]["pairs"].as_array().unwrap();
    for pair in pairs {
        let (grd, gdal, ours) = read_twins(pair);
        let (worst, _) = differences_from_gdal(&grd, &gdal.layers[0], &ours.layers[0]);
        assert_eq!(worst, 0.0, "{grd}");
    }
    let files: Vec<PathBuf> = pairs
        .iter()
        .map(|pair| PathBuf::from(pair[1].as_str().unwrap()))
        .collect();
    assert!(damage_files(&files, &dir.path().join("damaged.grd"), 60) >= 180);
}

/// GeoPackage rasters as GDAL writes them (its GPKG driver): imagery in JPEG and PNG
/// tiles (GDAL's default), PNG, palette PNG and (lossy) WebP tiles, grey with nodata,
/// tiles of zeros left out (read back as zeros), cells
/// not square, overviews, a Web Mercator tile grid; gridded coverages (int16, uint16,
/// float32 in PNG and in TIFF tiles, heights in feet, one in degrees). Each reads to
/// the grid, CRS,
/// colour bands, values and nodata GDAL reads it to (lossy tiles as close to GDAL's
/// decoding as libjpeg-turbo's or libwebp's is). Two rasters in
/// one file, a file of features alone and a file that is not SQLite are refused by
/// name; damaged, each is read or refused naming the file, never a panic.
#[test]
fn geopackage_rasters_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("geopackage_rasters.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    let lossy = info["lossy"].as_object().unwrap();
    let pairs = info["pairs"].as_array().unwrap();
    assert!(pairs.len() >= 17 && lossy.len() >= 3, "{pairs:?} {lossy:?}");
    for pair in pairs {
        let (gpkg, gdal, ours) = read_twins(pair);
        assert_decoded_as_gdal_or_peer(&gpkg, &gdal, &ours, lossy.get(&gpkg));
    }
    let refusals = [
        (
            "two",
            &["two_rasters.gpkg", "2 rasters", "a map is one"][..],
        ),
        (
            "features",
            &["features.gpkg", "no raster", "roads (features)"],
        ),
        ("text", &["text.gpkg", "not a GeoPackage"]),
    ];
    assert_refused(dir.path(), &info["refused"], &refusals);
    assert!(damage_pairs(pairs, &dir.path().join("damaged.gpkg"), 40) >= 200);
    assert_nothing_beside(dir.path());
}

/// MBTiles as GDAL writes them (its MBTiles driver, warping a UTM source to Web
/// Mercator): PNG (the default), JPEG, palette PNG and (lossy) WebP tiles, grey,
/// overviews; and as tools leave them: no bounds, bounds rounded off a cell edge, a
/// deduplicated `tiles` view over `map` and `images`. Each reads to the grid, CRS,
/// colour bands, values and nodata GDAL reads it to (lossy tiles as close to GDAL's
/// decoding as libjpeg-turbo's or libwebp's is). Vector tiles, a GeoPackage and a text
/// file named .mbtiles are refused by name; damaged, each is read or refused naming the
/// file, never a panic; nothing is written beside them.
#[test]
fn mbtiles_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("mbtiles_rasters.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    let lossy = info["lossy"].as_object().unwrap();
    let pairs = info["pairs"].as_array().unwrap();
    assert!(pairs.len() >= 9 && lossy.len() >= 2, "{pairs:?} {lossy:?}");
    for pair in pairs {
        let (mbtiles, gdal, ours) = read_twins(pair);
        assert_eq!(ours.geo.frame, "EPSG:3857", "{mbtiles}");
        assert_decoded_as_gdal_or_peer(&mbtiles, &gdal, &ours, lossy.get(&mbtiles));
    }
    plans_across(dir.path(), "grey.mbtiles", "60,60", "180,120");
    let refusals = [
        ("vector", &["roads.mbtiles", "vector tiles"][..]),
        ("geopackage", &["geopackage.mbtiles", "not an MBTiles file"]),
        ("text", &["text.mbtiles", "not an MBTiles file"]),
    ];
    assert_refused(dir.path(), &info["refused"], &refusals);
    assert!(damage_pairs(pairs, &dir.path().join("damaged.mbtiles"), 40) >= 100);
    assert_nothing_beside(dir.path());
}

/// PMTiles archives as Protomaps' library converts GDAL's MBTiles packages (PNG, JPEG,
/// palette PNG, lossless WebP tiles; a grey world whose equal tiles are stored once, as
/// a run), and each laid out again with its entries in leaf directories: each reads to
/// what GDAL reads the package to once the package's bounds are the archive's (lossy
/// tiles as close to GDAL's decoding as libjpeg-turbo's is). Vector tiles, a version 2
/// archive and a text file are refused by name; damaged, each is read or refused naming
/// the file, never a panic.
#[test]
fn pmtiles_read_as_gdal_reads_their_mbtiles() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("pmtiles_rasters.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    let lossy = info["lossy"].as_object().unwrap();
    let pairs = info["pairs"].as_array().unwrap();
    assert!(pairs.len() >= 7 && !lossy.is_empty(), "{pairs:?} {lossy:?}");
    for pair in pairs {
        let (pmtiles, gdal, ours) = read_twins(pair);
        assert_eq!(ours.geo.frame, "EPSG:3857", "{pmtiles}");
        assert_decoded_as_gdal_or_peer(&pmtiles, &gdal, &ours, lossy.get(&pmtiles));
    }
    plans_across(dir.path(), "world.pmtiles", "10,10", "100,100");
    let refusals = [
        ("vector", &["roads.pmtiles", "vector tiles"][..]),
        ("old", &["old.pmtiles", "version 2"]),
        ("text", &["text.pmtiles", "not a PMTiles archive"]),
    ];
    assert_refused(dir.path(), &info["refused"], &refusals);
    assert!(damage_pairs(pairs, &dir.path().join("damaged.pmtiles"), 40) >= 100);
}

/// ERDAS Imagine files as GDAL writes them (its HFA driver): raw and run-length
/// compressed blocks, edge blocks, blocks of 32, 1-, 4- and 8-bit to 64-bit samples,
/// nodata, band names, a CRS from the PE string or from ERDAS's projection parameters
/// alone, blocks in a spill file (`.ige`); each reads to the grid, CRS, values, names
/// and nodata GDAL reads it to, and a layer with a colour table holds classes. A `.img`
/// that is neither Imagine nor ENVI is refused, naming the file.
#[test]
fn erdas_imagine_rasters_read_as_gdal_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(written) = python_script("imagine_rasters.py", &[dir.path()]) else {
        return;
    };
    let info = &written[0];
    let thematic = strings(&info["thematic"]);
    for pair in info["pairs"].as_array().unwrap() {
        let (img, gdal, ours) = read_twins(pair);
        let img = img.as_str();
        for (a, b) in gdal.layers.iter().zip(&ours.layers) {
            let (worst, _) = differences_from_gdal(img, a, b);
            assert_eq!(worst, 0.0, "{img} {}", b.name);
            let declared = b.kind == LayerKind::Classes;
            assert_eq!(declared, thematic.contains(&img), "{img}");
        }
    }
    let out = imitate(
        dir.path(),
        &["bench", "terrain", "headerless.img", "--method", "uniform"],
    );
    assert_input_error(&out, &["headerless.img", "ERDAS Imagine", "ENVI"]);
}
