//! R's raster grids (`.grd` beside its `.gri` samples): the native format of R's
//! `raster` package (`writeRaster`'s default) and of `terra` where asked, as ecologists
//! and environmental modellers hand out DEMs, land covers and climate layers, read as
//! GDAL's RRASTER driver reads them.
//!
//! The header is INI-like text (`[general]`, `[georeference]`, `[data]`,
//! `[description]`): `ncols`, `nrows` and the extent (`xmin`, `ymin`, `xmax`, `ymax`,
//! whose cells GDAL divides evenly), `datatype` (`INT1U`, `INT1S`, `INT2S`, `INT2U`,
//! `INT4S`, `INT4U`, `FLT4S`, `FLT8S`, `LOG1S`), `byteorder`, `nbands`, `bandorder`
//! (`BIL`, `BIP`, `BSQ`), `nodatavalue` and `layername` (band names, `:` between them).
//! The CRS is the header's `wkt`, else its PROJ string (`projection`: longitude and
//! latitude or a UTM zone on WGS 84, NAD83 or NAD27, as R writes them), else a `.prj` or
//! GDAL's sidecar.

use std::path::{Path, PathBuf};

use super::FileOrder;
use super::ascii_grid::crs_keys;
use super::ehdr::{Interleave, KeyValues, Layout, RawRaster, RawValues, Sample, read_raw_bytes};
use super::geotiff::{sidecar, wkt_geokeys};
use super::proj_string::{CrsKeys, proj_string_geokeys};
use crate::error::{Error, Result, read_input};
use crate::grid::Map;

/// Whether `path` (a `.grd`) is an R raster header: text whose first section is one of
/// the header's (Surfer and GMT grids are binary or open otherwise).
pub fn is_rraster(path: &Path) -> bool {
    let Ok(mut file) = std::fs::File::open(path) else {
        return false;
    };
    let mut start = [0u8; 64];
    let read = std::io::Read::read(&mut file, &mut start).unwrap_or(0);
    let text = String::from_utf8_lossy(&start[..read]).to_ascii_lowercase();
    ["[general]", "[georeference]", "[data]", "[description]"]
        .iter()
        .any(|section| text.trim_start().starts_with(section))
}

/// The samples beside a header: `x.gri` (`x.GRI` beside `x.GRD`, as GDAL looks).
fn samples_path(path: &Path) -> PathBuf {
    let upper = path
        .extension()
        .is_some_and(|e| e.to_string_lossy().starts_with('G'));
    path.with_extension(if upper { "GRI" } else { "gri" })
}

/// The files reading the grid at `path` depends on: its samples, `.prj` and GDAL
/// sidecar.
pub fn rraster_sidecars(path: &Path) -> Vec<PathBuf> {
    [
        samples_path(path),
        path.with_extension("prj"),
        sidecar(path),
    ]
    .into_iter()
    .filter(|f| f.is_file())
    .collect()
}

/// The R raster whose header is `path` as map `name`, with whether its rows ran from
/// the north.
pub fn read_rraster_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let text = std::fs::read_to_string(path)
        .map_err(|e| problem(format!("its header cannot be read as text ({e})")))?;
    let (mut raster, crs) = read_header(&text).map_err(problem)?;
    raster.crs = match crs {
        Some(keys) => keys,
        None => crs_keys(path).map_err(problem)?,
    };
    let samples = samples_path(path);
    if !samples.is_file() {
        return Err(problem(format!(
            "its samples {} are missing: an R raster is its .grd header beside its .gri",
            samples.display()
        )));
    }
    let bytes = read_input(&samples)?;
    // Named by its header, as GDAL names the dataset (its sidecar is `x.grd.aux.xml`).
    read_raw_bytes(path, &bytes, name, path, raster)
}

/// The sample a `datatype` names.
fn sample(datatype: &str) -> std::result::Result<Sample, String> {
    Ok(match datatype {
        "LOG1S" | "INT1U" => Sample::Unsigned(1),
        "INT1S" => Sample::Signed(1),
        "INT2S" => Sample::Signed(2),
        "INT2U" => Sample::Unsigned(2),
        "INT4S" => Sample::Signed(4),
        "INT4U" => Sample::Unsigned(4),
        "FLT4S" => Sample::Float(4),
        "FLT8S" => Sample::Float(8),
        other => {
            return Err(format!(
                "its datatype is '{other}', not one of INT1U, INT1S, INT2S, INT2U, INT4S, \
                 INT4U, FLT4S, FLT8S or LOG1S (GDAL reads no other)"
            ));
        }
    })
}

/// The raster a header describes (its CRS left empty) and the CRS it gives, if any.
fn read_header(text: &str) -> std::result::Result<(RawRaster, Option<CrsKeys>), String> {
    let fields = KeyValues::parse(text);
    let text_of = |key: &str| fields.get(key);
    let number = |key: &str| -> std::result::Result<f64, String> {
        let v = text_of(key).ok_or_else(|| format!("its header gives no {key}"))?;
        v.parse::<f64>()
            .ok()
            .filter(|n| n.is_finite())
            .ok_or_else(|| format!("its header's {key} is '{v}', not a number"))
    };
    let count = |key: &str, default: Option<usize>| -> std::result::Result<usize, String> {
        match text_of(key) {
            None => default.ok_or_else(|| format!("its header gives no {key}")),
            Some(v) => v
                .parse::<usize>()
                .ok()
                .filter(|&n| n >= 1 && n <= u32::MAX as usize)
                .ok_or_else(|| format!("its header's {key} is '{v}', not a count")),
        }
    };
    let (columns, rows) = (count("ncols", None)?, count("nrows", None)?);
    let bands = count("nbands", Some(1))?;
    let datatype = text_of("datatype").ok_or("its header gives no datatype")?;
    let sample = sample(&datatype.to_ascii_uppercase())?;
    let little_endian = match text_of("byteorder").map(str::to_ascii_lowercase).as_deref() {
        None | Some("little") => true,
        Some("big") => false,
        Some(other) => {
            return Err(format!(
                "its header's byteorder is '{other}', not little or big"
            ));
        }
    };
    let interleave = match text_of("bandorder").map(str::to_ascii_uppercase).as_deref() {
        Some("BIL") => Interleave::Line,
        Some("BIP") => Interleave::Pixel,
        Some("BSQ") => Interleave::Band,
        None if bands == 1 => Interleave::Line,
        None => return Err(format!("its header gives {bands} bands and no bandorder")),
        Some(other) => {
            return Err(format!(
                "its header's bandorder is '{other}', not BIL, BIP or BSQ"
            ));
        }
    };
    let mut layout = Layout::packed(columns, rows, bands, sample, little_endian, 0, interleave)?;
    let (x_min, y_min) = (number("xmin")?, number("ymin")?);
    let (x_max, y_max) = (number("xmax")?, number("ymax")?);
    if !(x_max > x_min && y_max > y_min) {
        return Err(format!(
            "its header's extent ({x_min}, {y_min}) to ({x_max}, {y_max}) is empty"
        ));
    }
    // GDAL's geotransform, as GDAL divides the extent.
    layout.transform = Some([
        (x_max - x_min) / columns as f64,
        0.0,
        x_min,
        0.0,
        -(y_max - y_min) / rows as f64,
        y_max,
    ]);
    layout.nodata = match text_of("nodatavalue") {
        None => None,
        Some(v) if v.eq_ignore_ascii_case("NA") => None,
        Some(v) => Some(
            v.parse::<f64>()
                .map_err(|_| format!("its header's nodatavalue is '{v}', not a number"))?,
        ),
    };
    let crs = match (text_of("wkt"), text_of("projection")) {
        (Some(wkt), _) => Some(wkt_geokeys(wkt).ok_or_else(|| {
            format!("its header's wkt is neither a projected nor a geographic CRS: {wkt}")
        })?),
        (None, Some(proj)) if !proj.eq_ignore_ascii_case("NA") => {
            Some(proj_string_geokeys(proj).map_err(|e| format!("its header's {e}"))?)
        }
        _ => None,
    };
    let descriptions = text_of("layername")
        .map(|names| {
            names
                .split(':')
                .map(|n| Some(n.trim().to_string()).filter(|n| !n.is_empty()))
                .collect()
        })
        .unwrap_or_default();
    let raster = RawRaster {
        layout,
        crs: (Vec::new(), String::new()),
        descriptions,
        grid_keys: "xmin, ymin, xmax and ymax",
        values: RawValues::default(),
    };
    Ok((raster, crs))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A header as R's `raster` package writes one (no WKT).
    const R: &str = "[general]\ncreator=R package 'raster'\ncreated=2021-03-02 10:11:12\n\
        [georeference]\nnrows=3\nncols=4\nxmin=500000\nymin=3999940\nxmax=500120\n\
        ymax=4000000\nprojection=+proj=utm +zone=33 +datum=WGS84 +units=m +no_defs\n\
        [data]\ndatatype=INT2S\nbyteorder=big\nnbands=1\nbandorder=BIL\n\
        categorical=FALSE\nminvalue=1\nmaxvalue=9\nnodatavalue=-32768\n[legend]\n\
        legendtype=\nvalues=\ncolor=\n[description]\nlayername=elevation\nhistory=\n";

    #[test]
    fn r_header_gives_grid_samples_names_and_crs() {
        let (raster, crs) = read_header(R).unwrap();
        let layout = &raster.layout;
        assert_eq!((layout.columns, layout.rows, layout.bands), (4, 3, 1));
        assert_eq!(layout.sample, Sample::Signed(2));
        assert!(!layout.little_endian);
        assert_eq!(
            layout.transform,
            Some([30.0, 0.0, 500000.0, 0.0, -20.0, 4000000.0])
        );
        assert_eq!(layout.nodata, Some(-32768.0));
        assert_eq!(raster.descriptions, vec![Some("elevation".to_string())]);
        assert_eq!(
            crs.unwrap().0,
            crate::io::named_crs::epsg_geokeys(32633, true)
        );
    }

    #[test]
    fn projections_other_than_utm_are_read_from_the_proj_string() {
        // R's own example (raster's test.grd): the Dutch RD grid, no WKT.
        let rd = "+proj=sterea +lat_0=52.1561605555556 +lon_0=5.38763888888889 \
                  +k=0.9999079 +x_0=155000 +y_0=463000 +datum=WGS84 +units=m +no_defs";
        let header = R.replace("+proj=utm +zone=33 +datum=WGS84 +units=m +no_defs", rd);
        let (keys, citation) = read_header(&header).unwrap().1.unwrap();
        assert!(citation.contains("Double_Stereographic"), "{citation}");
        assert!(keys.contains(&32767));
    }

    #[test]
    fn malformed_headers_name_the_key() {
        for (from, to, needle) in [
            ("ncols=4", "ncols=0", "ncols"),
            ("datatype=INT2S", "datatype=INT8S", "INT8S"),
            ("xmax=500120", "xmax=499000", "extent"),
            ("bandorder=BIL", "bandorder=XYZ", "bandorder"),
            ("byteorder=big", "byteorder=middle", "byteorder"),
            ("+proj=utm +zone=33", "+proj=robin +zone=33", ".prj"),
            ("nodatavalue=-32768", "nodatavalue=low", "nodatavalue"),
        ] {
            let error = read_header(&R.replace(from, to)).err().unwrap();
            assert!(error.contains(needle), "{to}: {error}");
        }
    }

    #[test]
    fn headers_are_told_from_surfer_and_netcdf_grids() {
        let dir = tempfile::tempdir().unwrap();
        let r = dir.path().join("r.grd");
        std::fs::write(&r, R).unwrap();
        assert!(is_rraster(&r));
        let surfer = dir.path().join("s.grd");
        std::fs::write(&surfer, b"DSRB\x04\0\0\0").unwrap();
        assert!(!is_rraster(&surfer));
        assert!(!is_rraster(&dir.path().join("missing.grd")));
    }
}
