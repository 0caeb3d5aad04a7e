//! Reading and writing files: Parquet tables, PNG images, atomic writes.

pub mod ascii_grid;
mod blosc;
pub mod demo_tables;
pub mod dted;
pub mod ehdr;
pub mod envi;
pub mod ers;
pub mod fs;
pub mod geojson;
pub mod geopackage;
pub mod geopackage_paths;
pub mod geotiff;
pub mod gpx;
pub mod hfa;
pub mod hgt;
pub mod jp2;
pub mod kml;
pub mod leftovers;
pub mod mbtiles;
pub mod mcap;
pub mod mdp_tables;
pub mod movingai;
mod named_crs;
pub mod nav2;
pub mod netcdf;
pub mod parquet_check;
pub mod picture;
pub mod pmtiles;
pub mod png;
mod proj_string;
pub mod raster_report;
pub mod rraster;
pub mod saga;
mod sidecar_bands;
mod sqlite_tiles;
pub mod surfer;
pub mod tables;
pub mod usgs_dem;
pub mod vrt;
pub mod xyz;
pub mod zarr;

use std::path::Path;

use crate::error::{Error, Result};

/// The most cells a raster read as a map may declare (per band of a VRT, in all the
/// layers of an Imagine or raw raster): its layers must fit in memory as f32.
pub(crate) const MAX_MAP_CELLS: usize = 1 << 32;
use crate::grid::Map;

/// The order a file stores its cells in. The readers turn them to ours, rows from the
/// south and columns from the west; a VRT's windows count in the file's own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FileOrder {
    /// Whether the file's rows run from the north (most rasters').
    pub rows_from_north: bool,
    /// Whether its columns run from the east (a geotransform stepping west).
    pub columns_from_east: bool,
}

impl FileOrder {
    /// Rows from the north, columns from the west: most rasters' order.
    pub const NORTH_UP: FileOrder = FileOrder {
        rows_from_north: true,
        columns_from_east: false,
    };

    /// Rows from the north or the south, as `rows_from_north` says; columns from the west.
    pub fn rows(rows_from_north: bool) -> FileOrder {
        FileOrder {
            rows_from_north,
            columns_from_east: false,
        }
    }

    /// The order of a file whose cells GDAL's geotransform `transform` places.
    pub fn of_transform(transform: &[f64; 6]) -> FileOrder {
        FileOrder {
            rows_from_north: transform[4] < 0.0,
            columns_from_east: transform[0] < 0.0,
        }
    }

    /// The file's row and column (counted as it stores them) of our cell `row` (from the
    /// south), `col` (from the west) on a `width` × `height` grid; and the reverse, the
    /// turn being its own inverse.
    pub fn file_cell(self, row: usize, col: usize, width: usize, height: usize) -> (usize, usize) {
        (
            if self.rows_from_north {
                height - 1 - row
            } else {
                row
            },
            if self.columns_from_east {
                width - 1 - col
            } else {
                col
            },
        )
    }
}

/// The extensions of the raster files read as maps: GeoTIFF, Esri ASCII grid, SRTM tile,
/// GDAL virtual raster, zipped SRTM tile, JPEG 2000, georeferenced PNG and JPEG, raw
/// rasters with an ESRI `.hdr` (BIL, BIP, BSQ, GridFloat, GTOPO30's `.dem`), USGS
/// ASCII DEMs (`.dem`), DTED tiles, gridded XYZ,
/// ERDAS Imagine, ENVI (raw samples beside an ENVI header: `.img`, `.dat`, `.envi`...),
/// netCDF (classic and netCDF-4; GMT's `.grd`, Ferret's `.cdf`, h5netcdf's `.h5`),
/// Surfer grids (`.grd`), GeoPackage rasters (`.gpkg`), MBTiles and PMTiles, SAGA grids (`.sdat`, `.sgrd`, `.sg-grd-z`),
/// R's raster grids (`.grd` beside `.gri`), Zarr stores (`.zarr` folders), ER Mapper
/// rasters (`.ers`).
pub const RASTER_EXTENSIONS: [&str; 37] = [
    "tif", "tiff", "asc", "hgt", "vrt", "zip", "jp2", "j2k", "png", "jpg", "jpeg", "bil", "bip",
    "bsq", "flt", "dem", "dt0", "dt1", "dt2", "xyz", "img", "dat", "envi", "nc", "nc4", "cdf",
    "h5", "hdf5", "grd", "gpkg", "mbtiles", "pmtiles", "sdat", "sgrd", "sg-grd-z", "zarr", "ers",
];

/// Whether `path` names a raster file by its extension (one of [`RASTER_EXTENSIONS`]).
pub fn is_raster(path: &Path) -> bool {
    RASTER_EXTENSIONS.contains(&extension_of(path).as_str())
}

fn extension_of(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// The name of the map a file holds: its name less its extension, and less `.hgt` for a
/// zipped SRTM tile (`N46E007.SRTMGL1.hgt.zip` is `N46E007.SRTMGL1`, as its `.hgt` is).
pub fn map_name(path: &Path) -> String {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let zipped_tile = extension_of(path) == "zip" && stem.to_ascii_lowercase().ends_with(".hgt");
    if zipped_tile {
        stem[..stem.len() - 4].to_string()
    } else {
        stem
    }
}

/// The raster at `path` as map `name`, read by its extension's reader.
pub fn read_raster(path: &Path, name: &str) -> Result<Map> {
    read_raster_rows(path, name).map(|(map, _)| map)
}

/// The raster at `path` as map `name`, with the order the file stored its cells in (the
/// readers turn them to ours): what a VRT's windows count in.
fn read_raster_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    match extension_of(path).as_str() {
        "asc" => ascii_grid::read_ascii_grid(path, name).map(|map| (map, FileOrder::NORTH_UP)),
        "hgt" => hgt::read_hgt(path, name).map(|map| (map, FileOrder::NORTH_UP)),
        "zip" => hgt::read_hgt_zip(path, name).map(|map| (map, FileOrder::NORTH_UP)),
        "tif" | "tiff" => geotiff::read_geotiff_rows(path, name),
        "vrt" => vrt::read_vrt_rows(path, name, 0),
        "jp2" | "j2k" => jp2::read_jp2_rows(path, name),
        "png" | "jpg" | "jpeg" => picture::read_picture_rows(path, name),
        "img" if hfa::is_imagine(path) => hfa::read_hfa_rows(path, name),
        "bil" | "bip" | "bsq" | "flt" | "img" | "dat" if envi::envi_header(path).is_some() => {
            envi::read_envi_rows(path, name)
        }
        "dem" if usgs_dem::is_usgs_dem(path) => {
            usgs_dem::read_usgs_dem(path, name).map(|map| (map, FileOrder::NORTH_UP))
        }
        "bil" | "bip" | "bsq" | "flt" | "dem" => ehdr::read_ehdr_rows(path, name),
        "dt0" | "dt1" | "dt2" => dted::read_dted(path, name).map(|map| (map, FileOrder::NORTH_UP)),
        "xyz" => xyz::read_xyz_rows(path, name),
        "img" => hfa::read_hfa_rows(path, name),
        "dat" | "envi" => envi::read_envi_rows(path, name),
        "grd" if surfer::is_surfer(path) => surfer::read_surfer_rows(path, name),
        "grd" if rraster::is_rraster(path) => rraster::read_rraster_rows(path, name),
        "nc" | "nc4" | "cdf" | "h5" | "hdf5" | "grd" => netcdf::read_netcdf_rows(path, name),
        "gpkg" => geopackage::read_geopackage_rows(path, name),
        "mbtiles" => mbtiles::read_mbtiles_rows(path, name),
        "pmtiles" => pmtiles::read_pmtiles_rows(path, name),
        "sdat" | "sgrd" => saga::read_saga_rows(path, name),
        "sg-grd-z" => saga::read_saga_zip_rows(path, name),
        "zarr" => zarr::read_zarr_rows(path, name),
        "ers" => ers::read_ers_rows(path, name),
        other => Err(Error::input(
            path,
            format!(
                "rasters are GeoTIFFs (.tif, .tiff), Esri ASCII grids (.asc), SRTM tiles \
                 (.hgt, .hgt.zip), GDAL virtual rasters (.vrt), JPEG 2000 (.jp2), \
                 georeferenced PNG or JPEG images (.png, .jpg) or raw rasters with an ESRI \
                 header (.bil, .bip, .bsq, .flt, GTOPO30's .dem), USGS DEMs (.dem), DTED \
                 tiles (.dt0, .dt1, .dt2), gridded \
                 XYZ text (.xyz), ERDAS Imagine files (.img), ENVI rasters (.img, .dat, .envi \
                 with an ENVI .hdr), netCDF grids (.nc, .nc4, .cdf, GMT's .grd; .h5 as h5netcdf \
                 writes it), Surfer \
                 grids (.grd), R rasters (.grd beside .gri), GeoPackage rasters (.gpkg), \
                 MBTiles (.mbtiles), PMTiles (.pmtiles), SAGA grids (.sdat, .sgrd, \
                 .sg-grd-z), Zarr stores (.zarr) or ER Mapper rasters (.ers), not \
                 '.{other}'"
            ),
        )),
    }
}

/// The files beside or behind a raster that reading it depends on: a GeoTIFF's or an
/// ASCII grid's sidecars, a VRT's sources and theirs.
pub fn raster_sidecars(path: &Path) -> Vec<std::path::PathBuf> {
    match extension_of(path).as_str() {
        "asc" | "xyz" => ascii_grid::ascii_grid_sidecars(path),
        "vrt" => vrt::vrt_inputs(path),
        "img" if hfa::is_imagine(path) => hfa::hfa_sidecars(path),
        "bil" | "bip" | "bsq" | "flt" | "img" | "dat" if envi::envi_header(path).is_some() => {
            envi::envi_sidecars(path)
        }
        "dem" if usgs_dem::is_usgs_dem(path) => Vec::new(),
        "bil" | "bip" | "bsq" | "flt" | "dem" => ehdr::ehdr_sidecars(path),
        "img" | "dat" => hfa::hfa_sidecars(path),
        "envi" => envi::envi_sidecars(path),
        "sdat" | "sgrd" => saga::saga_sidecars(path),
        "ers" => ers::ers_sidecars(path),
        "grd" if rraster::is_rraster(path) => rraster::rraster_sidecars(path),
        // netCDF and Surfer grids take their CRS where an ASCII grid does.
        "nc" | "nc4" | "cdf" | "h5" | "hdf5" | "grd" => ascii_grid::ascii_grid_sidecars(path),
        // A Zarr store is a folder: digested whole as an input.
        "hgt" | "zip" | "dt0" | "dt1" | "dt2" | "zarr" => Vec::new(),
        _ => geotiff::sidecars(path),
    }
}
