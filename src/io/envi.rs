//! ENVI rasters: raw samples beside an ENVI header (`x.hdr` or `x.img.hdr`, whose first
//! line is `ENVI`), as hyperspectral and SAR imagery is handed out (AVIRIS, PRISMA, ESA's
//! SNAP exports) and as GDAL's ENVI driver writes them. The raw file may be named
//! anything: `.img`, `.dat`, `.bsq`, `.bil`, `.bip`.
//!
//! The header gives the layout (`samples`, `lines`, `bands`, `header offset`, `data
//! type`, `interleave`, `byte order`), the grid (`map info`: a reference pixel, counted
//! from 1 at the top-left cell's corner, its map coordinates and the cell's size), the
//! CRS (`coordinate system string`, ESRI WKT; else `map info`'s UTM zone or geographic
//! coordinates and datum), `band names` and `data ignore value` (nodata). The samples
//! are read by the raw-raster reader the ESRI `.hdr` formats share.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::FileOrder;
use super::ascii_grid::crs_keys;
use super::ehdr::{Interleave, Layout, RawRaster, RawValues, Sample, read_raw};
use super::geotiff::{sidecar, wkt_geokeys};
use super::named_crs::{self, Named};
use crate::error::{Error, Result};
use crate::grid::Map;

/// The ENVI header of the raw raster at `path`, where one is beside it: `x.hdr`, then
/// `x.img.hdr` (either in upper case too), as GDAL looks for it; a `.hdr` that is not an
/// ENVI header (an ESRI one) is not.
pub fn envi_header(path: &Path) -> Option<PathBuf> {
    let mut appended = path.as_os_str().to_owned();
    appended.push(".hdr");
    let mut appended_upper = path.as_os_str().to_owned();
    appended_upper.push(".HDR");
    [
        path.with_extension("hdr"),
        path.with_extension("HDR"),
        PathBuf::from(appended),
        PathBuf::from(appended_upper),
    ]
    .into_iter()
    .find(|header| {
        std::fs::read(header).is_ok_and(|bytes| {
            let text = String::from_utf8_lossy(&bytes[..bytes.len().min(64)]).into_owned();
            text.trim_start().starts_with("ENVI")
        })
    })
}

/// The files reading an ENVI raster depends on: its header, a `.prj` and GDAL's sidecar.
pub fn envi_sidecars(path: &Path) -> Vec<PathBuf> {
    envi_header(path)
        .into_iter()
        .chain([path.with_extension("prj"), sidecar(path)])
        .filter(|f| f.is_file())
        .collect()
}

/// An ENVI header's fields: keys in lower case, values with their braces removed (a
/// braced value may run over several lines).
fn fields(text: &str) -> std::result::Result<HashMap<String, String>, String> {
    let mut lines = text.lines();
    if !lines.next().is_some_and(|l| l.trim().starts_with("ENVI")) {
        return Err("it does not open with ENVI".into());
    }
    let mut fields = HashMap::new();
    let mut open: Option<(String, String)> = None;
    for line in lines {
        if let Some((key, mut value)) = open.take() {
            value.push('\n');
            value.push_str(line);
            match value.rfind('}') {
                Some(end) => {
                    fields.insert(key, value[..end].trim().to_string());
                }
                None => open = Some((key, value)),
            }
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            continue;
        };
        let key = key.trim().to_ascii_lowercase();
        let value = value.trim();
        match value.strip_prefix('{') {
            Some(braced) => match braced.rfind('}') {
                Some(end) => {
                    fields.insert(key, braced[..end].trim().to_string());
                }
                None => open = Some((key, braced.to_string())),
            },
            None => {
                fields.insert(key, value.to_string());
            }
        }
    }
    if let Some((key, _)) = open {
        return Err(format!("its '{key}' opens a brace it never closes"));
    }
    Ok(fields)
}

/// The sample type of ENVI's `data type` code.
fn sample(code: &str) -> std::result::Result<Sample, String> {
    Ok(match code.trim() {
        "1" => Sample::Unsigned(1),
        "2" => Sample::Signed(2),
        "3" => Sample::Signed(4),
        "4" => Sample::Float(4),
        "5" => Sample::Float(8),
        "12" => Sample::Unsigned(2),
        "13" => Sample::Unsigned(4),
        "14" => Sample::Signed(8),
        "15" => Sample::Unsigned(8),
        other => {
            return Err(format!(
                "its data type {other} is not read (1, 2, 3, 4, 5, 12, 13, 14 and 15 are; \
                 6 and 9 are complex)"
            ));
        }
    })
}

/// What a `map info` says.
#[derive(Debug, Clone, PartialEq)]
struct MapInfo {
    /// GDAL's geotransform as ours.
    transform: [f64; 6],
    /// The UTM zone or geographic coordinates, with the datum, where it names them.
    crs: Option<(Named, String)>,
}

/// The grid and named CRS of a `map info`.
fn map_info(value: &str) -> std::result::Result<MapInfo, String> {
    let items: Vec<&str> = value.split(',').map(str::trim).collect();
    let number = |i: usize| -> std::result::Result<f64, String> {
        let text = items.get(i).copied().unwrap_or_default();
        text.parse::<f64>()
            .ok()
            .filter(|n| n.is_finite())
            .ok_or_else(|| format!("its map info's item {} is '{text}', not a number", i + 1))
    };
    let (reference_x, reference_y) = (number(1)?, number(2)?);
    let (easting, northing) = (number(3)?, number(4)?);
    let (dx, dy) = (number(5)?, number(6)?);
    let rotation = items
        .iter()
        .find_map(|item| item.strip_prefix("rotation="))
        .and_then(|r| r.trim().parse::<f64>().ok())
        .unwrap_or(0.0);
    if rotation != 0.0 {
        return Err(format!(
            "its map info rotates the grid by {rotation}°; only axis-aligned rasters are \
             supported: warp it first (gdalwarp)"
        ));
    }
    let transform = [
        dx,
        0.0,
        easting - (reference_x - 1.0) * dx,
        0.0,
        -dy,
        northing + (reference_y - 1.0) * dy,
    ];
    let datum_at = |i: usize| {
        items
            .get(i)
            .filter(|d| !d.contains('='))
            .map(|d| d.to_string())
    };
    let projection = items[0].to_ascii_lowercase();
    let crs = if projection == "utm" {
        let zone = items.get(7).and_then(|z| z.parse::<u16>().ok());
        let north = items
            .get(8)
            .map(|h| !h.eq_ignore_ascii_case("south"))
            .unwrap_or(true);
        zone.zip(datum_at(9))
            .map(|(zone, datum)| (Named::Utm { zone, north }, datum))
    } else if projection.starts_with("geographic") {
        datum_at(7).map(|datum| (Named::Geographic, datum))
    } else {
        None
    };
    Ok(MapInfo { transform, crs })
}

/// The layout, grid, nodata, CRS and band names an ENVI header gives.
fn raster(text: &str, path: &Path) -> std::result::Result<RawRaster, String> {
    let fields = fields(text)?;
    let count = |key: &str, default: Option<usize>| -> std::result::Result<usize, String> {
        match fields.get(key) {
            Some(v) => v
                .trim()
                .parse::<usize>()
                .ok()
                .filter(|&n| n <= u32::MAX as usize)
                .ok_or_else(|| format!("its {key} is '{v}', not a count")),
            None => default.ok_or_else(|| format!("it gives no {key}")),
        }
    };
    let (columns, rows) = (count("samples", None)?, count("lines", None)?);
    if columns == 0 || rows == 0 {
        return Err(format!("its grid is {columns} × {rows} cells"));
    }
    let bands = count("bands", Some(1))?.max(1);
    let sample = sample(fields.get("data type").ok_or("it gives no data type")?)?;
    let interleave = match fields
        .get("interleave")
        .map(|v| v.trim().to_ascii_lowercase())
    {
        None => Interleave::Band,
        Some(v) if v == "bsq" => Interleave::Band,
        Some(v) if v == "bil" => Interleave::Line,
        Some(v) if v == "bip" => Interleave::Pixel,
        Some(other) => return Err(format!("its interleave is '{other}', not bsq, bil or bip")),
    };
    let little_endian = match count("byte order", Some(0))? {
        0 => true,
        1 => false,
        other => return Err(format!("its byte order is {other}, neither 0 nor 1")),
    };
    let skip = count("header offset", Some(0))?;
    let mut layout = Layout::packed(
        columns,
        rows,
        bands,
        sample,
        little_endian,
        skip,
        interleave,
    )?;
    let mut named = None;
    if let Some(info) = fields.get("map info") {
        let info = map_info(info)?;
        layout.transform = Some(info.transform);
        named = info.crs;
    }
    layout.nodata = match fields.get("data ignore value") {
        Some(v) => Some(
            v.trim()
                .parse::<f64>()
                .map_err(|_| format!("its data ignore value '{v}' is not a number"))?,
        ),
        None => None,
    };
    let crs = match fields.get("coordinate system string") {
        Some(wkt) => wkt_geokeys(wkt).ok_or_else(|| {
            format!(
                "its coordinate system string is neither a projected nor a geographic CRS: {wkt}"
            )
        })?,
        None => match named.and_then(|(crs, datum)| named_crs::geokeys(crs, &datum)) {
            Some(keys) => (keys, String::new()),
            None => crs_keys(path)?,
        },
    };
    let descriptions = fields
        .get("band names")
        .map(|names| {
            names
                .split(',')
                .map(|n| Some(n.trim().to_string()).filter(|n| !n.is_empty()))
                .collect()
        })
        .unwrap_or_default();
    Ok(RawRaster {
        layout,
        crs,
        descriptions,
        grid_keys: "map info",
        values: RawValues::default(),
    })
}

/// The ENVI raster at `path` as map `name`, with whether its rows ran from the north.
pub fn read_envi_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let header = envi_header(path).ok_or_else(|| {
        problem(
            "no ENVI header beside it (x.hdr or x.img.hdr opening with ENVI): a raw raster \
             needs its header"
                .into(),
        )
    })?;
    let text = std::fs::read_to_string(&header).map_err(|e| {
        problem(format!(
            "its header {} cannot be read ({e})",
            header.display()
        ))
    })?;
    let raster = raster(&text, path)
        .map_err(|e| problem(format!("its header {}: {e}", header.display())))?;
    read_raw(path, name, &header, raster)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_as_gdal_and_envi_write_them() {
        let header = "ENVI\ndescription = {\n  a scene}\nsamples = 50\nlines    = 40\n\
            bands   = 3\nheader offset = 0\nfile type = ENVI Standard\ndata type = 12\n\
            interleave = bil\nbyte order = 1\nmap info = {UTM, 1, 1, 440000, 4640000, 30, \
            30, 16, North,WGS-84}\nband names = {\nred,\n green, nir}\n\
            data ignore value = 0\n";
        let raster = raster(header, Path::new("/nowhere/scene.img")).unwrap();
        let layout = &raster.layout;
        assert_eq!((layout.columns, layout.rows, layout.bands), (50, 40, 3));
        assert_eq!(layout.sample, Sample::Unsigned(2));
        assert!(!layout.little_endian);
        assert_eq!(layout.interleave, Interleave::Line);
        assert_eq!(
            layout.transform,
            Some([30.0, 0.0, 440000.0, 0.0, -30.0, 4640000.0])
        );
        assert_eq!(layout.nodata, Some(0.0));
        assert_eq!(raster.crs.0[11], 32616);
        assert_eq!(
            raster.descriptions,
            [Some("red".into()), Some("green".into()), Some("nir".into())]
        );
        // A reference pixel at the centre of the first cell moves the corner by half.
        let info =
            map_info("Geographic Lat/Lon, 1.5, 1.5, -100.0, 40.0, 0.5, 0.25, WGS-84").unwrap();
        assert_eq!(info.transform, [0.5, 0.0, -100.25, 0.0, -0.25, 40.125]);
        assert_eq!(info.crs, Some((Named::Geographic, "WGS-84".into())));
        assert!(map_info("UTM, 1, 1, 0, 0, 30, 30, 16, North, WGS-84, rotation=30").is_err());
        assert!(raster_error("ENVI\nsamples = 5\nlines = 5\ndata type = 6\n").contains("complex"));
        assert!(raster_error("ENVI\nsamples = 5\ndata type = 1\n").contains("lines"));
        assert!(raster_error("ENVI\nband names = {a, b\n").contains("brace"));
    }

    proptest::proptest! {
        /// Any header text after `ENVI` reads or is refused with an error: never a panic.
        #[test]
        fn any_header_reads_or_is_refused(
            lines in proptest::collection::vec(
                "(samples|lines|bands|data type|interleave|byte order|header offset|map info|band names|data ignore value|coordinate system string) = [{}0-9a-zA-Z ,.=-]{0,40}",
                0..12,
            ),
        ) {
            let text = format!("ENVI\n{}\n", lines.join("\n"));
            let _ = raster(&text, Path::new("/nowhere/x.img"));
        }
    }

    fn raster_error(header: &str) -> String {
        raster(header, Path::new("/nowhere/x.img")).err().unwrap()
    }
}
