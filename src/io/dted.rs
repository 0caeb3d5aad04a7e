//! DTED tiles (`.dt0`, `.dt1`, `.dt2`): the Digital Terrain Elevation Data format of
//! NGA, in which USGS EarthExplorer also hands out SRTM. A tile is 1° of heights in
//! metres on WGS 84: an 80-byte user header label (`UHL1`: the south-west post's
//! longitude and latitude as `DDDMMSSH`, the posts' spacing in tenths of an arc-second,
//! the number of columns and of posts a column), a data set identification and an
//! accuracy record, then one record a column from west to east, each a sentinel (0xAA),
//! counts, the column's heights from south to north (big-endian, sign and magnitude)
//! and a checksum. Posts are cell centres, as GDAL reads them; -32767 is no data.

use std::path::Path;

use super::geotiff::{Georeferencing, georeference};
use super::hgt::WGS84_KEYS;
use crate::error::{Error, Result, read_input};
use crate::grid::{Layer, Map};

/// The lengths of the user header label, the data set identification and the accuracy
/// description records that precede the columns.
const UHL_LEN: usize = 80;
const DSI_LEN: usize = 648;
const ACC_LEN: usize = 2700;
/// A column record's bytes besides its heights: sentinel, block count, longitude and
/// latitude counts, and checksum.
const RECORD_OVERHEAD: usize = 12;
const SENTINEL: u8 = 0xaa;
/// DTED's no-data height, as GDAL gives it.
const VOID: f32 = -32767.0;

/// What the user header label gives.
#[derive(Debug, PartialEq)]
struct Header {
    /// Where the label starts (after any tape volume and header labels).
    at: usize,
    /// The south-west post's longitude and latitude, in degrees.
    origin: (f64, f64),
    /// The spacing of posts along a row and along a column, in degrees.
    spacing: (f64, f64),
    columns: usize,
    rows: usize,
}

/// The DTED tile at `path` as map `name`, its one layer `elevation`.
pub fn read_dted(path: &Path, name: &str) -> Result<Map> {
    let problem = |message: String| Error::input(path, message);
    let bytes = read_input(path)?;
    let header = read_header(&bytes).map_err(problem)?;
    let Header {
        at,
        origin: (west_post, south_post),
        spacing: (dx, dy),
        columns,
        rows,
    } = header;
    let record = RECORD_OVERHEAD + 2 * rows;
    let first = at + UHL_LEN + DSI_LEN + ACC_LEN;
    let needed = columns
        .checked_mul(record)
        .and_then(|n| n.checked_add(first))
        .ok_or_else(|| problem("its header's size overflows memory".into()))?;
    if bytes.len() < needed {
        return Err(problem(format!(
            "holds {} bytes; its {columns} columns of {rows} posts need {needed}",
            bytes.len()
        )));
    }
    // Ours run row by row from the south, as the columns' heights do.
    let mut values = vec![f32::NAN; columns * rows];
    for column in 0..columns {
        let start = first + column * record;
        if bytes[start] != SENTINEL {
            return Err(problem(format!(
                "column {column} (byte {start}) does not start with DTED's sentinel 0xAA"
            )));
        }
        let heights = &bytes[start + 8..start + 8 + 2 * rows];
        for (row, pair) in heights.chunks_exact(2).enumerate() {
            let raw = u16::from_be_bytes([pair[0], pair[1]]);
            // Sign and magnitude, as the standard has it.
            let height = if raw & 0x8000 != 0 {
                -f32::from(raw & 0x7fff)
            } else {
                f32::from(raw)
            };
            if height != VOID {
                values[row * columns + column] = height;
            }
        }
    }
    // Posts are centres: the grid reaches half a spacing past them. North up, as GDAL
    // presents the tile (its rows, which a VRT's windows count, run from the north).
    let transform = [
        dx,
        0.0,
        west_post - dx / 2.0,
        0.0,
        -dy,
        south_post - dy / 2.0 + rows as f64 * dy,
    ];
    let (geo, heights) = georeference(
        path,
        columns as u32,
        rows as u32,
        Georeferencing::of_grid(transform, &WGS84_KEYS, String::new()),
    )?;
    debug_assert_eq!(heights, 1.0);
    if values.iter().all(|v| v.is_nan()) {
        return Err(problem("every post is void (-32767)".into()));
    }
    Ok(Map {
        name: name.to_string(),
        geo,
        layers: vec![Layer::new("elevation", values)],
    })
}

/// The user header label, found where GDAL looks for it: at the start, or after tape
/// labels (`VOL`, `HDR`) of 80 bytes each.
fn read_header(bytes: &[u8]) -> std::result::Result<Header, String> {
    let at = (0..4)
        .map(|i| i * UHL_LEN)
        .find(|&at| bytes.get(at..at + 3) == Some(b"UHL"))
        .ok_or("not a DTED tile: no user header label (UHL) in its first 320 bytes")?;
    let label = bytes
        .get(at..at + UHL_LEN)
        .ok_or("its user header label is cut short")?;
    let text = |range: std::ops::Range<usize>| {
        std::str::from_utf8(&label[range.clone()])
            .map_err(|_| format!("its user header label's bytes {range:?} are not text"))
    };
    let origin = (
        angle(text(4..12)?).map_err(|e| format!("its origin's longitude: {e}"))?,
        angle(text(12..20)?).map_err(|e| format!("its origin's latitude: {e}"))?,
    );
    let number = |range: std::ops::Range<usize>, what: &str| {
        let digits = text(range)?.trim();
        digits
            .parse::<usize>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("its {what} is '{digits}', not a positive whole number"))
    };
    let tenths = |n: usize| n as f64 / 36_000.0;
    let spacing = (
        tenths(number(20..24, "longitude interval")?),
        tenths(number(24..28, "latitude interval")?),
    );
    Ok(Header {
        at,
        origin,
        spacing,
        columns: number(47..51, "number of longitude lines")?,
        rows: number(51..55, "number of latitude points")?,
    })
}

/// An angle written `DDDMMSSH` (degrees, minutes, seconds, hemisphere), in degrees.
fn angle(text: &str) -> std::result::Result<f64, String> {
    let bad = || format!("'{text}' is not DDDMMSSH");
    let (digits, hemisphere) = text.split_at_checked(7).ok_or_else(bad)?;
    if !digits.bytes().all(|b| b.is_ascii_digit()) {
        return Err(bad());
    }
    let part = |range: std::ops::Range<usize>| digits[range].parse::<f64>().map_err(|_| bad());
    let degrees = part(0..3)? + part(3..5)? / 60.0 + part(5..7)? / 3600.0;
    match hemisphere {
        "N" | "E" => Ok(degrees),
        "S" | "W" => Ok(-degrees),
        _ => Err(bad()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn label(origin: &str, intervals: &str, counts: &str) -> Vec<u8> {
        let mut uhl = format!("UHL1{origin}{intervals}NA  U              {counts}");
        uhl.push_str(&" ".repeat(UHL_LEN - uhl.len()));
        uhl.into_bytes()
    }

    #[test]
    fn the_label_gives_the_south_west_post_the_spacing_and_the_size() {
        let uhl = label("0070000E0460000N", "03000300", "01210121");
        let header = read_header(&uhl).unwrap();
        assert_eq!(header.origin, (7.0, 46.0));
        assert_eq!(header.spacing, (30.0 / 3600.0, 30.0 / 3600.0));
        assert_eq!((header.columns, header.rows), (121, 121));
        // After a tape's volume label.
        let mut taped = vec![b' '; 80];
        taped[..3].copy_from_slice(b"VOL");
        taped.extend(label("1213000W0123000S", "00100010", "36013601"));
        let header = read_header(&taped).unwrap();
        assert_eq!(header.at, 80);
        assert_eq!(header.origin, (-121.5, -12.5));
    }

    #[test]
    fn broken_labels_are_explained() {
        assert!(
            read_header(b"not dted")
                .unwrap_err()
                .contains("no user header label")
        );
        let bad = label("0070000X0460000N", "03000300", "01210121");
        assert!(read_header(&bad).unwrap_err().contains("longitude"));
        let zero = label("0070000E0460000N", "00000300", "01210121");
        assert!(
            read_header(&zero)
                .unwrap_err()
                .contains("longitude interval")
        );
    }

    proptest::proptest! {
        /// A label of any size over a body of any bytes reads or is refused with an
        /// error: never a panic.
        #[test]
        fn any_label_over_any_body_reads_or_is_refused(
            columns in 1usize..40,
            rows in 1usize..40,
            body in proptest::collection::vec(proptest::num::u8::ANY, 0..4000),
        ) {
            let mut file = label("0070000E0460000N", "03000300", &format!("{columns:04}{rows:04}"));
            file.extend(body);
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("n46.dt0");
            std::fs::write(&path, &file).unwrap();
            let _ = read_dted(&path, "n46");
        }
    }
}
