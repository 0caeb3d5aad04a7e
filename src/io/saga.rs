//! SAGA GIS grids: raw samples (`x.sdat`) beside their text header (`x.sgrd`), as SAGA,
//! QGIS's SAGA tools and GDAL write them, and SAGA's compressed grids (`.sg-grd-z`: a
//! ZIP of the header, the samples and the `.prj`, SAGA 7's default), which GDAL reads
//! too. Either file of a pair may be named.
//!
//! The header gives the layout (`CELLCOUNT_X`, `CELLCOUNT_Y`, `DATAFORMAT`,
//! `BYTEORDER_BIG`, `DATAFILE_OFFSET`, `TOPTOBOTTOM`), the grid (`POSITION_XMIN`,
//! `POSITION_YMIN`: the lower-left cell's centre; `CELLSIZE`) and the values
//! (`NODATA_VALUE`, one value or a range `low;high`; `Z_FACTOR` and `Z_OFFSET`). The grid
//! is GDAL's to the last bit. Where GDAL departs from SAGA, the grid is read as SAGA
//! writes and reads it: rows from the top where `TOPTOBOTTOM` says so (GDAL refuses
//! them), the data file's offset honoured, samples scaled by the z factor and offset and
//! masked over the whole nodata range (GDAL ignores the three and masks the range's
//! first value), and `BYTE` samples signed (SAGA's `char`). The CRS is the `.prj` beside
//! the samples, else GDAL's sidecar (where SAGA also writes it).

use std::io::Read;
use std::path::{Path, PathBuf};

use super::FileOrder;
use super::ascii_grid::crs_keys;
use super::ehdr::{
    Interleave, KeyValues, Layout, RawRaster, RawValues, Sample, check_cells, read_raw,
    read_raw_bytes,
};
use super::geotiff::{sidecar, wkt_geokeys};
use crate::error::{Error, Result, open_input};
use crate::grid::Map;

/// The header beside a grid's samples, or the header itself where `path` names it.
fn header_path(path: &Path) -> PathBuf {
    if is_header(path) {
        return path.to_path_buf();
    }
    let lower = path.with_extension("sgrd");
    if lower.is_file() {
        return lower;
    }
    let upper = path.with_extension("SGRD");
    if upper.is_file() { upper } else { lower }
}

fn is_header(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("sgrd"))
}

/// The files reading the grid at `path` depends on: its header, samples, `.prj` and
/// GDAL sidecar.
pub fn saga_sidecars(path: &Path) -> Vec<PathBuf> {
    let header = header_path(path);
    let data = std::fs::read_to_string(&header)
        .ok()
        .and_then(|text| read_header(&text).ok())
        .map_or_else(|| header.with_extension("sdat"), |h| data_path(&header, &h));
    [
        header,
        data.clone(),
        data.with_extension("prj"),
        sidecar(&data),
    ]
    .into_iter()
    .filter(|f| f.is_file() && f != path)
    .collect()
}

/// The samples' file: the header's `DATAFILE_NAME` (beside the header unless it names a
/// folder), else the `.sdat` beside the header.
fn data_path(header: &Path, parsed: &Header) -> PathBuf {
    match &parsed.data_file {
        Some(name) if Path::new(name).parent().is_some_and(|p| p != Path::new("")) => {
            PathBuf::from(name)
        }
        Some(name) => header.with_file_name(name),
        None => header.with_extension("sdat"),
    }
}

/// The grid at `path` (its `.sdat` or its `.sgrd`) as map `name`, with whether its rows
/// ran from the north.
pub fn read_saga_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let header = header_path(path);
    let text = std::fs::read_to_string(&header).map_err(|e| {
        problem(format!(
            "its header {} cannot be read ({e}): a SAGA grid is its .sdat beside its .sgrd",
            header.display()
        ))
    })?;
    let parsed =
        read_header(&text).map_err(|e| problem(format!("its header {}: {e}", header.display())))?;
    let data = if is_header(path) {
        data_path(&header, &parsed)
    } else {
        path.to_path_buf()
    };
    let crs = crs_keys(&data).map_err(|e| Error::input(&data, e))?;
    read_raw(&data, name, &header, parsed.raster(crs))
}

/// The compressed grid at `path` (`.sg-grd-z`) as map `name`, with whether its rows ran
/// from the north: read from the archive as it is, never unzipped to disk.
pub fn read_saga_zip_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let unreadable =
        |e: zip::result::ZipError| problem(format!("is not a readable ZIP archive: {e}"));
    let mut archive = zip::ZipArchive::new(open_input(path)?).map_err(unreadable)?;
    let names: Vec<String> = archive
        .file_names()
        .map(|n| n.map(|n| n.into_owned()))
        .collect::<std::result::Result<_, _>>()
        .map_err(unreadable)?;
    let stem = super::map_name(path);
    let with = |extension: &str| {
        let wanted = format!("{stem}.{extension}");
        names
            .iter()
            .find(|n| n.eq_ignore_ascii_case(&wanted))
            .or_else(|| {
                names
                    .iter()
                    .find(|n| n.to_ascii_lowercase().ends_with(&format!(".{extension}")))
            })
            .cloned()
    };
    let header_name = with("sgrd").or_else(|| with("sg-grd")).ok_or_else(|| {
        problem(format!(
            "holds no SAGA header (.sgrd) among its {} files ({}): a compressed SAGA grid \
             holds its .sgrd, .sdat and .prj",
            names.len(),
            names.join(", ")
        ))
    })?;
    let inside = |entry: &str| path.join(entry);
    let mut read_entry = |entry: &str, most: u64| -> Result<Vec<u8>> {
        let mut file = archive
            .by_name(entry)
            .map_err(|e| problem(format!("{entry}: {e}")))?;
        let mut bytes = Vec::new();
        (&mut file)
            .take(most)
            .read_to_end(&mut bytes)
            .map_err(|e| problem(format!("{entry} cannot be unzipped: {e}")))?;
        Ok(bytes)
    };
    // A header is a few hundred bytes of text.
    let text = String::from_utf8(read_entry(&header_name, 1 << 16)?)
        .map_err(|_| problem(format!("its header {header_name} is not text")))?;
    let parsed =
        read_header(&text).map_err(|e| problem(format!("its header {header_name}: {e}")))?;
    let header_stem = header_name
        .rsplit_once('.')
        .map_or(header_name.as_str(), |(stem, _)| stem);
    let data_name = parsed
        .data_file
        .as_deref()
        .and_then(|file| names.iter().find(|n| n.eq_ignore_ascii_case(file)))
        .or_else(|| {
            let wanted = format!("{header_stem}.sdat");
            names.iter().find(|n| n.eq_ignore_ascii_case(&wanted))
        })
        .cloned()
        .ok_or_else(|| {
            problem(format!(
                "holds no samples for its header {header_name} ({header_stem}.sdat)"
            ))
        })?;
    let prj = names
        .iter()
        .find(|n| n.eq_ignore_ascii_case(&format!("{header_stem}.prj")))
        .cloned();
    let crs = match prj {
        Some(prj) => {
            let wkt = String::from_utf8_lossy(&read_entry(&prj, 1 << 20)?).into_owned();
            wkt_geokeys(wkt.trim()).ok_or_else(|| {
                problem(format!(
                    "the CRS in {prj} is neither a projected nor a geographic CRS in WKT"
                ))
            })?
        }
        None => crs_keys(path).map_err(problem)?,
    };
    let raster = parsed.raster(crs);
    let header = inside(&header_name);
    check_cells(path, &header, &raster.layout)?;
    let needed = raster
        .layout
        .extent()
        .ok_or_else(|| problem("its header's layout overflows memory".into()))?;
    let bytes = read_entry(&data_name, needed as u64)?;
    read_raw_bytes(path, &bytes, name, &header, raster)
}

/// What a header says: the samples' layout and grid, how they become values, and where
/// they lie.
#[derive(Debug, Clone, PartialEq)]
struct Header {
    layout: Layout,
    values: RawValues,
    data_file: Option<String>,
}

impl Header {
    fn raster(self, crs: (Vec<u16>, String)) -> RawRaster {
        RawRaster {
            layout: self.layout,
            crs,
            descriptions: Vec::new(),
            grid_keys: "POSITION_XMIN, POSITION_YMIN and CELLSIZE",
            values: self.values,
        }
    }
}

/// The sample a `DATAFORMAT` names, as SAGA stores it.
fn sample(format: &str) -> std::result::Result<Sample, String> {
    Ok(match format {
        "BYTE_UNSIGNED" => Sample::Unsigned(1),
        "BYTE" => Sample::Signed(1),
        "SHORTINT_UNSIGNED" => Sample::Unsigned(2),
        "SHORTINT" => Sample::Signed(2),
        "INTEGER_UNSIGNED" => Sample::Unsigned(4),
        "INTEGER" => Sample::Signed(4),
        "LONGINT_UNSIGNED" => Sample::Unsigned(8),
        "LONGINT" => Sample::Signed(8),
        "FLOAT" => Sample::Float(4),
        "DOUBLE" => Sample::Float(8),
        "BIT" => {
            return Err(
                "its samples are bits (DATAFORMAT BIT), which are not read: save \
                 the grid as BYTE_UNSIGNED in SAGA"
                    .into(),
            );
        }
        "ASCII" => {
            return Err(
                "its samples are text (DATAFORMAT ASCII), which are not read: save \
                 the grid as binary in SAGA"
                    .into(),
            );
        }
        other => {
            return Err(format!(
                "its DATAFORMAT is '{other}', not one of BYTE_UNSIGNED, BYTE, \
                 SHORTINT_UNSIGNED, SHORTINT, INTEGER_UNSIGNED, INTEGER, LONGINT_UNSIGNED, \
                 LONGINT, FLOAT or DOUBLE"
            ));
        }
    })
}

/// The layout, grid, values and data file a header gives: `KEY = VALUE` lines, keys in
/// any case.
fn read_header(text: &str) -> std::result::Result<Header, String> {
    let fields = KeyValues::parse(text);
    let text_of = |key: &str| fields.get(key);
    let number_in = |key: &str, v: &str| -> std::result::Result<f64, String> {
        v.trim()
            .parse::<f64>()
            .ok()
            .filter(|n| n.is_finite())
            .ok_or_else(|| format!("its {key} is '{v}', not a number"))
    };
    let number = |key: &str| text_of(key).map(|v| number_in(key, v)).transpose();
    let required = |key: &str| number(key)?.ok_or_else(|| format!("it gives no {key}"));
    let count = |key: &str| -> std::result::Result<usize, String> {
        let n = required(key)?;
        if n >= 1.0 && n.fract() == 0.0 && n <= f64::from(u32::MAX) {
            Ok(n as usize)
        } else {
            Err(format!("its {key} is {n}, not a count of cells"))
        }
    };
    let flag = |key: &str| text_of(key).is_some_and(|v| v.to_ascii_uppercase().starts_with("TRUE"));

    let (columns, rows) = (count("CELLCOUNT_X")?, count("CELLCOUNT_Y")?);
    let format = text_of("DATAFORMAT").ok_or("it gives no DATAFORMAT")?;
    let sample = sample(&format.to_ascii_uppercase())?;
    let skip = match number("DATAFILE_OFFSET")? {
        None => 0,
        Some(n) if n >= 0.0 && n.fract() == 0.0 => n as usize,
        Some(n) => return Err(format!("its DATAFILE_OFFSET is {n}, not a byte offset")),
    };
    let mut layout = Layout::packed(
        columns,
        rows,
        1,
        sample,
        !flag("BYTEORDER_BIG"),
        skip,
        Interleave::Band,
    )?;
    let size = required("CELLSIZE")?;
    if size <= 0.0 {
        return Err(format!("its CELLSIZE is {size}, not a size"));
    }
    let (x_min, y_min) = (required("POSITION_XMIN")?, required("POSITION_YMIN")?);
    // GDAL's geotransform, north up, computed as GDAL computes it.
    let west = x_min - size / 2.0;
    let north = y_min + (rows - 1) as f64 * size + size / 2.0;
    layout.transform = Some(if flag("TOPTOBOTTOM") {
        [size, 0.0, west, 0.0, -size, north]
    } else {
        // Rows from the bottom: the south edge, as GDAL's north-up grid ends there.
        [size, 0.0, west, 0.0, size, north + -size * rows as f64]
    });
    // SAGA's default where a header gives none.
    let nodata = text_of("NODATA_VALUE").unwrap_or("-99999");
    let (low, high) = match nodata.split_once(';') {
        Some((low, high)) => (
            number_in("NODATA_VALUE", low)?,
            number_in("NODATA_VALUE", high)?,
        ),
        None => {
            let n = number_in("NODATA_VALUE", nodata)?;
            (n, n)
        }
    };
    let factor = number("Z_FACTOR")?.unwrap_or(1.0);
    if factor == 0.0 {
        return Err("its Z_FACTOR is 0: every value would be its Z_OFFSET".into());
    }
    let values = RawValues {
        nodata_range: Some([low.min(high) as f32, low.max(high) as f32]),
        factor,
        offset: number("Z_OFFSET")?.unwrap_or(0.0),
    };
    Ok(Header {
        layout,
        values,
        data_file: text_of("DATAFILE_NAME").map(str::to_string),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GDAL: &str = "NAME\t= dem\nDESCRIPTION\t=\nUNIT\t=\nDATAFILE_OFFSET\t= 0\n\
        DATAFORMAT\t= FLOAT\nBYTEORDER_BIG\t= FALSE\nPOSITION_XMIN\t= 500015.0000000000\n\
        POSITION_YMIN\t= 3999925.0000000000\nCELLCOUNT_X\t= 4\nCELLCOUNT_Y\t= 3\n\
        CELLSIZE\t= 30.0000000000\nZ_FACTOR\t= 1.000000\nNODATA_VALUE\t= -99999.000000\n\
        TOPTOBOTTOM\t= FALSE\n";

    #[test]
    fn gdal_header_gives_gdal_grid_from_the_south() {
        let header = read_header(GDAL).unwrap();
        let layout = &header.layout;
        assert_eq!((layout.columns, layout.rows), (4, 3));
        assert_eq!(layout.sample, Sample::Float(4));
        assert!(layout.little_endian);
        // GDAL: origin (500000, 4000000), 30 m cells north up; from the south here.
        let [a, _, c, _, e, f] = layout.transform.unwrap();
        assert_eq!((a, c, e), (30.0, 500000.0, 30.0));
        assert_eq!(f, 4000000.0 - 90.0);
        assert_eq!(header.values.nodata_range, Some([-99999.0, -99999.0]));
        assert_eq!(header.values.factor, 1.0);
    }

    #[test]
    fn saga_header_with_range_scale_and_rows_from_the_top() {
        let text = GDAL
            .replace("TOPTOBOTTOM\t= FALSE", "TOPTOBOTTOM\t= TRUE")
            .replace("-99999.000000", "-5.000000;-1.000000")
            .replace("Z_FACTOR\t= 1.000000", "Z_FACTOR\t= 0.1\nZ_OFFSET\t= 100")
            .replace("DATAFORMAT\t= FLOAT", "DATAFORMAT\t= SHORTINT")
            .replace("BYTEORDER_BIG\t= FALSE", "BYTEORDER_BIG\t= TRUE");
        let header = read_header(&text).unwrap();
        let [_, _, _, _, e, f] = header.layout.transform.unwrap();
        assert_eq!((e, f), (-30.0, 4000000.0));
        assert_eq!(header.layout.sample, Sample::Signed(2));
        assert!(!header.layout.little_endian);
        let values = header.values;
        assert!(values.value(-3.0).is_nan() && values.value(-5.0).is_nan());
        assert_eq!(values.value(20.0), 102.0);
    }

    #[test]
    fn malformed_headers_name_the_key() {
        for (from, to, needle) in [
            ("CELLCOUNT_X\t= 4", "CELLCOUNT_X\t= 0", "CELLCOUNT_X"),
            ("CELLSIZE\t= 30.0000000000", "CELLSIZE\t= -3", "CELLSIZE"),
            ("POSITION_XMIN\t= 500015.0000000000", "", "POSITION_XMIN"),
            ("DATAFORMAT\t= FLOAT", "DATAFORMAT\t= BIT", "BIT"),
            ("DATAFORMAT\t= FLOAT", "DATAFORMAT\t= COLOR", "COLOR"),
            (
                "NODATA_VALUE\t= -99999.000000",
                "NODATA_VALUE\t= x",
                "NODATA_VALUE",
            ),
            (
                "DATAFILE_OFFSET\t= 0",
                "DATAFILE_OFFSET\t= -4",
                "DATAFILE_OFFSET",
            ),
            ("Z_FACTOR\t= 1.000000", "Z_FACTOR\t= 0", "Z_FACTOR"),
        ] {
            let text = GDAL.replace(from, to);
            let error = read_header(&text).unwrap_err();
            assert!(error.contains(needle), "{to}: {error}");
        }
    }

    #[test]
    fn either_file_of_the_pair_finds_the_header() {
        assert_eq!(
            header_path(Path::new("a/dem.sgrd")),
            Path::new("a/dem.sgrd")
        );
        assert_eq!(
            header_path(Path::new("a/dem.sdat")),
            Path::new("a/dem.sgrd")
        );
        let header = read_header(&format!("{GDAL}DATAFILE_NAME\t= values.sdat\n")).unwrap();
        assert_eq!(
            data_path(Path::new("a/dem.sgrd"), &header),
            Path::new("a/values.sdat")
        );
    }

    proptest::proptest! {
        /// Any header the GDAL one may be damaged into, over samples of any length,
        /// reads or is refused with an error naming the file: never a panic, and never
        /// a read past the samples.
        #[test]
        fn any_header_over_any_samples_reads_or_is_refused(
            cut in 0usize..400,
            at in 0usize..400,
            junk in "[0-9A-Z_;=.\\- \t\n]{0,12}",
            format in 0usize..10,
            length in 0usize..200,
        ) {
            let formats = ["BYTE_UNSIGNED", "BYTE", "SHORTINT_UNSIGNED", "SHORTINT",
                "INTEGER_UNSIGNED", "INTEGER", "LONGINT_UNSIGNED", "LONGINT", "FLOAT", "DOUBLE"];
            let mut text = GDAL.replace("FLOAT", formats[format]);
            let at = at.min(text.len());
            let at = (0..=at).rev().find(|&i| text.is_char_boundary(i)).unwrap_or(0);
            text.insert_str(at, &junk);
            let cut = (text.len() * (400 - cut.min(399)) / 400).max(1);
            let cut = (0..=cut).rev().find(|&i| text.is_char_boundary(i)).unwrap_or(0);
            text.truncate(cut);
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("g.sdat");
            std::fs::write(dir.path().join("g.sgrd"), &text).unwrap();
            std::fs::write(&path, vec![7u8; length]).unwrap();
            if let Err(e) = read_saga_rows(&path, "g") {
                proptest::prop_assert!(e.to_string().contains("g.s"), "{e}");
            }
        }
    }
}
