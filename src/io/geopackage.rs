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
use std::path::Path;

use rusqlite::{Connection, OptionalExtension};

use super::FileOrder;
use super::geotiff::metadata::metres_per_unit;
use super::geotiff::{Georeferencing, georeference, wkt_geokeys};
use super::picture::Picture;
use super::sidecar_bands::{self, FileMasks, Samples};
use super::sqlite_tiles::{
    Bands, MAX_TILE_SIDE, PNG_SIGNATURE, Raster, Tile, TileMatrix, Window, decode_tile, has_tables,
    open_sqlite, quoted,
};
use crate::error::{Error, Result};
use crate::grid::Map;

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

/// The GeoPackage raster at `path` as map `name`, with whether its rows ran from the
/// north (always: tiles run from the north-west).
pub fn read_geopackage_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let db = open_sqlite(path, "a GeoPackage")?;
    let table = raster_table(&db).map_err(&problem)?;
    let matrix = tile_matrix(&db, &table).map_err(&problem)?;
    let window = Window::of(table.extent, table.origin, &matrix).map_err(&problem)?;
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
        order: FileOrder::NORTH_UP,
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
                stored_row: r.get(2)?,
                data: r.get(3)?,
            })
        })
        .and_then(Iterator::collect)
        .map_err(unreadable)
}

impl Raster {
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
}

#[cfg(test)]
mod tests {
    use super::super::sqlite_tiles::fixtures::{decoded, grey_tile, two_grey_tiles};
    use super::*;

    fn covered(tiles: &[(Tile, Picture)], c: &Coverage, m: &TileMatrix, w: &Window) -> Raster {
        let (stored, decode) = decoded(tiles);
        Raster::of_coverage(stored, decode, c, m, w).unwrap()
    }

    #[test]
    fn coverage_tiles_are_scaled_by_their_tile_and_the_coverage() {
        let (m, w, tiles) = two_grey_tiles();
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
        let nulls = [grey_tile(2, 1, 1, [8.0, 6.0, 7.0, 8.0])];
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
}
