//! GDAL's sidecars: what GDAL keeps of a GeoTIFF beside it.
//!
//! GDAL takes the georeference from the PAM sidecar (`<file>.aux.xml`: `<SRS>` and
//! `<GeoTransform>`, each in preference to the TIFF's own: GDAL writes them there when
//! it may not change the TIFF itself), then from the GeoTIFF tags, then
//! from a world file (`.tfw`, `.tifw`, `.wld`: six numbers, the cell size and the centre
//! of the top-left cell), which TIFFs with no georeference of their own have (GDAL's
//! `PROFILE=BASELINE`, scanners, older tools).
//!
//! The PAM sidecar also says which bands hold classes, as land covers converted by
//! `gdal_translate` or classified in QGIS carry them:
//! - a colour table (`<ColorTable>`) on a band that is not a palette image;
//! - category names (`<CategoryNames>`);
//! - a raster attribute table (`<GDALRasterAttributeTable>`) with a name or a colour
//!   per value (a string field, or a field of usage Name, Red, Green, Blue or Alpha).
//!   A table of values and counts alone is not enough: GDAL calls every table
//!   "thematic", and ArcGIS builds one for any integer raster, DEMs included.

use std::path::{Path, PathBuf};

use quick_xml::events::{BytesStart, Event};
use quick_xml::reader::Reader;

use super::metadata::BandMetadata;

/// `path` with `suffix` added to its name.
fn beside(path: &Path, suffix: &str) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(suffix);
    PathBuf::from(name)
}

/// The PAM sidecar GDAL reads beside `path`.
pub fn sidecar(path: &Path) -> PathBuf {
    beside(path, ".aux.xml")
}

/// The world files GDAL looks for beside `path`, in its order: the extension's first
/// and last letters and `w`, the extension and `w`, then `wld` (`x.tfw`, `x.tifw`,
/// `x.wld` for `x.tif`; `x.pgw`, `x.pngw` for `x.png`; `x.jgw`, `x.jpgw` for `x.jpg`),
/// and for a TIFF `x.tif.tfw`.
fn world_files(path: &Path) -> Vec<PathBuf> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let mut extensions = Vec::new();
    if let (Some(first), Some(last)) = (extension.chars().next(), extension.chars().last())
        && extension.chars().count() >= 2
    {
        extensions.push(format!("{first}{last}w"));
        extensions.push(format!("{extension}w"));
    }
    extensions.push("wld".into());
    let mut files: Vec<PathBuf> = extensions
        .iter()
        .map(|ext| path.with_extension(ext))
        .collect();
    if extension.starts_with("tif") {
        files.push(beside(path, ".tfw"));
    }
    files
}

/// Every sidecar of `path` that exists: what reading it may depend on.
pub fn sidecars(path: &Path) -> Vec<PathBuf> {
    let mut files = vec![sidecar(path)];
    files.extend(world_files(path));
    files.retain(|f| f.is_file());
    files.dedup();
    files
}

/// What the PAM sidecar says of the dataset's georeference, which GDAL prefers to the
/// TIFF's own (its `GDAL_GEOREF_SOURCES`: the sidecar, the GeoTIFF tags, a world file).
#[derive(Debug, Default, Clone, PartialEq)]
pub(crate) struct PamGeoreference {
    /// GDAL's geotransform as ours (x = a·col + b·row + c, y = d·col + e·row + f).
    pub transform: Option<[f64; 6]>,
    /// The CRS as the GeoKeys GDAL would have written for it; `Err` saying why where
    /// the sidecar has a CRS we cannot read.
    pub keys: Option<Result<Vec<u16>, String>>,
    /// The GeoAsciiParams those keys point into: for a CRS with no EPSG code, its WKT
    /// as an ESRI PE string (GTCitationGeoKey), whose parameters give the projection.
    pub citation: String,
}

/// The georeference in the PAM sidecar of `path` (nothing where there is none); an
/// error names the sidecar where its XML is malformed.
pub(crate) fn georeference(path: &Path) -> Result<PamGeoreference, String> {
    let pam = sidecar(path);
    let Ok(xml) = std::fs::read_to_string(&pam) else {
        return Ok(PamGeoreference::default());
    };
    let (srs, transform) = dataset_georeference(&xml)
        .map_err(|e| format!("{}: its XML is malformed: {e}", pam.display()))?;
    let mut citation = String::new();
    let keys = srs.map(|wkt| {
        let (keys, ascii) = wkt_geokeys(&wkt).ok_or_else(|| {
            format!(
                "{}: its CRS is neither a projected nor a geographic CRS in WKT: give the \
                 raster its GeoTIFF tags (gdal_translate -a_srs EPSG:<code>)",
                pam.display()
            )
        })?;
        citation = ascii;
        Ok(keys)
    });
    Ok(PamGeoreference {
        transform,
        keys,
        citation,
    })
}

/// The GeoKeys GDAL would write for a CRS in WKT (a sidecar's `<SRS>`, a `.prj` file),
/// with the GeoAsciiParams they point into (empty where the CRS has an EPSG code);
/// `None` for what is neither a projected nor a geographic CRS.
pub fn wkt_geokeys(wkt: &str) -> Option<(Vec<u16>, String)> {
    match geokeys_of_wkt(wkt) {
        Some(keys) => Some((keys, String::new())),
        None => user_defined_geokeys(wkt),
    }
}

/// The geotransform of the first world file beside `path` (`None` where there is none),
/// as ours; an error names the file and what is wrong with it.
pub(crate) fn world_file_transform(path: &Path) -> Result<Option<[f64; 6]>, String> {
    let Some(world) = world_files(path).into_iter().find(|f| f.is_file()) else {
        return Ok(None);
    };
    let text = std::fs::read_to_string(&world)
        .map_err(|e| format!("{}: cannot be read: {e}", world.display()))?;
    world_file(&text)
        .map(Some)
        .map_err(|e| format!("{}: {e}", world.display()))
}

/// GDAL's geotransform [x0, dx, rx, y0, ry, dy] as ours: x = a·col + b·row + c,
/// y = d·col + e·row + f.
fn from_gdal([x0, dx, rx, y0, ry, dy]: [f64; 6]) -> [f64; 6] {
    [dx, rx, x0, ry, dy, y0]
}

/// A world file's six numbers (A, D, B, E, C, F: the cell's x size, the rotation terms,
/// its y size, and the centre of the top-left cell) as our geotransform, whose origin
/// is that cell's corner.
fn world_file(text: &str) -> Result<[f64; 6], String> {
    let numbers: Vec<f64> = text
        .split_whitespace()
        .map(|t| {
            t.parse::<f64>()
                .map_err(|_| format!("'{t}' is not a number"))
        })
        .collect::<Result<_, _>>()?;
    let [a, d, b, e, c, f] = numbers[..] else {
        return Err(format!(
            "a world file holds six numbers, this one {}",
            numbers.len()
        ));
    };
    Ok([a, b, c - a / 2.0 - b / 2.0, d, e, f - d / 2.0 - e / 2.0])
}

/// The dataset's `<SRS>` (WKT) and `<GeoTransform>` in a PAM document.
pub(crate) fn dataset_georeference(
    xml: &str,
) -> Result<(Option<String>, Option<[f64; 6]>), String> {
    let mut reader = Reader::from_str(xml);
    let (mut srs, mut transform) = (None, None);
    let mut depth = 0usize;
    let mut element = Vec::new();
    let mut text = String::new();
    loop {
        match reader.read_event().map_err(|e| e.to_string())? {
            Event::Eof => break,
            Event::Start(tag) => {
                depth += 1;
                element = tag.name().as_ref().to_vec();
                text.clear();
            }
            Event::Text(t) => text.push_str(&t.decode().map_err(|e| e.to_string())?),
            Event::GeneralRef(reference) => {
                let name = reference.decode().map_err(|e| e.to_string())?;
                match quick_xml::escape::resolve_xml_entity(&name) {
                    Some(resolved) => text.push_str(resolved),
                    None => text.push_str(&format!("&{name};")),
                }
            }
            Event::End(_) => {
                // Children of <PAMDataset> only: bands have no georeference.
                if depth == 2 {
                    match element.as_slice() {
                        b"SRS" => srs = Some(text.trim().to_string()),
                        b"GeoTransform" => {
                            let numbers: Vec<f64> = text
                                .split(',')
                                .map(|t| t.trim().parse::<f64>())
                                .collect::<Result<_, _>>()
                                .map_err(|_| format!("<GeoTransform> '{}'", text.trim()))?;
                            let six: [f64; 6] = numbers.try_into().map_err(|_| {
                                format!("<GeoTransform> '{}' is not six numbers", text.trim())
                            })?;
                            transform = Some(from_gdal(six));
                        }
                        _ => {}
                    }
                }
                depth = depth.saturating_sub(1);
                element.clear();
                text.clear();
            }
            _ => {}
        }
    }
    Ok((srs.filter(|s| !s.is_empty()), transform))
}

/// The GeoKeys (a GeoKeyDirectory) GDAL would write for a CRS given as WKT 1 or 2 with
/// its EPSG code at the top (`AUTHORITY["EPSG","32633"]`, `ID["EPSG",32633]`): the model
/// type, the code, and for a projected CRS its linear unit ([`linear_unit_code`]).
fn geokeys_of_wkt(wkt: &str) -> Option<Vec<u16>> {
    let wkt = wkt.trim();
    let root = wkt.split('[').next()?.trim().to_ascii_uppercase();
    if matches!(root.as_str(), "COMPD_CS" | "COMPOUNDCRS") {
        return geokeys_of_compound(wkt);
    }
    let geographic = matches!(root.as_str(), "GEOGCS" | "GEOGCRS" | "GEOGRAPHICCRS");
    let projected = matches!(root.as_str(), "PROJCS" | "PROJCRS" | "PROJECTEDCRS");
    if !geographic && !projected {
        return None;
    }
    let top = top_level(wkt);
    let code = |items: &[(String, String)]| {
        items
            .iter()
            .filter(|(keyword, _)| keyword == "AUTHORITY" || keyword == "ID")
            .filter_map(|(_, body)| epsg_code(body))
            .next_back()
    };
    let code = code(&top).or_else(|| esri_name_code(&crs_name(wkt)?))?;
    let mut keys: Vec<[u16; 4]> = vec![[1024, 0, 1, if geographic { 2 } else { 1 }]];
    keys.push([if geographic { 2048 } else { 3072 }, 0, 1, code]);
    if projected && let Some(unit) = linear_unit_code(&top) {
        keys.push([3076, 0, 1, unit]);
    }
    let mut directory = vec![1, 1, 0, keys.len() as u16];
    directory.extend(keys.into_iter().flatten());
    Some(directory)
}

/// The name a WKT CRS gives itself (its first quoted string).
fn crs_name(wkt: &str) -> Option<String> {
    let start = wkt.find('"')? + 1;
    let length = wkt[start..].find('"')?;
    Some(wkt[start..start + length].to_string())
}

/// The EPSG code of the CRSs ArcGIS names without one in its WKT (ESRI's names of UTM
/// zones on WGS 84, NAD83, NAD27 and ETRS89, their geographic CRSs, and Web Mercator).
fn esri_name_code(name: &str) -> Option<u16> {
    let fixed = match name {
        "GCS_WGS_1984" => Some(4326),
        "GCS_North_American_1983" => Some(4269),
        "GCS_North_American_1927" => Some(4267),
        "GCS_ETRS_1989" => Some(4258),
        "WGS_1984_Web_Mercator_Auxiliary_Sphere" | "WGS_1984_Web_Mercator" => Some(3857),
        _ => None,
    };
    if fixed.is_some() {
        return fixed;
    }
    let (datum, zone) = name.split_once("_UTM_Zone_")?;
    let hemisphere = zone.chars().last()?;
    let number: u16 = zone[..zone.len() - hemisphere.len_utf8()].parse().ok()?;
    let (base, zones) = match (datum, hemisphere) {
        ("WGS_1984", 'N') => (32600, 1..=60),
        ("WGS_1984", 'S') => (32700, 1..=60),
        ("NAD_1983", 'N') => (26900, 1..=23),
        ("NAD_1927", 'N') => (26700, 1..=22),
        ("ETRS_1989", 'N') => (25800, 28..=38),
        _ => return None,
    };
    zones.contains(&number).then_some(base + number)
}

/// The GeoKeys GDAL writes for a CRS with no EPSG code (ArcGIS's sidecars hold such
/// ESRI WKT; WKT 2 where WKT 1 cannot say it): user-defined (32767), its unit, and a
/// citation (GTCitationGeoKey) holding the WKT (WKT 1 as an ESRI PE string, as GDAL
/// writes one), returned beside the keys as the GeoAsciiParams they point into; the
/// reader takes the projection's parameters from it. `None` for what is neither a
/// projected nor a geographic CRS.
fn user_defined_geokeys(wkt: &str) -> Option<(Vec<u16>, String)> {
    let wkt = wkt.trim();
    let root = wkt.split('[').next()?.trim().to_ascii_uppercase();
    let geographic = matches!(root.as_str(), "GEOGCS" | "GEOGCRS" | "GEOGRAPHICCRS");
    let projected = matches!(root.as_str(), "PROJCS" | "PROJCRS" | "PROJECTEDCRS");
    if !geographic && !projected {
        return None;
    }
    let top = top_level(wkt);
    let citation = if root.ends_with("CS") {
        format!("ESRI PE String = {wkt}|")
    } else {
        format!("{wkt}|")
    };
    let length = u16::try_from(citation.len()).ok()?;
    let mut keys: Vec<[u16; 4]> = vec![
        [1024, 0, 1, if geographic { 2 } else { 1 }],
        [1026, 34737, length, 0],
    ];
    if geographic {
        let angular = match angular_unit_factor(&top) {
            Some(f) if (f / 1f64.to_radians() - 1.0).abs() < 1e-9 => 9102,
            Some(f) if (f - 1.0).abs() < 1e-12 => 9101,
            Some(f) if (f / 0.9f64.to_radians() - 1.0).abs() < 1e-9 => 9105,
            _ => 32767,
        };
        keys.extend([[2048, 0, 1, 32767], [2054, 0, 1, angular]]);
    } else {
        keys.push([3072, 0, 1, 32767]);
        if let Some(unit) = linear_unit_code(&top) {
            keys.push([3076, 0, 1, unit]);
        }
    }
    let mut directory = vec![1, 1, 0, keys.len() as u16];
    directory.extend(keys.into_iter().flatten());
    Some((directory, citation))
}

/// Radians per unit of a geographic CRS's angles ([`unit_body`]); `None` where the
/// unit gives no factor, and degrees where the CRS gives no unit, as GDAL takes them.
fn angular_unit_factor(top: &[(String, String)]) -> Option<f64> {
    match unit_body(top, "ANGLEUNIT") {
        Some(body) => body.split(',').nth(1)?.trim().parse().ok(),
        None => Some(1f64.to_radians()),
    }
}

/// The body of a CRS's unit: WKT 1's `UNIT` or WKT 2's `unit_keyword` (`LENGTHUNIT`,
/// `ANGLEUNIT`) at its top level, else in its axes (where PROJ's WKT 2 puts it).
fn unit_body(top: &[(String, String)], unit_keyword: &str) -> Option<String> {
    let is_unit = |keyword: &str| keyword == "UNIT" || keyword == unit_keyword;
    top.iter()
        .filter(|(keyword, _)| is_unit(keyword))
        .map(|(_, body)| body.clone())
        .next_back()
        .or_else(|| {
            top.iter()
                .filter(|(keyword, _)| keyword == "AXIS")
                .find_map(|(_, axis)| {
                    top_level(&format!("AXIS[{axis}]"))
                        .into_iter()
                        .find(|(keyword, _)| is_unit(keyword))
                        .map(|(_, body)| body)
                })
        })
}

/// The GeoKeys of a compound CRS (GDAL's for a DEM with a vertical datum,
/// `EPSG:2263+6360`): its horizontal CRS's, and its vertical CRS's code and unit
/// (VerticalCSType, VerticalUnits), which give the heights' unit.
fn geokeys_of_compound(wkt: &str) -> Option<Vec<u16>> {
    let top = top_level(wkt);
    let horizontal = top.iter().find(|(keyword, _)| {
        matches!(
            keyword.as_str(),
            "PROJCS" | "PROJCRS" | "PROJECTEDCRS" | "GEOGCS" | "GEOGCRS" | "GEOGRAPHICCRS"
        )
    })?;
    let mut directory = geokeys_of_wkt(&format!("{}[{}]", horizontal.0, horizontal.1))?;
    if let Some((_, vertical)) = top
        .iter()
        .find(|(keyword, _)| matches!(keyword.as_str(), "VERT_CS" | "VERTCRS" | "VERTICALCRS"))
    {
        let items = top_level(&format!("VERT_CS[{vertical}]"));
        let mut keys = Vec::new();
        if let Some(code) = items
            .iter()
            .filter(|(keyword, _)| keyword == "AUTHORITY" || keyword == "ID")
            .filter_map(|(_, body)| epsg_code(body))
            .next_back()
        {
            keys.push([4096, 0, 1, code]);
        }
        if let Some(unit) = linear_unit_code(&items) {
            keys.push([4099, 0, 1, unit]);
        }
        directory[3] += keys.len() as u16;
        directory.extend(keys.into_iter().flatten());
    }
    Some(directory)
}

/// Metres per unit of the EPSG linear units a CRS's WKT may give by factor alone.
const LINEAR_UNITS: [(u16, f64); 4] = [
    (9001, 1.0),
    (9002, 0.3048),
    (9003, 1200.0 / 3937.0),
    (9036, 1000.0),
];

/// The EPSG code of a projected CRS's linear unit, from the unit at its top level
/// (WKT 1's `UNIT`, WKT 2's `LENGTHUNIT`) or in its axes (where PROJ's WKT 2 puts it,
/// without a code): by its factor to metres, else by its own code, else user-defined
/// (32767, which cannot be measured). `None` where the CRS gives no unit.
fn linear_unit_code(top: &[(String, String)]) -> Option<u16> {
    let body = unit_body(top, "LENGTHUNIT")?;
    let factor = body
        .split(',')
        .nth(1)
        .and_then(|f| f.trim().parse::<f64>().ok());
    let by_factor = factor.and_then(|factor| {
        LINEAR_UNITS
            .iter()
            .find(|(_, metres)| (factor / metres - 1.0).abs() < 1e-9)
            .map(|&(code, _)| code)
    });
    let by_code = || {
        top_level(&format!("UNIT[{body}]"))
            .iter()
            .filter(|(keyword, _)| keyword == "AUTHORITY" || keyword == "ID")
            .find_map(|(_, authority)| epsg_code(authority))
    };
    Some(by_factor.or_else(by_code).unwrap_or(32767))
}

/// The elements directly inside a WKT node's brackets: (KEYWORD, the text between its
/// brackets).
fn top_level(wkt: &str) -> Vec<(String, String)> {
    let mut items = Vec::new();
    let (mut depth, mut quoted) = (0usize, false);
    let (mut keyword, mut start) = (String::new(), 0usize);
    let mut token = String::new();
    for (i, ch) in wkt.char_indices() {
        match ch {
            '"' => quoted = !quoted,
            _ if quoted => {}
            '[' | '(' => {
                depth += 1;
                if depth == 2 {
                    keyword = token.trim().to_ascii_uppercase();
                    start = i + 1;
                }
                token.clear();
            }
            ']' | ')' => {
                if depth == 2 {
                    items.push((keyword.clone(), wkt[start..i].to_string()));
                }
                depth = depth.saturating_sub(1);
                token.clear();
            }
            ',' => token.clear(),
            _ => token.push(ch),
        }
    }
    items
}

/// The code of an authority's body (`"EPSG","32633"` or `"EPSG",32633`), if EPSG's.
fn epsg_code(body: &str) -> Option<u16> {
    let mut parts = body.split(',').map(|p| p.trim().trim_matches('"'));
    if !parts.next()?.eq_ignore_ascii_case("EPSG") {
        return None;
    }
    parts.next()?.parse::<u16>().ok()
}

/// The bands (numbered from 0) that the sidecar of `path` declares classes; none where
/// there is no sidecar. A sidecar that cannot be read or parsed is left out with a
/// warning, as GDAL does.
pub(crate) fn declared_class_bands(path: &Path) -> Vec<usize> {
    let sidecar = sidecar(path);
    let Ok(xml) = std::fs::read_to_string(&sidecar) else {
        return Vec::new();
    };
    match class_bands(&xml) {
        Ok(bands) => bands,
        Err(e) => {
            tracing::warn!(
                "{}: not read (its XML is malformed: {e}); its bands are read without it",
                sidecar.display()
            );
            Vec::new()
        }
    }
}

/// What a PAM sidecar says of the bands of a raster whose format has no room for it
/// (GDAL keeps a PNG's, a JPEG's or a JPEG 2000's band descriptions, units, scales,
/// offsets and nodata values there).
#[derive(Debug, Default, Clone, PartialEq)]
pub(crate) struct PamBands {
    /// Each band's description, unit, scale and offset.
    pub metadata: Vec<BandMetadata>,
    /// Each band's `<NoDataValue>`.
    pub nodata: Vec<Option<f64>>,
    /// Whether the sidecar has a `<PAMRasterBand>` for the band: GDAL then takes its
    /// `<Description>`, empty where it has none, over the band's own description.
    pub listed: Vec<bool>,
    /// The dataset's `NODATA_VALUES` (one per band: a cell is nodata where every band
    /// holds its value), as GDAL keeps an RGB PNG's transparent colour.
    pub nodata_values: Option<Vec<f64>>,
}

/// What the PAM sidecar of `path` says of its `count` bands (nothing where there is no
/// sidecar); an error names the sidecar where its XML or a number in it is malformed.
pub(crate) fn bands(path: &Path, count: usize) -> Result<PamBands, String> {
    let pam = sidecar(path);
    let mut bands = PamBands {
        metadata: vec![BandMetadata::default(); count],
        nodata: vec![None; count],
        nodata_values: None,
        listed: vec![false; count],
    };
    let Ok(xml) = std::fs::read_to_string(&pam) else {
        return Ok(bands);
    };
    read_bands(&xml, &mut bands).map_err(|e| format!("{}: {e}", pam.display()))?;
    Ok(bands)
}

/// Fills `bands` from a PAM document's `<PAMRasterBand>` children and its dataset
/// metadata's `NODATA_VALUES`.
fn read_bands(xml: &str, bands: &mut PamBands) -> Result<(), String> {
    let mut reader = Reader::from_str(xml);
    // The open elements, the open <PAMRasterBand>'s band, the open <MDI>'s key, and
    // the text read in the innermost element so far.
    let mut open: Vec<Vec<u8>> = Vec::new();
    let mut band: Option<usize> = None;
    let mut key: Option<String> = None;
    let mut default_domain = false;
    let mut text = String::new();
    let number = |element: &str, text: &str| {
        text.trim()
            .parse::<f64>()
            .map_err(|_| format!("<{element}> '{}' is not a number", text.trim()))
    };
    loop {
        match reader
            .read_event()
            .map_err(|e| format!("its XML is malformed: {e}"))?
        {
            Event::Eof => break,
            Event::Start(tag) => {
                match tag.name().as_ref() {
                    b"PAMRasterBand" => {
                        band = band_number(&tag);
                        if let Some(listed) = band.and_then(|b| bands.listed.get_mut(b)) {
                            *listed = true;
                        }
                    }
                    b"Metadata" => {
                        default_domain = tag
                            .attributes()
                            .flatten()
                            .find(|a| a.key.as_ref() == b"domain")
                            .is_none_or(|a| a.value.is_empty());
                    }
                    b"MDI" => {
                        key = tag
                            .attributes()
                            .flatten()
                            .find(|a| a.key.as_ref() == b"key")
                            .map(|a| String::from_utf8_lossy(&a.value).into_owned());
                    }
                    _ => {}
                }
                open.push(tag.name().as_ref().to_vec());
                text.clear();
            }
            Event::Text(t) => text.push_str(&t.decode().map_err(|e| e.to_string())?),
            Event::End(_) => {
                let element = open.pop().unwrap_or_default();
                let parent = open.last().map(Vec::as_slice);
                let in_band = parent == Some(b"PAMRasterBand");
                let value = text.trim();
                match (element.as_slice(), band) {
                    (b"PAMRasterBand", _) => band = None,
                    (b"Description", Some(b)) if in_band && b < bands.metadata.len() => {
                        bands.metadata[b].description =
                            Some(value.to_string()).filter(|d| !d.is_empty());
                    }
                    (b"UnitType", Some(b)) if in_band && b < bands.metadata.len() => {
                        bands.metadata[b].unit = Some(value.to_string()).filter(|u| !u.is_empty());
                    }
                    (b"Scale", Some(b)) if in_band && b < bands.metadata.len() => {
                        bands.metadata[b].scale = number("Scale", value)?;
                    }
                    (b"Offset", Some(b)) if in_band && b < bands.metadata.len() => {
                        bands.metadata[b].offset = number("Offset", value)?;
                    }
                    (b"NoDataValue", Some(b)) if in_band && b < bands.nodata.len() => {
                        bands.nodata[b] = Some(number("NoDataValue", value)?);
                    }
                    // The dataset's own metadata (a <Metadata> of the default domain
                    // under <PAMDataset>).
                    (b"MDI", None)
                        if open.len() == 2
                            && default_domain
                            && key.as_deref() == Some("NODATA_VALUES") =>
                    {
                        let values = value
                            .split_whitespace()
                            .map(|v| number("MDI key=\"NODATA_VALUES\"", v))
                            .collect::<Result<Vec<f64>, String>>()?;
                        if values.len() == bands.nodata.len() {
                            bands.nodata_values = Some(values);
                        }
                    }
                    _ => {}
                }
                text.clear();
            }
            _ => {}
        }
    }
    Ok(())
}

/// GDAL's field usages that give each value a name or a colour (GFU_Name, GFU_Red,
/// GFU_Green, GFU_Blue, GFU_Alpha), and its string field type (GFT_String).
const NAME_OR_COLOUR_USAGES: [&str; 5] = ["2", "6", "7", "8", "9"];
const STRING_TYPE: &str = "2";

/// The bands that a PAM document declares classes, numbered from 0, in ascending order.
fn class_bands(xml: &str) -> Result<Vec<usize>, quick_xml::Error> {
    let mut reader = Reader::from_str(xml);
    let mut bands = Vec::new();
    // The open <PAMRasterBand>'s number, whether it holds a <GDALRasterAttributeTable>,
    // the innermost open element's name, and the text read in it so far.
    let mut band: Option<usize> = None;
    let mut in_table = false;
    let mut element = Vec::new();
    let mut text = String::new();
    loop {
        match reader.read_event()? {
            Event::Eof => break,
            Event::Start(tag) => {
                match tag.name().as_ref() {
                    b"PAMRasterBand" => band = band_number(&tag),
                    b"GDALRasterAttributeTable" => in_table = true,
                    b"ColorTable" | b"CategoryNames" => declare(band, &mut bands),
                    _ => {}
                }
                element = tag.name().as_ref().to_vec();
                text.clear();
            }
            Event::Empty(tag) if tag.name().as_ref() == b"ColorTable" => declare(band, &mut bands),
            Event::Text(t) => text.push_str(&t.decode().map_err(quick_xml::Error::from)?),
            Event::End(tag) => {
                let value = text.trim();
                let name_or_colour = match element.as_slice() {
                    b"Type" => value == STRING_TYPE,
                    b"Usage" => NAME_OR_COLOUR_USAGES.contains(&value),
                    _ => false,
                };
                if in_table && name_or_colour {
                    declare(band, &mut bands);
                }
                match tag.name().as_ref() {
                    b"PAMRasterBand" => band = None,
                    b"GDALRasterAttributeTable" => in_table = false,
                    _ => {}
                }
                element.clear();
                text.clear();
            }
            _ => {}
        }
    }
    bands.sort_unstable();
    Ok(bands)
}

/// Adds the open band, if any, to `bands` once.
fn declare(band: Option<usize>, bands: &mut Vec<usize>) {
    if let Some(b) = band
        && !bands.contains(&b)
    {
        bands.push(b);
    }
}

/// A `<PAMRasterBand band="N">`'s band, numbered from 0 (GDAL numbers from 1).
fn band_number(tag: &BytesStart) -> Option<usize> {
    tag.attributes()
        .flatten()
        .find(|a| a.key.as_ref() == b"band")
        .and_then(|a| {
            std::str::from_utf8(&a.value)
                .ok()?
                .trim()
                .parse::<usize>()
                .ok()
        })
        .and_then(|n| n.checked_sub(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PAM document with one band holding `inner`.
    fn pam(inner: &str) -> String {
        format!(
            "<PAMDataset>\n  <PAMRasterBand band=\"1\">\n    <Metadata>\n      \
             <MDI key=\"STATISTICS_MAXIMUM\">44</MDI>\n    </Metadata>\n{inner}  \
             </PAMRasterBand>\n  <PAMRasterBand band=\"2\"/>\n</PAMDataset>\n"
        )
    }

    /// A raster attribute table of `fields` (name, type, usage), as GDAL writes it.
    fn table(fields: &[(&str, u8, u8)]) -> String {
        let mut xml = String::from("<GDALRasterAttributeTable tableType=\"thematic\">\n");
        for (i, (name, kind, usage)) in fields.iter().enumerate() {
            xml += &format!(
                "<FieldDefn index=\"{i}\"><Name>{name}</Name><Type>{kind}</Type>\
                 <Usage>{usage}</Usage></FieldDefn>\n"
            );
        }
        xml += "<Row index=\"0\"><F>1</F><F>10</F></Row>\n</GDALRasterAttributeTable>\n";
        xml
    }

    #[test]
    fn names_and_colours_declare_classes_and_counts_alone_do_not() {
        let categories =
            pam("<CategoryNames><Category/><Category>Urban</Category></CategoryNames>");
        assert_eq!(class_bands(&categories).unwrap(), [0]);
        let colours =
            pam("<ColorTable><Entry c1=\"0\" c2=\"0\" c3=\"0\" c4=\"255\"/></ColorTable>");
        assert_eq!(class_bands(&colours).unwrap(), [0]);
        let labels = pam(&table(&[
            ("Value", 0, 5),
            ("Count", 0, 1),
            ("LABEL3", 2, 2),
        ]));
        assert_eq!(class_bands(&labels).unwrap(), [0]);
        let red = pam(&table(&[("Value", 0, 5), ("Red", 0, 6)]));
        assert_eq!(class_bands(&red).unwrap(), [0]);
        // ArcGIS's table of an integer DEM, and statistics: no declaration.
        let counts = pam(&table(&[("Value", 0, 5), ("Count", 0, 1)]));
        assert!(class_bands(&counts).unwrap().is_empty());
        assert!(class_bands(&pam("")).unwrap().is_empty());
        // A usage "2" outside a table (statistics' text) declares nothing.
        assert!(class_bands(&pam("<Usage>2</Usage>\n")).unwrap().is_empty());
    }

    #[test]
    fn world_files_and_wkt_give_the_grid_and_the_geokeys() {
        // The centre of the top-left cell, as a world file gives it, is half a cell in.
        let grid = world_file("30\n0\n0\n-30\n500015\n4999985\n").unwrap();
        assert_eq!(grid, [30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0]);
        assert!(
            world_file("30 0 0 -30 500015")
                .unwrap_err()
                .contains("six numbers")
        );
        assert!(world_file("30 0 0 -30 x 1").unwrap_err().contains("'x'"));
        let utm = r#"PROJCS["WGS 84 / UTM zone 33N",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563,AUTHORITY["EPSG","7030"]],AUTHORITY["EPSG","6326"]],AUTHORITY["EPSG","4326"]],PROJECTION["Transverse_Mercator"],UNIT["metre",1,AUTHORITY["EPSG","9001"]],AXIS["Easting",EAST],AUTHORITY["EPSG","32633"]]"#;
        assert_eq!(
            geokeys_of_wkt(utm).unwrap(),
            [
                1, 1, 0, 3, 1024, 0, 1, 1, 3072, 0, 1, 32633, 3076, 0, 1, 9001
            ]
        );
        let wgs84 = r#"GEOGCRS["WGS 84",DATUM["World Geodetic System 1984",ELLIPSOID["WGS 84",6378137,298.257223563]],CS[ellipsoidal,2],ID["EPSG",4326]]"#;
        assert_eq!(
            geokeys_of_wkt(wgs84).unwrap(),
            [1, 1, 0, 2, 1024, 0, 1, 2, 2048, 0, 1, 4326]
        );
        // A CRS without its code at the top, or no CRS at all: no EPSG keys.
        assert_eq!(
            geokeys_of_wkt(r#"PROJCS["custom",GEOGCS["x",AUTHORITY["EPSG","4326"]]]"#),
            None
        );
        assert_eq!(geokeys_of_wkt("LOCAL_CS[\"x\"]"), None);
        assert_eq!(user_defined_geokeys("LOCAL_CS[\"x\"]"), None);
        let xml = "<PAMDataset><SRS>GEOGCS[&quot;x&quot;,AUTHORITY[&quot;EPSG&quot;,&quot;4326&quot;]]</SRS>\
                   <GeoTransform> 10, 0.5, 0, 50, 0, -0.5</GeoTransform></PAMDataset>";
        let (srs, transform) = dataset_georeference(xml).unwrap();
        assert_eq!(
            srs.as_deref(),
            Some(r#"GEOGCS["x",AUTHORITY["EPSG","4326"]]"#)
        );
        assert_eq!(transform, Some([0.5, 0.0, 10.0, 0.0, -0.5, 50.0]));
    }

    #[test]
    fn world_files_are_named_by_gdals_rule_for_every_extension() {
        let names = |file: &str| -> Vec<String> {
            world_files(Path::new(file))
                .iter()
                .map(|p| p.to_string_lossy().into_owned())
                .collect()
        };
        assert_eq!(names("a.tif"), ["a.tfw", "a.tifw", "a.wld", "a.tif.tfw"]);
        assert_eq!(names("a.png"), ["a.pgw", "a.pngw", "a.wld"]);
        assert_eq!(names("a.JPG"), ["a.jgw", "a.jpgw", "a.wld"]);
        assert_eq!(names("a.jpeg"), ["a.jgw", "a.jpegw", "a.wld"]);
    }

    #[test]
    fn band_descriptions_units_scales_and_nodata_come_from_the_sidecar() {
        let xml = "<PAMDataset><Metadata><MDI key=\"NODATA_VALUES\">5 5 5</MDI></Metadata>\
                   <Metadata domain=\"IMAGE_STRUCTURE\"><MDI key=\"NODATA_VALUES\">1 1 1</MDI></Metadata>\
                   <PAMRasterBand band=\"2\"><Description>elevation</Description>\
                   <NoDataValue>-9.999E+03</NoDataValue><UnitType>ft</UnitType>\
                   <Offset>10</Offset><Scale>0.5</Scale>\
                   <Metadata><MDI key=\"x\">y</MDI></Metadata></PAMRasterBand>\
                   <PAMRasterBand band=\"9\"><NoDataValue>1</NoDataValue></PAMRasterBand>\
                   </PAMDataset>";
        let mut bands = PamBands {
            metadata: vec![BandMetadata::default(); 3],
            nodata: vec![None; 3],
            nodata_values: None,
            listed: vec![false; 3],
        };
        read_bands(xml, &mut bands).unwrap();
        assert_eq!(bands.nodata, [None, Some(-9999.0), None]);
        assert_eq!(bands.listed, [false, true, false]);
        assert_eq!(bands.nodata_values, Some(vec![5.0; 3]));
        let band = &bands.metadata[1];
        assert_eq!(band.description.as_deref(), Some("elevation"));
        assert_eq!(band.unit.as_deref(), Some("ft"));
        assert_eq!((band.scale, band.offset), (0.5, 10.0));
        assert_eq!(bands.metadata[0], BandMetadata::default());
        let bad =
            "<PAMDataset><PAMRasterBand band=\"1\"><Scale>x</Scale></PAMRasterBand></PAMDataset>";
        assert!(
            read_bands(bad, &mut bands)
                .unwrap_err()
                .contains("<Scale> 'x'")
        );
    }

    #[test]
    fn esri_wkt_without_a_code_gives_the_code_of_its_name_or_user_defined_keys() {
        // ArcGIS's names of a UTM zone and of a geographic CRS: their EPSG codes.
        let utm = r#"PROJCS["WGS_1984_UTM_Zone_16N",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Transverse_Mercator"],PARAMETER["False_Easting",500000.0],PARAMETER["Central_Meridian",-87.0],PARAMETER["Scale_Factor",0.9996],UNIT["Meter",1.0]]"#;
        assert_eq!(
            geokeys_of_wkt(utm).unwrap(),
            [
                1, 1, 0, 3, 1024, 0, 1, 1, 3072, 0, 1, 32616, 3076, 0, 1, 9001
            ]
        );
        assert_eq!(esri_name_code("NAD_1983_UTM_Zone_10N"), Some(26910));
        assert_eq!(esri_name_code("WGS_1984_UTM_Zone_60S"), Some(32760));
        assert_eq!(esri_name_code("ETRS_1989_UTM_Zone_33N"), Some(25833));
        assert_eq!(esri_name_code("NAD_1983_UTM_Zone_61N"), None);
        assert_eq!(esri_name_code("WGS_1984_UTM_Zone_1é"), None);
        assert_eq!(esri_name_code("WGS_1984_UTM_Zone_"), None);
        assert_eq!(esri_name_code("GCS_WGS_1984"), Some(4326));
        // A State Plane grid in US survey feet by ESRI's name alone: user-defined keys,
        // its unit, and the WKT as the citation they point into.
        let feet = r#"PROJCS["NAD_1983_StatePlane_New_York_Long_Island_FIPS_3104_Feet",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic"],PARAMETER["False_Easting",984250.0],UNIT["US survey foot",0.304800609601219]]"#;
        assert_eq!(geokeys_of_wkt(feet), None);
        let (keys, citation) = user_defined_geokeys(feet).unwrap();
        let length = citation.len() as u16;
        assert_eq!(
            keys,
            [
                1, 1, 0, 4, 1024, 0, 1, 1, 1026, 34737, length, 0, 3072, 0, 1, 32767, 3076, 0, 1,
                9003
            ]
        );
        assert!(citation.starts_with("ESRI PE String = PROJCS[") && citation.ends_with("]|"));
        // WKT 2 with no code (PROJ's for a CRS given by parameters): its unit from
        // its axes, the WKT itself as the citation.
        let wkt2 = r#"PROJCRS["unknown",BASEGEOGCRS["unknown",DATUM["x",ELLIPSOID["GRS 1980",6378137,298.257222101]]],CONVERSION["unknown",METHOD["Albers Equal Area"]],CS[Cartesian,2],AXIS["(E)",east,ORDER[1],LENGTHUNIT["US survey foot",0.304800609601219,ID["EPSG",9003]]]]"#;
        let (keys, citation) = user_defined_geokeys(wkt2).unwrap();
        assert_eq!(&keys[12..], [3072, 0, 1, 32767, 3076, 0, 1, 9003]);
        assert_eq!(citation, format!("{wkt2}|"));
        let geographic = r#"GEOGCRS["unknown",DATUM["x",ELLIPSOID["Clarke 1866",6378206.4,294.978698213898]],CS[ellipsoidal,2],AXIS["longitude",east,ORDER[1],ANGLEUNIT["degree",0.0174532925199433]]]"#;
        let (keys, _) = user_defined_geokeys(geographic).unwrap();
        assert_eq!(&keys[12..], [2048, 0, 1, 32767, 2054, 0, 1, 9102]);
        let degrees = r#"GEOGCS["GCS_Custom",DATUM["D_x",SPHEROID["x",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]"#;
        let (keys, _) = user_defined_geokeys(degrees).unwrap();
        assert_eq!(&keys[12..], [2048, 0, 1, 32767, 2054, 0, 1, 9102]);
    }

    proptest::proptest! {
        /// Any text as a sidecar's SRS, and any cut of a real ESRI WKT, gives keys or
        /// none, and a projection or none: never a panic.
        #[test]
        fn any_srs_text_is_read_without_panicking(
            text in ".{0,200}",
            cut in 0usize..400,
        ) {
            let esri = r#"PROJCS["WGS_1984_UTM_Zone_16N",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],UNIT["Degree",0.0174532925199433]],PROJECTION["Albers"],PARAMETER["Standard_Parallel_1",29.5],UNIT["Meter",1.0]]"#;
            let cut = &esri[..cut.min(esri.len())];
            for wkt in [text.as_str(), cut] {
                let _ = geokeys_of_wkt(wkt);
                if let Some((_, citation)) = user_defined_geokeys(wkt) {
                    let _ = super::super::projection::of_wkt_citation(&citation, None, 1.0);
                }
            }
        }
    }

    #[test]
    fn the_linear_unit_comes_from_its_factor_at_the_top_or_in_the_axes() {
        let unit = |wkt: &str| {
            let keys = geokeys_of_wkt(wkt).unwrap();
            keys[4..]
                .chunks_exact(4)
                .find(|k| k[0] == 3076)
                .map(|k| k[3])
        };
        // PROJ's WKT 2 (as GDAL writes a CRS WKT 1 cannot hold): the unit in each axis,
        // with no code of its own.
        let long_island = r#"PROJCRS["NAD83 / New York Long Island (ftUS)",BASEGEOGCRS["NAD83",DATUM["North American Datum 1983",ELLIPSOID["GRS 1980",6378137,298.257222101,LENGTHUNIT["metre",1]]],PRIMEM["Greenwich",0,ANGLEUNIT["degree",0.0174532925199433]],ID["EPSG",4269]],CONVERSION["SPCS83 New York Long Island zone (US survey foot)",METHOD["Lambert Conic Conformal (2SP)",ID["EPSG",9802]],PARAMETER["False easting",984250,LENGTHUNIT["US survey foot",0.304800609601219],ID["EPSG",8826]]],CS[Cartesian,2],AXIS["easting (X)",east,ORDER[1],LENGTHUNIT["US survey foot",0.304800609601219]],AXIS["northing (Y)",north,ORDER[2],LENGTHUNIT["US survey foot",0.304800609601219]],ID["EPSG",2263]]"#;
        assert_eq!(unit(long_island), Some(9003));
        let top = |u: &str| {
            format!(
                r#"PROJCS["x",GEOGCS["y",AUTHORITY["EPSG","4269"]],{u},AUTHORITY["EPSG","2263"]]"#
            )
        };
        assert_eq!(
            unit(&top(r#"UNIT["Foot_US",0.3048006096012192]"#)),
            Some(9003)
        );
        assert_eq!(
            unit(&top(r#"UNIT["foot",0.3048,AUTHORITY["EPSG","9002"]]"#)),
            Some(9002)
        );
        assert_eq!(unit(&top(r#"LENGTHUNIT["metre",1]"#)), Some(9001));
        // Clarke's foot is no unit we measure: its own code, else a user-defined one,
        // which the reader refuses by name.
        assert_eq!(
            unit(&top(
                r#"UNIT["Clarke's foot",0.3047972654,AUTHORITY["EPSG","9005"]]"#
            )),
            Some(9005)
        );
        assert_eq!(
            unit(&top(r#"UNIT["Clarke's foot",0.3047972654]"#)),
            Some(32767)
        );
        assert_eq!(unit(&top(r#"AXIS["E",EAST]"#)), None);
    }

    #[test]
    fn a_compound_crs_gives_its_horizontal_keys_and_its_heights_unit() {
        // As GDAL writes EPSG:2263+6360 into a sidecar (shortened).
        let wkt1 = r#"COMPD_CS["NAD83 / New York Long Island (ftUS) + NAVD88 height (ftUS)",PROJCS["NAD83 / New York Long Island (ftUS)",GEOGCS["NAD83",AUTHORITY["EPSG","4269"]],PROJECTION["Lambert_Conformal_Conic_2SP"],UNIT["US survey foot",0.304800609601219,AUTHORITY["EPSG","9003"]],AXIS["Easting",EAST],AUTHORITY["EPSG","2263"]],VERT_CS["NAVD88 height (ftUS)",VERT_DATUM["North American Vertical Datum 1988",2005,AUTHORITY["EPSG","5103"]],UNIT["US survey foot",0.304800609601219,AUTHORITY["EPSG","9003"]],AXIS["Gravity-related height",UP],AUTHORITY["EPSG","6360"]]]"#;
        let expected = [
            1, 1, 0, 5, 1024, 0, 1, 1, 3072, 0, 1, 2263, 3076, 0, 1, 9003, 4096, 0, 1, 6360, 4099,
            0, 1, 9003,
        ];
        assert_eq!(geokeys_of_wkt(wkt1).unwrap(), expected);
        let wkt2 = r#"COMPOUNDCRS["x",PROJCRS["NAD83 / New York Long Island (ftUS)",BASEGEOGCRS["NAD83",ID["EPSG",4269]],CS[Cartesian,2],AXIS["easting (X)",east,ORDER[1],LENGTHUNIT["US survey foot",0.304800609601219]],ID["EPSG",2263]],VERTCRS["NAVD88 height (ftUS)",VDATUM["North American Vertical Datum 1988"],CS[vertical,1],AXIS["gravity-related height (H)",up,LENGTHUNIT["US survey foot",0.304800609601219]],ID["EPSG",6360]]]"#;
        assert_eq!(geokeys_of_wkt(wkt2).unwrap(), expected);
        // With no horizontal CRS it names no code a raster can be measured by.
        assert_eq!(
            geokeys_of_wkt(r#"COMPD_CS["x",VERT_CS["h",AUTHORITY["EPSG","5703"]]]"#),
            None
        );
    }

    #[test]
    fn malformed_or_missing_sidecars_declare_nothing() {
        assert!(class_bands("<PAMDataset><PAMRasterBand band=\"1\"></Oops>").is_err());
        let dir = tempfile::tempdir().unwrap();
        let tif = dir.path().join("x.tif");
        assert!(declared_class_bands(&tif).is_empty());
        std::fs::write(
            sidecar(&tif),
            "<PAMDataset><PAMRasterBand band=\"1\"></Oops>",
        )
        .unwrap();
        assert!(declared_class_bands(&tif).is_empty());
        std::fs::write(
            sidecar(&tif),
            pam("<CategoryNames><Category>A</Category></CategoryNames>"),
        )
        .unwrap();
        assert_eq!(declared_class_bands(&tif), [0]);
    }
}
