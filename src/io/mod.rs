//! Reading and writing files: Parquet tables, PNG images, atomic writes.

pub mod ascii_grid;
pub mod demo_tables;
pub mod fs;
pub mod geojson;
pub mod geotiff;
pub mod gpx;
pub mod hgt;
pub mod leftovers;
pub mod mcap;
pub mod mdp_tables;
pub mod movingai;
pub mod nav2;
pub mod parquet_check;
pub mod png;
pub mod tables;

use std::path::Path;

use crate::error::{Error, Result};
use crate::grid::Map;

/// The extensions of the raster files read as maps: GeoTIFF, Esri ASCII grid, SRTM tile.
pub const RASTER_EXTENSIONS: [&str; 4] = ["tif", "tiff", "asc", "hgt"];

/// The raster at `path` as map `name`, read by its extension's reader.
pub fn read_raster(path: &Path, name: &str) -> Result<Map> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match extension.as_str() {
        "asc" => ascii_grid::read_ascii_grid(path, name),
        "hgt" => hgt::read_hgt(path, name),
        "tif" | "tiff" => geotiff::read_geotiff(path, name),
        other => Err(Error::input(
            path,
            format!(
                "rasters are GeoTIFFs (.tif, .tiff), Esri ASCII grids (.asc) or SRTM tiles \
                 (.hgt), not '.{other}'"
            ),
        )),
    }
}
