//! ER Mapper rasters (`.ers`), as Geoscience Australia hands out its national grids
//! and as GDAL's ERS driver writes them: a text header of nested `Name Begin` ...
//! `Name End` blocks beside a raw file of the samples (band-interleaved by line), named
//! as the header less `.ers` unless its `DataFile` says otherwise. The header gives the
//! layout (`CellType`, `NrOfLines`, `NrOfCellsPerLine`, `NrOfBands`, `ByteOrder`, the
//! dataset's `HeaderOffset`), the grid (`CellInfo`'s cell size, `RegistrationCoord` at
//! `RegistrationCellX`/`Y`), `NullCellValue`, each band's `BandId` and the CRS by ER
//! Mapper's names: a datum (`WGS84`, `NAD83`, `NAD27`, `GDA94`, `GDA2020`) with
//! `GEODETIC`, `NUTMzz`/`SUTMzz` or `MGAzz`, or `EPSG:n` as GDAL writes CRSs ER Mapper
//! has no name for.

use std::path::{Path, PathBuf};

use super::FileOrder;
use super::ehdr::{Interleave, Layout, RawRaster, RawValues, Sample, read_raw_bytes};
use super::geotiff::sidecar;
use super::named_crs::{Named, epsg_geokeys, geokeys};
use crate::error::{Error, Result, read_input};
use crate::grid::Map;

/// The header's `key = value` lines, each key the path of blocks it lies in
/// (`RasterInfo.CellInfo.Xdimension`, less the outer `DatasetHeader`), in order.
struct Header(Vec<(String, String)>);

impl Header {
    fn parse(text: &str) -> std::result::Result<Header, String> {
        let mut blocks: Vec<&str> = Vec::new();
        let mut first_block = None;
        let mut fields = Vec::new();
        for (number, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            if let Some((key, value)) = line.split_once('=') {
                let path = blocks
                    .iter()
                    .skip(1)
                    .chain(std::iter::once(&key.trim()))
                    .copied()
                    .collect::<Vec<_>>()
                    .join(".");
                fields.push((path, value.trim().trim_matches('"').to_string()));
            } else if let Some(block) = line.strip_suffix(" Begin") {
                first_block.get_or_insert(block.trim());
                blocks.push(block.trim());
            } else if let Some(block) = line.strip_suffix(" End") {
                if blocks.pop() != Some(block.trim()) {
                    return Err(format!(
                        "line {}: '{line}' closes no open block",
                        number + 1
                    ));
                }
            } else {
                return Err(format!(
                    "line {}: '{line}' is neither a block nor key = value",
                    number + 1
                ));
            }
        }
        if first_block != Some("DatasetHeader") {
            return Err("it does not open with 'DatasetHeader Begin'".into());
        }
        if let Some(open) = blocks.last() {
            return Err(format!("its block '{open}' is never closed"));
        }
        Ok(Header(fields))
    }

    /// The value of `key` (a block path, in any case).
    fn get(&self, key: &str) -> Option<&str> {
        self.0
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(key))
            .map(|(_, v)| v.as_str())
    }

    fn number(&self, key: &str) -> std::result::Result<Option<f64>, String> {
        self.get(key)
            .map(|v| {
                v.parse::<f64>()
                    .ok()
                    .filter(|n| n.is_finite())
                    .ok_or_else(|| format!("{key} is '{v}', not a number"))
            })
            .transpose()
    }

    fn count(&self, key: &str) -> std::result::Result<usize, String> {
        match self.number(key)? {
            Some(v) if v >= 1.0 && v.fract() == 0.0 && v <= f64::from(u32::MAX) => Ok(v as usize),
            Some(v) => Err(format!("{key} is {v}, not a count")),
            None => Err(format!("it gives no {key}")),
        }
    }
}

/// The file of the samples: the header's `DataFile`, else its own name less `.ers`.
fn data_path(path: &Path, header: &Header) -> PathBuf {
    match header.get("DataFile") {
        Some(file) => path.with_file_name(file),
        None => path.with_extension(""),
    }
}

/// The files reading an ER Mapper raster depends on: its samples and GDAL's sidecar.
pub fn ers_sidecars(path: &Path) -> Vec<PathBuf> {
    let data = std::fs::read_to_string(path)
        .ok()
        .and_then(|text| Header::parse(&text).ok())
        .map(|header| data_path(path, &header));
    data.into_iter()
        .chain(std::iter::once(sidecar(path)))
        .filter(|f| f.is_file())
        .collect()
}

/// The ER Mapper raster whose header is `path`, as map `name`, with whether its rows
/// ran from the north.
pub fn read_ers_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let bytes = read_input(path)?;
    let text = std::str::from_utf8(&bytes)
        .map_err(|e| problem(format!("is not an ER Mapper header (not text: {e})")))?;
    let header =
        Header::parse(text).map_err(|e| problem(format!("is not an ER Mapper header: {e}")))?;
    let raster = raster(&header).map_err(problem)?;
    let data = data_path(path, &header);
    let samples = read_input(&data).map_err(|e| {
        problem(format!(
            "its samples {} cannot be read ({e}): an ER Mapper header needs its data file \
             beside it",
            data.display()
        ))
    })?;
    read_raw_bytes(path, &samples, name, path, raster)
}

/// The layout, grid, CRS and band names the header gives.
fn raster(header: &Header) -> std::result::Result<RawRaster, String> {
    if let Some(kind) = header.get("DataSetType")
        && !kind.eq_ignore_ascii_case("ERStorage")
    {
        return Err(format!(
            "its DataSetType is '{kind}': only rasters stored beside their header \
             (ERStorage) are read, not ER Mapper algorithms"
        ));
    }
    if let Some(kind) = header.get("DataType")
        && !kind.eq_ignore_ascii_case("Raster")
    {
        return Err(format!("its DataType is '{kind}', not Raster"));
    }
    // GDAL's defaults: bytes, in this machine's order (LSBFirst where rasters are read).
    let cell_type = header
        .get("RasterInfo.CellType")
        .unwrap_or("Unsigned8BitInteger");
    let sample = match cell_type.to_ascii_lowercase().as_str() {
        "unsigned8bitinteger" => Sample::Unsigned(1),
        "signed8bitinteger" => Sample::Signed(1),
        "unsigned16bitinteger" => Sample::Unsigned(2),
        "signed16bitinteger" => Sample::Signed(2),
        "unsigned32bitinteger" => Sample::Unsigned(4),
        "signed32bitinteger" => Sample::Signed(4),
        "ieee4bytereal" => Sample::Float(4),
        "ieee8bytereal" => Sample::Float(8),
        _ => return Err(format!("its CellType '{cell_type}' is not one read here")),
    };
    let little_endian = match header.get("ByteOrder") {
        Some(order) if order.eq_ignore_ascii_case("LSBFirst") => true,
        Some(order) if order.eq_ignore_ascii_case("MSBFirst") => false,
        Some(order) => {
            return Err(format!(
                "its ByteOrder '{order}' is neither MSBFirst nor LSBFirst"
            ));
        }
        None => true,
    };
    let skip = match header.number("HeaderOffset")? {
        Some(v) if v >= 0.0 && v.fract() == 0.0 => v as usize,
        Some(v) => return Err(format!("its HeaderOffset {v} is not a count of bytes")),
        None => 0,
    };
    let mut layout = Layout::packed(
        header.count("RasterInfo.NrOfCellsPerLine")?,
        header.count("RasterInfo.NrOfLines")?,
        header.count("RasterInfo.NrOfBands")?,
        sample,
        little_endian,
        skip,
        Interleave::Line,
    )?;
    let (crs, degrees) = crs(header)?;
    layout.transform = Some(transform(header, degrees)?);
    layout.nodata = header.number("RasterInfo.NullCellValue")?;
    let descriptions = header
        .0
        .iter()
        .filter(|(key, _)| key.eq_ignore_ascii_case("RasterInfo.BandId.Value"))
        .map(|(_, value)| Some(value.clone()).filter(|v| !v.is_empty()))
        .collect();
    Ok(RawRaster {
        layout,
        crs: (crs, String::new()),
        descriptions,
        grid_keys: "RasterInfo's RegistrationCoord",
        values: RawValues::default(),
    })
}

/// The CRS's GeoKeys (empty for a raster on no CRS: `RAW`, `LOCAL`), and whether its
/// coordinates are degrees.
fn crs(header: &Header) -> std::result::Result<(Vec<u16>, bool), String> {
    let datum = header.get("CoordinateSpace.Datum").unwrap_or("RAW");
    let projection = header.get("CoordinateSpace.Projection").unwrap_or("RAW");
    let upper = projection.to_ascii_uppercase();
    if let Some(units) = header.get("CoordinateSpace.Units")
        && !["METERS", "METRES", "NATIVE", "DEGREES"].contains(&units.to_ascii_uppercase().as_str())
    {
        return Err(format!(
            "its CoordinateSpace's Units are '{units}': only metres are read \
             (gdal_translate -of GTiff keeps the CRS)"
        ));
    }
    if let Some(rotation) = header.get("CoordinateSpace.Rotation")
        && dms(rotation).is_none_or(|r| r != 0.0)
    {
        return Err(format!(
            "the raster is rotated (CoordinateSpace Rotation {rotation}); only \
             axis-aligned rasters are supported: warp it first (gdalwarp)"
        ));
    }
    // GDAL writes a CRS ER Mapper has no name for as its EPSG code.
    if let Some(code) = upper.strip_prefix("EPSG:") {
        let code: u16 = code
            .parse()
            .map_err(|_| format!("its Projection '{projection}' names no EPSG code"))?;
        let geographic = crate::grid::epsg_crs(code)
            .ok_or_else(|| format!("its Projection '{projection}' is not in the EPSG registry"))?
            .is_geographic();
        return Ok((epsg_geokeys(code, !geographic), geographic));
    }
    if upper == "RAW" || upper == "LOCAL" {
        return Ok((Vec::new(), false));
    }
    let named = if upper == "GEODETIC" {
        Named::Geographic
    } else if let Some((north, zone)) = upper
        .strip_prefix("NUTM")
        .map(|z| (true, z))
        .or_else(|| upper.strip_prefix("SUTM").map(|z| (false, z)))
    {
        Named::Utm {
            zone: zone
                .parse()
                .map_err(|_| format!("its Projection '{projection}' names no UTM zone"))?,
            north,
        }
    } else if let Some(zone) = upper.strip_prefix("MGA") {
        // The Map Grid of Australia: UTM south on GDA94 or GDA2020.
        let zone: u16 = zone
            .parse()
            .map_err(|_| format!("its Projection '{projection}' names no MGA zone"))?;
        let code = match datum.to_ascii_uppercase().as_str() {
            "GDA94" if (46..=59).contains(&zone) => 28300 + zone,
            "GDA2020" if (46..=59).contains(&zone) => 7800 + zone,
            _ => {
                return Err(format!(
                    "its Projection '{projection}' on Datum '{datum}' is no MGA zone of GDA94 \
                     or GDA2020"
                ));
            }
        };
        return Ok((epsg_geokeys(code, true), false));
    } else {
        return Err(format!(
            "its Projection '{projection}' is not one of ER Mapper's read here (GEODETIC, \
             NUTMzz, SUTMzz, MGAzz, EPSG:n): convert it with gdal_translate -of GTiff"
        ));
    };
    let degrees = named == Named::Geographic;
    let australian = match (datum.to_ascii_uppercase().as_str(), named) {
        ("GDA94", Named::Geographic) => Some(4283),
        ("GDA2020", Named::Geographic) => Some(7844),
        _ => None,
    };
    if let Some(code) = australian {
        return Ok((epsg_geokeys(code, false), true));
    }
    geokeys(named, datum)
        .map(|keys| (keys, degrees))
        .ok_or_else(|| {
            format!("its Datum '{datum}' with Projection '{projection}' is not a CRS read here")
        })
}

/// GDAL's geotransform of the header's grid: the registration coordinate (eastings and
/// northings, metres; or longitude and latitude, degrees as `d:m:s`) lies at the
/// corner `RegistrationCellX`, `RegistrationCellY` cells from the top-left one.
fn transform(header: &Header, degrees: bool) -> std::result::Result<[f64; 6], String> {
    let size = |key: &str| -> std::result::Result<f64, String> {
        match header.number(&format!("RasterInfo.CellInfo.{key}"))? {
            Some(v) if v > 0.0 => Ok(v),
            Some(v) => Err(format!("its cell's {key} is {v}, not a size")),
            None => Ok(1.0),
        }
    };
    let (dx, dy) = (size("Xdimension")?, size("Ydimension")?);
    let registration = |key: &str| header.number(&format!("RasterInfo.RegistrationCoord.{key}"));
    let angle = |key: &str| -> std::result::Result<Option<f64>, String> {
        header
            .get(&format!("RasterInfo.RegistrationCoord.{key}"))
            .map(|v| dms(v).ok_or_else(|| format!("its {key} '{v}' is not degrees as d:m:s")))
            .transpose()
    };
    let (x, y) = match (registration("Eastings")?, registration("Northings")?) {
        (Some(x), Some(y)) => (x, y),
        _ => match (registration("MetersX")?, registration("MetersY")?) {
            (Some(x), Some(y)) => (x, y),
            _ => match (angle("Longitude")?, angle("Latitude")?) {
                (Some(x), Some(y)) if degrees => (x, y),
                (Some(_), Some(_)) => {
                    return Err("it registers longitude and latitude on a projected CRS".into());
                }
                _ => return Err("it gives no RasterInfo's RegistrationCoord".into()),
            },
        },
    };
    let cell = |key: &str| -> std::result::Result<f64, String> {
        Ok(header.number(&format!("RasterInfo.{key}"))?.unwrap_or(0.0))
    };
    let (cell_x, cell_y) = (cell("RegistrationCellX")?, cell("RegistrationCellY")?);
    Ok([dx, 0.0, x - cell_x * dx, 0.0, -dy, y + cell_y * dy])
}

/// Degrees of ER Mapper's `d:m:s` (or plain degrees), signed by its first field.
fn dms(text: &str) -> Option<f64> {
    let text = text.trim();
    let negative = text.starts_with('-');
    let mut total = 0.0;
    for (part, scale) in text
        .trim_start_matches(['-', '+'])
        .split(':')
        .zip([1.0, 60.0, 3600.0])
    {
        let value: f64 = part
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite() && *v >= 0.0)?;
        total += value / scale;
    }
    (text.split(':').count() <= 3).then_some(if negative { -total } else { total })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GDAL_HEADER: &str = "DatasetHeader Begin\n\tVersion\t= \"6.0\"\n\tName\t= \"dem.ers\"\n\
        \tDataSetType\t= ERStorage\n\tDataType\t= Raster\n\tByteOrder\t= LSBFirst\n\
        \tCoordinateSpace Begin\n\t\tDatum\t= \"GDA94\"\n\t\tProjection\t= \"MGA55\"\n\
        \t\tCoordinateType\t= EN\n\t\tUnits\t= \"METERS\"\n\t\tRotation\t= 0:0:0.0\n\
        \tCoordinateSpace End\n\tRasterInfo Begin\n\t\tCellType\t= Signed16BitInteger\n\
        \t\tNrOfLines\t= 60\n\t\tNrOfCellsPerLine\t= 80\n\t\tNrOfBands\t= 2\n\
        \t\tCellInfo Begin\n\t\t\tXdimension\t= 30\n\t\t\tYdimension\t= 25\n\
        \t\tCellInfo End\n\t\tRegistrationCoord Begin\n\t\t\tEastings\t= 400000\n\
        \t\t\tNorthings\t= 6000000\n\t\tRegistrationCoord End\n\
        \t\tNullCellValue\t= -9999\n\t\tBandId Begin\n\t\t\tValue\t= \"height\"\n\
        \t\tBandId End\n\t\tBandId Begin\n\t\t\tValue\t= \"slope\"\n\t\tBandId End\n\
        \tRasterInfo End\nDatasetHeader End\n";

    #[test]
    fn headers_as_gdal_writes_them() {
        let header = Header::parse(GDAL_HEADER).unwrap();
        let raster = raster(&header).unwrap();
        let layout = &raster.layout;
        assert_eq!((layout.columns, layout.rows, layout.bands), (80, 60, 2));
        assert_eq!(layout.sample, Sample::Signed(2));
        assert!(layout.little_endian);
        assert_eq!(layout.interleave, Interleave::Line);
        assert_eq!(
            layout.transform,
            Some([30.0, 0.0, 400_000.0, 0.0, -25.0, 6_000_000.0])
        );
        assert_eq!(layout.nodata, Some(-9999.0));
        // GDA94 / MGA zone 55.
        assert_eq!(raster.crs.0[11], 28355);
        assert_eq!(
            raster.descriptions,
            [Some("height".into()), Some("slope".into())]
        );
        assert_eq!(
            data_path(Path::new("/data/dem.ers"), &header),
            Path::new("/data/dem")
        );
    }

    #[test]
    fn er_mappers_own_headers_in_degrees_and_registered_cells() {
        // As ER Mapper writes a grid in degrees: longitude and latitude as d:m:s, the
        // registration at the centre of the top-left cell, big-endian samples.
        let text = GDAL_HEADER
            .replace("ByteOrder\t= LSBFirst", "ByteOrder\t= MSBFirst")
            .replace("\"GDA94\"", "\"WGS84\"")
            .replace("\"MGA55\"", "\"GEODETIC\"")
            .replace("CoordinateType\t= EN", "CoordinateType\t= LL")
            .replace("Units\t= \"METERS\"", "Units\t= \"DEGREES\"")
            .replace("Xdimension\t= 30", "Xdimension\t= 0.5")
            .replace("Ydimension\t= 25", "Ydimension\t= 0.25")
            .replace("Eastings\t= 400000", "Longitude\t= 150:30:0.0")
            .replace("Northings\t= 6000000", "Latitude\t= -33:15:00")
            .replace(
                "NullCellValue",
                "RegistrationCellX\t= 0.5\n\t\tRegistrationCellY\t= 0.5\n\t\tNullCellValue",
            );
        let raster = raster(&Header::parse(&text).unwrap()).unwrap();
        assert!(!raster.layout.little_endian);
        assert_eq!(raster.crs.0[11], 4326);
        assert_eq!(
            raster.layout.transform,
            Some([0.5, 0.0, 150.25, 0.0, -0.25, -33.125])
        );
    }

    #[test]
    fn headers_not_read_say_why() {
        let error = |from: &str, to: &str| {
            raster(&Header::parse(&GDAL_HEADER.replace(from, to)).unwrap())
                .err()
                .unwrap()
        };
        assert!(error("Rotation\t= 0:0:0.0", "Rotation\t= 12:0:0.0").contains("rotated"));
        assert!(error("\"MGA55\"", "\"TMAMG\"").contains("TMAMG"));
        assert!(error("Signed16BitInteger", "Complex64").contains("Complex64"));
        assert!(error("NrOfLines\t= 60", "NrOfLines\t= 0").contains("NrOfLines"));
        assert!(error("\"METERS\"", "\"FEET\"").contains("FEET"));
        assert!(
            error("DataSetType\t= ERStorage", "DataSetType\t= Translated").contains("algorithm")
        );
        assert!(Header::parse("DatasetHeader Begin\n\tRasterInfo Begin\n").is_err());
        assert!(Header::parse("DatasetHeader Begin\nfoo\nDatasetHeader End\n").is_err());
        assert_eq!(dms("-33:15:00"), Some(-33.25));
        assert_eq!(dms("151.5"), Some(151.5));
        assert_eq!(dms("1:2:3:4"), None);
    }

    proptest::proptest! {
        /// Any header text reads or is refused with an error: never a panic.
        #[test]
        fn any_header_reads_or_is_refused(text in "\\PC{0,400}") {
            if let Ok(header) = Header::parse(&text) {
                let _ = raster(&header);
            }
            let _ = Header::parse(&format!("{GDAL_HEADER}{text}"));
        }
    }
}
