//! GDAL virtual rasters (`.vrt`): the XML that `gdalbuildvrt` writes to mosaic tiles
//! into one raster without copying them (the four SRTM tiles around a site, a LiDAR
//! portal's kilometre tiles, an orthophoto's sheets) or, with `-separate`, to stack
//! single-band files as the bands of one raster. The raster's size, `<SRS>` and
//! `<GeoTransform>` are the VRT's; each `<VRTRasterBand>` is a layer filled from its
//! `<SimpleSource>`s and `<ComplexSource>`s in order, each source's `<SrcRect>` of its
//! file's band placed on the `<DstRect>` (nearest cell where the two differ in size, or
//! the mean of the cells under each, or their convolution, where the source averages
//! or interpolates),
//! as GDAL reads them. Sources are read as this tool reads them alone (GeoTIFF, ASCII
//! grid, SRTM tile, another VRT); their nodata is transparent, so a later tile's void
//! does not hide an earlier tile's ground. Cells no source covers are nodata, even
//! where the VRT declares no `<NoDataValue>` (GDAL reads 0 there: ground that is not).
//! A `VRTRawRasterBand` reads its cells from a raw file at the offsets it gives. The
//! `<SRS>` may be WKT, a PROJ string or an EPSG code, as GDAL takes it from a user.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use quick_xml::events::{BytesStart, Event};
use quick_xml::reader::Reader;

use rayon::prelude::*;

use super::FileOrder;
use super::MAX_MAP_CELLS as MAX_CELLS;
use super::ehdr::Sample;
use super::geotiff::metadata::{BandMetadata, layer_names, metres_per_unit};
use super::geotiff::{Georeferencing, dataset_georeference, georeference};
use super::proj_string::user_crs_geokeys;
use crate::error::{Error, Result, read_input};
use crate::grid::{Layer, LayerKind, Map};

/// How deep VRTs may nest (a VRT of VRTs, as tile indexes are built): deeper is a loop.
const MAX_NESTING: usize = 8;

/// The VRT at `path` as map `name`.
pub fn read_vrt(path: &Path, name: &str) -> Result<Map> {
    read_vrt_rows(path, name, 0).map(|(map, _)| map)
}

/// The files reading the VRT at `path` depends on: its sources, their sidecars, and
/// theirs in turn for VRTs of VRTs. Nothing for a VRT that cannot be read (reading it
/// then says why).
pub fn vrt_inputs(path: &Path) -> Vec<PathBuf> {
    let mut inputs = Vec::new();
    collect_inputs(path, 0, &mut inputs);
    inputs.sort();
    inputs.dedup();
    inputs
}

fn collect_inputs(path: &Path, depth: usize, inputs: &mut Vec<PathBuf>) {
    let Ok(text) = std::fs::read_to_string(path) else {
        return;
    };
    let Ok(dataset) = parse_dataset(path, &text) else {
        return;
    };
    for raw in dataset.bands.iter().filter_map(|b| b.raw.as_ref()) {
        if !inputs.contains(&raw.file) {
            inputs.push(raw.file.clone());
        }
    }
    for source in dataset.bands.iter().flat_map(|b| &b.sources) {
        if inputs.contains(&source.file) {
            continue;
        }
        inputs.push(source.file.clone());
        if is_vrt(&source.file) {
            if depth < MAX_NESTING {
                collect_inputs(&source.file, depth + 1, inputs);
            }
        } else {
            inputs.extend(super::raster_sidecars(&source.file));
        }
    }
}

/// Whether `path` names a VRT by its extension.
pub fn is_vrt(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("vrt"))
}

/// One XML element with what it holds.
#[derive(Debug, Default)]
struct Element {
    name: String,
    attributes: Vec<(String, String)>,
    text: String,
    children: Vec<Element>,
}

impl Element {
    fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.trim())
    }

    fn child(&self, name: &str) -> Option<&Element> {
        self.children.iter().find(|c| c.name == name)
    }

    fn child_text(&self, name: &str) -> Option<&str> {
        self.child(name)
            .map(|c| c.text.trim())
            .filter(|t| !t.is_empty())
    }
}

/// The innermost element open.
fn current(open: &mut [Element]) -> &mut Element {
    open.last_mut().expect("the document is open")
}

/// The document's root element.
fn parse_xml(xml: &str) -> std::result::Result<Element, String> {
    let mut reader = Reader::from_str(xml);
    let mut open: Vec<Element> = vec![Element::default()];
    let start = |tag: &BytesStart| -> std::result::Result<Element, String> {
        let mut element = Element {
            name: String::from_utf8_lossy(tag.name().as_ref()).into_owned(),
            ..Element::default()
        };
        for attribute in tag.attributes() {
            let attribute = attribute.map_err(|e| e.to_string())?;
            let value = attribute.unescape_value().map_err(|e| e.to_string())?;
            let key = String::from_utf8_lossy(attribute.key.as_ref()).into_owned();
            element.attributes.push((key, value.into_owned()));
        }
        Ok(element)
    };
    loop {
        match reader.read_event().map_err(|e| e.to_string())? {
            Event::Eof => break,
            Event::Start(tag) => open.push(start(&tag)?),
            Event::Empty(tag) => {
                let element = start(&tag)?;
                current(&mut open).children.push(element);
            }
            Event::End(_) => {
                let element = open.pop().expect("quick-xml matches end tags");
                if open.is_empty() {
                    return Err("an end tag closes nothing".into());
                }
                current(&mut open).children.push(element);
            }
            Event::Text(text) => {
                let text = text.decode().map_err(|e| e.to_string())?;
                current(&mut open).text.push_str(&text);
            }
            Event::CData(text) => {
                let text = text.decode().map_err(|e| e.to_string())?;
                current(&mut open).text.push_str(&text);
            }
            Event::GeneralRef(reference) => {
                let resolved = match reference.resolve_char_ref().map_err(|e| e.to_string())? {
                    Some(c) => c.to_string(),
                    None => {
                        let name = reference.decode().map_err(|e| e.to_string())?;
                        quick_xml::escape::resolve_xml_entity(&name)
                            .ok_or_else(|| format!("unknown entity &{name};"))?
                            .to_string()
                    }
                };
                current(&mut open).text.push_str(&resolved);
            }
            _ => {}
        }
    }
    if open.len() != 1 {
        return Err("the document ends inside an element".into());
    }
    open.pop()
        .and_then(|document| document.children.into_iter().next())
        .ok_or_else(|| "the document has no element".into())
}

/// A window in cells: offsets and sizes, fractional where GDAL writes them so.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Rect {
    x: f64,
    y: f64,
    width: f64,
    height: f64,
}

/// One `<SimpleSource>` or `<ComplexSource>`.
#[derive(Debug)]
struct Source {
    file: PathBuf,
    /// From 0.
    band: usize,
    /// `None`: the whole source.
    window: Option<Rect>,
    /// `None`: the source window's own place and size.
    place: Option<Rect>,
    /// A ComplexSource's `<NODATA>`: its cells of this value are transparent.
    nodata: Option<f64>,
    /// A ComplexSource's linear scaling: value × ratio + offset.
    ratio: f64,
    offset: f64,
    /// Other than nearest: where the windows differ in size, an average
    /// ([`Averaging`]) or a kernel ([`Kernel`]); other resamplings are refused.
    resampling: Option<String>,
    /// How GDAL averages this kind of source where its window is shrunk.
    averaging: Averaging,
}

/// How GDAL averages a source's cells onto a smaller place (`resampling="average"`), as
/// measured against GDAL 3.10 through rasterio: a `<ComplexSource>` weighs each source
/// cell by the share of the VRT cell it covers and leaves its voids out; a
/// `<SimpleSource>` or `<AveragedSource>` takes the plain mean of whole cells between
/// the span's ends rounded to the nearest cell. GDAL's plain mean counts the source's
/// nodata value as a number there (an elevation of −9999 in the mean); voids are left
/// out here, as everywhere else. Where a source has overviews (a COG) GDAL averages the
/// overview nearest the VRT's scale instead of its full-resolution cells, which is
/// what this tool averages: its means are the cells' own, GDAL's those of whatever the
/// overviews were built with.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Averaging {
    AreaWeighted,
    WholeCells,
}

/// GDAL's interpolating resamplings (`-r bilinear`, `cubic`, `cubicspline`, `lanczos`), as it
/// convolves a source onto a place of another size: the kernel stretched by the
/// shrink factor where the place is smaller, taps cut at the file's edges and their
/// weights normalised; rows filtered first, each over its cells with data, then
/// columns over the filtered rows with any. Where a kernel has negative lobes (cubic,
/// Lanczos),
/// a row or column whose longest run of taps with data is under half its taps is a
/// void, as GDAL has it (lest the lobes' weights, renormalised over a few cells, throw
/// the value far off). Measured against GDAL 3.10 through rasterio, the same for every
/// kind of source.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kernel {
    Bilinear,
    /// Keys' cubic convolution, a = −0.5.
    Cubic,
    /// The cubic B-spline (it smooths even an axis whose sizes agree).
    CubicSpline,
    /// Lanczos of three lobes: sinc(x) sinc(x / 3).
    Lanczos,
}

impl Kernel {
    fn named(name: &str) -> Option<Self> {
        match name {
            "bilinear" => Some(Self::Bilinear),
            "cubic" => Some(Self::Cubic),
            "cubicspline" => Some(Self::CubicSpline),
            "lanczos" => Some(Self::Lanczos),
            _ => None,
        }
    }

    fn has_negative_lobes(self) -> bool {
        matches!(self, Self::Cubic | Self::Lanczos)
    }

    /// Half the kernel's support, in source cells before any stretch.
    fn radius(self) -> f64 {
        match self {
            Self::Bilinear => 1.0,
            Self::Cubic | Self::CubicSpline => 2.0,
            Self::Lanczos => 3.0,
        }
    }

    fn weight(self, x: f64) -> f64 {
        let x = x.abs();
        match self {
            Self::Bilinear => (1.0 - x).max(0.0),
            Self::Cubic => {
                const A: f64 = -0.5;
                if x < 1.0 {
                    ((A + 2.0) * x - (A + 3.0)) * x * x + 1.0
                } else if x < 2.0 {
                    (((x - 5.0) * x + 8.0) * x - 4.0) * A
                } else {
                    0.0
                }
            }
            Self::CubicSpline => {
                if x < 1.0 {
                    (4.0 - 6.0 * x * x + 3.0 * x * x * x) / 6.0
                } else if x < 2.0 {
                    (2.0 - x).powi(3) / 6.0
                } else {
                    0.0
                }
            }
            Self::Lanczos => {
                use std::f64::consts::PI;
                if x == 0.0 {
                    1.0
                } else if x < 3.0 {
                    3.0 * (PI * x).sin() * (PI * x / 3.0).sin() / (PI * PI * x * x)
                } else {
                    0.0
                }
            }
        }
    }
}

/// One `<VRTRasterBand>`.
#[derive(Debug)]
struct Band {
    data_type: String,
    nodata: Option<f64>,
    metadata: BandMetadata,
    /// A colour table or category names declare its values classes.
    classes: bool,
    sources: Vec<Source>,
    /// A `VRTRawRasterBand`'s raw file, which gives its cells in place of sources.
    raw: Option<RawBand>,
}

/// A `VRTRawRasterBand`: its samples at fixed strides in a raw file, as GDAL describes
/// a binary file with no header of its own (SAR processors' outputs, a VRT written by
/// hand over a `.bin` or `.dat`).
#[derive(Debug)]
struct RawBand {
    file: PathBuf,
    sample: Sample,
    little_endian: bool,
    /// Bytes before the first sample, between a row's samples and between rows.
    image_offset: usize,
    pixel_offset: usize,
    line_offset: Option<usize>,
}

impl RawBand {
    fn parse(band: &Element, data_type: &str, folder: &Path) -> std::result::Result<Self, String> {
        let sample = match data_type {
            "Byte" => Sample::Unsigned(1),
            "Int8" => Sample::Signed(1),
            "UInt16" => Sample::Unsigned(2),
            "Int16" => Sample::Signed(2),
            "UInt32" => Sample::Unsigned(4),
            "Int32" => Sample::Signed(4),
            "UInt64" => Sample::Unsigned(8),
            "Int64" => Sample::Signed(8),
            "Float32" => Sample::Float(4),
            "Float64" => Sample::Float(8),
            other => return Err(format!("its raw samples' data type {other} is not read")),
        };
        let offset = |name: &str| -> std::result::Result<Option<usize>, String> {
            band.child_text(name)
                .map(|text| {
                    text.trim().parse::<usize>().map_err(|_| {
                        format!("its <{name}> '{}' is not a count of bytes", text.trim())
                    })
                })
                .transpose()
        };
        let little_endian = match band.child_text("ByteOrder").map(str::trim) {
            None | Some("LSB") => true,
            Some("MSB") => false,
            Some(other) => {
                return Err(format!("its <ByteOrder> '{other}' is not LSB or MSB"));
            }
        };
        Ok(RawBand {
            file: resolve(folder, band, source_file(band)?),
            sample,
            little_endian,
            image_offset: offset("ImageOffset")?.unwrap_or(0),
            pixel_offset: offset("PixelOffset")?.unwrap_or(sample.bytes()),
            line_offset: offset("LineOffset")?,
        })
    }

    /// The band's cells, rows from the top; an error where the file is too short.
    fn cells(&self, width: usize, height: usize) -> std::result::Result<Vec<f32>, String> {
        let bytes = std::fs::read(&self.file)
            .map_err(|e| format!("its raw file {} cannot be read: {e}", self.file.display()))?;
        let size = self.sample.bytes();
        let line = match self.line_offset {
            Some(line) => line,
            None => self
                .pixel_offset
                .checked_mul(width)
                .ok_or("its rows overflow memory")?,
        };
        let needed = (height - 1)
            .checked_mul(line)
            .and_then(|rows| rows.checked_add((width - 1).checked_mul(self.pixel_offset)?))
            .and_then(|last| last.checked_add(self.image_offset)?.checked_add(size))
            .ok_or("its offsets overflow memory")?;
        if bytes.len() < needed {
            return Err(format!(
                "its raw file {} holds {} bytes; its {width} × {height} samples at its \
                 offsets need {needed}",
                self.file.display(),
                bytes.len()
            ));
        }
        let mut cells = vec![0f32; width * height];
        cells
            .par_chunks_mut(width)
            .enumerate()
            .for_each(|(row, cells)| {
                let start = self.image_offset + row * line;
                for (col, cell) in cells.iter_mut().enumerate() {
                    let at = start + col * self.pixel_offset;
                    *cell = self.sample.read(&bytes[at..at + size], self.little_endian);
                }
            });
        Ok(cells)
    }
}

/// A VRT's dataset.
#[derive(Debug)]
struct Dataset {
    width: u32,
    height: u32,
    bands: Vec<Band>,
}

/// The VRT's dataset from its XML; sources' paths resolved as GDAL resolves them.
fn parse_dataset(path: &Path, xml: &str) -> std::result::Result<Dataset, String> {
    let root = parse_xml(xml).map_err(|e| format!("is not a VRT: its XML is malformed: {e}"))?;
    if root.name != "VRTDataset" {
        return Err(format!(
            "is not a VRT: its root element is <{}>, not <VRTDataset>",
            root.name
        ));
    }
    if let Some(kind) = root.attribute("subClass") {
        return Err(format!(
            "is a {kind}, which this tool does not read (a warped, pansharpened or processed \
             VRT computes its cells): write it out with gdal_translate or gdalwarp to a \
             GeoTIFF first"
        ));
    }
    let size = |name: &str| -> std::result::Result<u32, String> {
        let text = root
            .attribute(name)
            .ok_or_else(|| format!("its <VRTDataset> has no {name}"))?;
        text.parse::<u32>()
            .ok()
            .filter(|&n| n >= 1)
            .ok_or_else(|| format!("its {name} '{text}' is not a count of cells"))
    };
    let (width, height) = (size("rasterXSize")?, size("rasterYSize")?);
    if width as usize * height as usize > MAX_CELLS {
        return Err(format!(
            "its {width} × {height} cells are more than this tool holds in memory"
        ));
    }
    let folder = path.parent().unwrap_or(Path::new(""));
    let bands = root
        .children
        .iter()
        .filter(|c| c.name == "VRTRasterBand")
        .enumerate()
        .map(|(index, band)| {
            parse_band(band, folder).map_err(|why| format!("band {}: {why}", index + 1))
        })
        .collect::<std::result::Result<Vec<_>, _>>()?;
    if bands.is_empty() {
        return Err("has no <VRTRasterBand>".into());
    }
    Ok(Dataset {
        width,
        height,
        bands,
    })
}

/// A number of an element's text or attribute, named in the error.
fn number(text: &str, what: &str) -> std::result::Result<f64, String> {
    text.trim()
        .parse::<f64>()
        .map_err(|_| format!("its {what} '{}' is not a number", text.trim()))
}

fn parse_band(band: &Element, folder: &Path) -> std::result::Result<Band, String> {
    let data_type = band.attribute("dataType").unwrap_or("Byte").to_string();
    if data_type.starts_with('C') {
        return Err(format!(
            "its data type {data_type} is complex, not a map layer: write its magnitude as a \
             real band first"
        ));
    }
    let raw = match band.attribute("subClass") {
        None => None,
        Some("VRTRawRasterBand") => Some(RawBand::parse(band, &data_type, folder)?),
        Some(kind) => {
            return Err(format!(
                "is a {kind}, whose cells a pixel function computes; this tool reads bands \
                 of sources and raw files (gdal_translate it to a GeoTIFF first)"
            ));
        }
    };
    let optional = |name: &str| {
        band.child_text(name)
            .map(|t| number(t, &format!("<{name}>")))
            .transpose()
    };
    let metadata = BandMetadata {
        scale: optional("Scale")?.unwrap_or(1.0),
        offset: optional("Offset")?.unwrap_or(0.0),
        description: band.child_text("Description").map(str::to_string),
        unit: band.child_text("UnitType").map(str::to_string),
    };
    let mut sources = Vec::new();
    for child in &band.children {
        match child.name.as_str() {
            "SimpleSource" | "ComplexSource" | "AveragedSource" => {
                let source = parse_source(child, folder)
                    .map_err(|why| format!("source {}: {why}", sources.len() + 1))?;
                sources.push(source);
            }
            "KernelFilteredSource" | "ArraySource" => {
                return Err(format!(
                    "its <{}> computes its cells, which this tool does not: gdal_translate \
                     the VRT to a GeoTIFF first",
                    child.name
                ));
            }
            _ => {}
        }
    }
    Ok(Band {
        data_type,
        nodata: optional("NoDataValue")?,
        metadata,
        classes: band.child("ColorTable").is_some() || band.child("CategoryNames").is_some(),
        sources,
        raw,
    })
}

/// The file `element`'s `<SourceFilename>` names, as written.
fn source_file(element: &Element) -> std::result::Result<PathBuf, String> {
    let name = element
        .child("SourceFilename")
        .ok_or("has no <SourceFilename>")?;
    let written = name.text.trim();
    if written.is_empty() {
        return Err("its <SourceFilename> is empty".into());
    }
    if written.starts_with("/vsi") || written.contains("://") {
        return Err(format!(
            "its file '{written}' is a GDAL virtual file system path; this tool reads files \
             on disk (unpack or download it, and point the VRT at the file)"
        ));
    }
    Ok(PathBuf::from(written))
}

/// `file` as GDAL resolves `element`'s `<SourceFilename>`: in the VRT's folder where
/// `relativeToVRT` is 1 (any case, as GDAL writes `relativeToVRT` and GDAL's docs
/// `relativetoVRT`).
fn resolve(folder: &Path, element: &Element, file: PathBuf) -> PathBuf {
    let relative = element.child("SourceFilename").is_some_and(|name| {
        name.attributes
            .iter()
            .any(|(key, value)| key.eq_ignore_ascii_case("relativeToVRT") && value == "1")
    });
    if relative { folder.join(file) } else { file }
}

fn parse_source(source: &Element, folder: &Path) -> std::result::Result<Source, String> {
    let file = resolve(folder, source, source_file(source)?);
    let band_text = source.child_text("SourceBand").unwrap_or("1");
    let band = band_text
        .parse::<usize>()
        .ok()
        .and_then(|b| b.checked_sub(1))
        .ok_or_else(|| {
            format!("its <SourceBand> '{band_text}' is not a band number (mask bands are not read)")
        })?;
    let rect = |name: &str| -> std::result::Result<Option<Rect>, String> {
        let Some(element) = source.child(name) else {
            return Ok(None);
        };
        let field = |key: &str| {
            let text = element
                .attribute(key)
                .ok_or_else(|| format!("its <{name}> has no {key}"))?;
            number(text, &format!("<{name}> {key}"))
        };
        let rect = Rect {
            x: field("xOff")?,
            y: field("yOff")?,
            width: field("xSize")?,
            height: field("ySize")?,
        };
        let finite = [rect.x, rect.y, rect.width, rect.height]
            .iter()
            .all(|v| v.is_finite());
        if !finite || rect.width <= 0.0 || rect.height <= 0.0 {
            return Err(format!("its <{name}> is not a window of cells"));
        }
        Ok(Some(rect))
    };
    let scalar = |name: &str, default: f64| {
        source
            .child_text(name)
            .map_or(Ok(default), |t| number(t, &format!("<{name}>")))
    };
    if source.child("LUT").is_some() || source.child("ColorTableComponent").is_some() {
        return Err(
            "its <LUT> or <ColorTableComponent> maps values through a table, which this tool \
             does not: gdal_translate the VRT to a GeoTIFF first"
                .into(),
        );
    }
    let resampling = match source.name.as_str() {
        "AveragedSource" => Some("average".to_string()),
        _ => source
            .attribute("resampling")
            .map(str::to_ascii_lowercase)
            .filter(|r| !r.starts_with("near")),
    };
    Ok(Source {
        file,
        band,
        window: rect("SrcRect")?,
        place: rect("DstRect")?,
        nodata: source
            .child_text("NODATA")
            .map(|t| number(t, "<NODATA>"))
            .transpose()?,
        ratio: scalar("ScaleRatio", 1.0)?,
        offset: scalar("ScaleOffset", 0.0)?,
        resampling,
        averaging: match source.name.as_str() {
            "ComplexSource" => Averaging::AreaWeighted,
            _ => Averaging::WholeCells,
        },
    })
}

/// A source file as read, with the order it stored its cells in.
type Read = (Map, FileOrder);

/// The VRT at `path` as map `name`, with the order its cells run in; `depth` VRTs deep.
pub(super) fn read_vrt_rows(path: &Path, name: &str, depth: usize) -> Result<Read> {
    let problem = |message: String| Error::input(path, message);
    let bytes = read_input(path)?;
    let xml = std::str::from_utf8(&bytes)
        .map_err(|e| problem(format!("is not a VRT (not UTF-8 text: {e})")))?;
    let dataset = parse_dataset(path, xml).map_err(problem)?;
    let (srs, transform) = dataset_georeference(xml)
        .map_err(|e| problem(format!("is not a VRT: its XML is malformed: {e}")))?;
    let transform = transform.ok_or_else(|| {
        problem(
            "has no <GeoTransform>: a raster without one has no place on the ground \
             (gdalbuildvrt writes it from its sources)"
                .into(),
        )
    })?;
    let (keys, ascii) = match srs {
        Some(srs) => user_crs_geokeys(&srs).map_err(|e| problem(format!("its <SRS>: {e}")))?,
        None => (Vec::new(), String::new()),
    };
    let (width, height) = (dataset.width, dataset.height);
    let (geo, heights) = georeference(
        path,
        width,
        height,
        Georeferencing::of_grid(transform, &keys, ascii),
    )?;
    let order = FileOrder::of_transform(&transform);
    let names = layer_names(
        &dataset
            .bands
            .iter()
            .map(|b| b.metadata.clone())
            .collect::<Vec<_>>(),
    );
    let mut files: HashMap<PathBuf, Read> = HashMap::new();
    let mut layers = Vec::with_capacity(dataset.bands.len());
    for (index, band) in dataset.bands.iter().enumerate() {
        let in_band = |message: String| problem(format!("band {}: {message}", index + 1));
        let mut cells = match &band.raw {
            Some(raw) => raw
                .cells(width as usize, height as usize)
                .map_err(&in_band)?,
            None => vec![f32::NAN; width as usize * height as usize],
        };
        let mut classes = band.classes;
        for (s, source) in band.sources.iter().enumerate() {
            let in_source = |message: String| in_band(format!("source {}: {message}", s + 1));
            if !files.contains_key(&source.file) {
                let read = if is_vrt(&source.file) {
                    if depth >= MAX_NESTING {
                        return Err(in_source(format!(
                            "VRTs nest more than {MAX_NESTING} deep (a VRT that holds itself?)"
                        )));
                    }
                    read_vrt_rows(&source.file, name, depth + 1)
                } else {
                    super::read_raster_rows(&source.file, name)
                };
                let read = read.map_err(|e| in_source(e.to_string()))?;
                files.insert(source.file.clone(), read);
            }
            let (map, file_order) = &files[&source.file];
            let layer = map.layers.get(source.band).ok_or_else(|| {
                in_source(format!(
                    "{} has {} band(s), not band {}",
                    source.file.display(),
                    map.layers.len(),
                    source.band + 1
                ))
            })?;
            classes |= layer.kind == LayerKind::Classes;
            let file = SourceCells {
                values: &layer.values,
                width: map.geo.width as usize,
                height: map.geo.height as usize,
                order: *file_order,
            };
            place(&mut cells, [width, height], source, &file).map_err(in_source)?;
        }
        let BandMetadata {
            scale,
            offset,
            ref unit,
            ..
        } = band.metadata;
        let heights = unit.as_deref().and_then(metres_per_unit).unwrap_or(heights);
        let nodata = band.nodata.map(|n| in_type(n, &band.data_type));
        for cell in &mut cells {
            if cell.is_nan() {
                continue;
            }
            let stored = in_type(f64::from(*cell), &band.data_type);
            *cell = if Some(stored) == nodata {
                f32::NAN
            } else {
                ((stored * scale + offset) * heights) as f32
            };
        }
        let (row, rows) = (width as usize, height as usize);
        cells = (0..rows * row)
            .map(|cell| {
                let (r, c) = order.file_cell(cell / row, cell % row, row, rows);
                cells[r * row + c]
            })
            .collect();
        let layer = Layer::new(names[index].clone(), cells);
        layers.push(if classes {
            layer.declared_classes()
        } else {
            layer
        });
    }
    if layers.iter().all(|l| l.values.iter().all(|v| v.is_nan())) {
        return Err(problem(
            "every cell of every band is nodata: its sources cover none of its cells with data"
                .into(),
        ));
    }
    let map = Map {
        name: name.to_string(),
        geo,
        layers,
    };
    Ok((map, order))
}

/// A source band's values as the reader gave them (rows from the south, columns from
/// the west), and the order the file stored them in, as the VRT's windows count them.
struct SourceCells<'a> {
    values: &'a [f32],
    width: usize,
    height: usize,
    order: FileOrder,
}

impl SourceCells<'_> {
    /// The value at the file's column `col`, row `row` (counted as the file counts).
    fn at(&self, col: usize, row: usize) -> f32 {
        let (ours_row, ours_col) = self.order.file_cell(row, col, self.width, self.height);
        self.values[ours_row * self.width + ours_col]
    }
}

/// Places `source`'s window of `file` on its place in `cells` (the VRT's rows as its file
/// counts them): each cell whose centre the place covers takes the source cell under
/// it (or, averaging or interpolating, the mean or the kernel's sum of the source cells
/// around it), unless that is nodata.
fn place(
    cells: &mut [f32],
    [width, height]: [u32; 2],
    source: &Source,
    file: &SourceCells,
) -> std::result::Result<(), String> {
    let whole = Rect {
        x: 0.0,
        y: 0.0,
        width: file.width as f64,
        height: file.height as f64,
    };
    let window = source.window.unwrap_or(whole);
    let place = source.place.unwrap_or(window);
    let [sx, sy] = [window.width / place.width, window.height / place.height];
    if let Some(resampling) = &source.resampling
        && (sx != 1.0 || sy != 1.0)
    {
        let places = [window, place];
        if resampling == "average" {
            average_onto(
                cells,
                [width, height],
                source,
                file,
                places,
                source.averaging,
            );
        } else if let Some(kernel) = Kernel::named(resampling) {
            convolve_onto(cells, [width, height], source, file, places, kernel);
        } else {
            return Err(format!(
                "its resampling '{resampling}' is not read: this tool places sources by \
                 nearest cell, average, bilinear, cubic, cubicspline or lanczos (build the VRT with \
                 one of them, or gdalwarp it to a GeoTIFF)"
            ));
        }
        return Ok(());
    }
    // The source cell under a VRT cell's centre, per axis; `None` outside the window or
    // the file.
    let along = |centre: f64, place_off: f64, place_size: f64, off: f64, scale: f64, size: f64| {
        let into = centre - place_off;
        if into < 0.0 || into >= place_size {
            return None;
        }
        let at = off + into * scale;
        let cell = at.floor();
        (at >= off.max(0.0) && cell < size && at < off + place_size * scale)
            .then_some(cell as usize)
    };
    let columns: Vec<Option<usize>> = (0..width as usize)
        .map(|col| {
            along(
                col as f64 + 0.5,
                place.x,
                place.width,
                window.x,
                sx,
                whole.width,
            )
        })
        .collect();
    for row in 0..height as usize {
        let Some(source_row) = along(
            row as f64 + 0.5,
            place.y,
            place.height,
            window.y,
            sy,
            whole.height,
        ) else {
            continue;
        };
        let cells = &mut cells[row * width as usize..][..width as usize];
        for (cell, source_col) in cells.iter_mut().zip(&columns) {
            let Some(source_col) = *source_col else {
                continue;
            };
            let value = file.at(source_col, source_row);
            let transparent =
                value.is_nan() || source.nodata.is_some_and(|n| f64::from(value) == n);
            if !transparent {
                *cell = (f64::from(value) * source.ratio + source.offset) as f32;
            }
        }
    }
    Ok(())
}

/// One axis of a source's window (in the file's cells) and of its place (in the VRT's).
#[derive(Debug, Clone, Copy)]
struct Axis {
    /// The VRT's cells along the axis.
    cells: usize,
    place_off: f64,
    place_size: f64,
    window_off: f64,
    window_size: f64,
    /// The file's cells along the axis.
    file_cells: usize,
}

impl Axis {
    /// The columns' axis and the rows'.
    fn both(
        [width, height]: [u32; 2],
        [window, place]: [Rect; 2],
        file: &SourceCells,
    ) -> [Axis; 2] {
        [
            Axis {
                cells: width as usize,
                place_off: place.x,
                place_size: place.width,
                window_off: window.x,
                window_size: window.width,
                file_cells: file.width,
            },
            Axis {
                cells: height as usize,
                place_off: place.y,
                place_size: place.height,
                window_off: window.y,
                window_size: window.height,
                file_cells: file.height,
            },
        ]
    }

    /// The file's cells per VRT cell.
    fn ratio(&self) -> f64 {
        self.window_size / self.place_size
    }

    /// For each VRT cell along the axis whose centre the place covers, the file's cells
    /// and weights `taps(start, centre)` gives from where the cell starts and where its
    /// centre falls in the file's cells; none for the others.
    fn taps(&self, taps: impl Fn(f64, f64) -> Vec<(usize, f64)>) -> Vec<Vec<(usize, f64)>> {
        (0..self.cells)
            .map(|cell| {
                let into = cell as f64 - self.place_off;
                if !(0.0..self.place_size).contains(&(into + 0.5)) {
                    return Vec::new();
                }
                let start = self.window_off + into * self.ratio();
                let centre = self.window_off + (into + 0.5) * self.ratio();
                taps(start, centre)
            })
            .collect()
    }
}

/// Places the averages of `source`'s window of `file` on its place in `cells` (see
/// [`place`]); `[window, place]` in the file's and the VRT's cells.
fn average_onto(
    cells: &mut [f32],
    [width, height]: [u32; 2],
    source: &Source,
    file: &SourceCells,
    [window, place]: [Rect; 2],
    averaging: Averaging,
) {
    // The source cells and their weights under each VRT cell, per axis.
    let [columns, rows] = Axis::both([width, height], [window, place], file).map(|axis| {
        let last = (axis.window_off + axis.window_size).min(axis.file_cells as f64);
        axis.taps(|start, _| {
            let end = start + axis.ratio();
            match averaging {
                Averaging::AreaWeighted => {
                    let (from, to) = (start.max(axis.window_off).max(0.0), end.min(last));
                    (from.floor() as usize..to.ceil().max(0.0) as usize)
                        .map(|i| (i, to.min(i as f64 + 1.0) - from.max(i as f64)))
                        .filter(|&(_, w)| w > 0.0)
                        .collect()
                }
                Averaging::WholeCells => {
                    let round = |v: f64| (v + 0.5).floor().max(0.0) as usize;
                    let from = round(start);
                    let to = round(end).max(from + 1).min(axis.file_cells);
                    (from..to).map(|i| (i, 1.0)).collect()
                }
            }
        })
    });
    for (row, row_span) in rows.iter().enumerate() {
        let cells = &mut cells[row * width as usize..][..width as usize];
        for (cell, column_span) in cells.iter_mut().zip(&columns) {
            let (mut sum, mut weights) = (0.0, 0.0);
            for &(source_row, row_weight) in row_span {
                for &(source_col, col_weight) in column_span {
                    let value = file.at(source_col, source_row);
                    let void =
                        value.is_nan() || source.nodata.is_some_and(|n| f64::from(value) == n);
                    if !void {
                        sum += row_weight * col_weight * f64::from(value);
                        weights += row_weight * col_weight;
                    }
                }
            }
            if weights > 0.0 {
                *cell = (sum / weights * source.ratio + source.offset) as f32;
            }
        }
    }
}

/// Places `source`'s window of `file` on its place in `cells` through `kernel` (see
/// [`Kernel`]); `[window, place]` in the file's and the VRT's cells.
fn convolve_onto(
    cells: &mut [f32],
    [width, height]: [u32; 2],
    source: &Source,
    file: &SourceCells,
    [window, place]: [Rect; 2],
    kernel: Kernel,
) {
    // The source cells and their kernel weights for each VRT cell, per axis.
    let [columns, rows] = Axis::both([width, height], [window, place], file).map(|axis| {
        let stretch = (1.0 / axis.ratio()).min(1.0);
        let reach = kernel.radius() / stretch;
        axis.taps(|_, at| {
            let first = (at - reach + 0.5).floor().max(0.0) as usize;
            let end = ((at + reach + 0.5).floor().max(0.0) as usize).min(axis.file_cells);
            (first..end)
                .map(|j| (j, kernel.weight((j as f64 + 0.5 - at) * stretch)))
                .collect()
        })
    });
    let void = |value: f32| value.is_nan() || source.nodata.is_some_and(|n| f64::from(value) == n);
    // Taps whose longest run with data is under half of them give no value, for a
    // kernel with negative lobes.
    let too_broken = |with_data: &[bool]| {
        let mut longest = 0;
        let mut run = 0;
        for &has in with_data {
            run = if has { run + 1 } else { 0 };
            longest = longest.max(run);
        }
        kernel.has_negative_lobes() && longest < with_data.len() / 2
    };
    // Each source row the cells' taps reach, filtered along it for every VRT column (its
    // value, if any), then the columns: in blocks of rows, in parallel, the filtered
    // rows computed once for the block.
    let horizontal =
        |source_row: usize, column_taps: &[(usize, f64)], with_data: &mut Vec<bool>| {
            with_data.clear();
            let (mut sum, mut weights) = (0.0, 0.0);
            for &(source_col, weight) in column_taps {
                let value = file.at(source_col, source_row);
                with_data.push(!void(value));
                if !void(value) {
                    sum += weight * f64::from(value);
                    weights += weight;
                }
            }
            (weights > 0.0 && !too_broken(with_data)).then(|| sum / weights)
        };
    const BLOCK_ROWS: usize = 64;
    let width = width as usize;
    cells
        .par_chunks_mut(BLOCK_ROWS * width)
        .zip(rows.par_chunks(BLOCK_ROWS))
        .for_each(|(block, block_rows)| {
            let reached = block_rows.iter().flatten().map(|&(row, _)| row);
            let (Some(first), Some(last)) = (reached.clone().min(), reached.max()) else {
                return;
            };
            let mut with_data = Vec::new();
            let mut filtered = Vec::with_capacity((last + 1 - first) * width);
            for source_row in first..=last {
                for column_taps in &columns {
                    filtered.push(horizontal(source_row, column_taps, &mut with_data));
                }
            }
            for (cells, row_taps) in block.chunks_exact_mut(width).zip(block_rows) {
                for (col, cell) in cells.iter_mut().enumerate() {
                    let at = |source_row: usize| filtered[(source_row - first) * width + col];
                    with_data.clear();
                    with_data.extend(row_taps.iter().map(|&(row, _)| at(row).is_some()));
                    if too_broken(&with_data) {
                        continue;
                    }
                    let (mut sum, mut weights) = (0.0, 0.0);
                    for &(source_row, weight) in row_taps {
                        if let Some(value) = at(source_row) {
                            sum += weight * value;
                            weights += weight;
                        }
                    }
                    if weights > 0.0 {
                        *cell = (sum / weights * source.ratio + source.offset) as f32;
                    }
                }
            }
        });
}

/// `value` as the band's data type holds it: integers rounded to the nearest and held
/// within their range, as GDAL converts; floats as they are.
fn in_type(value: f64, data_type: &str) -> f64 {
    let range = match data_type {
        "Byte" => (0.0, 255.0),
        "Int8" => (-128.0, 127.0),
        "UInt16" => (0.0, 65535.0),
        "Int16" => (-32768.0, 32767.0),
        "UInt32" => (0.0, 4_294_967_295.0),
        "Int32" => (-2_147_483_648.0, 2_147_483_647.0),
        "UInt64" => (0.0, u64::MAX as f64),
        "Int64" => (i64::MIN as f64, i64::MAX as f64),
        "Float32" => return f64::from(value as f32),
        _ => return value,
    };
    if value.is_nan() {
        return value;
    }
    (value + 0.5).floor().clamp(range.0, range.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    const VRT: &str = r#"<VRTDataset rasterXSize="4" rasterYSize="2">
  <GeoTransform>100, 10, 0, 200, 0, -10</GeoTransform>
  <VRTRasterBand dataType="Int16" band="1">
    <NoDataValue>-1</NoDataValue>
    <Description>elevation &amp; more</Description>
    <SimpleSource>
      <SourceFilename relativeToVRT="1">a.tif</SourceFilename>
      <SourceBand>2</SourceBand>
      <SrcRect xOff="0" yOff="0" xSize="2" ySize="2" />
      <DstRect xOff="2" yOff="0" xSize="2" ySize="2" />
    </SimpleSource>
    <ComplexSource resampling="nearest">
      <SourceFilename relativeToVRT="0">/data/b.tif</SourceFilename>
      <NODATA>0</NODATA>
      <ScaleOffset>1</ScaleOffset>
      <ScaleRatio>2</ScaleRatio>
    </ComplexSource>
  </VRTRasterBand>
</VRTDataset>"#;

    #[test]
    fn bands_and_sources_as_gdalbuildvrt_writes_them() {
        let dataset = parse_dataset(Path::new("/maps/m.vrt"), VRT).unwrap();
        assert_eq!((dataset.width, dataset.height), (4, 2));
        let band = &dataset.bands[0];
        assert_eq!(band.data_type, "Int16");
        assert_eq!(band.nodata, Some(-1.0));
        assert_eq!(
            band.metadata.description.as_deref(),
            Some("elevation & more")
        );
        let [a, b] = &band.sources[..] else {
            panic!("{:?}", band.sources)
        };
        assert_eq!(a.file, Path::new("/maps/a.tif"));
        assert_eq!(a.band, 1);
        assert_eq!(a.place, Some(rect(2.0, 0.0, 2.0, 2.0)));
        assert_eq!((a.nodata, a.ratio, a.offset), (None, 1.0, 0.0));
        assert_eq!(b.file, Path::new("/data/b.tif"));
        assert_eq!((b.band, b.window, b.place), (0, None, None));
        assert_eq!((b.nodata, b.ratio, b.offset), (Some(0.0), 2.0, 1.0));
        assert_eq!(b.resampling, None);
    }

    #[test]
    fn what_computes_its_cells_is_refused_by_name() {
        let path = Path::new("m.vrt");
        let refused = |xml: &str, needle: &str| {
            let why = parse_dataset(path, xml).unwrap_err();
            assert!(why.contains(needle), "{needle}: {why}");
        };
        // What is replaced in a readable VRT, by what, and what the error then says.
        for (from, to, needle) in [
            (
                "<VRTDataset ",
                "<VRTDataset subClass=\"VRTWarpedDataset\" ",
                "VRTWarpedDataset",
            ),
            (
                "band=\"1\"",
                "band=\"1\" subClass=\"VRTDerivedRasterBand\"",
                "VRTDerivedRasterBand",
            ),
            (
                "<NODATA>0</NODATA>",
                "<LUT>0:0,1:10</LUT>",
                "band 1: source 2: its <LUT>",
            ),
            (
                "/data/b.tif",
                "/vsicurl/https://x/b.tif",
                "virtual file system",
            ),
            (
                "<SourceBand>2</SourceBand>",
                "<SourceBand>mask,1</SourceBand>",
                "'mask,1'",
            ),
            ("dataType=\"Int16\"", "dataType=\"CFloat32\"", "complex"),
            ("rasterXSize=\"4\"", "rasterXSize=\"0\"", "rasterXSize"),
            ("</VRTDataset>", "", "malformed"),
        ] {
            refused(&VRT.replace(from, to), needle);
        }
        refused("<PAMDataset/>", "<PAMDataset>");
    }

    fn rect(x: f64, y: f64, width: f64, height: f64) -> Rect {
        Rect {
            x,
            y,
            width,
            height,
        }
    }

    /// A 2 × 2 source: rows from the south as the reader gives them, from the north as
    /// the file has them.
    fn source(values: &[f32]) -> SourceCells<'_> {
        SourceCells {
            values,
            width: 2,
            height: 2,
            order: FileOrder::NORTH_UP,
        }
    }

    fn a_source(window: Option<Rect>, place: Option<Rect>) -> Source {
        Source {
            file: PathBuf::from("a.tif"),
            band: 0,
            window,
            place,
            nodata: None,
            ratio: 1.0,
            offset: 0.0,
            resampling: None,
            averaging: Averaging::WholeCells,
        }
    }

    #[test]
    fn sources_land_on_their_place_with_their_voids_transparent() {
        // File rows from the north: [1, 2] over [3, NaN]; ours from the south.
        let values = [3.0, f32::NAN, 1.0, 2.0];
        let mut cells = vec![9.0; 8];
        let place = rect(2.0, 0.0, 2.0, 2.0);
        place_source(&mut cells, &a_source(None, Some(place)), &values);
        assert_eq!(cells, [9.0, 9.0, 1.0, 2.0, 9.0, 9.0, 3.0, 9.0]);
        // Scaled, with the source's own nodata value transparent too.
        let mut cells = vec![9.0; 8];
        let scaled = Source {
            nodata: Some(2.0),
            ratio: 2.0,
            offset: 1.0,
            ..a_source(None, None)
        };
        place_source(&mut cells, &scaled, &values);
        assert_eq!(cells, [3.0, 9.0, 9.0, 9.0, 7.0, 9.0, 9.0, 9.0]);
    }

    #[test]
    fn a_window_of_another_size_takes_the_nearest_cell() {
        // The whole 2 × 2 source spread over 4 × 2 cells: each column twice.
        let values = [3.0, 4.0, 1.0, 2.0];
        let mut cells = vec![0.0; 8];
        let spread = rect(0.0, 0.0, 4.0, 2.0);
        place_source(&mut cells, &a_source(None, Some(spread)), &values);
        assert_eq!(cells, [1.0, 1.0, 2.0, 2.0, 3.0, 3.0, 4.0, 4.0]);
        let mode = Source {
            resampling: Some("mode".into()),
            ..a_source(None, Some(spread))
        };
        let why = place(&mut cells, [4, 2], &mode, &source(&values)).unwrap_err();
        assert!(why.contains("'mode'"), "{why}");
        // A window reaching past the file takes only the file's cells.
        let mut cells = vec![0.0; 8];
        let window = rect(1.0, 0.0, 2.0, 2.0);
        let past = a_source(Some(window), Some(Rect { x: 0.0, ..window }));
        place_source(&mut cells, &past, &values);
        assert_eq!(cells, [2.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn a_shrunk_window_is_averaged_as_gdal_averages_its_kind_of_source() {
        // File rows from the north: [1, 2, 3] over [4, NaN, 6]; ours from the south.
        let values = [4.0, f32::NAN, 6.0, 1.0, 2.0, 3.0];
        let file = SourceCells {
            values: &values,
            width: 3,
            height: 2,
            order: FileOrder::NORTH_UP,
        };
        // Three columns onto two cells of one row: 1.5 source cells each.
        let onto = |averaging| {
            let source = Source {
                resampling: Some("average".into()),
                averaging,
                ..a_source(None, Some(rect(0.0, 0.0, 2.0, 1.0)))
            };
            let mut cells = vec![0.0f32; 2];
            place(&mut cells, [2, 1], &source, &file).unwrap();
            cells
        };
        // Shares of the cells covered, the void left out: (1 + 0.5·2 + 4) / 2.5 and
        // (0.5·2 + 3 + 6) / 2.5.
        assert_eq!(onto(Averaging::AreaWeighted), [2.4, 4.0]);
        // Whole cells between rounded ends: columns 0–1 and 2 (1.5 rounds up).
        assert_eq!(onto(Averaging::WholeCells), [7.0 / 3.0, 4.5]);
        // A span of voids leaves its cell as it was.
        let voids = [f32::NAN; 6];
        let file = SourceCells {
            values: &voids,
            ..file
        };
        let source = Source {
            resampling: Some("average".into()),
            ..a_source(None, Some(rect(0.0, 0.0, 1.0, 1.0)))
        };
        let mut cells = vec![9.0f32];
        place(&mut cells, [1, 1], &source, &file).unwrap();
        assert_eq!(cells, [9.0]);
    }

    #[test]
    fn a_window_of_another_size_is_interpolated_as_gdal_convolves_it() {
        // One row [0, 10] stretched over four cells: the textbook bilinear ramp, the
        // taps past the file's edges cut and the rest normalised.
        let values = [0.0, 10.0];
        let file = SourceCells {
            values: &values,
            width: 2,
            height: 1,
            order: FileOrder::rows(false),
        };
        let onto = |resampling: &str, file: &SourceCells| {
            let source = Source {
                resampling: Some(resampling.into()),
                ..a_source(None, Some(rect(0.0, 0.0, 4.0, 1.0)))
            };
            let mut cells = vec![-1.0f32; 4];
            place(&mut cells, [4, 1], &source, file).unwrap();
            cells
        };
        assert_eq!(onto("bilinear", &file), [0.0, 2.5, 7.5, 10.0]);
        // Keys' cubic overshoots past the ends: at the first cell's centre a quarter
        // cell from the file's first, 10 × w(1.25) / (w(0.25) + w(1.25)) with
        // w(0.25) = 0.8671875, w(1.25) = −0.0703125; the same mirrored at the other end.
        let cubic = onto("cubic", &file);
        assert!((cubic[0] + 0.882_352_9).abs() < 1e-5, "{cubic:?}");
        for (a, b) in cubic.iter().zip(cubic.iter().rev()) {
            assert!((a + b - 10.0).abs() < 1e-5, "{cubic:?}");
        }
        // A void takes no weight: the other cell alone.
        let with_void = [f32::NAN, 10.0];
        let file = SourceCells {
            values: &with_void,
            ..file
        };
        assert_eq!(onto("cubicspline", &file), [10.0; 4]);
        // The kernels: one at 0 (but the B-spline's), none at their reach.
        for kernel in [
            Kernel::Bilinear,
            Kernel::Cubic,
            Kernel::CubicSpline,
            Kernel::Lanczos,
        ] {
            assert!(kernel.weight(kernel.radius()).abs() < 1e-12, "{kernel:?}");
        }
        assert!(Kernel::Lanczos.weight(1.0).abs() < 1e-12);
        assert_eq!(Kernel::Lanczos.weight(0.0), 1.0);
        assert_eq!(Kernel::Cubic.weight(0.0), 1.0);
        assert!((Kernel::CubicSpline.weight(0.0) - 2.0 / 3.0).abs() < 1e-12);
        assert!((Kernel::CubicSpline.weight(1.0) - 1.0 / 6.0).abs() < 1e-12);
    }

    fn place_source(cells: &mut [f32], source_: &Source, values: &[f32]) {
        place(cells, [4, 2], source_, &source(values)).unwrap();
    }

    #[test]
    fn values_are_held_as_the_band_type_holds_them() {
        assert_eq!(in_type(2.5, "Int16"), 3.0);
        assert_eq!(in_type(-2.5, "Int16"), -2.0);
        assert_eq!(in_type(300.0, "Byte"), 255.0);
        assert_eq!(in_type(-4.0, "UInt16"), 0.0);
        assert_eq!(in_type(0.1, "Float32"), f64::from(0.1f32));
        assert_eq!(in_type(0.1, "Float64"), 0.1);
    }
}
