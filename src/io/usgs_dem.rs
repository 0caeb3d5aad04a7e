//! USGS ASCII DEMs (`.dem`): the 7.5- and 15-minute quadrangle DEMs (and 1-degree DEMs)
//! the USGS handed out until The National Map, still in archives, course material and
//! state clearinghouses, and what GDAL's USGSDEM driver writes. Read as GDAL reads them:
//!
//! - record A (the first 1,024 characters) gives the planimetric system (geographic in
//!   arc-seconds, or UTM and its zone), the horizontal datum (NAD27, WGS 84, NAD83), the
//!   units of heights (feet or metres), the spacing of the nodes, the quadrangle's
//!   corners and the number of profiles;
//! - each record B is one profile, a column of nodes from south to north: its first
//!   node's position, its count, a datum elevation added to each, then the heights in
//!   units of the z resolution; -32767 is void;
//! - the grid: one column per profile from the quadrangle's west corner, rows from its
//!   corners (in UTM, widened to whole nodes), nodes at cell centres.
//!
//! Fields are Fortran's fixed-width integers (read as tokens, as GDAL reads them) and
//! `D`-exponent reals. State Plane and other systems, and datums other than those three,
//! are refused by name.

use std::path::Path;

use super::geotiff::{Georeferencing, georeference};
use super::named_crs::{self, Named};
use crate::error::{Error, Result, read_input};
use crate::grid::{Layer, Map};

/// Record A's length, and where its fields start (0-based; the standard counts from 1).
const RECORD: usize = 1024;
const PATTERN_AT: usize = 150;
const SYSTEM_AT: usize = 156;
const UNITS_AT: usize = 528;
const CORNERS_AT: usize = 546;
const RESOLUTION_AT: usize = 816;
const PROFILES_AT: usize = 858;
const OLD_DATA_AT: usize = 864;
const DATUM_AT: usize = 890;
/// Where some files' first profile starts (GDAL's "undocumented format").
const ODD_DATA_AT: usize = 893;
/// A void node.
const VOID: i64 = -32767;

/// Whether `bytes` start with a USGS DEM's record A, as GDAL identifies one: an
/// elevation pattern of 1 or 4 and a planimetric system of 0 to 3 (or -9999).
pub fn is_usgs_dem_header(bytes: &[u8]) -> bool {
    let field = |at: usize| bytes.get(at..at + 6);
    matches!(field(PATTERN_AT), Some(b"     1" | b"     4"))
        && matches!(
            field(SYSTEM_AT),
            Some(b"     0" | b"     1" | b"     2" | b"     3" | b" -9999")
        )
}

/// Whether the file at `path` is a USGS DEM (else a `.dem` is GTOPO30's raw tile
/// beside its `.hdr`).
pub fn is_usgs_dem(path: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 200];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| is_usgs_dem_header(&head))
}

/// A cursor over the text: integers as whitespace-separated tokens, reals as fixed
/// fields.
struct Cursor<'a> {
    text: &'a [u8],
    at: usize,
}

impl Cursor<'_> {
    /// The next integer: spaces skipped, then a sign and digits (the next field's sign
    /// ends it, as Fortran's fields abut).
    fn int(&mut self) -> Option<i64> {
        while self.text.get(self.at)?.is_ascii_whitespace() {
            self.at += 1;
        }
        let start = self.at;
        if matches!(self.text.get(self.at), Some(b'-' | b'+')) {
            self.at += 1;
        }
        while self.text.get(self.at).is_some_and(u8::is_ascii_digit) {
            self.at += 1;
        }
        std::str::from_utf8(&self.text[start..self.at])
            .ok()?
            .parse()
            .ok()
    }

    /// The real in the next `width` characters (`D` or `E` exponent).
    fn real(&mut self, width: usize) -> Option<f64> {
        let field = self.text.get(self.at..self.at + width)?;
        self.at += width;
        let text = std::str::from_utf8(field)
            .ok()?
            .trim()
            .replace(['D', 'd'], "E");
        text.parse().ok().filter(|v: &f64| v.is_finite())
    }
}

/// Record A's fields the grid needs.
struct Header {
    geographic: bool,
    zone: i64,
    feet: bool,
    corners: [[f64; 2]; 4],
    resolution: [f64; 3],
    profiles: usize,
    datum: i64,
    data_at: usize,
}

fn read_header(text: &[u8]) -> std::result::Result<Header, String> {
    let cut = || "its record A is cut short".to_string();
    let at = |at: usize| Cursor { text, at };
    let mut system = at(SYSTEM_AT);
    let (system_code, zone) = (system.int().ok_or_else(cut)?, system.int().ok_or_else(cut)?);
    let mut units = at(UNITS_AT);
    let (ground_units, height_units) = (units.int().ok_or_else(cut)?, units.int().ok_or_else(cut)?);
    let mut corners = at(CORNERS_AT);
    let mut corner = || -> std::result::Result<[f64; 2], String> {
        Ok([
            corners.real(24).ok_or_else(cut)?,
            corners.real(24).ok_or_else(cut)?,
        ])
    };
    let corners = [corner()?, corner()?, corner()?, corner()?];
    let mut spacing = at(RESOLUTION_AT);
    let mut resolution = [0.0; 3];
    for r in &mut resolution {
        *r = spacing.real(12).ok_or_else(cut)?;
    }
    let profiles = at(PROFILES_AT).int().ok_or_else(cut)?;
    // The first profile: in the new format at record B's start, after two 1s.
    let mut old = at(OLD_DATA_AT);
    let (row, column) = (old.int(), old.int());
    let new_format = old.at >= RECORD || row != Some(1) || column != Some(1);
    let data_at = if !new_format {
        OLD_DATA_AT
    } else {
        let mut first = at(RECORD);
        let (i, j) = (first.int(), first.int());
        if i == Some(1) && matches!(j, Some(0 | 1)) {
            RECORD
        } else {
            ODD_DATA_AT
        }
    };
    // A two-character field, often blank.
    let datum = text
        .get(DATUM_AT..DATUM_AT + 2)
        .filter(|_| new_format)
        .and_then(|field| std::str::from_utf8(field).ok()?.trim().parse().ok());
    let geographic = match system_code {
        0 if ground_units == 3 => true,
        0 => {
            return Err(format!(
                "its geographic coordinates are in ground unit {ground_units}, not \
                 arc-seconds (3)"
            ));
        }
        1 => false,
        2 => {
            return Err(
                "it is in State Plane coordinates, which are not read: convert it to a \
                 GeoTIFF first (gdal_translate)"
                    .into(),
            );
        }
        other => {
            return Err(format!(
                "its planimetric reference system {other} is not geographic (0) or UTM (1)"
            ));
        }
    };
    if !(resolution[0] > 0.0 && resolution[1] > 0.0) {
        return Err(format!(
            "its spacing {} × {} is not a cell size",
            resolution[0], resolution[1]
        ));
    }
    Ok(Header {
        geographic,
        zone,
        feet: height_units == 1,
        corners,
        resolution,
        profiles: usize::try_from(profiles)
            .ok()
            .filter(|&p| p >= 1)
            .ok_or_else(|| format!("its profile count {profiles} is not a count"))?,
        datum: datum.unwrap_or(1),
        data_at,
    })
}

/// The USGS DEM at `path` as map `name` (one layer, `elevation`, in metres).
pub fn read_usgs_dem(path: &Path, name: &str) -> Result<Map> {
    let problem = |message: String| Error::input(path, message);
    let bytes = read_input(path)?;
    if !is_usgs_dem_header(&bytes) {
        return Err(problem(
            "is not a USGS DEM: its record A holds no elevation pattern and planimetric \
             system where the standard puts them (a GTOPO30 .dem needs its .hdr beside it)"
                .into(),
        ));
    }
    let header = read_header(&bytes).map_err(&problem)?;
    let [dx, dy, dz] = header.resolution;
    let [xs, ys] = [0, 1].map(|axis| header.corners.map(|c| c[axis]));
    let x_min = xs[0].min(xs[1]);
    let (mut y_min, mut y_max) = (ys[0].min(ys[3]), ys[1].max(ys[2]));
    let per_unit = if header.geographic {
        1.0 / 3600.0
    } else {
        // Rows of UTM nodes widened to whole nodes, as GDAL does (profiles start at
        // any node along y; the first is the west corner's).
        y_min = (y_min / dy).floor() * dy;
        y_max = (y_max / dy).ceil() * dy;
        1.0
    };
    // A column per profile.
    let width = header.profiles;
    let height = ((y_max - y_min) / dy + 1.5) as usize;
    if width == 0 || height == 0 || width.saturating_mul(height) > super::MAX_MAP_CELLS {
        return Err(problem(format!(
            "its corners give a grid of {width} × {height} nodes, not one a map may hold"
        )));
    }
    let (cell_x, cell_y) = (dx * per_unit, dy * per_unit);
    let transform = [
        cell_x,
        0.0,
        x_min * per_unit - cell_x / 2.0,
        0.0,
        -cell_y,
        y_max * per_unit + cell_y / 2.0,
    ];
    let keys = crs_keys(&header).map_err(&problem)?;

    // Rows from the south, as ours run; a profile's nodes run from the south too.
    let mut values = vec![f32::NAN; width * height];
    // The bottom row's centre, from the top as GDAL counts.
    let bottom = y_max * per_unit - (height - 1) as f64 * cell_y;
    let mut cursor = Cursor {
        text: &bytes,
        at: header.data_at,
    };
    let feet = if header.feet { 0.3048 } else { 1.0 };
    for column in 0..width {
        let cut = || problem(format!("its profile {} is cut short", column + 1));
        for _ in 0..2 {
            cursor.int().ok_or_else(cut)?;
        }
        let nodes = cursor.int().ok_or_else(cut)?;
        cursor.int().ok_or_else(cut)?;
        cursor.real(24).ok_or_else(cut)?;
        let y_start = cursor.real(24).ok_or_else(cut)? * per_unit;
        let datum_elevation = cursor.real(24).ok_or_else(cut)?;
        cursor.real(24).ok_or_else(cut)?;
        cursor.real(24).ok_or_else(cut)?;
        let nodes = usize::try_from(nodes)
            .ok()
            .filter(|&n| n <= height)
            .ok_or_else(|| {
                problem(format!(
                    "its profile {} holds {nodes} nodes, where the grid has {height} rows",
                    column + 1
                ))
            })?;
        let first_row = ((y_start - bottom) / cell_y).round() as i64;
        for k in 0..nodes {
            let raw = cursor.int().ok_or_else(cut)?;
            let row = first_row + k as i64;
            if raw == VOID || row < 0 || row >= height as i64 {
                continue;
            }
            let elevation = raw as f64 * dz + datum_elevation;
            values[row as usize * width + column] = (elevation * feet) as f32;
        }
    }
    if values.iter().all(|v| v.is_nan()) {
        return Err(problem("every node is void (-32767)".into()));
    }
    let (geo, _) = georeference(
        path,
        width as u32,
        height as u32,
        Georeferencing::of_grid(transform, &keys, String::new()),
    )?;
    Ok(Map {
        name: name.to_string(),
        geo,
        layers: vec![Layer::new("elevation", values)],
    })
}

/// The GeoKeys of the header's system on its datum (record A's code: 1 NAD27, 3 WGS 84,
/// 4 NAD83; none given is NAD27, as GDAL takes it).
fn crs_keys(header: &Header) -> std::result::Result<Vec<u16>, String> {
    let datum = match header.datum {
        1 | 0 | -9 => "NAD27",
        3 => "WGS84",
        4 => "NAD83",
        2 => return Err("its horizontal datum is WGS 72, which is not read".into()),
        other => return Err(format!("its horizontal datum code {other} is not read")),
    };
    let named = if header.geographic {
        Named::Geographic
    } else {
        let zone = u16::try_from(header.zone.unsigned_abs()).unwrap_or(0);
        Named::Utm {
            zone,
            north: header.zone >= 0,
        }
    };
    named_crs::geokeys(named, datum).ok_or_else(|| {
        format!(
            "its UTM zone {} on {datum} is not one EPSG defines",
            header.zone
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_read_as_fortran_writes_them() {
        let mut cursor = Cursor {
            text: b"     1   -32767-32767   4.400000000000000D+05",
            at: 0,
        };
        assert_eq!(cursor.int(), Some(1));
        assert_eq!(cursor.int(), Some(-32767));
        assert_eq!(cursor.int(), Some(-32767));
        assert_eq!(cursor.real(24), Some(440000.0));
        assert_eq!(cursor.int(), None);
        assert_eq!(cursor.real(24), None);
    }

    #[test]
    fn record_a_is_told_from_other_text() {
        let mut header = vec![b' '; 1024];
        header[150..156].copy_from_slice(b"     1");
        header[156..162].copy_from_slice(b"     1");
        assert!(is_usgs_dem_header(&header));
        header[156..162].copy_from_slice(b"     7");
        assert!(!is_usgs_dem_header(&header));
        assert!(!is_usgs_dem_header(b"ncols 4\nnrows 4\n"));
    }
}
