//! MBTiles rasters (`.mbtiles`): the tile packages GDAL, QGIS ("Generate XYZ tiles"),
//! MapTiler and rio-mbtiles write, and in which field teams carry satellite imagery
//! offline. An SQLite file of PNG, JPEG or WebP tiles on the Web Mercator tile grid
//! (EPSG:3857, rows counted from the south), read as GDAL's MBTiles driver reads it:
//!
//! - the zoom level is `maxzoom` where the metadata gives `minzoom` and `maxzoom`, else
//!   the highest that holds tiles;
//! - the extent is the metadata's `bounds` (longitudes and latitudes) in Web Mercator,
//!   as they are, where they are valid, else the tiles the zoom level holds; the grid
//!   starts at the extent's north-west corner and takes its cells from the tile grid
//!   nearest it (GDAL shifts whole cells, never resamples);
//! - the layers are the colour bands (grey where every tile is grey); transparent cells
//!   and cells no tile holds are nodata, as in GDAL's RGBA reading.
//!
//! Vector tiles (`format` `pbf`) are refused. The file is opened read-only and
//! immutable: nothing is ever written beside it.

use std::collections::HashMap;
use std::path::Path;

use rusqlite::types::Value;
use rusqlite::{Connection, OptionalExtension};

use super::FileOrder;
use super::geotiff::{Georeferencing, georeference};
use super::named_crs::epsg_geokeys;
use super::sidecar_bands::{self, FileMasks, Samples};
use super::sqlite_tiles::{
    Bands, MAX_TILE_SIDE, Raster, Tile, TileMatrix, Window, decode_image, decode_tile, open_sqlite,
};
use crate::error::{Error, Result};
use crate::grid::Map;

/// The sphere Web Mercator projects (metres), and half the world's width on it: the
/// tile grid runs from -`HALF_WORLD` to `HALF_WORLD` each way.
const SPHERE_RADIUS: f64 = 6_378_137.0;
pub(super) const HALF_WORLD: f64 = SPHERE_RADIUS * std::f64::consts::PI;

/// The deepest zoom level GDAL reads (cells of 4 cm at 256-cell tiles).
pub(super) const MAX_ZOOM: i64 = 22;

/// The MBTiles raster at `path` as map `name`, with whether its rows ran from the north
/// (always: the grid runs from the north-west).
pub fn read_mbtiles_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let db = open_sqlite(path, "an MBTiles file")?;
    let metadata = metadata(&db).map_err(&problem)?;
    if let Some(format) = metadata.get("format")
        && format.eq_ignore_ascii_case("pbf")
    {
        return Err(problem(
            "it holds vector tiles (format pbf), not a raster: rasterize the layer wanted \
             first (gdal_rasterize)"
                .into(),
        ));
    }
    let zoom = zoom_level(&db, &metadata).map_err(&problem)?;
    let extent = match bounds(&metadata) {
        Some(extent) => extent,
        None => tiles_extent(&db, zoom).map_err(&problem)?,
    };
    let matrix = tile_matrix(&db, zoom, extent).map_err(&problem)?;
    let window = Window::of(extent, [-HALF_WORLD, HALF_WORLD], &matrix).map_err(&problem)?;
    let tiles = tiles(&db, &matrix, &window).map_err(&problem)?;
    tiles_map(path, name, extent, &matrix, &window, tiles)
}

/// The map of Web Mercator imagery `tiles` (of `matrix`) over `extent`, in `window`, as
/// GDAL reads an MBTiles package: RGBA, so alpha and missing tiles are nodata.
pub(super) fn tiles_map(
    path: &Path,
    name: &str,
    extent: [f64; 4],
    matrix: &TileMatrix,
    window: &Window,
    tiles: Vec<Tile>,
) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let keys = epsg_geokeys(3857, true);
    let transform = [
        matrix.pixel[0],
        0.0,
        extent[0],
        0.0,
        -matrix.pixel[1],
        extent[3],
    ];
    let (width, height) = (window.width, window.height);
    let (geo, heights) = georeference(
        path,
        width as u32,
        height as u32,
        Georeferencing::of_grid(transform, &keys, String::new()),
    )?;
    window.check_filled(tiles.len(), matrix).map_err(&problem)?;
    let decode = |tile: &Tile| decode_tile(tile, false, matrix);
    let bands = Bands {
        colour: None,
        alpha: true,
    };
    let Raster { bands, values } =
        Raster::of_imagery(tiles, decode, bands, matrix, window).map_err(&problem)?;
    let samples = Samples {
        width: width as u32,
        height: height as u32,
        bands,
        order: FileOrder::NORTH_UP,
        heights,
        sample: |band: usize, cell: usize| values[cell * bands + band],
    };
    sidecar_bands::map(path, name, geo, samples, &FileMasks::default())
}

/// The `metadata` table's names and values (as text, whatever type SQLite stored).
fn metadata(db: &Connection) -> std::result::Result<HashMap<String, String>, String> {
    let unreadable = |e: rusqlite::Error| {
        format!("it is not an MBTiles file: its table metadata cannot be read ({e})")
    };
    let mut statement = db
        .prepare("SELECT name, value FROM metadata")
        .map_err(unreadable)?;
    let rows: Vec<(Value, Value)> = statement
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
        .and_then(Iterator::collect)
        .map_err(unreadable)?;
    let text = |value: Value| match value {
        Value::Text(text) => Some(text),
        Value::Integer(n) => Some(n.to_string()),
        Value::Real(x) => Some(x.to_string()),
        Value::Null | Value::Blob(_) => None,
    };
    Ok(rows
        .into_iter()
        .filter_map(|(name, value)| Some((text(name)?, text(value)?)))
        .collect())
}

/// The zoom level read: `maxzoom` where the metadata gives both `minzoom` and
/// `maxzoom`, else the highest that holds tiles (GDAL's rule).
fn zoom_level(
    db: &Connection,
    metadata: &HashMap<String, String>,
) -> std::result::Result<i64, String> {
    let level = |key: &str| metadata.get(key).and_then(|v| v.trim().parse::<i64>().ok());
    let zoom = match (level("minzoom"), level("maxzoom")) {
        (Some(min), Some(max)) if (0..=max).contains(&min) => max,
        (Some(min), Some(max)) => {
            return Err(format!(
                "its metadata's zoom levels are inconsistent: minzoom {min}, maxzoom {max}"
            ));
        }
        _ => db
            .query_row(
                "SELECT MAX(zoom_level) FROM tiles WHERE zoom_level BETWEEN 0 AND 32",
                [],
                |r| r.get::<_, Option<i64>>(0),
            )
            .map_err(|e| {
                format!("it is not an MBTiles file: its table tiles cannot be read ({e})")
            })?
            .ok_or("it holds no tile")?,
    };
    if zoom > MAX_ZOOM {
        return Err(format!(
            "its zoom level {zoom} is deeper than the {MAX_ZOOM} GDAL reads"
        ));
    }
    Ok(zoom)
}

/// Longitude and latitude (degrees) in Web Mercator metres, as GDAL computes them.
fn web_mercator(longitude: f64, latitude: f64) -> [f64; 2] {
    use std::f64::consts::PI;
    [
        SPHERE_RADIUS * longitude / 180.0 * PI,
        SPHERE_RADIUS * (PI / 4.0 + 0.5 * latitude / 180.0 * PI).tan().ln(),
    ]
}

/// The metadata's `bounds` (west, south, east, north in degrees) in Web Mercator, where
/// they are four numbers GDAL accepts; `None` otherwise, as GDAL then ignores them.
fn bounds(metadata: &HashMap<String, String>) -> Option<[f64; 4]> {
    let numbers: Vec<f64> = metadata
        .get("bounds")?
        .split(',')
        .map(|token| token.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .ok()?;
    degrees_to_extent(numbers.try_into().ok()?)
}

/// Bounds in degrees (west, south, east, north) in Web Mercator metres, where GDAL
/// accepts them: longitudes within ±180, latitudes within ±89.99, west of east and
/// south of north.
pub(super) fn degrees_to_extent([west, south, east, north]: [f64; 4]) -> Option<[f64; 4]> {
    let longitude_ok = |x: f64| x.abs() <= 180.0;
    let latitude_ok = |y: f64| y.abs() < 89.99;
    let valid = longitude_ok(west)
        && longitude_ok(east)
        && latitude_ok(south)
        && latitude_ok(north)
        && west <= east
        && south <= north;
    if !valid {
        return None;
    }
    let [min_x, min_y] = web_mercator(west, south);
    let [max_x, max_y] = web_mercator(east, north);
    Some([min_x, min_y.max(-HALF_WORLD), max_x, max_y.min(HALF_WORLD)])
}

/// The extent of the tiles zoom level `zoom` holds, in Web Mercator metres.
fn tiles_extent(db: &Connection, zoom: i64) -> std::result::Result<[f64; 4], String> {
    let range: Option<[i64; 4]> = db
        .query_row(
            "SELECT MIN(tile_column), MAX(tile_column), MIN(tile_row), MAX(tile_row) \
             FROM tiles WHERE zoom_level = ?1",
            [zoom],
            |r| {
                Ok(match (r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?) {
                    (Some(a), Some(b), Some(c), Some(d)) => Some([a, b, c, d]),
                    _ => None,
                })
            },
        )
        .map_err(|e| format!("its table tiles cannot be read: {e}"))?;
    let range = range.ok_or_else(|| format!("it holds no tile at zoom level {zoom}"))?;
    Ok(tile_range_extent(zoom, range))
}

/// The extent (Web Mercator metres) of tiles `first_column` to `last_column` and
/// `first_row` to `last_row`, rows counted from the south, at zoom level `zoom`, as
/// GDAL computes it.
pub(super) fn tile_range_extent(zoom: i64, range: [i64; 4]) -> [f64; 4] {
    let [first_column, last_column, first_row, last_row] = range;
    let world = |tile: i64| -HALF_WORLD + 2.0 * HALF_WORLD * (tile as f64 / (1u64 << zoom) as f64);
    [
        world(first_column),
        world(first_row),
        world(last_column + 1),
        world(last_row + 1),
    ]
}

/// The tile matrix of zoom level `zoom`: tiles as wide as the one GDAL samples (the
/// tile nearest the middle of `extent`, else any at that level), square.
fn tile_matrix(
    db: &Connection,
    zoom: i64,
    extent: [f64; 4],
) -> std::result::Result<TileMatrix, String> {
    let tiles_across = 1i64 << zoom;
    let tile_of =
        |metres: f64| ((metres + HALF_WORLD) / (2.0 * HALF_WORLD) * tiles_across as f64) as i64;
    let [west, south, east, north] = extent;
    let (column, row) = (
        tile_of(west) / 2 + tile_of(east) / 2,
        tile_of(south) / 2 + tile_of(north) / 2,
    );
    let sample = |sql: &str, params: &[&dyn rusqlite::ToSql]| {
        db.query_row(sql, params, |r| r.get::<_, Vec<u8>>(0))
            .optional()
            .map_err(|e| format!("its table tiles cannot be read: {e}"))
    };
    let data = match sample(
        "SELECT tile_data FROM tiles WHERE zoom_level = ?1 AND tile_column = ?2 \
         AND tile_row = ?3",
        &[&zoom, &column, &row],
    )? {
        Some(data) => data,
        None => sample(
            "SELECT tile_data FROM tiles WHERE zoom_level = ?1 LIMIT 1",
            &[&zoom],
        )?
        .ok_or_else(|| format!("it holds no tile at zoom level {zoom}"))?,
    };
    let picture =
        decode_image(&data, false).map_err(|e| format!("its tile at zoom level {zoom}: {e}"))?;
    web_mercator_matrix(zoom, picture.width, picture.height)
}

/// Zoom level `zoom`'s tile matrix on the Web Mercator grid, for tiles of `width` ×
/// `height` cells (which must be square).
pub(super) fn web_mercator_matrix(
    zoom: i64,
    width: u32,
    height: u32,
) -> std::result::Result<TileMatrix, String> {
    let side = i64::from(width);
    if side != i64::from(height) || !(1..=MAX_TILE_SIDE).contains(&side) {
        return Err(format!(
            "its tiles at zoom level {zoom} are {width} × {height} cells: Web Mercator tiles \
             are square, at most {MAX_TILE_SIDE} a side"
        ));
    }
    let tiles_across = 1i64 << zoom;
    let cell = 2.0 * HALF_WORLD / side as f64 / tiles_across as f64;
    Ok(TileMatrix {
        zoom,
        columns: tiles_across,
        rows: tiles_across,
        tile: [side, side],
        pixel: [cell, cell],
    })
}

/// The stored tiles that hold the window's cells, their rows turned to count from the
/// north as the tile grid does (MBTiles counts them from the south).
fn tiles(
    db: &Connection,
    matrix: &TileMatrix,
    window: &Window,
) -> std::result::Result<Vec<Tile>, String> {
    let unreadable = |e: rusqlite::Error| format!("its table tiles cannot be read: {e}");
    let [first_column, last_column, first_row, last_row] = window.tiles(matrix);
    let from_south = |row: i64| matrix.rows - 1 - row;
    let mut statement = db
        .prepare(
            "SELECT tile_column, tile_row, tile_data FROM tiles WHERE zoom_level = ?1 \
             AND tile_column BETWEEN ?2 AND ?3 AND tile_row BETWEEN ?4 AND ?5 \
             ORDER BY tile_row DESC, tile_column",
        )
        .map_err(unreadable)?;
    let params = [
        matrix.zoom,
        first_column,
        last_column,
        from_south(last_row),
        from_south(first_row),
    ];
    statement
        .query_map(params, |r| {
            let stored_row: i64 = r.get(1)?;
            Ok(Tile {
                id: 0,
                column: r.get(0)?,
                row: from_south(stored_row),
                stored_row,
                data: r.get(2)?,
            })
        })
        .and_then(Iterator::collect)
        .map_err(unreadable)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with(pairs: &[(&str, &str)]) -> HashMap<String, String> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    #[test]
    fn bounds_are_web_mercator_metres_where_gdal_accepts_them() {
        let [w, s, e, n] = bounds(&with(&[("bounds", "-180,-85.0511287798066,180, 0")])).unwrap();
        assert_eq!((w, e), (-HALF_WORLD, HALF_WORLD));
        assert!((s + HALF_WORLD).abs() < 1e-6 && n.abs() < 1e-9, "{s} {n}");
        let [_, _, e, n] = bounds(&with(&[("bounds", "7.0,46.0,7.5,46.5")])).unwrap();
        assert!(
            (e - 834_896.181).abs() < 1e-3 && (n - 5_860_839.830).abs() < 1e-3,
            "{e} {n}"
        );
        for refused in [
            "1,2,3",
            "0,0,1,89.99",
            "2,0,1,1",
            "0,1,1,0",
            "a,b,c,d",
            "0,0,181,1",
        ] {
            assert_eq!(bounds(&with(&[("bounds", refused)])), None, "{refused}");
        }
        assert_eq!(bounds(&with(&[])), None);
    }

    fn database(sql: &str) -> Connection {
        let db = Connection::open_in_memory().unwrap();
        db.execute_batch(
            "CREATE TABLE metadata (name TEXT, value TEXT);
             CREATE TABLE tiles (zoom_level INTEGER, tile_column INTEGER, tile_row INTEGER,
                                 tile_data BLOB);",
        )
        .unwrap();
        db.execute_batch(sql).unwrap();
        db
    }

    #[test]
    fn the_zoom_level_is_maxzoom_else_the_deepest_holding_tiles() {
        let db =
            database("INSERT INTO tiles VALUES (3, 0, 0, x''), (5, 1, 1, x''), (40, 0, 0, x'');");
        let zoom = |pairs: &[(&str, &str)]| zoom_level(&db, &with(pairs));
        assert_eq!(zoom(&[]), Ok(5));
        assert_eq!(zoom(&[("minzoom", "2"), ("maxzoom", "4")]), Ok(4));
        // One of the two is not enough: GDAL then looks at the tiles.
        assert_eq!(zoom(&[("maxzoom", "4")]), Ok(5));
        assert!(
            zoom(&[("minzoom", "6"), ("maxzoom", "4")])
                .unwrap_err()
                .contains("inconsistent")
        );
        assert!(
            zoom(&[("minzoom", "0"), ("maxzoom", "23")])
                .unwrap_err()
                .contains("22")
        );
        let empty = database("");
        assert_eq!(
            zoom_level(&empty, &with(&[])),
            Err("it holds no tile".into())
        );
    }

    #[test]
    fn without_bounds_the_extent_is_the_tiles_and_rows_count_from_the_south() {
        let db = database("INSERT INTO tiles VALUES (2, 1, 0, x''), (2, 2, 1, x'');");
        let quarter = HALF_WORLD / 2.0;
        let extent = tiles_extent(&db, 2).unwrap();
        let expected = [-quarter, -HALF_WORLD, quarter, 0.0];
        assert!(
            extent
                .iter()
                .zip(expected)
                .all(|(a, b)| (a - b).abs() < 1e-6),
            "{extent:?}"
        );
        let matrix = TileMatrix {
            zoom: 2,
            columns: 4,
            rows: 4,
            tile: [256, 256],
            pixel: [HALF_WORLD / 512.0; 2],
        };
        // The southern half of the world: tile rows 2 and 3 from the north.
        let window = Window::of(
            tiles_extent(&db, 2).unwrap(),
            [-HALF_WORLD, HALF_WORLD],
            &matrix,
        )
        .unwrap();
        assert_eq!(
            (window.width, window.height, window.shift),
            (512, 512, [256, 512])
        );
        let found = tiles(&db, &matrix, &window).unwrap();
        let placed: Vec<(i64, i64, i64)> = found
            .iter()
            .map(|t| (t.column, t.row, t.stored_row))
            .collect();
        assert_eq!(placed, [(2, 2, 1), (1, 3, 0)]);
        assert!(
            tiles_extent(&db, 4)
                .unwrap_err()
                .contains("no tile at zoom level 4")
        );
    }
}
