//! Rasters stored as tiles in an SQLite file, as GeoPackage and MBTiles store them:
//! the file opened read-only, the window a raster covers in one zoom level's tile grid,
//! and its tiles (PNG, JPEG, WebP, TIFF) decoded and copied into that window a row of
//! tiles at a time. What the tiles mean (their bands, alpha, scales) is the format's.

use std::io::Cursor;
use std::path::Path;

use rayon::prelude::*;
use rusqlite::{Connection, OpenFlags};

use super::MAX_MAP_CELLS;
use super::picture::{Picture, decode_jpeg, decode_png};
use super::sidecar_bands::FileMasks;
use crate::error::{Error, Result, catch_decoder_panic, first_error_in_order, open_input};

/// The first bytes of every PNG image.
pub(super) const PNG_SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";

/// The first 16 bytes of every SQLite 3 database.
const SQLITE_MAGIC: &[u8; 16] = b"SQLite format 3\0";

/// The widest tile a tile matrix may declare, in cells each way (GDAL writes 256 or
/// 512; the spec sets no limit).
pub(super) const MAX_TILE_SIDE: i64 = 1 << 14;

/// A window of up to this many cells is read however few tiles it holds; a larger one
/// must hold tiles for at least 1/`SPARSE_RATIO` of its cells.
const SPARSE_WINDOW_CELLS: f64 = (1u64 << 24) as f64;
const SPARSE_RATIO: f64 = 64.0;

/// The tile matrix of the zoom level read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct TileMatrix {
    pub(super) zoom: i64,
    pub(super) columns: i64,
    pub(super) rows: i64,
    pub(super) tile: [i64; 2],
    pub(super) pixel: [f64; 2],
}

/// The raster's grid: its size in cells and where its first cell lies in the tile grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Window {
    pub(super) width: usize,
    pub(super) height: usize,
    /// Cells from the tile grid's west and north edges to the raster's.
    pub(super) shift: [i64; 2],
}

impl Window {
    /// GDAL's window of `extent` (west, south, east, north) in a tile grid whose tile
    /// (0, 0) starts at `origin` (west, north): the extent in whole cells (rounded),
    /// snapped to the grid.
    pub(super) fn of(
        extent: [f64; 4],
        origin: [f64; 2],
        matrix: &TileMatrix,
    ) -> std::result::Result<Self, String> {
        let [west, south, east, north] = extent;
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
            ((west - origin[0]) / px + 0.5).floor(),
            ((origin[1] - north) / py + 0.5).floor(),
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
    pub(super) fn check_filled(
        &self,
        tiles: usize,
        matrix: &TileMatrix,
    ) -> std::result::Result<(), String> {
        let cells = self.width as f64 * self.height as f64;
        let filled = tiles as f64 * (matrix.tile[0] * matrix.tile[1]) as f64;
        if cells > SPARSE_WINDOW_CELLS.max(SPARSE_RATIO * filled) {
            return Err(format!(
                "its extent of {} × {} cells holds only {tiles} tiles of {} × {}: its bounds \
                 are far wider than its raster",
                self.width, self.height, matrix.tile[0], matrix.tile[1]
            ));
        }
        Ok(())
    }

    /// The tiles (first and last column, first and last row) that hold the window's
    /// cells.
    pub(super) fn tiles(&self, matrix: &TileMatrix) -> [i64; 4] {
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

/// The SQLite file at `path`, which should be `what` ("a GeoPackage", "an MBTiles
/// file"), opened read-only; an input error where it is not an SQLite database.
pub(super) fn open_sqlite(path: &Path, what: &str) -> Result<Connection> {
    let mut magic = [0u8; 16];
    let read = std::io::Read::read_exact(&mut open_input(path)?, &mut magic);
    if read.is_err() || &magic != SQLITE_MAGIC {
        return Err(Error::input(
            path,
            format!("it is not {what} (not an SQLite database)"),
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

/// One stored tile.
#[derive(Debug, Clone)]
pub(super) struct Tile {
    pub(super) id: i64,
    pub(super) column: i64,
    /// The tile's row from the tile grid's north edge.
    pub(super) row: i64,
    /// Its row as the file numbers it (from the south in MBTiles).
    pub(super) stored_row: i64,
    pub(super) data: Vec<u8>,
}

/// A tile decoded: an imagery tile as its grey or colour channels with or without
/// alpha, a coverage's tile as its one band of stored values.
pub(super) fn decode_tile(
    tile: &Tile,
    coverage: bool,
    matrix: &TileMatrix,
) -> std::result::Result<Picture, String> {
    let at = || {
        format!(
            "its tile at zoom level {}, column {}, row {}",
            matrix.zoom, tile.column, tile.stored_row
        )
    };
    let decoded = decode_image(&tile.data, coverage).map_err(|e| format!("{}: {e}", at()))?;
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

/// A tile's image as it is stored: PNG (palette and low bit depths expanded, unless it
/// holds a coverage's values), JPEG, WebP, or a coverage's TIFF.
pub(super) fn decode_image(bytes: &[u8], coverage: bool) -> std::result::Result<Picture, String> {
    if bytes.starts_with(PNG_SIGNATURE) {
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
}

/// Whether an imagery tile holds colour, by its header alone: a PNG of RGB, RGBA or a
/// palette (which GDAL expands to RGB), a JPEG of three components, any WebP; grey
/// otherwise. A header too damaged to tell says colour (decoding will name the fault).
fn holds_colour(bytes: &[u8]) -> bool {
    if bytes.starts_with(PNG_SIGNATURE) {
        // IHDR is the first chunk: its colour type follows width, height and depth.
        return bytes.get(25).is_none_or(|&kind| matches!(kind, 2 | 3 | 6));
    }
    if !bytes.starts_with(&[0xff, 0xd8]) {
        return true;
    }
    // Walk the JPEG's marker segments to its frame header (SOF0 to SOF15 but DHT, JPG
    // and DAC), whose byte 9 counts the components.
    let mut at = 2;
    while let Some(&[0xff, marker, high, low]) = bytes.get(at..at + 4) {
        let frame = (0xc0..=0xcf).contains(&marker) && !matches!(marker, 0xc4 | 0xc8 | 0xcc);
        if frame {
            return bytes.get(at + 9).is_none_or(|&components| components >= 3);
        }
        at += 2 + usize::from(u16::from_be_bytes([high, low]));
    }
    true
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
pub(super) struct Raster {
    pub(super) bands: usize,
    pub(super) values: Vec<f32>,
}

/// The bands GDAL shows of imagery tiles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Bands {
    /// Colour (3 bands) or grey (1); `None` where GDAL recorded no band count: colour
    /// where any tile is.
    pub(super) colour: Option<bool>,
    /// Whether an alpha band is among them (GDAL's RGBA where no count is recorded):
    /// then alpha 0 and missing tiles are nodata; without, GDAL skipped writing tiles
    /// of zeros, and missing tiles read as zeros.
    pub(super) alpha: bool,
}

impl Bands {
    pub(super) fn of(band_count: Option<u32>) -> Self {
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
    pub(super) fn of_imagery(
        tiles: Vec<Tile>,
        decode: impl Fn(&Tile) -> std::result::Result<Picture, String> + Sync,
        bands: Bands,
        matrix: &TileMatrix,
        window: &Window,
    ) -> std::result::Result<Self, String> {
        let missing = if bands.alpha { f32::NAN } else { 0.0 };
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
        // Where GDAL recorded no band count, colour if any tile's header says colour.
        let colour = bands
            .colour
            .unwrap_or_else(|| tiles.par_iter().any(|tile| holds_colour(&tile.data)));
        let count = if colour { 3 } else { 1 };
        Raster::read(tiles, count, missing, matrix, window, decode, write)
    }

    /// The window's `bands` (holding `missing` where no tile is) from `tiles`, a row of
    /// tiles at a time in parallel, each tile decoded by `decode` and its pixels in the
    /// window given to `write` with the cell's band values: no tile is held decoded
    /// longer than its copy takes.
    pub(super) fn read(
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
pub(super) mod fixtures {
    use std::collections::HashMap;

    use super::*;

    pub(crate) type Decode = Box<dyn Fn(&Tile) -> std::result::Result<Picture, String> + Sync>;

    pub(crate) fn decoded(tiles: &[(Tile, Picture)]) -> (Vec<Tile>, Decode) {
        let pictures: HashMap<i64, Picture> =
            tiles.iter().map(|(t, p)| (t.id, p.clone())).collect();
        let stored = tiles.iter().map(|(t, _)| t.clone()).collect();
        (
            stored,
            Box::new(move |tile: &Tile| Ok(pictures[&tile.id].clone())),
        )
    }

    /// The first bytes of a grey 2 × 2 PNG: its signature and header chunk.
    pub(crate) fn grey_png_header() -> Vec<u8> {
        let mut bytes = PNG_SIGNATURE.to_vec();
        bytes.extend([0, 0, 0, 13]);
        bytes.extend(b"IHDR");
        bytes.extend([0, 0, 0, 2, 0, 0, 0, 2, 8, 0, 0, 0, 0]);
        bytes
    }

    /// Two grey 2 × 2 tiles of a 2 × 2 tile matrix, (0, 0) and (1, 1), and a 3 × 3
    /// window whose column 0 is the grid's column 1.
    pub(crate) fn two_grey_tiles() -> (TileMatrix, Window, [(Tile, Picture); 2]) {
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
        let tiles = [
            grey_tile(1, 0, 0, [1.0, 2.0, 3.0, 4.0]),
            grey_tile(2, 1, 1, [5.0, 6.0, 7.0, 8.0]),
        ];
        (m, w, tiles)
    }

    /// A grey 2 × 2 tile, stored as PNG (its header is all the reading looks at).
    pub(crate) fn grey_tile(id: i64, column: i64, row: i64, values: [f32; 4]) -> (Tile, Picture) {
        (
            Tile {
                id,
                column,
                row,
                stored_row: row,
                data: grey_png_header(),
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

    pub(crate) fn matrix() -> TileMatrix {
        TileMatrix {
            zoom: 3,
            columns: 2,
            rows: 2,
            tile: [256, 256],
            pixel: [30.0, 30.0],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::fixtures::*;
    use super::*;

    /// `tiles` read as the reader reads them, each decoded to its picture.
    fn imagery(tiles: &[(Tile, Picture)], bands: Bands, m: &TileMatrix, w: &Window) -> Raster {
        let (stored, decode) = decoded(tiles);
        Raster::of_imagery(stored, decode, bands, m, w).unwrap()
    }

    #[test]
    fn the_window_is_the_extent_snapped_to_the_tile_grid() {
        // GDAL's layout: the tile grid starts at the matrix set's north-west corner,
        // the raster at its contents' bounds.
        let w = Window::of(
            [500_000.0, 4_191_000.0, 512_510.0, 4_200_000.0],
            [500_000.0, 4_200_000.0],
            &matrix(),
        )
        .unwrap();
        assert_eq!((w.width, w.height, w.shift), (417, 300, [0, 0]));
        assert_eq!(w.tiles(&matrix()), [0, 1, 0, 1]);
        // A raster a tile and a bit in from the grid's corner.
        let w = Window::of(
            [507_690.0, 4_180_000.0, 508_590.0, 4_192_290.0],
            [500_000.0, 4_200_000.0],
            &matrix(),
        )
        .unwrap();
        assert_eq!((w.width, w.height, w.shift), (30, 410, [256, 257]));
        assert_eq!(w.tiles(&matrix()), [1, 1, 1, 1]);
        let empty = Window::of([0.0, 0.0, 10.0, 10.0], [0.0, 10.0], &matrix());
        assert!(empty.unwrap_err().contains("no cell"));
    }

    #[test]
    fn tiles_land_in_their_cells_and_missing_cells_hold_no_data() {
        let (m, w, tiles) = two_grey_tiles();
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
            stored_row: 0,
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
    fn colour_is_told_from_a_tiles_header() {
        let mut png = grey_png_header();
        assert!(!holds_colour(&png));
        for (kind, colour) in [(2, true), (3, true), (4, false), (6, true)] {
            png[25] = kind;
            assert_eq!(holds_colour(&png), colour, "colour type {kind}");
        }
        // SOI, an APP0 segment, then a baseline frame header of 1 or 3 components.
        let jpeg = |components: u8| {
            let mut bytes = vec![0xff, 0xd8, 0xff, 0xe0, 0, 4, 0, 0];
            bytes.extend([0xff, 0xc0, 0, 11, 8, 0, 16, 0, 16, components, 1, 0x11, 0]);
            bytes
        };
        assert!(!holds_colour(&jpeg(1)));
        assert!(holds_colour(&jpeg(3)));
        assert!(holds_colour(b"RIFF....WEBP"));
        assert!(holds_colour(&[0xff, 0xd8, 0xff]));
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
