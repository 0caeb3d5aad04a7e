//! GeoPackage rasters (`.gpkg`), as QGIS, GDAL and rasterio write them: an SQLite file
//! whose raster is a pyramid of tiles. The full-resolution level is read (the highest
//! zoom level that holds tiles), over the extent `gpkg_contents` gives, in the CRS its
//! `gpkg_spatial_ref_sys` row defines.
//!
//! Two kinds of raster table:
//! - `tiles`: imagery in PNG, JPEG or WebP tiles (GDAL's default mixes JPEG for opaque
//!   tiles and PNG for those with transparent cells). The layers are the colour bands
//!   GDAL shows: the band count GDAL recorded in its metadata (grey, grey and alpha,
//!   RGB, RGBA), else those the tiles hold; alpha is not a layer but marks nodata where
//!   it is 0, as every missing tile does, and so does GDAL's recorded nodata value.
//! - `2d-gridded-coverage` (OGC 17-066r1: elevation, any measured quantity): one band
//!   in 16-bit PNG or 32-bit float TIFF tiles, each value the stored one times the
//!   tile's and then the coverage's scale, plus their offsets; the coverage's
//!   `data_null` stored value and missing tiles are nodata. The layer is named by its
//!   `field_name` (GDAL's band description: `Height` by default), and a `uom` of length
//!   (feet, say) converts its values to metres.
//!
//! The file is opened read-only and immutable: nothing is ever written beside it.

use std::collections::HashMap;
use std::io::Cursor;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;
use rusqlite::{Connection, OpenFlags, OptionalExtension};

use super::MAX_MAP_CELLS;
use super::geotiff::metadata::metres_per_unit;
use super::geotiff::{Georeferencing, georeference, wkt_geokeys};
use super::picture::{Picture, decode_jpeg, decode_png};
use super::sidecar_bands::{self, FileMasks, Samples};
use crate::error::{Error, Result, catch_decoder_panic, first_error_in_order, open_input};
use crate::grid::Map;

/// The first bytes of every PNG image.
const PNG_SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";

/// The first 16 bytes of every SQLite 3 database.
const SQLITE_MAGIC: &[u8; 16] = b"SQLite format 3\0";

/// The widest tile a tile matrix may declare, in cells each way (GDAL writes 256 or
/// 512; the spec sets no limit).
const MAX_TILE_SIDE: i64 = 1 << 14;

/// A window of up to this many cells is read however few tiles it holds; a larger one
/// must hold tiles for at least 1/`SPARSE_RATIO` of its cells.
const SPARSE_WINDOW_CELLS: f64 = (1u64 << 24) as f64;
const SPARSE_RATIO: f64 = 64.0;

/// A raster table, as `gpkg_contents` and its tile matrix set give it.
#[derive(Debug, Clone, PartialEq)]
struct RasterTable {
    name: String,
    /// A gridded coverage (one band of values) rather than imagery tiles.
    coverage: bool,
    srs_id: i64,
    /// The raster's extent (west, south, east, north): the contents' bounds where all
    /// four are given, else the tile matrix set's.
    extent: [f64; 4],
    /// The tile matrix set's west and north edges, where tile (0, 0) starts.
    origin: [f64; 2],
}

/// The tile matrix of the zoom level read.
#[derive(Debug, Clone, Copy, PartialEq)]
struct TileMatrix {
    zoom: i64,
    columns: i64,
    rows: i64,
    tile: [i64; 2],
    pixel: [f64; 2],
}

/// How a gridded coverage's stored values become its values.
#[derive(Debug, Clone, PartialEq)]
struct Coverage {
    scale: f64,
    offset: f64,
    /// Whether values from 16-bit PNG tiles are rounded to whole units, as GDAL rounds
    /// them where the coverage's precision is 1 (its default).
    whole: bool,
    /// The stored value that marks a cell as null.
    null: Option<f64>,
    /// Each tile's own scale and offset, by tile id.
    tiles: HashMap<i64, (f64, f64)>,
    /// The quantity's name (GDAL's band description) and unit of measure.
    field_name: Option<String>,
    uom: Option<String>,
}

/// The raster's grid: its size in cells and where its first cell lies in the tile grid.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Window {
    width: usize,
    height: usize,
    /// Cells from the tile grid's west and north edges to the raster's.
    shift: [i64; 2],
}

impl Window {
    /// GDAL's window: the extent in whole cells (rounded), snapped to the tile grid.
    fn of(table: &RasterTable, matrix: &TileMatrix) -> std::result::Result<Self, String> {
        let [west, south, east, north] = table.extent;
        let [px, py] = matrix.pixel;
        let cells = |span: f64, size: f64| (span / size + 0.5).floor();
        let (width, height) = (cells(east - west, px), cells(north - south, py));
        if !(width >= 1.0 && height >= 1.0) {
            return Err(format!(
                "its extent {west}, {south} to {east}, {north} holds no cell of {px} × {py}"
            ));
        }
        if width * height > MAX_MAP_CELLS as f64 {
            return Err(format!(
                "its {width} × {height} cells are more than the {MAX_MAP_CELLS} a map may \
                 hold: clip it to the site first (gdal_translate -projwin)"
            ));
        }
        let shift = [
            ((west - table.origin[0]) / px + 0.5).floor(),
            ((table.origin[1] - north) / py + 0.5).floor(),
        ];
        if !shift.iter().all(|s| s.abs() < 1e15) {
            return Err(format!(
                "its extent lies {} × {} cells from its tile grid's origin",
                shift[0], shift[1]
            ));
        }
        Ok(Window {
            width: width as usize,
            height: height as usize,
            shift: [shift[0] as i64, shift[1] as i64],
        })
    }

    /// Refuses a window far larger than its stored tiles could fill: the extent of a
    /// damaged file, which would take memory for nothing.
    fn check_filled(&self, tiles: usize, matrix: &TileMatrix) -> std::result::Result<(), String> {
        let cells = self.width as f64 * self.height as f64;
        let filled = tiles as f64 * (matrix.tile[0] * matrix.tile[1]) as f64;
        if cells > SPARSE_WINDOW_CELLS.max(SPARSE_RATIO * filled) {
            return Err(format!(
                "its extent of {} × {} cells holds only {tiles} tiles of {} × {}: its bounds \
                 in gpkg_contents are far wider than its raster",
                self.width, self.height, matrix.tile[0], matrix.tile[1]
            ));
        }
        Ok(())
    }

    /// The tiles (first and last column, first and last row) that hold the window's
    /// cells.
    fn tiles(&self, matrix: &TileMatrix) -> [i64; 4] {
        let [tw, th] = matrix.tile;
        let last = |shift: i64, n: usize| shift + n as i64 - 1;
        [
            self.shift[0].div_euclid(tw).max(0),
            last(self.shift[0], self.width)
                .div_euclid(tw)
                .min(matrix.columns - 1),
            self.shift[1].div_euclid(th).max(0),
            last(self.shift[1], self.height)
                .div_euclid(th)
                .min(matrix.rows - 1),
        ]
    }
}

/// The GeoPackage raster at `path` as map `name`, with whether its rows ran from the
/// north (always: tiles run from the north-west).
pub fn read_geopackage_rows(path: &Path, name: &str) -> Result<(Map, bool)> {
    let problem = |message: String| Error::input(path, message);
    let db = open_geopackage(path)?;
    let table = raster_table(&db).map_err(&problem)?;
    let matrix = tile_matrix(&db, &table).map_err(&problem)?;
    let window = Window::of(&table, &matrix).map_err(&problem)?;
    let coverage = if table.coverage {
        Some(coverage(&db, &table.name).map_err(&problem)?)
    } else {
        None
    };
    let (keys, ascii) = crs_keys(&db, table.srs_id).map_err(&problem)?;
    let transform = [
        matrix.pixel[0],
        0.0,
        table.extent[0],
        0.0,
        -matrix.pixel[1],
        table.extent[3],
    ];
    let (width, height) = (window.width, window.height);
    let (geo, heights) = georeference(
        path,
        width as u32,
        height as u32,
        Georeferencing::of_grid(transform, &keys, ascii),
    )?;
    let tiles = tiles(&db, &table.name, &matrix, &window).map_err(&problem)?;
    window
        .check_filled(tiles.len(), &matrix)
        .map_err(&problem)?;
    let gdal = gdal_metadata(&db, &table.name).map_err(&problem)?;
    let raster = match &coverage {
        Some(coverage) => {
            let decode = |tile: &Tile| decode_tile(tile, true, &matrix);
            Raster::of_coverage(tiles, decode, coverage, &matrix, &window)
        }
        None => {
            let decode = |tile: &Tile| decode_tile(tile, false, &matrix);
            let bands = Bands::of(gdal.band_count);
            Raster::of_imagery(tiles, decode, bands, &matrix, &window)
        }
    }
    .map_err(&problem)?;
    let Raster { bands, values } = raster;
    // A coverage's unit of measure, where it is a length, sets the metres of its values.
    let unit = coverage.as_ref().and_then(|c| c.uom.as_deref());
    let samples = Samples {
        width: width as u32,
        height: height as u32,
        bands,
        north_up: true,
        heights: unit.and_then(metres_per_unit).unwrap_or(heights),
        sample: |band: usize, cell: usize| values[cell * bands + band],
    };
    let masks = match &coverage {
        Some(coverage) => FileMasks {
            descriptions: vec![coverage.field_name.clone()],
            ..FileMasks::default()
        },
        None => FileMasks {
            nodata: vec![gdal.nodata; bands],
            ..FileMasks::default()
        },
    };
    sidecar_bands::map(path, name, geo, samples, &masks)
}

/// The GeoPackage at `path`, opened read-only; an input error where it is not an
/// SQLite database.
pub(super) fn open_geopackage(path: &Path) -> Result<Connection> {
    let mut magic = [0u8; 16];
    let read = std::io::Read::read_exact(&mut open_input(path)?, &mut magic);
    if read.is_err() || &magic != SQLITE_MAGIC {
        return Err(Error::input(
            path,
            "it is not a GeoPackage (not an SQLite database)",
        ));
    }
    open_immutable(path).map_err(|message| Error::input(path, message))
}

/// The database at `path`, opened read-only and immutable (SQLite then takes no lock
/// and reads no journal: nothing is created beside the file).
fn open_immutable(path: &Path) -> std::result::Result<Connection, String> {
    let mut uri = String::from("file:");
    for &byte in path.as_os_str().as_encoded_bytes() {
        match byte {
            b'%' | b'?' | b'#' | 0..=0x20 | 0x7f.. => uri.push_str(&format!("%{byte:02X}")),
            _ => uri.push(char::from(byte)),
        }
    }
    uri.push_str("?immutable=1");
    let flags = OpenFlags::SQLITE_OPEN_READ_ONLY
        | OpenFlags::SQLITE_OPEN_URI
        | OpenFlags::SQLITE_OPEN_NO_MUTEX;
    Connection::open_with_flags(uri, flags).map_err(|e| format!("it cannot be opened: {e}"))
}

/// `value` rounded half up, as GDAL rounds a coverage's values (`floor(v + 0.5)`), by
/// truncation where it fits an integer: `floor` is a library call on baseline x86-64,
/// and a coverage rounds every one of its cells.
fn half_up(value: f64) -> f64 {
    let shifted = value + 0.5;
    if shifted.abs() < 4.5e15 {
        let truncated = shifted as i64 as f64;
        if truncated > shifted {
            truncated - 1.0
        } else {
            truncated
        }
    } else {
        shifted.floor()
    }
}

/// A real as GDAL reads it from a GeoPackage: through SQLite's text, which keeps 15
/// significant digits (Web Mercator's 19.10925707129406 m cells are 19.1092570712941 m
/// to GDAL), so that the grid is GDAL's to the last bit.
fn as_gdal_reads(value: f64) -> f64 {
    format!("{value:.14e}").parse().unwrap_or(value)
}

/// Whether the database holds every one of the (optional) tables `names`.
pub(super) fn has_tables(db: &Connection, names: &[&str]) -> std::result::Result<bool, String> {
    for name in names {
        let count: i64 = db
            .query_row(
                "SELECT COUNT(*) FROM sqlite_master WHERE type = 'table' AND name = ?1",
                [name],
                |r| r.get(0),
            )
            .map_err(|e| format!("its schema cannot be read: {e}"))?;
        if count == 0 {
            return Ok(false);
        }
    }
    Ok(true)
}

/// A table name quoted for SQL.
pub(super) fn quoted(name: &str) -> String {
    format!("\"{}\"", name.replace('"', "\"\""))
}

/// The one raster table `gpkg_contents` lists, with its tile matrix set.
fn raster_table(db: &Connection) -> std::result::Result<RasterTable, String> {
    let listed = |e: rusqlite::Error| {
        format!("it is not a GeoPackage: its table gpkg_contents cannot be read ({e})")
    };
    let mut statement = db
        .prepare(
            "SELECT table_name, data_type, min_x, min_y, max_x, max_y, srs_id \
             FROM gpkg_contents ORDER BY table_name",
        )
        .map_err(listed)?;
    type Row = (String, String, [Option<f64>; 4], Option<i64>);
    let rows: Vec<Row> = statement
        .query_map([], |r| {
            Ok((
                r.get(0)?,
                r.get(1)?,
                [r.get(2)?, r.get(3)?, r.get(4)?, r.get(5)?],
                r.get(6)?,
            ))
        })
        .and_then(Iterator::collect)
        .map_err(listed)?;
    let is_raster = |kind: &str| kind == "tiles" || kind == "2d-gridded-coverage";
    let rasters: Vec<&Row> = rows.iter().filter(|r| is_raster(&r.1)).collect();
    let (name, kind, bounds, srs_id) = match rasters[..] {
        [one] => one.clone(),
        [] => {
            let held: Vec<String> = rows.iter().map(|r| format!("{} ({})", r.0, r.1)).collect();
            return Err(format!(
                "it holds no raster (no table of tiles or gridded coverage){}",
                if held.is_empty() {
                    String::new()
                } else {
                    format!("; it holds {}", held.join(", "))
                }
            ));
        }
        _ => {
            let names: Vec<&str> = rasters.iter().map(|r| r.0.as_str()).collect();
            return Err(format!(
                "it holds {} rasters ({}); a map is one: copy the one wanted to its own \
                 file (gdal_translate -oo TABLE=<name>)",
                names.len(),
                names.join(", ")
            ));
        }
    };
    let set: Option<(i64, [f64; 4])> = db
        .query_row(
            "SELECT srs_id, min_x, min_y, max_x, max_y FROM gpkg_tile_matrix_set \
             WHERE table_name = ?1",
            [&name],
            |r| Ok((r.get(0)?, [r.get(1)?, r.get(2)?, r.get(3)?, r.get(4)?])),
        )
        .optional()
        .map_err(|e| format!("its table gpkg_tile_matrix_set cannot be read: {e}"))?;
    let (set_srs, set_bounds) =
        set.ok_or_else(|| format!("its raster {name} has no row in gpkg_tile_matrix_set"))?;
    let set_bounds = set_bounds.map(as_gdal_reads);
    let extent = match bounds {
        [Some(w), Some(s), Some(e), Some(n)] => [w, s, e, n].map(as_gdal_reads),
        _ => set_bounds,
    };
    if !extent.iter().chain(&set_bounds).all(|v| v.is_finite()) {
        return Err(format!(
            "its raster {name}'s bounds {extent:?} or its tile matrix set's {set_bounds:?} \
             are not finite"
        ));
    }
    Ok(RasterTable {
        coverage: kind == "2d-gridded-coverage",
        srs_id: srs_id.unwrap_or(set_srs),
        extent,
        origin: [set_bounds[0], set_bounds[3]],
        name,
    })
}

/// The tile matrix of the highest zoom level that holds tiles: the full resolution.
fn tile_matrix(db: &Connection, table: &RasterTable) -> std::result::Result<TileMatrix, String> {
    let name = &table.name;
    let zoom: Option<i64> = db
        .query_row(
            &format!("SELECT MAX(zoom_level) FROM {}", quoted(name)),
            [],
            |r| r.get(0),
        )
        .map_err(|e| format!("its tile table {name} cannot be read: {e}"))?;
    let zoom = zoom.ok_or_else(|| format!("its raster {name} holds no tile"))?;
    let matrix = db
        .query_row(
            "SELECT matrix_width, matrix_height, tile_width, tile_height, pixel_x_size, \
             pixel_y_size FROM gpkg_tile_matrix WHERE table_name = ?1 AND zoom_level = ?2",
            rusqlite::params![name, zoom],
            |r| {
                Ok(TileMatrix {
                    zoom,
                    columns: r.get(0)?,
                    rows: r.get(1)?,
                    tile: [r.get(2)?, r.get(3)?],
                    pixel: [r.get::<_, f64>(4)?, r.get(5)?].map(as_gdal_reads),
                })
            },
        )
        .optional()
        .map_err(|e| format!("its table gpkg_tile_matrix cannot be read: {e}"))?
        .ok_or_else(|| format!("its raster {name} has no tile matrix for zoom level {zoom}"))?;
    let sides_ok = matrix
        .tile
        .iter()
        .all(|&s| (1..=MAX_TILE_SIDE).contains(&s));
    let counts_ok = matrix.columns >= 1 && matrix.rows >= 1;
    let pixel_ok = matrix.pixel.iter().all(|&p| p.is_finite() && p > 0.0);
    if !(sides_ok && counts_ok && pixel_ok) {
        return Err(format!(
            "its tile matrix at zoom level {zoom} is {} × {} tiles of {} × {} cells of {} × \
             {}: each must be positive (tiles at most {MAX_TILE_SIDE} cells a side)",
            matrix.columns,
            matrix.rows,
            matrix.tile[0],
            matrix.tile[1],
            matrix.pixel[0],
            matrix.pixel[1]
        ));
    }
    Ok(matrix)
}

/// A gridded coverage's scale, offset, null value and tiles' own scales and offsets.
fn coverage(db: &Connection, name: &str) -> std::result::Result<Coverage, String> {
    type Row = (
        Option<f64>,
        Option<f64>,
        Option<f64>,
        Option<f64>,
        Option<String>,
        Option<String>,
    );
    let (scale, offset, precision, null, field_name, uom): Row = db
        .query_row(
            "SELECT scale, offset, precision, data_null, field_name, uom \
             FROM gpkg_2d_gridded_coverage_ancillary WHERE tile_matrix_set_name = ?1",
            [name],
            |r| {
                Ok((
                    r.get(0)?,
                    r.get(1)?,
                    r.get(2)?,
                    r.get(3)?,
                    r.get(4)?,
                    r.get(5)?,
                ))
            },
        )
        .optional()
        .map_err(|e| format!("its table gpkg_2d_gridded_coverage_ancillary cannot be read: {e}"))?
        .unwrap_or_default();
    let mut tiles = HashMap::new();
    // A coverage may leave out its tiles' ancillary table: every tile is then 1 and 0.
    if has_tables(db, &["gpkg_2d_gridded_tile_ancillary"])? {
        let unreadable = |e: rusqlite::Error| {
            format!("its table gpkg_2d_gridded_tile_ancillary cannot be read: {e}")
        };
        let mut statement = db
            .prepare(
                "SELECT tpudt_id, scale, offset FROM gpkg_2d_gridded_tile_ancillary \
                 WHERE tpudt_name = ?1",
            )
            .map_err(unreadable)?;
        let rows = statement
            .query_map([name], |r| {
                Ok((
                    r.get::<_, i64>(0)?,
                    r.get::<_, Option<f64>>(1)?.unwrap_or(1.0),
                    r.get::<_, Option<f64>>(2)?.unwrap_or(0.0),
                ))
            })
            .map_err(unreadable)?;
        for row in rows {
            let (id, s, o) = row.map_err(unreadable)?;
            tiles.insert(id, (s, o));
        }
    }
    let named = |text: Option<String>| text.filter(|t| !t.trim().is_empty());
    Ok(Coverage {
        scale: scale.unwrap_or(1.0),
        offset: offset.unwrap_or(0.0),
        whole: precision.unwrap_or(1.0) == 1.0,
        null,
        tiles,
        field_name: named(field_name),
        uom: named(uom),
    })
}

/// The GeoKeys of the raster's CRS (none where the GeoPackage leaves it undefined).
fn crs_keys(db: &Connection, srs_id: i64) -> std::result::Result<(Vec<u16>, String), String> {
    let row: Option<(String, i64, String)> = db
        .query_row(
            "SELECT organization, organization_coordsys_id, definition \
             FROM gpkg_spatial_ref_sys WHERE srs_id = ?1",
            [srs_id],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
        )
        .optional()
        .map_err(|e| format!("its table gpkg_spatial_ref_sys cannot be read: {e}"))?;
    let Some((organization, code, definition)) = row else {
        return Err(format!(
            "its raster's CRS (srs_id {srs_id}) has no row in gpkg_spatial_ref_sys"
        ));
    };
    let definition = definition.trim();
    if definition.is_empty() || definition.eq_ignore_ascii_case("undefined") {
        return Ok((Vec::new(), String::new()));
    }
    wkt_geokeys(definition).ok_or_else(|| {
        format!(
            "its CRS (srs_id {srs_id}, {organization} {code}) is neither a projected nor a \
             geographic CRS in WKT"
        )
    })
}

/// What GDAL records of an imagery table in `gpkg_metadata` (its `IMAGE_STRUCTURE`
/// domain), where it does.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct GdalMetadata {
    /// `BAND_COUNT`: 1 grey, 2 grey and alpha, 3 RGB, 4 RGBA; `None` where unrecorded
    /// (GDAL then shows RGBA).
    band_count: Option<u32>,
    /// `NODATA_VALUE`.
    nodata: Option<f32>,
}

/// GDAL's metadata of table `name`: none where the GeoPackage has no metadata tables.
fn gdal_metadata(db: &Connection, name: &str) -> std::result::Result<GdalMetadata, String> {
    if !has_tables(db, &["gpkg_metadata", "gpkg_metadata_reference"])? {
        return Ok(GdalMetadata::default());
    }
    let unreadable = |e: rusqlite::Error| format!("its table gpkg_metadata cannot be read: {e}");
    let mut statement = db
        .prepare(
            "SELECT m.metadata FROM gpkg_metadata m JOIN gpkg_metadata_reference r \
             ON m.id = r.md_file_id WHERE r.reference_scope = 'table' AND \
             r.table_name = ?1 AND m.md_standard_uri = 'http://gdal.org' \
             AND m.mime_type = 'text/xml'",
        )
        .map_err(unreadable)?;
    let documents: Vec<String> = statement
        .query_map([name], |r| r.get(0))
        .and_then(Iterator::collect)
        .map_err(unreadable)?;
    let mut found = GdalMetadata::default();
    for xml in &documents {
        let Some(start) = xml.find("<Metadata domain=\"IMAGE_STRUCTURE\">") else {
            continue;
        };
        let domain = &xml[start..];
        let domain = &domain[..domain.find("</Metadata>").unwrap_or(domain.len())];
        let item = |key: &str| {
            let open = format!("<MDI key=\"{key}\">");
            let at = domain.find(&open)? + open.len();
            let length = domain[at..].find("</MDI>")?;
            Some(domain[at..at + length].trim().to_string())
        };
        if let Some(count) = item("BAND_COUNT").and_then(|c| c.parse::<u32>().ok()) {
            found.band_count = Some(count);
        }
        if let Some(nodata) = item("NODATA_VALUE").and_then(|v| v.parse::<f32>().ok()) {
            found.nodata = Some(nodata);
        }
    }
    Ok(found)
}

/// One stored tile.
#[derive(Debug, Clone)]
struct Tile {
    id: i64,
    column: i64,
    row: i64,
    data: Vec<u8>,
}

/// The stored tiles of the matrix that hold the window's cells.
fn tiles(
    db: &Connection,
    name: &str,
    matrix: &TileMatrix,
    window: &Window,
) -> std::result::Result<Vec<Tile>, String> {
    let unreadable = |e: rusqlite::Error| format!("its tile table {name} cannot be read: {e}");
    let [first_column, last_column, first_row, last_row] = window.tiles(matrix);
    let mut statement = db
        .prepare(&format!(
            "SELECT id, tile_column, tile_row, tile_data FROM {} WHERE zoom_level = ?1 \
             AND tile_column BETWEEN ?2 AND ?3 AND tile_row BETWEEN ?4 AND ?5 \
             ORDER BY tile_row, tile_column",
            quoted(name)
        ))
        .map_err(unreadable)?;
    let params = [matrix.zoom, first_column, last_column, first_row, last_row];
    statement
        .query_map(params, |r| {
            Ok(Tile {
                id: r.get(0)?,
                column: r.get(1)?,
                row: r.get(2)?,
                data: r.get(3)?,
            })
        })
        .and_then(Iterator::collect)
        .map_err(unreadable)
}

/// A tile decoded: an imagery tile as its grey or colour channels with or without
/// alpha, a coverage's tile as its one band of stored values.
fn decode_tile(
    tile: &Tile,
    coverage: bool,
    matrix: &TileMatrix,
) -> std::result::Result<Picture, String> {
    let bytes = &tile.data;
    let at = || {
        format!(
            "its tile at zoom level {}, column {}, row {}",
            matrix.zoom, tile.column, tile.row
        )
    };
    let decoded = if bytes.starts_with(PNG_SIGNATURE) {
        let transformations = if coverage {
            ::png::Transformations::IDENTITY
        } else {
            ::png::Transformations::EXPAND
        };
        decode_png(bytes, transformations).map_err(|e| format!("not a readable PNG: {e}"))
    } else if bytes.starts_with(&[0xff, 0xd8]) && !coverage {
        decode_jpeg(bytes).map_err(|e| format!("not a readable JPEG: {e}"))
    } else if bytes.starts_with(b"RIFF") && bytes.get(8..12) == Some(b"WEBP") && !coverage {
        decode_webp(bytes).map_err(|e| format!("not a readable WebP image: {e}"))
    } else if (bytes.starts_with(b"II*\0") || bytes.starts_with(b"MM\0*")) && coverage {
        decode_tiff(bytes).map_err(|e| format!("not a readable TIFF: {e}"))
    } else {
        Err(if coverage {
            "neither a PNG nor a TIFF, which a gridded coverage's tiles are".into()
        } else {
            "neither a PNG, a JPEG nor a WebP image, which imagery tiles are".into()
        })
    }
    .map_err(|e| format!("{}: {e}", at()))?;
    let [tw, th] = matrix.tile;
    if (i64::from(decoded.width), i64::from(decoded.height)) != (tw, th) {
        return Err(format!(
            "{}: it is {} × {} cells, its tile matrix's tiles {tw} × {th}",
            at(),
            decoded.width,
            decoded.height
        ));
    }
    if coverage && decoded.bands != 1 {
        return Err(format!(
            "{}: it holds {} bands; a gridded coverage's tiles hold one",
            at(),
            decoded.bands
        ));
    }
    Ok(decoded)
}

/// A WebP tile's RGB or RGBA samples.
fn decode_webp(bytes: &[u8]) -> std::result::Result<Picture, String> {
    let mut image = image_webp::WebPDecoder::new(Cursor::new(bytes)).map_err(|e| e.to_string())?;
    let (width, height) = image.dimensions();
    let bands = if image.has_alpha() { 4 } else { 3 };
    let size = image
        .output_buffer_size()
        .filter(|&n| n == width as usize * height as usize * bands)
        .ok_or("its decoded size overflows")?;
    let mut pixels = vec![0u8; size];
    image.read_image(&mut pixels).map_err(|e| e.to_string())?;
    Ok(Picture {
        width,
        height,
        bands,
        samples: pixels.iter().map(|&b| f32::from(b)).collect(),
        masks: FileMasks {
            alpha: (bands == 4).then_some(3),
            ..FileMasks::default()
        },
    })
}

/// A gridded coverage's TIFF tile: one band of 32-bit floats (or any numeric samples).
fn decode_tiff(bytes: &[u8]) -> std::result::Result<Picture, String> {
    use tiff::decoder::{Decoder, DecodingResult};
    let decoded = catch_decoder_panic(|| -> tiff::TiffResult<_> {
        let mut decoder = Decoder::new(Cursor::new(bytes))?;
        let (width, height) = decoder.dimensions()?;
        let bands = usize::from(decoder.colortype()?.num_samples());
        Ok((width, height, bands, decoder.read_image()?))
    })
    .map_err(|cause| format!("the decoder failed ({cause})"))?
    .map_err(|e| e.to_string())?;
    let (width, height, bands, image) = decoded;
    let samples: Vec<f32> = match image {
        DecodingResult::U8(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::U16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::U32(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::U64(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::I8(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::I16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::I32(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::I64(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::F16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::F32(v) => v,
        DecodingResult::F64(v) => v.into_iter().map(|x| x as f32).collect(),
    };
    if samples.len() != width as usize * height as usize * bands {
        return Err(format!(
            "it holds {} samples for {width} × {height} cells",
            samples.len()
        ));
    }
    Ok(Picture {
        width,
        height,
        bands,
        samples,
        masks: FileMasks::default(),
    })
}

/// The window's cells, band-interleaved; NaN where no tile holds them or alpha clears
/// them, and where a coverage holds its null value.
struct Raster {
    bands: usize,
    values: Vec<f32>,
}

/// The bands GDAL shows of imagery tiles.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Bands {
    /// Colour (3 bands) or grey (1); `None` where GDAL recorded no band count: colour
    /// where any tile is.
    colour: Option<bool>,
    /// Whether an alpha band is among them (GDAL's RGBA where no count is recorded):
    /// then alpha 0 and missing tiles are nodata; without, GDAL skipped writing tiles
    /// of zeros, and missing tiles read as zeros.
    alpha: bool,
}

impl Bands {
    fn of(band_count: Option<u32>) -> Self {
        Bands {
            colour: band_count.map(|n| n >= 3),
            alpha: band_count.is_none_or(|n| n == 2 || n == 4),
        }
    }
}

impl Raster {
    /// Imagery: grey or colour as GDAL recorded, else grey where every tile is grey; a
    /// grey tile's one value in each band of a colour raster, a colour tile's first
    /// channel in a grey one.
    fn of_imagery(
        tiles: Vec<Tile>,
        decode: impl Fn(&Tile) -> std::result::Result<Picture, String> + Sync,
        bands: Bands,
        matrix: &TileMatrix,
        window: &Window,
    ) -> std::result::Result<Self, String> {
        let missing = if bands.alpha { f32::NAN } else { 0.0 };
        let any_colour = AtomicBool::new(false);
        let decode = |tile: &Tile| {
            let picture = decode(tile)?;
            if picture.bands >= 3 {
                any_colour.store(true, Ordering::Relaxed);
            }
            Ok(picture)
        };
        let write = |_: &Tile, picture: &Picture, pixel: usize, out: &mut [f32]| {
            let alpha = picture.masks.alpha;
            let colours = picture.bands - usize::from(alpha.is_some());
            let at = pixel * picture.bands;
            let clear = alpha.is_some_and(|a| picture.samples[at + a] == 0.0);
            if clear && bands.alpha {
                return;
            }
            // GDAL reads a colour tile of a grey raster as its first channel.
            for (band, value) in out.iter_mut().enumerate() {
                *value = picture.samples[at + band.min(colours - 1)];
            }
        };
        // Where GDAL recorded no band count, read as colour, then keep one band if no
        // tile held colour.
        let count = if bands.colour == Some(false) { 1 } else { 3 };
        let mut raster = Raster::read(tiles, count, missing, matrix, window, decode, write)?;
        if bands.colour.is_none() && !any_colour.into_inner() {
            raster.values = raster.values.iter().step_by(3).copied().collect();
            raster.bands = 1;
        }
        Ok(raster)
    }

    /// A gridded coverage: a 16-bit PNG tile's stored values scaled by its tile's and
    /// the coverage's scale and offset (rounded to whole units where the precision is
    /// 1), a float TIFF tile's as they are (the spec fixes their scales at 1 and
    /// offsets at 0; GDAL applies none); the null value, and missing tiles where there
    /// is one, hold no data.
    fn of_coverage(
        tiles: Vec<Tile>,
        decode: impl Fn(&Tile) -> std::result::Result<Picture, String> + Sync,
        coverage: &Coverage,
        matrix: &TileMatrix,
        window: &Window,
    ) -> std::result::Result<Self, String> {
        // GDAL fills a missing tile with the nodata value, else zeros.
        let missing = if coverage.null.is_some() {
            f32::NAN
        } else {
            0.0
        };
        // Each tile's values, scaled once: the copy then takes them as they are.
        let decode = |tile: &Tile| {
            let mut picture = decode(tile)?;
            let png = tile.data.starts_with(PNG_SIGNATURE);
            let (tile_scale, tile_offset) =
                coverage.tiles.get(&tile.id).copied().unwrap_or((1.0, 0.0));
            for sample in &mut picture.samples {
                let stored = f64::from(*sample);
                *sample = if coverage.null == Some(stored) || !stored.is_finite() {
                    f32::NAN
                } else if png {
                    let value =
                        (stored * tile_scale + tile_offset) * coverage.scale + coverage.offset;
                    if coverage.whole {
                        half_up(value) as f32
                    } else {
                        value as f32
                    }
                } else {
                    stored as f32
                };
            }
            Ok(picture)
        };
        let write = |_: &Tile, picture: &Picture, pixel: usize, out: &mut [f32]| {
            out[0] = picture.samples[pixel];
        };
        Raster::read(tiles, 1, missing, matrix, window, decode, write)
    }

    /// The window's `bands` (holding `missing` where no tile is) from `tiles`, a row of
    /// tiles at a time in parallel, each tile decoded by `decode` and its pixels in the
    /// window given to `write` with the cell's band values: no tile is held decoded
    /// longer than its copy takes.
    fn read(
        tiles: Vec<Tile>,
        bands: usize,
        missing: f32,
        matrix: &TileMatrix,
        window: &Window,
        decode: impl Fn(&Tile) -> std::result::Result<Picture, String> + Sync,
        write: impl Fn(&Tile, &Picture, usize, &mut [f32]) + Sync,
    ) -> std::result::Result<Self, String> {
        let [tw, th] = matrix.tile;
        let [_, _, first_row, last_row] = window.tiles(matrix);
        let height = window.height as i64;
        let row_length = window.width * bands;
        let mut values = vec![missing; row_length * window.height];
        // The window's rows each row of tiles covers (from `top`), and its tiles; rows
        // beyond the tile matrix stay as they are.
        let mut rows: Vec<(i64, &mut [f32], Vec<Tile>)> = Vec::new();
        let (mut rest, mut reached) = (values.as_mut_slice(), 0);
        for r in first_row..=last_row {
            let top = (r * th - window.shift[1]).clamp(reached, height);
            let bottom = ((r + 1) * th - window.shift[1]).clamp(top, height);
            let (_, after) =
                std::mem::take(&mut rest).split_at_mut((top - reached) as usize * row_length);
            let (these, others) = after.split_at_mut((bottom - top) as usize * row_length);
            rest = others;
            reached = bottom;
            rows.push((top, these, Vec::new()));
        }
        for tile in tiles {
            if let Some(row) = usize::try_from(tile.row - first_row)
                .ok()
                .and_then(|i| rows.get_mut(i))
            {
                row.2.push(tile);
            }
        }
        let results: Vec<std::result::Result<(), String>> = rows
            .into_par_iter()
            .map(|(top, out, row_tiles)| {
                for tile in &row_tiles {
                    let picture = decode(tile)?;
                    debug_assert_eq!(picture.samples.len() as i64, tw * th * picture.bands as i64);
                    for y in 0..th {
                        let row = tile.row * th + y - window.shift[1];
                        if row < top || row >= window.height as i64 {
                            continue;
                        }
                        let line = (row - top) as usize * window.width;
                        for x in 0..tw {
                            let column = tile.column * tw + x - window.shift[0];
                            if column < 0 || column >= window.width as i64 {
                                continue;
                            }
                            let cell = line + column as usize;
                            write(
                                tile,
                                &picture,
                                (y * tw + x) as usize,
                                &mut out[cell * bands..(cell + 1) * bands],
                            );
                        }
                    }
                }
                Ok(())
            })
            .collect();
        first_error_in_order(results)?;
        Ok(Raster { bands, values })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(extent: [f64; 4], origin: [f64; 2]) -> RasterTable {
        RasterTable {
            name: "t".into(),
            coverage: false,
            srs_id: 0,
            extent,
            origin,
        }
    }

    /// `tiles` read as the reader reads them, each decoded to its picture.
    fn imagery(tiles: &[(Tile, Picture)], bands: Bands, m: &TileMatrix, w: &Window) -> Raster {
        let (stored, decode) = decoded(tiles);
        Raster::of_imagery(stored, decode, bands, m, w).unwrap()
    }

    fn covered(tiles: &[(Tile, Picture)], c: &Coverage, m: &TileMatrix, w: &Window) -> Raster {
        let (stored, decode) = decoded(tiles);
        Raster::of_coverage(stored, decode, c, m, w).unwrap()
    }

    type Decode = Box<dyn Fn(&Tile) -> std::result::Result<Picture, String> + Sync>;

    fn decoded(tiles: &[(Tile, Picture)]) -> (Vec<Tile>, Decode) {
        let pictures: HashMap<i64, Picture> =
            tiles.iter().map(|(t, p)| (t.id, p.clone())).collect();
        let stored = tiles.iter().map(|(t, _)| t.clone()).collect();
        (
            stored,
            Box::new(move |tile: &Tile| Ok(pictures[&tile.id].clone())),
        )
    }

    /// A grey 2 × 2 tile, stored as PNG (its signature is all the reading looks at).
    fn grey_tile(id: i64, column: i64, row: i64, values: [f32; 4]) -> (Tile, Picture) {
        (
            Tile {
                id,
                column,
                row,
                data: PNG_SIGNATURE.to_vec(),
            },
            Picture {
                width: 2,
                height: 2,
                bands: 1,
                samples: values.to_vec(),
                masks: FileMasks::default(),
            },
        )
    }

    fn matrix() -> TileMatrix {
        TileMatrix {
            zoom: 3,
            columns: 2,
            rows: 2,
            tile: [256, 256],
            pixel: [30.0, 30.0],
        }
    }

    #[test]
    fn the_window_is_the_contents_extent_snapped_to_the_tile_grid() {
        // GDAL's layout: the tile grid starts at the matrix set's north-west corner,
        // the raster at its contents' bounds.
        let t = table(
            [500_000.0, 4_191_000.0, 512_510.0, 4_200_000.0],
            [500_000.0, 4_200_000.0],
        );
        let w = Window::of(&t, &matrix()).unwrap();
        assert_eq!((w.width, w.height, w.shift), (417, 300, [0, 0]));
        assert_eq!(w.tiles(&matrix()), [0, 1, 0, 1]);
        // A raster a tile and a bit in from the grid's corner.
        let t = table(
            [507_690.0, 4_180_000.0, 508_590.0, 4_192_290.0],
            [500_000.0, 4_200_000.0],
        );
        let w = Window::of(&t, &matrix()).unwrap();
        assert_eq!((w.width, w.height, w.shift), (30, 410, [256, 257]));
        assert_eq!(w.tiles(&matrix()), [1, 1, 1, 1]);
        let empty = table([0.0, 0.0, 10.0, 10.0], [0.0, 10.0]);
        assert!(
            Window::of(&empty, &matrix())
                .unwrap_err()
                .contains("no cell")
        );
    }

    #[test]
    fn tiles_land_in_their_cells_and_missing_cells_hold_no_data() {
        let m = TileMatrix {
            tile: [2, 2],
            columns: 2,
            rows: 2,
            ..matrix()
        };
        let w = Window {
            width: 3,
            height: 3,
            shift: [1, 0],
        };
        let grey = grey_tile;
        let tiles = [
            grey(1, 0, 0, [1.0, 2.0, 3.0, 4.0]),
            grey(2, 1, 1, [5.0, 6.0, 7.0, 8.0]),
        ];
        let raster = imagery(&tiles, Bands::of(None), &m, &w);
        assert_eq!(raster.bands, 1);
        // Column 0 of the window is the tile grid's column 1.
        let held: Vec<bool> = raster.values.iter().map(|v| !v.is_nan()).collect();
        assert_eq!(
            held,
            [true, false, false, true, false, false, false, true, true]
        );
        assert_eq!((raster.values[0], raster.values[3]), (2.0, 4.0));
        assert_eq!(raster.values[7..9], [5.0, 6.0]);

        let coverage = Coverage {
            scale: 2.0,
            offset: -1.0,
            whole: false,
            null: Some(8.0),
            tiles: HashMap::from([(2, (0.5, 10.0))]),
            field_name: None,
            uom: None,
        };
        let raster = covered(&tiles, &coverage, &m, &w);
        assert_eq!(raster.values[0], 3.0);
        // (5 × 0.5 + 10) × 2 − 1
        assert_eq!(raster.values[7], 24.0);
        let nulls = [grey(2, 1, 1, [8.0, 6.0, 7.0, 8.0])];
        let raster = covered(&nulls, &coverage, &m, &w);
        assert!(raster.values[7].is_nan() && !raster.values[8].is_nan());
        // At a precision of 1, (5 × 0.25 + 10) × 2 − 1 = 21.5 rounds half up, as GDAL.
        let whole = Coverage {
            whole: true,
            tiles: HashMap::from([(2, (0.25, 10.0))]),
            ..coverage.clone()
        };
        assert_eq!(covered(&tiles, &whole, &m, &w).values[7], 22.0);
        // A float TIFF tile's values are as stored.
        let mut tiff = tiles;
        tiff[1].0.data = b"II*\0".to_vec();
        assert_eq!(covered(&tiff, &whole, &m, &w).values[7], 5.0);
    }

    #[test]
    fn a_window_reaching_past_the_tile_grid_keeps_its_rows_in_place() {
        let m = TileMatrix {
            tile: [2, 2],
            columns: 1,
            rows: 2,
            ..matrix()
        };
        // One column, from a row above the grid to a row below it.
        let w = Window {
            width: 1,
            height: 6,
            shift: [0, -1],
        };
        let tiles = [
            grey_tile(1, 0, 0, [1.0, 9.0, 2.0, 9.0]),
            grey_tile(2, 0, 1, [3.0, 9.0, 4.0, 9.0]),
        ];
        assert_eq!(w.tiles(&m), [0, 0, 0, 1]);
        let raster = imagery(&tiles, Bands::of(Some(1)), &m, &w);
        assert_eq!(raster.values, [0.0, 1.0, 2.0, 3.0, 4.0, 0.0]);
    }

    #[test]
    fn a_grey_tile_fills_every_band_of_a_colour_raster_and_alpha_clears() {
        let m = TileMatrix {
            tile: [1, 1],
            columns: 2,
            rows: 1,
            ..matrix()
        };
        let w = Window {
            width: 2,
            height: 1,
            shift: [0, 0],
        };
        let tile = |column| Tile {
            id: column,
            column,
            row: 0,
            data: Vec::new(),
        };
        let tiles = [
            (
                tile(0),
                Picture {
                    width: 1,
                    height: 1,
                    bands: 2,
                    samples: vec![7.0, 255.0],
                    masks: FileMasks {
                        alpha: Some(1),
                        ..FileMasks::default()
                    },
                },
            ),
            (
                tile(1),
                Picture {
                    width: 1,
                    height: 1,
                    bands: 4,
                    samples: vec![1.0, 2.0, 3.0, 0.0],
                    masks: FileMasks {
                        alpha: Some(3),
                        ..FileMasks::default()
                    },
                },
            ),
        ];
        let raster = imagery(&tiles, Bands::of(None), &m, &w);
        assert_eq!(raster.bands, 3);
        assert_eq!(raster.values[..3], [7.0, 7.0, 7.0]);
        assert!(raster.values[3..].iter().all(|v| v.is_nan()));
        // Recorded without alpha, missing tiles and clear cells read as GDAL reads them.
        let grey = imagery(&tiles[..1], Bands::of(Some(1)), &m, &w);
        assert_eq!(grey.values, [7.0, 0.0]);
        let rgb = imagery(&tiles[1..], Bands::of(Some(3)), &m, &w);
        assert_eq!(rgb.values, [0.0, 0.0, 0.0, 1.0, 2.0, 3.0]);
        // Recorded as grey, a colour tile reads as its first channel.
        let mut opaque = tiles;
        opaque[1].1.samples[3] = 255.0;
        let raster = imagery(&opaque, Bands::of(Some(2)), &m, &w);
        assert_eq!(raster.values, [7.0, 1.0]);
    }

    #[test]
    fn values_round_half_up_as_floor_does() {
        for v in [
            -2.5, -2.4999, -0.5, -0.2, 0.0, 0.49999, 0.5, 2.5, 1965.4999, 1e17, -1e17,
        ] {
            assert_eq!(half_up(v), (v + 0.5).floor(), "{v}");
        }
        assert!(half_up(f64::NAN).is_nan());
    }

    #[test]
    fn reals_keep_the_15_digits_gdal_reads() {
        assert_eq!(as_gdal_reads(19.10925707129406), 19.1092570712941);
        assert_eq!(as_gdal_reads(30.0), 30.0);
        assert_eq!(as_gdal_reads(-20037508.34278924), -20037508.3427892);
    }

    #[test]
    fn paths_become_uris_sqlite_reads_as_the_file() {
        assert_eq!(quoted("a\"b"), "\"a\"\"b\"");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("odd ?#% name.gpkg");
        let db = Connection::open(&path).unwrap();
        db.execute_batch("CREATE TABLE t (x); INSERT INTO t VALUES (5);")
            .unwrap();
        drop(db);
        let db = open_immutable(&path).unwrap();
        let x: i64 = db.query_row("SELECT x FROM t", [], |r| r.get(0)).unwrap();
        assert_eq!(x, 5);
        assert!(db.execute("INSERT INTO t VALUES (6)", []).is_err());
    }
}
