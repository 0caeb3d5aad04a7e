//! PMTiles raster archives (`.pmtiles`, version 3): the single-file tile archives of
//! Protomaps, which `pmtiles convert` makes of an MBTiles package and rio-pmtiles writes
//! from any raster: PNG, JPEG or WebP tiles on the Web Mercator tile grid, found through
//! a directory of tile ids (a Hilbert curve's order within each zoom level). GDAL reads
//! no raster PMTiles, so the archive is read as GDAL's MBTiles driver reads the same
//! tiles: at the header's maximum zoom level, over its bounds (else the tiles' extent),
//! with the same layers and nodata as an MBTiles package (see `mbtiles`).
//!
//! Directories compressed with gzip or zstd are read, root and leaves; tiles stored
//! compressed are inflated. Vector tiles (MVT, MLT) are refused, as are AVIF tiles.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use super::FileOrder;
use super::mbtiles::{
    HALF_WORLD, MAX_ZOOM, degrees_to_extent, tile_range_extent, tiles_map, web_mercator_matrix,
};
use super::sqlite_tiles::{Tile, TileMatrix, Window, decode_image};
use crate::error::{Error, Result, open_input};
use crate::grid::Map;

/// The header's length and its first bytes.
const HEADER_LENGTH: usize = 127;
const MAGIC: &[u8; 7] = b"PMTiles";

/// Directories nest at most this deep (the root and three levels of leaves: the spec's
/// writers use one).
const MAX_DEPTH: usize = 4;

/// The most tiles whose places are looked at for an extent (where the header's bounds
/// cannot be used).
const MAX_TILES_SCANNED: u64 = 1 << 24;

/// The most a tile stored compressed may inflate to (an RGBA tile of 4096², far past
/// the 256 or 512 cells a side tiles have).
const MAX_TILE_BYTES: u64 = 1 << 26;

/// The most a directory may hold once inflated (a leaf of 4096 entries takes a few
/// tens of kilobytes; a damaged length is refused before it takes memory).
const MAX_DIRECTORY_BYTES: u64 = 1 << 28;

/// How a section of the archive is compressed (the header's codes).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Compression {
    None,
    Gzip,
    Zstd,
}

impl Compression {
    fn of(code: u8, what: &str) -> std::result::Result<Self, String> {
        match code {
            0 | 1 => Ok(Compression::None),
            2 => Ok(Compression::Gzip),
            4 => Ok(Compression::Zstd),
            3 => Err(format!(
                "its {what} are compressed with Brotli, which is not read here: convert it \
                 with gzip (pmtiles convert)"
            )),
            other => Err(format!(
                "its {what} have compression code {other}, not PMTiles'"
            )),
        }
    }

    fn inflate(self, bytes: Vec<u8>, limit: u64) -> std::result::Result<Vec<u8>, String> {
        let mut out = Vec::new();
        let read = match self {
            Compression::None => return Ok(bytes),
            Compression::Gzip => flate2::read::GzDecoder::new(bytes.as_slice())
                .take(limit + 1)
                .read_to_end(&mut out),
            Compression::Zstd => zstd::stream::read::Decoder::new(bytes.as_slice())
                .and_then(|d| d.take(limit + 1).read_to_end(&mut out)),
        };
        read.map_err(|e| format!("it does not inflate ({e})"))?;
        if out.len() as u64 > limit {
            return Err(format!("it inflates past {limit} bytes"));
        }
        Ok(out)
    }
}

/// What the header says.
#[derive(Debug, Clone, PartialEq)]
struct Header {
    root: [u64; 2],
    leaves: [u64; 2],
    tile_data: [u64; 2],
    internal: Compression,
    tiles: Compression,
    max_zoom: i64,
    /// West, south, east, north in degrees.
    bounds: [f64; 4],
}

fn header(bytes: &[u8]) -> std::result::Result<Header, String> {
    // Versions 1 and 2 begin "PM" and their version as two bytes.
    let old = match bytes {
        [b'P', b'M', version @ (1 | 2), 0, ..] => Some(*version),
        [b'P', b'M', b'T', b'i', b'l', b'e', b's', version, ..] if *version != 3 => Some(*version),
        _ => None,
    };
    if let Some(version) = old {
        return Err(format!(
            "it is a PMTiles archive of version {version}; version 3 is read (pmtiles \
             convert upgrades an older one)"
        ));
    }
    if bytes.len() < HEADER_LENGTH || &bytes[..7] != MAGIC {
        return Err("it is not a PMTiles archive (no PMTiles header)".into());
    }
    let u64_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap());
    let degrees_at =
        |at: usize| f64::from(i32::from_le_bytes(bytes[at..at + 4].try_into().unwrap())) / 1e7;
    match bytes[99] {
        0 | 2..=4 => {}
        1 | 6 => {
            return Err(
                "it holds vector tiles, not a raster: rasterize the layer wanted first".into(),
            );
        }
        5 => return Err("its tiles are AVIF images, which are not read here".into()),
        other => return Err(format!("its tile type {other} is not PMTiles'")),
    }
    Ok(Header {
        root: [u64_at(8), u64_at(16)],
        leaves: [u64_at(40), u64_at(48)],
        tile_data: [u64_at(56), u64_at(64)],
        internal: Compression::of(bytes[97], "directories")?,
        tiles: Compression::of(bytes[98], "tiles")?,
        max_zoom: i64::from(bytes[101]),
        bounds: [
            degrees_at(102),
            degrees_at(106),
            degrees_at(110),
            degrees_at(114),
        ],
    })
}

/// One directory entry: tiles `id` to `id + run - 1` all hold the bytes at `offset`
/// (from the tile data's start), or, where `run` is 0, a leaf directory at `offset`
/// from the leaf directories' start.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Entry {
    id: u64,
    offset: u64,
    length: u64,
    run: u64,
}

/// A directory's entries: a count, then delta-coded ids, runs, lengths and offsets
/// (0 for "right after the previous entry's bytes", else the offset plus 1), each a
/// varint.
fn directory(bytes: &[u8]) -> std::result::Result<Vec<Entry>, String> {
    let mut at = 0;
    let mut varint = || -> std::result::Result<u64, String> {
        let mut value = 0u64;
        for shift in (0..64).step_by(7) {
            let byte = *bytes.get(at).ok_or("it ends inside a number")?;
            at += 1;
            value |= u64::from(byte & 0x7f) << shift;
            if byte & 0x80 == 0 {
                return Ok(value);
            }
        }
        Err("a number runs past 64 bits".into())
    };
    let count = varint()?;
    // Each entry takes at least four bytes.
    if count > bytes.len() as u64 / 4 {
        return Err(format!(
            "it claims {count} entries in {} bytes",
            bytes.len()
        ));
    }
    let count = count as usize;
    let mut entries = vec![
        Entry {
            id: 0,
            offset: 0,
            length: 0,
            run: 0
        };
        count
    ];
    let mut id = 0u64;
    for entry in &mut entries {
        id = id.checked_add(varint()?).ok_or("its tile ids overflow")?;
        entry.id = id;
    }
    for entry in &mut entries {
        entry.run = varint()?;
    }
    for entry in &mut entries {
        entry.length = varint()?;
    }
    for i in 0..count {
        let coded = varint()?;
        entries[i].offset = match (i, coded) {
            (1.., 0) => entries[i - 1]
                .offset
                .checked_add(entries[i - 1].length)
                .ok_or("its offsets overflow")?,
            (0, 0) => return Err("its first entry has no offset".into()),
            _ => coded - 1,
        };
    }
    Ok(entries)
}

/// The tile id of column `x`, row `y` (from the north) at zoom level `z`: the tiles of
/// every level above, then the tile's place along the level's Hilbert curve.
fn tile_id(z: u32, mut x: u64, mut y: u64) -> u64 {
    let mut id = ((1u64 << (2 * z)) - 1) / 3;
    for level in (0..z).rev() {
        let side = 1u64 << level;
        let (rx, ry) = (x & side, y & side);
        id += ((3 * rx) ^ ry) << level;
        // Rotate the quadrant so that the curve continues (only the bits below `side`
        // count from here on, so the subtraction may wrap).
        if ry == 0 {
            if rx != 0 {
                x = (side - 1).wrapping_sub(x);
                y = (side - 1).wrapping_sub(y);
            }
            std::mem::swap(&mut x, &mut y);
        }
    }
    id
}

/// The zoom level, column and row of tile `id`.
fn tile_of_id(id: u64) -> (u32, u64, u64) {
    let z = (0..32u32)
        .take_while(|&z| ((1u64 << (2 * z)) - 1) / 3 <= id)
        .last()
        .unwrap_or(0);
    let mut position = id - ((1u64 << (2 * z)) - 1) / 3;
    let (mut x, mut y) = (0u64, 0u64);
    let mut side = 1u64;
    while side < 1u64 << z {
        let rx = (position / 2) & side;
        let ry = (position ^ rx) & side;
        if ry == 0 {
            if rx != 0 {
                x = side - 1 - x;
                y = side - 1 - y;
            }
            std::mem::swap(&mut x, &mut y);
        }
        x += rx;
        y += ry;
        position >>= 1;
        side <<= 1;
    }
    (z, x, y)
}

/// The archive: its file, header and every tile entry of its directories, by id.
struct Archive {
    file: File,
    header: Header,
    entries: Vec<Entry>,
}

impl Archive {
    fn open(path: &Path) -> Result<Self> {
        let problem = |message: String| Error::input(path, message);
        let mut file = open_input(path)?;
        let mut head = Vec::with_capacity(HEADER_LENGTH);
        (&mut file)
            .take(HEADER_LENGTH as u64)
            .read_to_end(&mut head)
            .map_err(|e| problem(e.to_string()))?;
        let header = header(&head).map_err(&problem)?;
        let mut archive = Archive {
            file,
            header,
            entries: Vec::new(),
        };
        let root = archive.header.root;
        let entries = archive
            .entries_at(root, 0)
            .map_err(|e| problem(format!("its root directory: {e}")))?;
        if !entries
            .windows(2)
            .all(|w| w[0].id.saturating_add(w[0].run) <= w[1].id)
        {
            return Err(problem("its directories' tile ids are not in order".into()));
        }
        archive.entries = entries;
        Ok(archive)
    }

    /// `length` bytes at `offset` in the file.
    fn bytes(&mut self, [offset, length]: [u64; 2]) -> std::result::Result<Vec<u8>, String> {
        let size = self.file.metadata().map_err(|e| e.to_string())?.len();
        if offset.checked_add(length).is_none_or(|end| end > size) {
            return Err(format!(
                "{length} bytes at {offset} lie past the file's end ({size} bytes)"
            ));
        }
        let mut bytes = vec![0u8; length as usize];
        self.file
            .seek(SeekFrom::Start(offset))
            .and_then(|_| self.file.read_exact(&mut bytes))
            .map_err(|e| e.to_string())?;
        Ok(bytes)
    }

    /// The tile entries of the directory at `range`, its leaves' entries in their place.
    fn entries_at(
        &mut self,
        range: [u64; 2],
        depth: usize,
    ) -> std::result::Result<Vec<Entry>, String> {
        if depth >= MAX_DEPTH {
            return Err(format!("its leaf directories nest deeper than {MAX_DEPTH}"));
        }
        let stored = self.bytes(range)?;
        let bytes = self.header.internal.inflate(stored, MAX_DIRECTORY_BYTES)?;
        let mut entries = Vec::new();
        for entry in directory(&bytes)? {
            if entry.run > 0 {
                entries.push(entry);
                continue;
            }
            let [leaves, leaves_length] = self.header.leaves;
            if entry
                .offset
                .checked_add(entry.length)
                .is_none_or(|end| end > leaves_length)
            {
                return Err(format!(
                    "a leaf directory at {} ({} bytes) lies outside the leaf directories",
                    entry.offset, entry.length
                ));
            }
            let leaf = self
                .entries_at([leaves + entry.offset, entry.length], depth + 1)
                .map_err(|e| format!("its leaf directory for tiles from id {}: {e}", entry.id))?;
            entries.extend(leaf);
        }
        Ok(entries)
    }

    /// The entry holding tile `id`, if any.
    fn entry(&self, id: u64) -> Option<Entry> {
        let after = self.entries.partition_point(|e| e.id <= id);
        let entry = *self.entries.get(after.checked_sub(1)?)?;
        (id - entry.id < entry.run).then_some(entry)
    }

    /// Tile `entry`'s image, as stored (inflated where the tiles are compressed).
    fn tile_bytes(&mut self, entry: Entry) -> std::result::Result<Vec<u8>, String> {
        let [data, data_length] = self.header.tile_data;
        if entry
            .offset
            .checked_add(entry.length)
            .is_none_or(|end| end > data_length)
        {
            return Err(format!(
                "{} bytes at {} lie outside the tile data",
                entry.length, entry.offset
            ));
        }
        let stored = self.bytes([data + entry.offset, entry.length])?;
        self.header.tiles.inflate(stored, MAX_TILE_BYTES)
    }

    /// The extent of the tiles zoom level `zoom` holds, in Web Mercator metres, as
    /// GDAL computes an MBTiles package's; `None` where it holds none or runs of more
    /// than `MAX_TILES_SCANNED` tiles.
    fn tiles_extent(&self, zoom: u32) -> Option<[f64; 4]> {
        let (first, next) = (tile_id(zoom, 0, 0), tile_id(zoom + 1, 0, 0));
        let mut range: Option<[u64; 4]> = None;
        let mut scanned = 0u64;
        let at_zoom = |e: &&Entry| e.id < next && e.id.saturating_add(e.run) > first;
        for entry in self.entries.iter().filter(at_zoom) {
            let ids = entry.id.max(first)..entry.id.saturating_add(entry.run).min(next);
            scanned += ids.end - ids.start;
            if scanned > MAX_TILES_SCANNED {
                return None;
            }
            for id in ids {
                let (_, x, y) = tile_of_id(id);
                let r = range.get_or_insert([x, x, y, y]);
                *r = [r[0].min(x), r[1].max(x), r[2].min(y), r[3].max(y)];
            }
        }
        let [west, east, north, south] = range?;
        // MBTiles' rows, from the south.
        let last_row = (1u64 << zoom) - 1;
        let tiles = [west, east, last_row - south, last_row - north].map(|t| t as i64);
        Some(tile_range_extent(i64::from(zoom), tiles))
    }
}

/// The PMTiles archive at `path` as map `name`, with whether its rows ran from the
/// north (always).
pub fn read_pmtiles_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let mut archive = Archive::open(path)?;
    let zoom = archive.header.max_zoom;
    if zoom > MAX_ZOOM {
        return Err(problem(format!(
            "its zoom level {zoom} is deeper than the {MAX_ZOOM} read here"
        )));
    }
    let z = zoom as u32;
    let extent = match degrees_to_extent(archive.header.bounds) {
        Some(extent) => extent,
        None => archive.tiles_extent(z).ok_or_else(|| {
            problem(format!(
                "its header's bounds {:?} are not longitudes and latitudes GDAL takes, and \
                     its tiles at zoom level {zoom} give no extent (none, or more than \
                     {MAX_TILES_SCANNED} to look at)",
                archive.header.bounds
            ))
        })?,
    };
    let matrix = tile_matrix(&mut archive, z).map_err(&problem)?;
    let window = Window::of(extent, [-HALF_WORLD, HALF_WORLD], &matrix).map_err(&problem)?;
    let [first_column, last_column, first_row, last_row] = window.tiles(&matrix);
    let mut tiles = Vec::new();
    for row in first_row..=last_row {
        for column in first_column..=last_column {
            let Some(entry) = archive.entry(tile_id(z, column as u64, row as u64)) else {
                continue;
            };
            let data = archive.tile_bytes(entry).map_err(|e| {
                problem(format!(
                    "its tile at zoom level {zoom}, column {column}, row {row}: {e}"
                ))
            })?;
            tiles.push(Tile {
                id: 0,
                column,
                row,
                stored_row: row,
                data,
            });
        }
    }
    tiles_map(path, name, extent, &matrix, &window, tiles)
}

/// Zoom level `z`'s tile matrix, its tiles as wide as its first tile.
fn tile_matrix(archive: &mut Archive, z: u32) -> std::result::Result<TileMatrix, String> {
    let first = tile_id(z, 0, 0);
    let entry = archive
        .entries
        .iter()
        .find(|e| e.id.saturating_add(e.run) > first && e.id < tile_id(z + 1, 0, 0))
        .copied()
        .ok_or_else(|| format!("it holds no tile at zoom level {z}"))?;
    let picture = archive
        .tile_bytes(entry)
        .and_then(|bytes| decode_image(&bytes, false))
        .map_err(|e| format!("its tile {} at zoom level {z}: {e}", entry.id.max(first)))?;
    web_mercator_matrix(i64::from(z), picture.width, picture.height)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tile_ids_follow_the_hilbert_curve_level_by_level() {
        // The spec's examples: level 0 is id 0; level 1 starts at 1 and turns
        // (0,0), (0,1), (1,1), (1,0).
        assert_eq!(tile_id(0, 0, 0), 0);
        let level_one: Vec<u64> = [(0, 0), (0, 1), (1, 1), (1, 0)]
            .iter()
            .map(|&(x, y)| tile_id(1, x, y))
            .collect();
        assert_eq!(level_one, [1, 2, 3, 4]);
        assert_eq!(tile_id(2, 0, 0), 5);
        for z in [0u32, 1, 2, 5, 12, 20] {
            for (x, y) in [
                (0u64, 0u64),
                (1, 0),
                (3, 2),
                (1000, 77),
                (u64::MAX, u64::MAX),
            ] {
                let (x, y) = (x % (1 << z), y % (1 << z));
                assert_eq!(tile_of_id(tile_id(z, x, y)), (z, x, y));
            }
        }
    }

    #[test]
    fn directories_decode_runs_lengths_and_offsets() {
        // Two entries: ids 5 and 7, runs 1 and 3, lengths 100 and 40, offsets 0 then
        // "right after".
        let bytes = [2, 5, 2, 1, 3, 100, 40, 1, 0];
        let entries = directory(&bytes).unwrap();
        assert_eq!(
            entries,
            [
                Entry {
                    id: 5,
                    offset: 0,
                    length: 100,
                    run: 1
                },
                Entry {
                    id: 7,
                    offset: 100,
                    length: 40,
                    run: 3
                },
            ]
        );
        assert!(
            directory(&[200, 1])
                .unwrap_err()
                .contains("claims 200 entries")
        );
        assert!(
            directory(&[1, 0x80, 0x80, 0x80])
                .unwrap_err()
                .contains("ends inside")
        );
        assert!(
            directory(&[1, 0, 1, 1, 0])
                .unwrap_err()
                .contains("no offset")
        );
    }

    #[test]
    fn headers_name_what_is_not_read() {
        let mut bytes = vec![0u8; HEADER_LENGTH];
        bytes[..7].copy_from_slice(MAGIC);
        bytes[7] = 3;
        bytes[97] = 2;
        bytes[99] = 2;
        bytes[101] = 14;
        assert_eq!(header(&bytes).unwrap().max_zoom, 14);
        bytes[99] = 1;
        assert!(header(&bytes).unwrap_err().contains("vector tiles"));
        bytes[99] = 2;
        bytes[97] = 3;
        assert!(header(&bytes).unwrap_err().contains("Brotli"));
        bytes[7] = 4;
        assert!(header(&bytes).unwrap_err().contains("version 4"));
        assert!(header(b"PM\x02\x00....").unwrap_err().contains("version 2"));
        assert!(header(b"PMTiles").unwrap_err().contains("not a PMTiles"));
    }
}
