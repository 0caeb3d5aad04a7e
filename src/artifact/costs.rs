//! The costmap a command or stage plans on: one map of a costmap artifact folder, a
//! costmap table, a GeoTIFF cost raster or a MovingAI grid.

use std::path::Path;

use super::read_manifest;
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::io::geotiff::read_geotiff;
use crate::io::movingai::read_map;
use crate::io::tables::read_costmap;

/// Loads the costmap named by `path` and its map name: an artifact folder (`map` picks
/// one of its maps), a `costmap/1` table, a GeoTIFF of costs (`.tif`/`.tiff`; `map`
/// picks a band when it has several) or a MovingAI `.map` grid (passable cells cost 1).
pub fn load_costs(path: &Path, map: Option<&str>) -> Result<(String, Grid<f32>)> {
    if !path.is_dir() {
        let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        return match extension.to_ascii_lowercase().as_str() {
            "tif" | "tiff" => raster_costs(path, map),
            "map" => Ok((file_stem(path), read_map(path)?)),
            _ => read_costmap(path),
        };
    }
    let manifest = read_manifest(path, "costmap")?;
    let files: Vec<_> = manifest.files_with_role("costmap").collect();
    let names: Vec<String> = files
        .iter()
        .map(|f| {
            f.path
                .trim_start_matches("costmaps/")
                .trim_end_matches(".parquet")
                .to_string()
        })
        .collect();
    let chosen = match map {
        Some(m) => names.iter().position(|n| n == m).ok_or_else(|| {
            Error::Usage(format!(
                "{} has no map '{m}' (it has: {})",
                path.display(),
                names.join(", ")
            ))
        })?,
        None if files.len() == 1 => 0,
        None => {
            return Err(Error::Usage(format!(
                "{} holds {} maps; choose one with --map ({})",
                path.display(),
                files.len(),
                names.join(", ")
            )));
        }
    };
    read_costmap(&path.join(&files[chosen].path))
}

fn file_stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// A GeoTIFF band as costs: nodata cells are blocked (∞), as are zeros (a planner
/// cannot price a free cell); negative costs are refused.
fn raster_costs(path: &Path, band: Option<&str>) -> Result<(String, Grid<f32>)> {
    let name = file_stem(path);
    let raster = read_geotiff(path, &name)?;
    let bands = || raster.layer_names().join(", ");
    let layer = match band {
        Some(b) => raster.layer(b).ok_or_else(|| {
            Error::Usage(format!(
                "{} has no band '{b}' (it has: {})",
                path.display(),
                bands()
            ))
        })?,
        None if raster.layers.len() == 1 => &raster.layers[0],
        None => {
            return Err(Error::Usage(format!(
                "{} holds {} bands; choose one with --map ({})",
                path.display(),
                raster.layers.len(),
                bands()
            )));
        }
    };
    if let Some(i) = layer.values.iter().position(|&c| c < 0.0) {
        let cell = raster.geo.cell_at(i);
        return Err(Error::input(
            path,
            format!(
                "band '{}', cell {cell}: cost {} is negative",
                layer.name, layer.values[i]
            ),
        ));
    }
    let costs = layer
        .values
        .iter()
        .map(|&c| if c.is_nan() { f32::INFINITY } else { c })
        .collect();
    Ok((name, Grid::from_vec(raster.geo.clone(), costs)))
}
