//! What a raster file reads to (`imitate inspect FILE.tif`): its grid, CRS, cell size in
//! the frame's units and on the ground, and each layer's range and nodata, so that a
//! user can check how imitate reads a raster before learning on it, as `gdalinfo
//! -stats` shows how GDAL reads it.

use std::path::Path;

use serde::Serialize;

use super::{map_name, read_raster};
use crate::error::Result;
use crate::grid::{GeoRef, LayerKind, classes_of};

/// A raster as read: the map's grid and its layers' statistics.
#[derive(Debug, Serialize)]
pub struct RasterReport {
    pub file: String,
    /// The map's name (the file's, less its extension).
    pub map: String,
    pub width: u32,
    pub height: u32,
    /// The frame's name: an EPSG code, or "map" for a CRS with no code (or none).
    pub frame: String,
    /// The CRS as a PROJ string, where the file defines it by its parameters.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub proj: Option<String>,
    /// What the frame's units are: "degrees", "Web Mercator metres" or "frame units".
    pub units: &'static str,
    /// Cell size (x, y) in the frame's units.
    pub cell_size: [f64; 2],
    /// Cell size (x, y) in ground metres at the middle row, as features and planners
    /// measure it.
    pub cell_metres: [f64; 2],
    /// How much the east-west ground size changes from the middle row to the north or
    /// south edge (0 where the frame's scale is fixed).
    pub scale_variation: f64,
    /// West, south, east and north edges in the frame's units.
    pub bounds: [f64; 4],
    pub layers: Vec<LayerReport>,
}

/// One layer's statistics over its data cells.
#[derive(Debug, Serialize)]
pub struct LayerReport {
    pub name: String,
    /// "classes" where the file declares them or the values look like classes
    /// (at most 32 distinct integers), "values" otherwise.
    pub kind: &'static str,
    /// Cells with data, and cells without (nodata, masked).
    pub cells: usize,
    pub nodata: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean: Option<f64>,
    /// The class codes present, where the layer holds classes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub classes: Option<Vec<f32>>,
}

/// Reads the raster at `path` as `ingest` would and reports what it holds.
pub fn describe(path: &Path) -> Result<RasterReport> {
    let name = map_name(path);
    let map = read_raster(path, &name)?;
    let geo = &map.geo;
    let layers = map
        .layers
        .iter()
        .map(|layer| {
            let data: Vec<f32> = layer
                .values
                .iter()
                .copied()
                .filter(|v| !v.is_nan())
                .collect();
            let classes = match layer.kind {
                LayerKind::Classes => Some(distinct(&data)),
                LayerKind::Values => classes_of(&data),
            };
            let (min, max) = data
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
                    (lo.min(v), hi.max(v))
                });
            let any = !data.is_empty();
            LayerReport {
                name: layer.name.clone(),
                kind: if classes.is_some() {
                    "classes"
                } else {
                    "values"
                },
                cells: data.len(),
                nodata: layer.values.len() - data.len(),
                min: any.then_some(min),
                max: any.then_some(max),
                mean: any
                    .then(|| data.iter().map(|&v| f64::from(v)).sum::<f64>() / data.len() as f64),
                classes,
            }
        })
        .collect();
    Ok(RasterReport {
        file: path.display().to_string(),
        map: name,
        width: geo.width,
        height: geo.height,
        frame: geo.frame.clone(),
        proj: geo.tiff_crs.as_ref().and_then(|crs| crs.proj.clone()),
        units: units(geo),
        cell_size: geo.cell_size(),
        cell_metres: geo.cell_metres(),
        scale_variation: geo.scale_variation(),
        bounds: geo.bounds(),
        layers,
    })
}

fn units(geo: &GeoRef) -> &'static str {
    if geo.degrees {
        "degrees"
    } else if geo.web_mercator {
        "Web Mercator metres"
    } else {
        "frame units"
    }
}

/// The distinct values of a declared class layer, in order.
fn distinct(values: &[f32]) -> Vec<f32> {
    let mut codes = values.to_vec();
    codes.sort_by(f32::total_cmp);
    codes.dedup();
    codes
}

/// The report as text, one line per fact and one per layer.
pub fn render(report: &RasterReport) -> String {
    let [w, s, e, n] = report.bounds;
    let mut text = format!(
        "file:        {}\nmap:         {}\ngrid:        {} × {} cells\nframe:       {}\n",
        report.file, report.map, report.width, report.height, report.frame
    );
    if let Some(proj) = &report.proj {
        text += &format!("proj:        {proj}\n");
    }
    text += &format!(
        "cell:        {} × {} {}\nground cell: {:.4} × {:.4} m (middle row)\n",
        report.cell_size[0],
        report.cell_size[1],
        report.units,
        report.cell_metres[0],
        report.cell_metres[1]
    );
    if report.scale_variation > 0.0 {
        text += &format!(
            "             the east-west size changes by {:.2} % to the edge rows\n",
            100.0 * report.scale_variation
        );
    }
    text += &format!("bounds:      west {w}, south {s}, east {e}, north {n}\nlayers:\n");
    for layer in &report.layers {
        text += &format!(
            "  {} ({}): {} cells with data, {} nodata",
            layer.name, layer.kind, layer.cells, layer.nodata
        );
        if let (Some(min), Some(max), Some(mean)) = (layer.min, layer.max, layer.mean) {
            text += &format!(", {min} .. {max}, mean {mean:.6}");
        }
        if let Some(classes) = &layer.classes {
            let codes: Vec<String> = classes.iter().map(|c| c.to_string()).collect();
            text += &format!(", classes {}", codes.join(" "));
        }
        text += "\n";
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_and_its_layers_are_reported_as_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("dem.asc");
        std::fs::write(
            &path,
            "ncols 3\nnrows 2\nxllcorner 100\nyllcorner 200\ncellsize 30\n\
             NODATA_value -9999\n1 2 -9999\n4 5 6\n",
        )
        .unwrap();
        let report = describe(&path).unwrap();
        assert_eq!((report.width, report.height), (3, 2));
        assert_eq!(report.cell_size, [30.0, 30.0]);
        assert_eq!(report.cell_metres, [30.0, 30.0]);
        assert_eq!(report.bounds, [100.0, 200.0, 190.0, 260.0]);
        let layer = &report.layers[0];
        assert_eq!((layer.cells, layer.nodata), (5, 1));
        assert_eq!(
            (layer.min, layer.max, layer.mean),
            (Some(1.0), Some(6.0), Some(3.6))
        );
        // Five distinct integers look like classes.
        assert_eq!(layer.kind, "classes");
        let text = render(&report);
        assert!(
            text.contains("3 × 2 cells") && text.contains("1 .. 6"),
            "{text}"
        );
    }

    #[test]
    fn a_raster_that_cannot_be_read_is_the_readers_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("empty.tif");
        std::fs::write(&path, b"not a tiff").unwrap();
        let error = describe(&path).unwrap_err().to_string();
        assert!(error.contains("empty.tif"), "{error}");
    }
}
