//! ESRI `.hdr`-labelled rasters (GDAL's EHdr): `.bil`, `.bip` and `.bsq` files, as
//! USGS EarthExplorer hands out SRTM and GTOPO30 tiles and as GDAL writes them, and
//! GridFloat (`.flt`), as the USGS National Map handed out its DEMs. The samples are
//! raw, band-interleaved by line, by pixel or by band; the header beside them
//! (`x.hdr`) gives their layout (`NROWS`, `NCOLS`, `NBANDS`, `NBITS`, `PIXELTYPE`,
//! `BYTEORDER`, `LAYOUT`, `SKIPBYTES`, `BANDROWBYTES`, `TOTALROWBYTES`,
//! `BANDGAPBYTES`), the grid (`ULXMAP`/`ULYMAP`, the top-left cell's centre, with
//! `XDIM`/`YDIM`; or GridFloat's `xllcorner`/`yllcorner` or centres with `cellsize`)
//! and `NODATA`. The CRS is the `.prj` beside them, as for an ASCII grid; band names,
//! scales and further nodata come from GDAL's sidecar, as for any raster.

use std::path::{Path, PathBuf};

use super::FileOrder;
use super::MAX_MAP_CELLS;
use super::ascii_grid::crs_keys;
use super::geotiff::{Georeferencing, georeference, sidecar};
use super::sidecar_bands::{self, FileMasks, Samples};
use crate::error::{Error, Result, read_input};
use crate::grid::Map;

/// The header beside a raw raster: `x.hdr` (GDAL also tries `x.HDR`).
fn header_path(path: &Path) -> PathBuf {
    let lower = path.with_extension("hdr");
    if lower.is_file() {
        return lower;
    }
    let upper = path.with_extension("HDR");
    if upper.is_file() { upper } else { lower }
}

/// The files reading a raw raster depends on: its header, `.prj` and GDAL sidecar.
pub fn ehdr_sidecars(path: &Path) -> Vec<PathBuf> {
    [header_path(path), path.with_extension("prj"), sidecar(path)]
        .into_iter()
        .filter(|f| f.is_file())
        .collect()
}

/// How one sample is stored.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Sample {
    Unsigned(usize),
    Signed(usize),
    Float(usize),
}

impl Sample {
    pub(super) fn bytes(self) -> usize {
        match self {
            Sample::Unsigned(b) | Sample::Signed(b) | Sample::Float(b) => b,
        }
    }

    /// The sample in `raw` (its bytes, little-endian first where `little`).
    pub(super) fn read(self, raw: &[u8], little: bool) -> f32 {
        /// The `$n` bytes of `raw` as a `$t` in the file's byte order.
        macro_rules! word {
            ($t:ty, $n:literal) => {{
                let bytes: [u8; $n] = raw[..$n].try_into().expect("a sample's bytes");
                if little {
                    <$t>::from_le_bytes(bytes)
                } else {
                    <$t>::from_be_bytes(bytes)
                }
            }};
        }
        match self {
            Sample::Unsigned(1) => f32::from(raw[0]),
            Sample::Signed(1) => f32::from(raw[0] as i8),
            Sample::Unsigned(2) => f32::from(word!(u16, 2)),
            Sample::Signed(2) => f32::from(word!(i16, 2)),
            Sample::Unsigned(4) => word!(u32, 4) as f32,
            Sample::Signed(4) => word!(i32, 4) as f32,
            Sample::Unsigned(8) => word!(u64, 8) as f32,
            Sample::Signed(8) => word!(i64, 8) as f32,
            Sample::Float(4) => word!(f32, 4),
            Sample::Float(_) => word!(f64, 8) as f32,
            Sample::Unsigned(n) | Sample::Signed(n) => {
                // Other widths (3 bytes): assembled, then sign-extended where signed.
                let mut word = [0u8; 8];
                word[..n].copy_from_slice(&raw[..n]);
                if !little {
                    word[..n].reverse();
                }
                let bits = u64::from_le_bytes(word);
                match self {
                    Sample::Signed(_) => {
                        let shift = 64 - 8 * n as u32;
                        (((bits << shift) as i64) >> shift) as f32
                    }
                    _ => bits as f32,
                }
            }
        }
    }
}

/// Where the samples lie and what they are, from the header.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Layout {
    pub columns: usize,
    pub rows: usize,
    pub bands: usize,
    pub sample: Sample,
    pub little_endian: bool,
    /// Byte offsets: of the first sample, between rows, between a row's bands (BIL,
    /// BSQ), and between bands (BSQ).
    pub skip: usize,
    pub row_bytes: usize,
    pub band_row_bytes: usize,
    pub band_bytes: usize,
    pub interleave: Interleave,
    /// GDAL's geotransform as ours.
    pub transform: Option<[f64; 6]>,
    pub nodata: Option<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Interleave {
    Line,
    Pixel,
    Band,
}

impl Layout {
    /// Samples of `sample` with no gaps: `skip` bytes, then rows of `columns` samples,
    /// the bands interleaved as `interleave` says; no grid and no nodata yet.
    pub(super) fn packed(
        columns: usize,
        rows: usize,
        bands: usize,
        sample: Sample,
        little_endian: bool,
        skip: usize,
        interleave: Interleave,
    ) -> std::result::Result<Self, String> {
        let overflow = "its layout overflows memory";
        let band_row_bytes = columns.checked_mul(sample.bytes()).ok_or(overflow)?;
        let row_bytes = match interleave {
            Interleave::Line | Interleave::Pixel => band_row_bytes.checked_mul(bands),
            Interleave::Band => Some(band_row_bytes),
        }
        .ok_or(overflow)?;
        Ok(Layout {
            columns,
            rows,
            bands,
            sample,
            little_endian,
            skip,
            row_bytes,
            band_row_bytes,
            band_bytes: band_row_bytes.checked_mul(rows).ok_or(overflow)?,
            interleave,
            transform: None,
            nodata: None,
        })
    }

    /// Where band `band`'s sample of cell `cell` (row by row from the top) starts.
    fn offset(&self, band: usize, cell: usize) -> usize {
        let size = self.sample.bytes();
        // Rows without gaps (as most files are): no division into row and column.
        let gapless = self.band_row_bytes == self.columns * size;
        match self.interleave {
            Interleave::Band if gapless => self.skip + band * self.band_bytes + cell * size,
            Interleave::Pixel if self.row_bytes == self.columns * self.bands * size => {
                self.skip + (cell * self.bands + band) * size
            }
            _ => {
                let (row, col) = (cell / self.columns, cell % self.columns);
                match self.interleave {
                    Interleave::Line => {
                        self.skip + row * self.row_bytes + band * self.band_row_bytes + col * size
                    }
                    Interleave::Pixel => {
                        self.skip + row * self.row_bytes + (col * self.bands + band) * size
                    }
                    Interleave::Band => {
                        self.skip + band * self.band_bytes + row * self.band_row_bytes + col * size
                    }
                }
            }
        }
    }

    /// The bytes the file must hold: up to the end of the last band's last sample.
    pub(super) fn extent(&self) -> Option<usize> {
        let last = self.columns.checked_mul(self.rows)?.checked_sub(1)?;
        let end = |band: usize| -> Option<usize> {
            let (row, col) = (last / self.columns, last % self.columns);
            let size = self.sample.bytes();
            let at = match self.interleave {
                Interleave::Line => self
                    .skip
                    .checked_add(row.checked_mul(self.row_bytes)?)?
                    .checked_add(band.checked_mul(self.band_row_bytes)?)?,
                Interleave::Pixel => self
                    .skip
                    .checked_add(row.checked_mul(self.row_bytes)?)?
                    .checked_add(band.checked_mul(size)?)?,
                Interleave::Band => self
                    .skip
                    .checked_add(band.checked_mul(self.band_bytes)?)?
                    .checked_add(row.checked_mul(self.band_row_bytes)?)?,
            };
            let col_at = match self.interleave {
                Interleave::Pixel => col.checked_mul(self.bands)?.checked_mul(size)?,
                _ => col.checked_mul(size)?,
            };
            at.checked_add(col_at)?.checked_add(size)
        };
        (0..self.bands)
            .map(end)
            .try_fold(0, |most, e| Some(most.max(e?)))
    }
}

/// The raw raster at `path` as map `name`, with whether its rows ran from the north.
pub fn read_ehdr_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let header = header_path(path);
    let text = std::fs::read_to_string(&header).map_err(|e| {
        problem(format!(
            "its header {} cannot be read ({e}): a raw raster needs the .hdr beside it",
            header.display()
        ))
    })?;
    let grid_float = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("flt"));
    let layout = read_header(&text, grid_float)
        .map_err(|e| problem(format!("its header {}: {e}", header.display())))?;
    let crs = crs_keys(path).map_err(problem)?;
    let raster = RawRaster {
        layout,
        crs,
        descriptions: Vec::new(),
        grid_keys: "ULXMAP/ULYMAP or xllcorner/yllcorner",
        values: RawValues::default(),
    };
    read_raw(path, name, &header, raster)
}

/// A raw raster as its header describes it.
pub(super) struct RawRaster {
    /// Where the samples lie, with the grid and nodata where the header gives them.
    pub layout: Layout,
    /// The CRS's GeoKeys and the citations they point into (empty where none).
    pub crs: (Vec<u16>, String),
    /// Each band's name in the header (empty where it names none).
    pub descriptions: Vec<Option<String>>,
    /// The header keys that would have given a grid, for the error where none does.
    pub grid_keys: &'static str,
    /// How stored samples become values beyond the layout's nodata.
    pub values: RawValues,
}

/// A text header's `key = value` lines (SAGA's `.sgrd`, R's `.grd`), keys in any case.
pub(super) struct KeyValues<'a>(Vec<(String, &'a str)>);

impl<'a> KeyValues<'a> {
    pub(super) fn parse(text: &'a str) -> Self {
        KeyValues(
            text.lines()
                .filter_map(|line| line.split_once('='))
                .map(|(key, value)| (key.trim().to_ascii_lowercase(), value.trim()))
                .collect(),
        )
    }

    /// The value of `key` (in any case) where a line gives it one.
    pub(super) fn get(&self, key: &str) -> Option<&'a str> {
        let key = key.to_ascii_lowercase();
        self.0
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| *v)
            .filter(|v| !v.is_empty())
    }
}

/// How a format turns stored samples into values, beyond one nodata value: SAGA's
/// nodata range and its z factor and offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct RawValues {
    /// Stored samples within this range (both ends in) are nodata.
    pub nodata_range: Option<[f32; 2]>,
    /// A value is `offset + factor · sample`.
    pub factor: f64,
    pub offset: f64,
}

impl Default for RawValues {
    fn default() -> Self {
        RawValues {
            nodata_range: None,
            factor: 1.0,
            offset: 0.0,
        }
    }
}

impl RawValues {
    /// The value of stored `sample`; NaN where it is nodata or infinite (a ratio's
    /// division by zero is no measurement).
    pub(super) fn value(&self, sample: f32) -> f32 {
        let in_range = self
            .nodata_range
            .is_some_and(|[low, high]| (low..=high).contains(&sample));
        if sample.is_infinite() || in_range {
            f32::NAN
        } else if self.factor == 1.0 && self.offset == 0.0 {
            sample
        } else {
            (self.offset + self.factor * f64::from(sample)) as f32
        }
    }
}

/// The raw raster at `path` as `header` describes it, as map `name`, with whether its
/// rows ran from the north; a grid the header does not give comes from GDAL's sidecar.
pub(super) fn read_raw(
    path: &Path,
    name: &str,
    header: &Path,
    raster: RawRaster,
) -> Result<(Map, FileOrder)> {
    let bytes = read_input(path)?;
    read_raw_bytes(path, &bytes, name, header, raster)
}

/// An error where `layout` declares more cells than a map may hold.
pub(super) fn check_cells(path: &Path, header: &Path, layout: &Layout) -> Result<()> {
    let cells = layout
        .columns
        .saturating_mul(layout.rows)
        .saturating_mul(layout.bands);
    if cells > MAX_MAP_CELLS {
        return Err(Error::input(
            path,
            format!(
                "its header {} declares {cells} cells in all, more than the {MAX_MAP_CELLS} \
                 a map may hold: clip it to the site first (gdal_translate -projwin)",
                header.display()
            ),
        ));
    }
    Ok(())
}

/// [`read_raw`] of the file's `bytes`, read already (or unzipped).
pub(super) fn read_raw_bytes(
    path: &Path,
    bytes: &[u8],
    name: &str,
    header: &Path,
    raster: RawRaster,
) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    check_cells(path, header, &raster.layout)?;
    let RawRaster {
        layout,
        crs: (keys, ascii),
        descriptions,
        grid_keys,
        values,
    } = raster;
    let needed = layout
        .extent()
        .ok_or_else(|| problem("its header's layout overflows memory".into()))?;
    if bytes.len() < needed {
        return Err(problem(format!(
            "holds {} bytes; its header's {} × {} cells of {} bands need {needed}",
            bytes.len(),
            layout.columns,
            layout.rows,
            layout.bands
        )));
    }
    let transform = match layout.transform {
        Some(transform) => transform,
        None => super::geotiff::pam_georeference(path)
            .map_err(problem)?
            .transform
            .ok_or_else(|| {
                problem(format!(
                    "no georeference: its header {} gives no {grid_keys}, and no GDAL \
                     sidecar (.aux.xml) gives a grid",
                    header.display()
                ))
            })?,
    };
    let (width, height) = (layout.columns as u32, layout.rows as u32);
    let (geo, heights) = georeference(
        path,
        width,
        height,
        Georeferencing::of_grid(transform, &keys, ascii),
    )?;
    let order = FileOrder::of_transform(&transform);
    let nodata = layout.nodata.map(|n| n as f32);
    let samples = Samples {
        width,
        height,
        bands: layout.bands,
        order,
        heights,
        sample: |band: usize, cell: usize| {
            let at = layout.offset(band, cell);
            values.value(
                layout
                    .sample
                    .read(&bytes[at..at + layout.sample.bytes()], layout.little_endian),
            )
        },
    };
    let masks = FileMasks {
        nodata: vec![nodata; layout.bands],
        descriptions,
        ..FileMasks::default()
    };
    sidecar_bands::map(path, name, geo, samples, &masks)
}

/// The layout, grid and nodata a header gives (keywords in any case, one a line, a
/// value after each). `grid_float`: a `.flt`, whose samples are 32-bit floats unless
/// the header says otherwise.
fn read_header(text: &str, grid_float: bool) -> std::result::Result<Layout, String> {
    let mut fields: Vec<(String, String)> = Vec::new();
    for line in text.lines() {
        let mut words = line.split_whitespace();
        if let (Some(key), Some(value)) = (words.next(), words.next()) {
            fields.push((key.to_ascii_lowercase(), value.to_string()));
        }
    }
    let text_of = |key: &str| {
        fields
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    };
    let number = |key: &str| -> std::result::Result<Option<f64>, String> {
        text_of(key)
            .map(|v| {
                v.parse::<f64>()
                    .map_err(|_| format!("{key} is '{v}', not a number"))
            })
            .transpose()
    };
    let count = |key: &str, default: Option<usize>| -> std::result::Result<usize, String> {
        match number(key)? {
            Some(v) if v >= 0.0 && v.fract() == 0.0 && v <= u32::MAX as f64 => Ok(v as usize),
            Some(v) => Err(format!("{key} is {v}, not a count")),
            None => default.ok_or_else(|| format!("it gives no {key}")),
        }
    };
    let columns = count("ncols", None)?;
    let rows = count("nrows", None)?;
    if columns == 0 || rows == 0 {
        return Err(format!("its grid is {columns} × {rows} cells"));
    }
    let bands = count("nbands", Some(1))?.max(1);
    let bits = count("nbits", Some(if grid_float { 32 } else { 8 }))?;
    let pixel_type = text_of("pixeltype").map(str::to_ascii_uppercase);
    let sample = match (pixel_type.as_deref(), bits) {
        (Some("FLOAT"), 32 | 64) => Sample::Float(bits / 8),
        (None, 32) if grid_float => Sample::Float(4),
        (Some("SIGNEDINT"), 8 | 16 | 32) => Sample::Signed(bits / 8),
        (Some("UNSIGNEDINT") | None, 8 | 16 | 32) => Sample::Unsigned(bits / 8),
        (kind, bits) => {
            return Err(format!(
                "samples of {bits} bits{} are not read (8, 16 and 32-bit integers, 32 and \
                 64-bit floats are)",
                kind.map_or(String::new(), |k| format!(" of PIXELTYPE {k}"))
            ));
        }
    };
    let little_endian = match text_of("byteorder").map(str::to_ascii_uppercase).as_deref() {
        None | Some("I" | "LSBFIRST") => true,
        Some("M" | "MSBFIRST") => false,
        Some(other) => return Err(format!("BYTEORDER is '{other}', neither I nor M")),
    };
    let interleave = match text_of("layout").map(str::to_ascii_uppercase).as_deref() {
        None | Some("BIL") => Interleave::Line,
        Some("BIP") => Interleave::Pixel,
        Some("BSQ") => Interleave::Band,
        Some(other) => return Err(format!("LAYOUT is '{other}', not BIL, BIP or BSQ")),
    };
    let skip = count("skipbytes", Some(0))?;
    let packed = Layout::packed(
        columns,
        rows,
        bands,
        sample,
        little_endian,
        skip,
        interleave,
    )?;
    let band_row_bytes = count("bandrowbytes", Some(packed.band_row_bytes))?;
    let row_bytes = count(
        "totalrowbytes",
        match interleave {
            Interleave::Line => band_row_bytes.checked_mul(bands),
            Interleave::Pixel => Some(packed.row_bytes),
            Interleave::Band => Some(band_row_bytes),
        },
    )?;
    let band_gap = count("bandgapbytes", Some(0))?;
    let band_bytes = band_row_bytes
        .checked_mul(rows)
        .and_then(|b| b.checked_add(band_gap))
        .ok_or("its bands' size overflows memory")?;
    // The grid: the top-left cell's centre and the cell's sides, or GridFloat's
    // lower-left corner or centre and one cell size.
    let (dx, dy) = match (number("xdim")?, number("ydim")?, number("cellsize")?) {
        (Some(dx), Some(dy), _) => (dx, dy),
        (_, _, Some(size)) => (size, size),
        _ => (1.0, 1.0),
    };
    let height = rows as f64 * dy;
    let transform = match (
        (number("ulxmap")?, number("ulymap")?),
        (number("xllcorner")?, number("yllcorner")?),
        (number("xllcenter")?, number("yllcenter")?),
    ) {
        ((Some(x), Some(y)), _, _) => Some([dx, 0.0, x - dx / 2.0, 0.0, -dy, y + dy / 2.0]),
        (_, (Some(x), Some(y)), _) => Some([dx, 0.0, x, 0.0, -dy, y + height]),
        (_, _, (Some(x), Some(y))) => {
            Some([dx, 0.0, x - dx / 2.0, 0.0, -dy, y - dy / 2.0 + height])
        }
        _ => None,
    };
    // A negative XDIM steps west and a negative YDIM north, as GDAL reads them.
    if !(dx.is_finite() && dy.is_finite() && dx != 0.0 && dy != 0.0) {
        return Err(format!("its cells of {dx} × {dy} are not a size"));
    }
    let nodata = match number("nodata")? {
        Some(n) => Some(n),
        None => number("nodata_value")?,
    };
    Ok(Layout {
        row_bytes,
        band_row_bytes,
        band_bytes,
        transform,
        nodata,
        ..packed
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_header_declaring_a_continent_is_refused_before_its_samples_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("conus.bil");
        std::fs::write(&path, [0u8; 16]).unwrap();
        std::fs::write(
            dir.path().join("conus.hdr"),
            "NROWS 104424\nNCOLS 161190\nULXMAP 0\nULYMAP 0\n",
        )
        .unwrap();
        let error = read_ehdr_rows(&path, "conus").unwrap_err().to_string();
        assert!(error.contains("clip"), "{error}");
    }

    #[test]
    fn headers_as_gdal_and_the_usgs_write_them() {
        let gdal = read_header(
            "BYTEORDER      I\nLAYOUT         BIL\nNROWS          40\nNCOLS          50\n\
             NBANDS         2\nNBITS          16\nBANDROWBYTES   100\nTOTALROWBYTES  200\n\
             PIXELTYPE      SIGNEDINT\nULXMAP         500015\nULYMAP         4199985\n\
             XDIM           30\nYDIM           30\nNODATA         -32768\n",
            false,
        )
        .unwrap();
        assert_eq!(gdal.sample, Sample::Signed(2));
        assert_eq!(
            gdal.transform,
            Some([30.0, 0.0, 500000.0, 0.0, -30.0, 4200000.0])
        );
        assert_eq!(gdal.nodata, Some(-32768.0));
        // Band 1 of row 1 starts after row 0's two bands; band 1 a row's half in.
        assert_eq!(gdal.offset(0, 50), 200);
        assert_eq!(gdal.offset(1, 51), 302);
        assert_eq!(gdal.extent(), Some(8000));
        let grid_float = read_header(
            "ncols 4\nnrows 3\nxllcorner -105\nyllcorner 39\ncellsize 0.5\n\
             NODATA_value -9999\nbyteorder MSBFIRST\n",
            true,
        )
        .unwrap();
        assert_eq!(grid_float.sample, Sample::Float(4));
        assert!(!grid_float.little_endian);
        assert_eq!(
            grid_float.transform,
            Some([0.5, 0.0, -105.0, 0.0, -0.5, 40.5])
        );
        assert_eq!(grid_float.nodata, Some(-9999.0));
        let pixel = read_header("NROWS 2\nNCOLS 3\nNBANDS 3\nLAYOUT BIP\n", false).unwrap();
        assert_eq!((pixel.offset(2, 4), pixel.extent()), (14, Some(18)));
        assert_eq!(pixel.transform, None);
        let band = read_header("NROWS 2\nNCOLS 3\nNBANDS 3\nLAYOUT BSQ\n", false).unwrap();
        assert_eq!((band.offset(2, 4), band.extent()), (16, Some(18)));
    }

    #[test]
    fn samples_read_in_either_byte_order_and_sign() {
        assert_eq!(Sample::Signed(2).read(&[0xff, 0xfe], false), -2.0);
        assert_eq!(Sample::Signed(2).read(&[0xfe, 0xff], true), -2.0);
        assert_eq!(Sample::Unsigned(2).read(&[0xfe, 0xff], true), 65534.0);
        assert_eq!(Sample::Signed(1).read(&[0x80], true), -128.0);
        assert_eq!(Sample::Float(4).read(&1.5f32.to_be_bytes(), false), 1.5);
        assert_eq!(
            Sample::Float(8).read(&(-2.25f64).to_le_bytes(), true),
            -2.25
        );
    }

    #[test]
    fn broken_headers_are_explained() {
        for (text, needle) in [
            ("NROWS 2\n", "no ncols"),
            ("NROWS 2\nNCOLS x\n", "'x', not a number"),
            ("NROWS 2\nNCOLS 3\nNBITS 4\n", "4 bits"),
            (
                "NROWS 2\nNCOLS 3\nNBITS 16\nPIXELTYPE FLOAT\n",
                "PIXELTYPE FLOAT",
            ),
            ("NROWS 2\nNCOLS 3\nBYTEORDER Q\n", "BYTEORDER"),
            ("NROWS 2\nNCOLS 3\nLAYOUT ZZZ\n", "LAYOUT"),
            ("NROWS 0\nNCOLS 3\n", "0 cells"),
            ("NROWS 2\nNCOLS 3\nXDIM 0\nYDIM 1\n", "not a size"),
        ] {
            let error = read_header(text, false).unwrap_err();
            assert!(error.contains(needle), "{text:?}: {error}");
        }
    }

    proptest::proptest! {
        /// Any layout a header may give, over a file of any length, reads or is refused
        /// with an error: never a panic, and never a read past the file.
        #[test]
        fn any_layout_over_any_file_reads_or_is_refused(
            columns in 1usize..9,
            rows in 1usize..9,
            bands in 1usize..4,
            kind in 0usize..6,
            layout in 0usize..3,
            skip in 0usize..5,
            big_endian in proptest::bool::ANY,
            length in 0usize..2000,
            fill in 0u8..=255,
        ) {
            let (bits, pixel) = [(8, "UNSIGNEDINT"), (8, "SIGNEDINT"), (16, "SIGNEDINT"),
                (32, "UNSIGNEDINT"), (32, "FLOAT"), (64, "FLOAT")][kind];
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("r.bil");
            std::fs::write(
                dir.path().join("r.hdr"),
                format!(
                    "NROWS {rows}\nNCOLS {columns}\nNBANDS {bands}\nNBITS {bits}\n\
                     PIXELTYPE {pixel}\nLAYOUT {}\nSKIPBYTES {skip}\nBYTEORDER {}\n\
                     ULXMAP 0.5\nULYMAP 9.5\nXDIM 1\nYDIM 1\n",
                    ["BIL", "BIP", "BSQ"][layout],
                    if big_endian { "M" } else { "I" }
                ),
            )
            .unwrap();
            std::fs::write(&path, vec![fill; length]).unwrap();
            let needed = skip + columns * rows * bands * bits / 8;
            match read_ehdr_rows(&path, "r") {
                Ok((map, _)) => {
                    proptest::prop_assert!(length >= needed);
                    proptest::prop_assert_eq!(map.layers.len(), bands);
                }
                Err(e) => proptest::prop_assert!(
                    length < needed || e.to_string().contains("nodata"),
                    "{}",
                    e
                ),
            }
        }
    }
}
