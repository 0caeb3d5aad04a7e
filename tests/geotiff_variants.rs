//! GeoTIFFs as GDAL writes them (through rasterio): every layout and compression of one
//! raster reads to the same grid, and rasters that cannot be used are refused by name.
//! The files are written by `tests/python/geotiff_variants.py` from the real rasters in
//! ../shared/data/raster; rasterio comes from `scripts/python-deps.sh`.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use common::{assert_input_error, imitate, python_script, shared_data};
use imitate::grid::Map;
use imitate::io::geotiff::read_geotiff;

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
            // JPEG: what GDAL decodes from the same file, within the rounding of two
            // inverse DCTs.
            let gdal = read_geotiff(&path(&format!("gdal-decoded--{source}-jpeg")), "m").unwrap();
            let (a, b) = (&map.layers[0].values, &gdal.layers[0].values);
            let largest = a
                .iter()
                .zip(b)
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f32::max);
            let mean = a.iter().zip(b).map(|(p, q)| (p - q).abs()).sum::<f32>() / a.len() as f32;
            assert!(
                largest <= 2.0 && mean < 0.5,
                "{name}: largest {largest}, mean {mean}"
            );
        }
        checked += 1;
    }
    assert!(checked >= 24, "only {checked} variants checked");
    // The float copy keeps the NaN block in the file's north-west corner (our top rows).
    let float = &references["aerial-float"];
    let (w, h) = (float.geo.width as usize, float.geo.height as usize);
    assert!(float.layers[0].values[(h - 1) * w].is_nan());
    assert!(!float.layers[0].values[0].is_nan());
}

#[test]
fn projected_units_in_feet_become_metres() {
    let dir = tempfile::tempdir().unwrap();
    if write_variants(dir.path()).is_none() {
        return;
    }
    let feet = read_geotiff(&dir.path().join("units--us-feet.tif"), "m").unwrap();
    let spot = read_geotiff(&dir.path().join("spot--none.tif"), "m").unwrap();
    assert_eq!(feet.geo.frame, "EPSG:2263");
    let foot = 1200.0 / 3937.0;
    let ([fx, fy], [sx, sy]) = (feet.geo.cell_metres(), spot.geo.cell_metres());
    assert!((fx - sx * foot).abs() < 1e-9 && (fy - sy * foot).abs() < 1e-9);
    assert!((feet.geo.origin[0] - spot.geo.origin[0] * foot).abs() < 1e-6);
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
