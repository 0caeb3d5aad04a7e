//! Golden Software Surfer grids (`.grd`), as geologists' and hydrologists' tools export
//! them and GDAL's GSAG, GSBG and GS7BG drivers write them: ASCII (`DSAA`), Surfer 6
//! binary (`DSBB`, float32) and Surfer 7 binary (`DSRB`, float64 in tagged sections).
//! A grid gives its node count, the coordinates of its first and last nodes (cell
//! centres) and its values row by row from the south; nodes at or above the blanking
//! value (1.70141e38) are nodata. The CRS comes from the `.prj` or GDAL's sidecar.

use std::path::Path;

use super::FileOrder;
use super::MAX_MAP_CELLS;
use super::ascii_grid::crs_keys;
use super::geotiff::{Georeferencing, georeference};
use super::sidecar_bands::{self, FileMasks, Samples};
use crate::error::{Error, Result, read_input};
use crate::grid::Map;

/// Surfer's blanking value: a node at or above it holds no data.
const BLANK: f64 = 1.70141e38;

/// Whether the file at `path` opens as a Surfer grid does (a `.grd` may be GMT's
/// netCDF instead).
pub fn is_surfer(path: &Path) -> bool {
    let mut tag = [0u8; 4];
    std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut tag))
        .is_ok_and(|()| [b"DSAA", b"DSBB", b"DSRB"].contains(&&tag))
}

/// A grid as its file gives it.
#[derive(Debug, Clone, PartialEq)]
struct Grid {
    columns: usize,
    rows: usize,
    /// The first node's (south-west) coordinates and the spacing between nodes.
    first: [f64; 2],
    step: [f64; 2],
    /// Row by row from the south; NaN where blanked.
    values: Vec<f32>,
}

/// The grid's node counts, checked against the map's bounds.
fn counts(columns: f64, rows: f64) -> std::result::Result<(usize, usize), String> {
    let whole = |n: f64| n.fract() == 0.0 && (2.0..=f64::from(u32::MAX)).contains(&n);
    if !whole(columns) || !whole(rows) {
        return Err(format!(
            "its grid is {columns} × {rows} nodes; a grid needs two or more each way"
        ));
    }
    let (columns, rows) = (columns as usize, rows as usize);
    if columns.saturating_mul(rows) > MAX_MAP_CELLS {
        return Err(format!(
            "its {columns} × {rows} nodes are more than the {MAX_MAP_CELLS} a map may hold: \
             clip it to the site first"
        ));
    }
    Ok((columns, rows))
}

/// The spacing between `n` nodes from `low` to `high`.
fn spacing(low: f64, high: f64, n: usize, axis: &str) -> std::result::Result<f64, String> {
    let step = (high - low) / (n - 1) as f64;
    if step.is_finite() && step > 0.0 {
        Ok(step)
    } else {
        Err(format!("its {axis} range {low} to {high} does not grow"))
    }
}

/// A blanked node as NaN.
fn unblanked(value: f64, blanked: impl Fn(f64) -> bool) -> f32 {
    if blanked(value) || !value.is_finite() {
        f32::NAN
    } else {
        value as f32
    }
}

/// An ASCII grid (`DSAA`): its header lines, then every node's value.
fn ascii(bytes: &[u8]) -> std::result::Result<Grid, String> {
    let text = std::str::from_utf8(bytes).map_err(|_| "it is not text".to_string())?;
    let mut words = text.split_ascii_whitespace().skip(1);
    let mut number = |what: &str| -> std::result::Result<f64, String> {
        let word = words
            .next()
            .ok_or_else(|| format!("it ends before its {what}"))?;
        word.parse::<f64>()
            .map_err(|_| format!("its {what} '{word}' is not a number"))
    };
    let (columns, rows) = counts(number("column count")?, number("row count")?)?;
    let (x_low, x_high) = (number("lowest x")?, number("highest x")?);
    let (y_low, y_high) = (number("lowest y")?, number("highest y")?);
    let _z_range = (number("lowest z")?, number("highest z")?);
    let step = [
        spacing(x_low, x_high, columns, "x")?,
        spacing(y_low, y_high, rows, "y")?,
    ];
    let values = (0..columns * rows)
        .map(|i| number(&format!("node {i}")).map(|v| unblanked(v, |v| v >= BLANK)))
        .collect::<std::result::Result<_, _>>()?;
    Ok(Grid {
        columns,
        rows,
        first: [x_low, y_low],
        step,
        values,
    })
}

/// Little-endian reads at offsets, an error naming what ran past the end.
struct Bytes<'a>(&'a [u8]);

impl Bytes<'_> {
    fn take<const N: usize>(&self, at: usize, what: &str) -> std::result::Result<[u8; N], String> {
        at.checked_add(N)
            .and_then(|end| self.0.get(at..end))
            .map(|b| b.try_into().unwrap_or([0; N]))
            .ok_or_else(|| format!("it ends before its {what} (byte {at})"))
    }
    fn i16(&self, at: usize, what: &str) -> std::result::Result<i16, String> {
        self.take(at, what).map(i16::from_le_bytes)
    }
    fn i32(&self, at: usize, what: &str) -> std::result::Result<i32, String> {
        self.take(at, what).map(i32::from_le_bytes)
    }
    fn f64(&self, at: usize, what: &str) -> std::result::Result<f64, String> {
        self.take(at, what).map(f64::from_le_bytes)
    }
    /// `n` values of `SIZE` bytes from `at`, as `decode` reads each.
    fn values<const SIZE: usize>(
        &self,
        at: usize,
        n: usize,
        decode: impl Fn([u8; SIZE]) -> f64,
        blanked: impl Fn(f64) -> bool,
    ) -> std::result::Result<Vec<f32>, String> {
        let data = n
            .checked_mul(SIZE)
            .and_then(|len| at.checked_add(len))
            .and_then(|end| self.0.get(at..end))
            .ok_or_else(|| format!("it ends before its {n} nodes' values"))?;
        Ok(data
            .chunks_exact(SIZE)
            .map(|c| unblanked(decode(c.try_into().unwrap_or([0; SIZE])), &blanked))
            .collect())
    }
}

/// A Surfer 6 binary grid (`DSBB`): counts as int16, ranges as float64, float32 nodes.
fn surfer6(bytes: &[u8]) -> std::result::Result<Grid, String> {
    let b = Bytes(bytes);
    let (columns, rows) = counts(
        f64::from(b.i16(4, "column count")?),
        f64::from(b.i16(6, "row count")?),
    )?;
    let range = |i: usize, what: &str| b.f64(8 + 8 * i, what);
    let (x_low, x_high) = (range(0, "lowest x")?, range(1, "highest x")?);
    let (y_low, y_high) = (range(2, "lowest y")?, range(3, "highest y")?);
    let step = [
        spacing(x_low, x_high, columns, "x")?,
        spacing(y_low, y_high, rows, "y")?,
    ];
    let values = b.values(
        56,
        columns * rows,
        |v| f64::from(f32::from_le_bytes(v)),
        |v| v >= f64::from(BLANK as f32),
    )?;
    Ok(Grid {
        columns,
        rows,
        first: [x_low, y_low],
        step,
        values,
    })
}

/// A Surfer 7 binary grid (`DSRB`): tagged sections, of which `GRID` gives the layout
/// and `DATA` the float64 nodes; others (faults) are skipped.
fn surfer7(bytes: &[u8]) -> std::result::Result<Grid, String> {
    let b = Bytes(bytes);
    let version = b.i32(8, "version")?;
    let mut at = 8 + b.i32(4, "header size")?.max(0) as usize;
    // The GRID section's layout (its values empty) and blanking value.
    let mut layout: Option<(Grid, f64)> = None;
    loop {
        let tag: [u8; 4] = b.take(at, "next section")?;
        let size = b.i32(at + 4, "section size")?;
        let size = usize::try_from(size)
            .map_err(|_| format!("its section at byte {at} has size {size}"))?;
        let body = at + 8;
        match &tag {
            b"GRID" => {
                let rows = f64::from(b.i32(body, "row count")?);
                let (columns, rows) = counts(f64::from(b.i32(body + 4, "column count")?), rows)?;
                let f = |i: usize, what: &str| b.f64(body + 8 + 8 * i, what);
                let first = [f(0, "lowest x")?, f(1, "lowest y")?];
                let step = [f(2, "x spacing")?, f(3, "y spacing")?];
                if !(step[0] > 0.0 && step[1] > 0.0 && step.iter().all(|s| s.is_finite())) {
                    return Err(format!(
                        "its node spacing {} × {} does not grow",
                        step[0], step[1]
                    ));
                }
                let rotation = f(6, "rotation")?;
                if rotation != 0.0 {
                    return Err(format!(
                        "its grid is rotated by {rotation}°; only axis-aligned rasters are \
                         supported: warp it first (gdalwarp)"
                    ));
                }
                let grid = Grid {
                    columns,
                    rows,
                    first,
                    step,
                    values: Vec::new(),
                };
                layout = Some((grid, f(7, "blanking value")?));
            }
            b"DATA" => {
                let (grid, blank) =
                    layout.ok_or("its DATA section comes before its GRID section")?;
                // Version 1 blanks every node at or above the blanking value, version 2
                // only nodes equal to it.
                let blanked = move |v: f64| if version >= 2 { v == blank } else { v >= blank };
                let n = grid.columns * grid.rows;
                let values = b.values(body, n, f64::from_le_bytes, blanked)?;
                return Ok(Grid { values, ..grid });
            }
            _ => {}
        }
        at = body
            .checked_add(size)
            .ok_or_else(|| format!("its section at byte {at} runs past any file"))?;
    }
}

/// The Surfer grid at `path` as map `name`, with whether its rows ran from the north
/// (never: Surfer's run from the south).
pub fn read_surfer_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let bytes = read_input(path)?;
    let grid = match bytes.get(..4) {
        Some(b"DSAA") => ascii(&bytes),
        Some(b"DSBB") => surfer6(&bytes),
        Some(b"DSRB") => surfer7(&bytes),
        _ => Err("it is neither a Surfer grid (DSAA, DSBB, DSRB) nor a netCDF grid (GMT's)".into()),
    }
    .map_err(&problem)?;
    let (keys, ascii) = crs_keys(path).map_err(&problem)?;
    let [dx, dy] = grid.step;
    let transform = [
        dx,
        0.0,
        grid.first[0] - dx / 2.0,
        0.0,
        dy,
        grid.first[1] - dy / 2.0,
    ];
    let (geo, heights) = georeference(
        path,
        grid.columns as u32,
        grid.rows as u32,
        Georeferencing::of_grid(transform, &keys, ascii),
    )?;
    let samples = Samples {
        width: grid.columns as u32,
        height: grid.rows as u32,
        bands: 1,
        order: FileOrder::rows(false),
        heights,
        sample: |_band: usize, cell: usize| grid.values[cell],
    };
    sidecar_bands::map(path, name, geo, samples, &FileMasks::default())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn surfer7_file(version: i32, rotation: f64) -> Vec<u8> {
        let mut bytes = b"DSRB".to_vec();
        bytes.extend(4i32.to_le_bytes());
        bytes.extend(version.to_le_bytes());
        bytes.extend(b"GRID");
        bytes.extend(72i32.to_le_bytes());
        bytes.extend(2i32.to_le_bytes()); // rows
        bytes.extend(3i32.to_le_bytes()); // columns
        for v in [10.0, 20.0, 2.0, 5.0, 0.0, 9.0, rotation, BLANK] {
            bytes.extend(f64::to_le_bytes(v));
        }
        bytes.extend(b"FLTI");
        bytes.extend(4i32.to_le_bytes());
        bytes.extend([0u8; 4]);
        bytes.extend(b"DATA");
        bytes.extend(48i32.to_le_bytes());
        for v in [1.0, 2.0, 3.0, 4.0, 2e38, BLANK] {
            bytes.extend(f64::to_le_bytes(v));
        }
        bytes
    }

    #[test]
    fn the_three_kinds_read_their_nodes_from_the_south() {
        let text = b"DSAA\n3 2\n10 14\n20 25\n0 9\n1 2 3\n4 1.70141e+38 6\n";
        let grid = ascii(text).unwrap();
        assert_eq!((grid.columns, grid.rows), (3, 2));
        assert_eq!((grid.first, grid.step), ([10.0, 20.0], [2.0, 5.0]));
        assert!(grid.values[4].is_nan());
        assert_eq!(grid.values[5], 6.0);

        let mut six = b"DSBB".to_vec();
        six.extend(3i16.to_le_bytes());
        six.extend(2i16.to_le_bytes());
        for v in [10.0, 14.0, 20.0, 25.0, 0.0, 9.0] {
            six.extend(f64::to_le_bytes(v));
        }
        for v in [1f32, 2.0, 3.0, 4.0, BLANK as f32, 6.0] {
            six.extend(v.to_le_bytes());
        }
        assert_eq!(surfer6(&six).unwrap().values[..4], grid.values[..4]);
        assert!(surfer6(&six).unwrap().values[4].is_nan());

        // Version 1 blanks at or above the value, version 2 only at it.
        let one = surfer7(&surfer7_file(1, 0.0)).unwrap();
        assert_eq!((one.columns, one.rows, one.first), (3, 2, [10.0, 20.0]));
        assert!(one.values[4].is_nan() && one.values[5].is_nan());
        let two = surfer7(&surfer7_file(2, 0.0)).unwrap();
        assert_eq!(two.values[4], 2e38);
        assert!(
            surfer7(&surfer7_file(1, 30.0))
                .unwrap_err()
                .contains("rotated")
        );
        assert!(
            ascii(b"DSAA\n3 2\n10 14\n20 25\n0 9\n1 2 3\n")
                .unwrap_err()
                .contains("node 3")
        );
        assert!(ascii(b"DSAA\n1 2\n10 14\n").unwrap_err().contains("1 × 2"));
    }

    proptest::proptest! {
        /// Any bytes after a Surfer tag read or are refused with an error: never a panic.
        #[test]
        fn damaged_grids_read_or_are_refused(
            cut in 0usize..200,
            at in 0usize..200,
            byte in proptest::num::u8::ANY,
        ) {
            let mut bytes = surfer7_file(1, 0.0);
            if at < bytes.len() {
                bytes[at] = byte;
            }
            bytes.truncate(cut.max(4));
            let _ = surfer7(&bytes);
            let _ = surfer6(&bytes);
            let _ = ascii(&bytes);
        }
    }
}
