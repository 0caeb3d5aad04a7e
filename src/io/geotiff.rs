//! GeoTIFF map layers through the `tiff` crate, as GDAL and rasterio write them: strips
//! or tiles, BigTIFF, cloud-optimised files (the full-resolution first image), pixel- or
//! band-interleaved, either byte order, uncompressed or Deflate (with either
//! predictor), PackBits, ZSTD or JPEG (`samples`, YCbCr converted to RGB), LZW and LZMA
//! (`unpack`, as are GDAL's `NBITS` widths of 9 to 31 bits and half floats under any
//! lossless compression), LERC (`lerc`) or WebP (`webp`); samples of 1 to 32 bits.
//! Every band becomes a layer (`band1`,
//! ...); cells GDAL reads as nodata become NaN (our nodata mask): equal to the GDAL
//! nodata value in the band's type, empty in GDAL's internal mask (`mask`),
//! transparent in an alpha band, or in a tile a sparse file leaves out. The others are
//! scaled and offset as GDAL's metadata says (`metadata`); palette images read as their
//! class codes (`grey`). The georeference comes from the pixel-scale + tiepoint tags or
//! the transformation matrix. Cells may be rectangles; a geographic CRS keeps its
//! degrees as frame units and is measured in metres from the latitude, Web Mercator
//! from the northing (`GeoRef::cell_metres`), projections far from true scale (polar
//! stereographic, Lambert conformal, equal-area) with their scale per axis at the
//! raster's centre (`projection`); a projected CRS in feet keeps its coordinates (the
//! user's other data in that CRS are in feet) and is measured in metres by the same
//! ground scale; heights in feet become metres.
//! Rasters stored north-up (row 0 at the top) are flipped to our south-first rows.

use std::io::Cursor;
use std::path::Path;

use rayon::prelude::*;
use tiff::decoder::{Decoder, Limits};
use tiff::tags::{PlanarConfiguration, Tag};

use super::FileOrder;
use crate::error::{Error, Result, read_input};
use crate::grid::{GeoRef, Layer, Map, TiffCrs, metres_per_epsg_unit};

mod chunks;
mod grey;
mod jxl;
mod lerc;
mod mask;
pub(crate) mod metadata;
mod pam;
mod projection;
mod samples;
mod unpack;
mod webp;

pub(crate) use pam::{
    bands as pam_bands, dataset_georeference, declared_class_bands,
    georeference as pam_georeference, world_file_transform,
};
pub use pam::{sidecar, sidecars, wkt_geokeys};

/// GeoKey ids (GeoTIFF 1.1) and the values we read.
const GT_MODEL_TYPE: u16 = 1024;
const GT_RASTER_TYPE: u16 = 1025;
const GEOGRAPHIC_CRS: u16 = 2048;
const GEOG_ANGULAR_UNITS: u16 = 2054;
const PROJECTED_CRS: u16 = 3072;
const PROJ_LINEAR_UNITS: u16 = 3076;
const MODEL_PROJECTED: u16 = 1;
const MODEL_GEOGRAPHIC: u16 = 2;
const MODEL_GEOCENTRIC: u16 = 3;
const PIXEL_IS_POINT: u16 = 2;
const USER_DEFINED: u16 = 32767;
const ANGULAR_DEGREE: u16 = 9102;
const ANGULAR_RADIAN: u16 = 9101;
/// Web Mercator's EPSG codes that fit a GeoKey: 3857 and its deprecated 3785.
const WEB_MERCATOR: [u16; 2] = [3857, 3785];
const VERTICAL_CRS: u16 = 4096;
/// The TIFF tag a GeoKey names as its value's location when the value is a double.
const GEO_DOUBLE_PARAMS: u16 = 34736;
/// TIFF ExtraSamples values of an alpha band.
const ASSOCIATED_ALPHA: u16 = 1;
const UNASSOCIATED_ALPHA: u16 = 2;
const VERTICAL_UNITS: u16 = 4099;

/// Metres per unit of height, for the vertical CRSs (EPSG) that US elevation data
/// comes in feet with: NAVD88 and NGVD29 heights in US survey feet, NAVD88 in feet.
/// GDAL writes the vertical CRS of a compound CRS (EPSG:2263+6360) but not its units.
fn metres_per_height_unit(vertical_crs: u16) -> Option<f64> {
    match vertical_crs {
        6360 | 5702 => metres_per_epsg_unit(9003),
        8228 => metres_per_epsg_unit(9002),
        _ => None,
    }
}

/// Metres per unit of the raster's values where its GeoKeys give them a vertical CRS
/// (its values are heights): from VerticalUnits, else from the vertical CRS; 1 where
/// neither says feet (or there is none).
fn height_scale(key: &dyn Fn(u16) -> Option<u16>) -> std::result::Result<f64, String> {
    match key(VERTICAL_UNITS) {
        Some(code) => metres_per_epsg_unit(code).ok_or_else(|| {
            format!(
                "the vertical unit {code} (GeoKey VerticalUnits) cannot be measured in \
                 metres"
            )
        }),
        None => Ok(key(VERTICAL_CRS)
            .and_then(metres_per_height_unit)
            .unwrap_or(1.0)),
    }
}

/// Degrees per angular unit, for the EPSG unit codes geographic rasters use: radians,
/// degrees (and EPSG's supplier-defined degree), arc-minutes and -seconds, and grads
/// (France's NTF Paris, EPSG:4807).
pub(super) fn degrees_per_angular_unit(code: u16) -> Option<f64> {
    match code {
        ANGULAR_RADIAN => Some(180.0 / std::f64::consts::PI),
        ANGULAR_DEGREE | 9122 => Some(1.0),
        9103 => Some(1.0 / 60.0),
        9104 => Some(1.0 / 3600.0),
        9105 => Some(0.9),
        _ => None,
    }
}

/// Names of the TIFF compression codes GDAL writes, for error messages.
fn compression_name(code: u16) -> &'static str {
    match code {
        1 => "none",
        5 => "LZW",
        6 | 7 => "JPEG",
        8 | 32946 => "Deflate",
        32773 => "PackBits",
        34925 => "LZMA",
        50000 => "ZSTD",
        50001 => "WebP",
        jxl::JXL | jxl::JXL_DNG => "JPEG XL",
        _ => "unknown",
    }
}

/// TIFF compression code of LERC (Esri's limited-error raster compression).
const LERC: u16 = 34887;

/// Largest decoded image we accept: the raster must fit in memory as f32 layers anyway.
const MAX_DECODED_BYTES: usize = 16 << 30;

/// Reads the GeoTIFF at `path` as the map `name`.
pub fn read_geotiff(path: &Path, name: &str) -> Result<Map> {
    read_geotiff_rows(path, name).map(|(map, _)| map)
}

/// Reads the GeoTIFF at `path` as the map `name`, with whether the file's rows ran from
/// the north (a north-up raster's: ours run from the south, so the reader turned them).
pub(crate) fn read_geotiff_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let mut bytes = read_input(path)?;
    // A palette image's values are the codes of its colours' classes (land cover):
    // its layers are declared classes.
    let palette = grey::relabel_grey(&mut bytes);
    // So do the bands GDAL's sidecar gives a colour table, category names or a table
    // of class names.
    let declared_bands = pam::declared_class_bands(path);
    if palette {
        tracing::debug!(
            "{}: a palette image: its layers hold the class codes",
            path.display()
        );
    }
    let problem = |message: String| Error::input(path, message);
    let tiff_error = |e: tiff::TiffError| problem(format!("not a readable TIFF: {e}"));
    let mut limits = Limits::default();
    limits.decoding_buffer_size = MAX_DECODED_BYTES;
    limits.intermediate_buffer_size = MAX_DECODED_BYTES;
    // Tile offset and byte-count arrays of large tiled rasters pass the 1 MiB default.
    limits.ifd_value_size = 256 << 20;
    let mut decoder = Decoder::new(Cursor::new(&bytes[..]))
        .map_err(tiff_error)?
        .with_limits(limits);
    let (width, height) = decoder.dimensions().map_err(tiff_error)?;
    let compression = decoder
        .find_tag_unsigned::<u16>(Tag::Compression)
        .map_err(tiff_error)?
        .unwrap_or(1);
    let planar = decoder
        .find_tag_unsigned::<u16>(Tag::PlanarConfiguration)
        .map_err(tiff_error)?
        .and_then(PlanarConfiguration::from_u16)
        .unwrap_or(PlanarConfiguration::Chunky);
    // SAR images come as complex integers or floats (SampleFormat 5, 6).
    if let Some(format @ (5 | 6)) = decoder
        .find_tag_unsigned_vec::<u16>(Tag::SampleFormat)
        .map_err(tiff_error)?
        .and_then(|f| f.first().copied())
    {
        return Err(problem(format!(
            "complex samples (tag SampleFormat = {format}) are not a map layer: write \
             their magnitude or power as a real band first (gdal_calc.py, rasterio)"
        )));
    }
    let nodata = decoder
        .find_tag(Tag::GdalNodata)
        .map_err(tiff_error)?
        .and_then(|v| v.into_string().ok())
        .and_then(|s| s.trim_end_matches('\0').trim().parse::<f64>().ok());
    // GDAL compares in the band's type: the "-3.40282346639e+38" that GDAL and ArcGIS
    // write for a float32 DEM's nodata (f32::MIN to 12 digits) is not f32::MIN as a
    // double. Our samples are f32, and integers and doubles round to f32 as it does.
    let nodata_sample = nodata.map(|n| n as f32);
    // Strips or tiles a sparse file leaves out read as the nodata value (GDAL's rule).
    let image = chunks::Image {
        file: &bytes,
        width,
        height,
        planar,
        fill: nodata_sample.unwrap_or(0.0),
    };
    let mut values: Vec<f32> = if compression == LERC {
        lerc::read(&mut decoder, &image)
            .map_err(|e| problem(format!("LERC (tag Compression = {compression}): {e}")))?
    } else if compression == webp::WEBP {
        webp::read(&mut decoder, &image)
            .map_err(|e| problem(format!("WebP (tag Compression = {compression}): {e}")))?
    } else if jxl::is_jxl(compression) {
        jxl::read(&mut decoder, &image)
            .map_err(|e| problem(format!("JPEG XL (tag Compression = {compression}): {e}")))?
    } else if unpack::reads(&mut decoder, compression)
        .map_err(|e| problem(format!("not a readable TIFF: {e}")))?
    {
        unpack::read(&mut decoder, &image, compression).map_err(|e| {
            problem(format!(
                "{} (tag Compression = {compression}): {e}",
                compression_name(compression)
            ))
        })?
    } else {
        samples::read(&mut decoder, &image).map_err(|e| {
            problem(format!(
                "the image cannot be decoded (tag Compression = {compression}, {}): {e}",
                compression_name(compression)
            ))
        })?
    };
    samples::cmyk_as_gdal_reads(
        &mut decoder,
        &mut values,
        planar == PlanarConfiguration::Planar,
    )
    .map_err(|e| problem(format!("not a readable TIFF: {e}")))?;
    let cells = width as usize * height as usize;
    if cells == 0 || !values.len().is_multiple_of(cells) {
        return Err(problem(format!(
            "{} samples do not fill {width}×{height} cells",
            values.len()
        )));
    }
    let bands = values.len() / cells;
    let samples_per_pixel = decoder
        .find_tag_unsigned::<u16>(Tag::SamplesPerPixel)
        .map_err(tiff_error)?
        .unwrap_or(1) as usize;
    if bands != samples_per_pixel {
        return Err(problem(format!(
            "decoded {bands} of the {samples_per_pixel} bands (tag SamplesPerPixel)"
        )));
    }

    let keys = decoder
        .find_tag_unsigned_vec::<u16>(Tag::GeoKeyDirectoryTag)
        .map_err(tiff_error)?
        .unwrap_or_default();
    // World x = a·col + b·row + c, y = d·col + e·row + f (GDAL's geotransform), from
    // where GDAL takes it: the PAM sidecar, the TIFF's own tags, a world file; the CRS
    // from the sidecar, else the TIFF. A sidecar GDAL could not use either is passed
    // over where the TIFF has its own.
    let own_transform = geotransform(&mut decoder).map_err(problem)?;
    let pam = match pam::georeference(path) {
        Ok(pam) => pam,
        Err(e) if own_transform.is_some() => {
            tracing::warn!("{e}; the TIFF's own georeference is used");
            pam::PamGeoreference::default()
        }
        Err(e) => return Err(problem(e)),
    };
    let (keys, pam_citation) = match pam.keys {
        Some(Ok(pam_keys)) => (pam_keys, Some(pam.citation)),
        Some(Err(e)) if !keys.is_empty() => {
            tracing::warn!("{e}; the TIFF's own CRS (GeoKeys) is used");
            (keys, None)
        }
        Some(Err(e)) => return Err(problem(e)),
        None => (keys, None),
    };
    let (transform, from_tags) = match (pam.transform, own_transform) {
        (Some(transform), _) => (transform, false),
        (None, Some(transform)) => (transform, true),
        (None, None) => match pam::world_file_transform(path).map_err(problem)? {
            Some(transform) => (transform, false),
            None => {
                return Err(problem(
                    "no georeference: neither ModelTransformationTag nor ModelPixelScaleTag \
                     with ModelTiepointTag, nor a GDAL sidecar (.aux.xml) or world file \
                     (.tfw) beside it"
                        .into(),
                ));
            }
        },
    };
    let doubles = decoder
        .find_tag(Tag::GeoDoubleParamsTag)
        .map_err(tiff_error)?
        .and_then(|v| v.into_f64_vec().ok())
        .unwrap_or_default();
    // The sidecar's keys point into its citation, never into the TIFF's parameters.
    let ascii = match pam_citation {
        Some(citation) => citation,
        None => decoder
            .find_tag(Tag::GeoAsciiParamsTag)
            .map_err(tiff_error)?
            .and_then(|v| v.into_string().ok())
            .unwrap_or_default(),
    };
    let (geo, heights) = georeference(
        path,
        width,
        height,
        Georeferencing {
            transform,
            keys: &keys,
            doubles,
            ascii,
            pixel_is_point_tags: from_tags,
        },
    )?;
    let order = FileOrder::of_transform(&transform);

    let is_nodata = |v: f32| match nodata_sample {
        Some(n) if n.is_nan() => v.is_nan(),
        Some(n) => v == n,
        None => false,
    };
    // Stored values times GDAL's per-band scale, plus its offset, are the physical ones;
    // heights in feet then become metres.
    let band_metadata = match decoder
        .find_tag(Tag::Unknown(metadata::GDAL_METADATA))
        .map_err(tiff_error)?
        .and_then(|v| v.into_string().ok())
    {
        Some(xml) => metadata::per_band(xml.trim_end_matches('\0'), bands).map_err(|e| {
            problem(format!(
                "tag GDAL_METADATA ({}): {e}",
                metadata::GDAL_METADATA
            ))
        })?,
        None => vec![metadata::BandMetadata::default(); bands],
    };
    let layer_names = metadata::layer_names(&band_metadata);
    // GDAL masks the cells an alpha band marks transparent (ExtraSamples 1 or 2: RGBA
    // imagery, orthomosaics): 0 there.
    let extra = decoder
        .find_tag_unsigned_vec::<u16>(Tag::ExtraSamples)
        .map_err(tiff_error)?
        .unwrap_or_default();
    let alpha = extra
        .iter()
        .position(|&kind| kind == ASSOCIATED_ALPHA || kind == UNASSOCIATED_ALPHA)
        .and_then(|i| (bands + i).checked_sub(extra.len()));
    // Cells GDAL's internal mask marks empty are nodata too (read last: it is a later
    // image of the file).
    let mask = mask::read(&mut decoder, &image).map_err(problem)?;
    // Where sample `band` of the file's row `row`, column `col` lies in `values`.
    let sample = |band: usize, row: usize, col: usize| match planar {
        PlanarConfiguration::Planar => band * cells + row * width as usize + col,
        _ => (row * width as usize + col) * bands + band,
    };
    // As GDAL reads them: the internal mask covers every band, the alpha band every
    // band but itself.
    let is_masked = |band: usize, row: usize, col: usize| {
        mask.as_ref()
            .is_some_and(|m| !m[row * width as usize + col])
            || alpha.is_some_and(|a| a != band && values[sample(a, row, col)] == 0.0)
    };
    let layers: Vec<Layer> = (0..bands)
        .map(|band| {
            let mut layer = vec![0f32; cells];
            let metadata::BandMetadata {
                scale,
                offset,
                ref unit,
                ..
            } = band_metadata[band];
            // A band whose unit is a length (rasterio's `units`) is measured in it;
            // others in the heights' unit the GeoKeys give.
            let heights = unit
                .as_deref()
                .and_then(metadata::metres_per_unit)
                .unwrap_or(heights);
            let physical = |v: f32| {
                if (scale, offset, heights) == (1.0, 0.0, 1.0) {
                    v
                } else {
                    ((f64::from(v) * scale + offset) * heights) as f32
                }
            };
            // Rows in parallel: a large raster's cells are a few seconds on one core,
            // and the fresh pages they land on are cleared by whichever core writes.
            layer
                .par_chunks_mut(width as usize)
                .enumerate()
                .for_each(|(row, cells)| {
                    for (col, cell) in cells.iter_mut().enumerate() {
                        let (source_row, source_col) =
                            order.file_cell(row, col, width as usize, height as usize);
                        let v = values[sample(band, source_row, source_col)];
                        *cell = if is_nodata(v) || is_masked(band, source_row, source_col) {
                            f32::NAN
                        } else {
                            physical(v)
                        };
                    }
                });
            // Infinities (a ratio's division by zero) are no measurement of the ground:
            // nodata, as NaN is.
            let infinite = layer.iter().filter(|v| v.is_infinite()).count();
            if infinite > 0 {
                tracing::warn!(
                    "{}: {infinite} cells of band {} are infinite; they are read as nodata",
                    path.display(),
                    band + 1
                );
                layer
                    .iter_mut()
                    .filter(|v| v.is_infinite())
                    .for_each(|v| *v = f32::NAN);
            }
            let layer = Layer::new(layer_names[band].clone(), layer);
            if palette || declared_bands.contains(&band) {
                layer.declared_classes()
            } else {
                layer
            }
        })
        .collect();
    if layers.iter().all(|l| l.values.iter().all(|v| v.is_nan())) {
        return Err(problem(format!(
            "every cell of every band is nodata (GDAL_NODATA = {})",
            nodata.map_or("NaN".into(), |n| n.to_string())
        )));
    }
    let map = Map {
        name: name.to_string(),
        geo,
        layers,
    };
    Ok((map, order))
}

/// Where a raster's cells lie, as GDAL gives it: its geotransform and its CRS as
/// GeoKeys (a GeoTIFF's own, or those GDAL would write for a sidecar's or a `.prj`
/// file's WKT).
pub(crate) struct Georeferencing<'a> {
    /// GDAL's geotransform as ours (x = a·col + b·row + c, y = d·col + e·row + f).
    pub transform: [f64; 6],
    /// The GeoKeyDirectory (header and keys); empty where there is no CRS.
    pub keys: &'a [u16],
    /// The GeoDoubleParams the keys point into.
    pub doubles: Vec<f64>,
    /// The GeoAsciiParams the keys point into.
    pub ascii: String,
    /// Whether the transform comes from TIFF tiepoints a PixelIsPoint key moves.
    pub pixel_is_point_tags: bool,
}

impl<'a> Georeferencing<'a> {
    /// A grid and CRS given outside TIFF tags (a header, a sidecar, a format's own
    /// georeference): GDAL's transform, the GeoKeys of the CRS and the citations they
    /// point into.
    pub(crate) fn of_grid(transform: [f64; 6], keys: &'a [u16], ascii: String) -> Self {
        Georeferencing {
            transform,
            keys,
            doubles: Vec::new(),
            ascii,
            pixel_is_point_tags: false,
        }
    }
}

/// The grid of a `width` × `height` raster read from `path`, and metres per unit of its
/// heights (vertical GeoKeys); an error says why the raster cannot be a map.
pub(crate) fn georeference(
    path: &Path,
    width: u32,
    height: u32,
    georeferencing: Georeferencing,
) -> Result<(GeoRef, f64)> {
    let problem = |message: String| Error::input(path, message);
    let Georeferencing {
        transform,
        keys,
        doubles,
        ascii,
        pixel_is_point_tags: from_tags,
    } = georeferencing;
    let [a, b, c, d, e, f] = transform;
    let key = |id: u16| {
        keys.get(4..)
            .unwrap_or_default()
            .chunks_exact(4)
            .find(|k| k[0] == id && k[1] == 0)
            .map(|k| k[3])
    };
    // PixelIsPoint moves the TIFF's own tiepoints; a sidecar's transform is GDAL's,
    // from cell corners already.
    let point = from_tags && key(GT_RASTER_TYPE) == Some(PIXEL_IS_POINT);
    let units = crs_units(&key).map_err(problem)?;
    // A linear unit other than the code's own (an old ERDAS State Plane file: its
    // metric EPSG code, coordinates in US survey feet) makes the CRS another than the
    // code's, as GDAL reads it: not named by the code.
    let unit_overridden = key(PROJECTED_CRS)
        .filter(|_| key(PROJ_LINEAR_UNITS).is_some())
        .and_then(crate::grid::epsg_crs)
        .and_then(|crs| crs.metres_per_unit())
        .is_some_and(|own| (own / units.scale - 1.0).abs() > 1e-9);
    let frame = key(PROJECTED_CRS)
        .or(key(GEOGRAPHIC_CRS))
        .filter(|&code| code != 0 && code != USER_DEFINED && !unit_overridden)
        .map_or_else(|| "map".to_string(), |code| format!("EPSG:{code}"));
    let heights = height_scale(&key).map_err(problem)?;

    // Rotation terms below a billionth of a cell are the writer's float noise (a
    // ModelTransformation computed in floating point): over a million rows they shift
    // the raster by a thousandth of a cell.
    let noise = 1e-9 * a.abs().min(e.abs());
    if b.abs() > noise || d.abs() > noise {
        return Err(problem(format!(
            "the raster is rotated (geotransform row/column terms {b}, {d}); only \
             axis-aligned rasters are supported: warp it first (gdalwarp)"
        )));
    }
    if !(a != 0.0 && e != 0.0 && a.is_finite() && e.is_finite()) {
        return Err(problem(format!(
            "cells of {} × {} are not a valid size",
            a.abs(),
            e.abs()
        )));
    }
    // Tiepoints of PixelIsPoint rasters are cell centres; move them to corners.
    let (c, f) = if point {
        (c - a / 2.0, f - e / 2.0)
    } else {
        (c, f)
    };
    // A file's columns may run west (a negative x step): the readers turn them east
    // (`FileOrder`), so the grid starts at its west edge.
    let (north_up, columns_from_east) = (e < 0.0, a < 0.0);
    // Angles become degrees; a projected CRS keeps its coordinates in its own unit
    // (feet, as the user's other data in that CRS are), measured on the ground by
    // `ground_scale`.
    let (coordinates, metres_per_unit) = if units.degrees {
        (units.scale, 1.0)
    } else {
        (1.0, units.scale)
    };
    let (x_size, y_size) = (a.abs() * coordinates, e.abs() * coordinates);
    let mut geo = GeoRef {
        width,
        height,
        resolution: x_size,
        resolution_y: (y_size != x_size).then_some(y_size),
        origin: [
            coordinates
                * if columns_from_east {
                    c + a * f64::from(width)
                } else {
                    c
                },
            coordinates
                * if north_up {
                    f + e * f64::from(height)
                } else {
                    f
                },
        ],
        frame,
        degrees: units.degrees,
        web_mercator: !units.degrees
            && key(PROJECTED_CRS).is_some_and(|code| WEB_MERCATOR.contains(&code)),
        ground_scale: None,
        tiff_crs: None,
    };
    let double = |id: u16| {
        keys.get(4..)
            .unwrap_or_default()
            .chunks_exact(4)
            .find(|k| k[0] == id && k[1] == GEO_DOUBLE_PARAMS && k[2] >= 1)
            .and_then(|k| doubles.get(usize::from(k[3])).copied())
    };
    let geo_keys = projection::GeoKeys {
        short: &key,
        double: &double,
        citations: &ascii,
    };
    if !geo.varies_by_row() {
        let projection = projection::of_keys(&geo_keys, metres_per_unit);
        projection::set_ground_scale(&mut geo, projection.as_ref(), metres_per_unit, path);
    }
    let proj = (geo.frame == "map")
        .then(|| projection::proj_string(&geo_keys, metres_per_unit, units.degrees))
        .flatten();
    geo.tiff_crs = tiff_crs(keys, doubles, ascii, coordinates).map(|crs| TiffCrs { proj, ..crs });
    geo.validate().map_err(problem)?;
    // Grids whose nodes lie on the poles (a global DEM registered on its grid lines, as
    // ETOPO and GMT's `_g` grids are) reach half a cell past them.
    let past_poles = if geo.degrees {
        0.5 * geo.cell_size()[1].abs() + 1e-6
    } else {
        1e-6
    };
    if let Some([south, north]) = geo.latitudes()
        && (south < -90.0 - past_poles || north > 90.0 + past_poles)
    {
        return Err(problem(format!(
            "the raster is in degrees but spans latitudes {south} to {north}"
        )));
    }
    Ok((geo, heights))
}

/// What the CRS's units are: a factor to metres for projected units, or degrees.
struct Units {
    scale: f64,
    degrees: bool,
}

/// The units of the raster's CRS from its GeoKeys; an error when they cannot be
/// measured in metres. A raster without GeoKeys is taken to be in metres.
fn crs_units(key: &dyn Fn(u16) -> Option<u16>) -> std::result::Result<Units, String> {
    let model = key(GT_MODEL_TYPE);
    let geographic = match model {
        Some(MODEL_GEOGRAPHIC) => true,
        Some(MODEL_PROJECTED) => false,
        Some(MODEL_GEOCENTRIC) => {
            return Err(
                "the CRS is geocentric (GeoKey GTModelType = 3): cells cannot be \
                        measured on the ground; reproject it (gdalwarp)"
                    .into(),
            );
        }
        // No model type, or a user-defined one (GDAL's for ESRI's projections that
        // GeoTIFF has no code for, such as Mollweide): trust the CRS keys that are
        // there, a linear unit meaning a projection.
        _ => {
            key(PROJECTED_CRS).is_none()
                && key(PROJ_LINEAR_UNITS).is_none()
                && key(GEOGRAPHIC_CRS).is_some()
        }
    };
    if geographic {
        return match key(GEOG_ANGULAR_UNITS).map_or(Some(1.0), degrees_per_angular_unit) {
            Some(scale) => Ok(Units {
                scale,
                degrees: true,
            }),
            None => Err(format!(
                "the geographic CRS's angular unit {} (GeoKey GeogAngularUnits) cannot \
                 be measured in metres; reproject it (gdalwarp -t_srs EPSG:4326)",
                key(GEOG_ANGULAR_UNITS).unwrap_or_default()
            )),
        };
    }
    match key(PROJ_LINEAR_UNITS) {
        // The CRS named by its EPSG code alone: its unit is the registry's (GDAL reads a
        // State Plane code in US survey feet so); metres for codes it does not hold.
        None => Ok(Units {
            scale: key(PROJECTED_CRS)
                .and_then(crate::grid::epsg_crs)
                .and_then(|crs| crs.metres_per_unit())
                .unwrap_or(1.0),
            degrees: false,
        }),
        Some(code) => metres_per_epsg_unit(code)
            .map(|scale| Units {
                scale,
                degrees: false,
            })
            .ok_or_else(|| {
                format!(
                    "the projected CRS's linear unit {code} (GeoKey ProjLinearUnits) cannot \
                     be measured in metres; reproject it (gdalwarp)"
                )
            }),
    }
}

/// What the GeoTIFF tags of a TIFF held in memory give: GeoJP2 embeds one, of 1 × 1
/// cells, in a JPEG 2000 file to georeference it. `None` where it has no geotransform.
pub(crate) struct TagGeoreference {
    /// As ours (x = a·col + b·row + c, y = d·col + e·row + f).
    pub transform: [f64; 6],
    pub keys: Vec<u16>,
    pub doubles: Vec<f64>,
    pub ascii: String,
}

/// The georeference of the GeoTIFF tags of the TIFF `bytes`; `None` where they give
/// no geotransform.
pub(crate) fn tags_georeference(
    bytes: &[u8],
) -> std::result::Result<Option<TagGeoreference>, String> {
    let mut decoder = Decoder::new(Cursor::new(bytes)).map_err(|e| e.to_string())?;
    let Some(transform) = geotransform(&mut decoder)? else {
        return Ok(None);
    };
    let keys = decoder
        .find_tag_unsigned_vec::<u16>(Tag::GeoKeyDirectoryTag)
        .map_err(|e| e.to_string())?
        .unwrap_or_default();
    let doubles = decoder
        .find_tag(Tag::GeoDoubleParamsTag)
        .map_err(|e| e.to_string())?
        .and_then(|v| v.into_f64_vec().ok())
        .unwrap_or_default();
    let ascii = decoder
        .find_tag(Tag::GeoAsciiParamsTag)
        .map_err(|e| e.to_string())?
        .and_then(|v| v.into_string().ok())
        .unwrap_or_default();
    Ok(Some(TagGeoreference {
        transform,
        keys,
        doubles,
        ascii,
    }))
}

/// The TIFF's own geotransform; `None` where it has no georeference tags at all.
fn geotransform<R: std::io::Read + std::io::Seek>(
    decoder: &mut Decoder<R>,
) -> std::result::Result<Option<[f64; 6]>, String> {
    let tag = |decoder: &mut Decoder<R>, tag: Tag| {
        decoder
            .find_tag(tag)
            .map_err(|e| e.to_string())?
            .map(|v| v.into_f64_vec().map_err(|e| e.to_string()))
            .transpose()
    };
    if let Some(m) = tag(decoder, Tag::ModelTransformationTag)? {
        if m.len() < 8 {
            return Err("ModelTransformationTag has fewer than 8 values".into());
        }
        return Ok(Some([m[0], m[1], m[3], m[4], m[5], m[7]]));
    }
    let scale = tag(decoder, Tag::ModelPixelScaleTag)?;
    let tie = tag(decoder, Tag::ModelTiepointTag)?;
    match (scale, tie) {
        (Some(s), Some(t)) if s.len() >= 2 && t.len() >= 6 => {
            // Tiepoint (i, j) ↔ (x, y); pixel scale y is positive for north-up rasters.
            let (i, j, x, y) = (t[0], t[1], t[3], t[4]);
            Ok(Some([s[0], 0.0, x - i * s[0], 0.0, -s[1], y + j * s[1]]))
        }
        (None, Some(t)) if t.len() >= 12 => Err(format!(
            "no georeference but {} ground control points (ModelTiepointTag): the raster \
             is not on a grid yet; warp it onto one (gdalwarp)",
            t.len() / 6
        )),
        (None, None) => Ok(None),
        _ => Err("no georeference: ModelPixelScaleTag and ModelTiepointTag are incomplete".into()),
    }
}

/// The GeoKeys of a frame named `EPSG:<code>` (none for other frames).
fn epsg_keys(geo: &GeoRef) -> Vec<[u16; 4]> {
    let epsg = geo
        .frame
        .strip_prefix("EPSG:")
        .and_then(|code| code.parse::<u16>().ok());
    let model = match (epsg, geo.degrees) {
        (_, true) => MODEL_GEOGRAPHIC,
        (Some(_), false) => MODEL_PROJECTED,
        (None, false) => 0,
    };
    let mut keys = vec![[GT_MODEL_TYPE, 0, 1, model]];
    if let Some(code) = epsg {
        let crs = if geo.degrees {
            GEOGRAPHIC_CRS
        } else {
            PROJECTED_CRS
        };
        keys.push([crs, 0, 1, code]);
        // Our coordinates are metres: say so where the code's own unit is another
        // (a State Plane code in US survey feet), or readers take them in that unit.
        let own_unit = crate::grid::epsg_crs(code).and_then(|crs| crs.metres_per_unit());
        if !geo.degrees && own_unit.is_some_and(|unit| unit != 1.0) {
            keys.push([PROJ_LINEAR_UNITS, 0, 1, 9001]);
        }
    }
    keys
}

/// The CRS of a GeoTIFF's GeoKeys, kept to be written back: every key but the raster
/// type (our origins are corners) and the vertical CRS (what is written back is not
/// heights), with the parameters they point into; `None` without a CRS key.
fn tiff_crs(keys: &[u16], doubles: Vec<f64>, ascii: String, per_unit: f64) -> Option<TiffCrs> {
    let keys: Vec<[u16; 4]> = keys
        .get(4..)
        .unwrap_or_default()
        .chunks_exact(4)
        .map(|k| [k[0], k[1], k[2], k[3]])
        .filter(|k| k[0] != GT_RASTER_TYPE && !(VERTICAL_CRS..=VERTICAL_UNITS).contains(&k[0]))
        .collect();
    keys.iter()
        .any(|k| [GEOGRAPHIC_CRS, PROJECTED_CRS, GT_MODEL_TYPE].contains(&k[0]))
        .then_some(TiffCrs {
            keys,
            doubles,
            ascii,
            frame_units_per_unit: per_unit,
            proj: None,
        })
}

/// Writes one float32 band as a north-up GeoTIFF: pixel scale and tiepoint tags, the
/// CRS the raster was read with (its GeoKeys, in its own units) or else the EPSG code
/// when the frame is `EPSG:<code>`, and NaN as the GDAL nodata value.
pub fn write_geotiff(path: &Path, geo: &GeoRef, values: &[f32]) -> Result<()> {
    let (width, height) = (geo.width as usize, geo.height as usize);
    // Our row 0 is the south edge; GeoTIFF rows run from the north.
    let mut north_up = Vec::with_capacity(values.len());
    for row in (0..height).rev() {
        north_up.extend_from_slice(&values[row * width..(row + 1) * width]);
    }
    // The CRS the raster was read with, in its own units (feet, radians); else the
    // frame's EPSG code.
    let (per_unit, mut entries, doubles, ascii) = match &geo.tiff_crs {
        Some(crs) => (
            crs.frame_units_per_unit,
            crs.keys.clone(),
            &crs.doubles[..],
            crs.ascii.as_str(),
        ),
        None => (1.0, epsg_keys(geo), &[][..], ""),
    };
    // PixelIsArea: our origin is the corner of a cell.
    entries.retain(|k| k[0] != GT_RASTER_TYPE);
    entries.push([GT_RASTER_TYPE, 0, 1, 1]);
    entries.sort_by_key(|k| k[0]);
    // GeoKeyDirectory: header (version 1.1.0, key count), then (id, location, count, value).
    let mut keys: Vec<u16> = vec![1, 1, 0, entries.len() as u16];
    keys.extend(entries.iter().flatten());
    let [x_size, y_size] = geo.cell_size().map(|s| s / per_unit);
    let [west, south] = geo.origin.map(|v| v / per_unit);
    let top = south + y_size * f64::from(geo.height);
    let failed = |e: tiff::TiffError| Error::Failed(format!("writing {}: {e}", path.display()));
    crate::io::fs::write_atomic_seekable(path, |out| {
        let mut encoder = tiff::encoder::TiffEncoder::new(out).map_err(failed)?;
        let mut image = encoder
            .new_image::<tiff::encoder::colortype::Gray32Float>(geo.width, geo.height)
            .map_err(failed)?;
        let tags = image.encoder();
        tags.write_tag(Tag::ModelPixelScaleTag, &[x_size, y_size, 0.0][..])
            .map_err(failed)?;
        tags.write_tag(Tag::ModelTiepointTag, &[0.0, 0.0, 0.0, west, top, 0.0][..])
            .map_err(failed)?;
        tags.write_tag(Tag::GeoKeyDirectoryTag, &keys[..])
            .map_err(failed)?;
        if !doubles.is_empty() {
            tags.write_tag(Tag::GeoDoubleParamsTag, doubles)
                .map_err(failed)?;
        }
        if !ascii.is_empty() {
            tags.write_tag(Tag::GeoAsciiParamsTag, ascii)
                .map_err(failed)?;
        }
        tags.write_tag(Tag::GdalNodata, "nan").map_err(failed)?;
        image.write_data(&north_up).map_err(failed)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raster(name: &str) -> Option<std::path::PathBuf> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/data/raster")
            .join(name);
        if path.exists() {
            Some(path)
        } else {
            eprintln!("skipped: {} is absent", path.display());
            None
        }
    }

    #[test]
    fn reads_a_north_up_web_mercator_hillshade_with_nodata() {
        let Some(path) = raster("rasterio_shade.tif") else {
            return;
        };
        let map = read_geotiff(&path, "shade").unwrap();
        let geo = &map.geo;
        assert_eq!((geo.width, geo.height), (1024, 1024));
        assert_eq!(geo.frame, "EPSG:3857");
        assert!((geo.resolution - 9.5546285343).abs() < 1e-9);
        // Web Mercator metres are ground metres only on the equator: at 39.6° N a cell
        // spans 9.555 · cos 39.6° ≈ 7.37 m (N·cos φ / A east, M·cos φ / A north).
        assert!(geo.web_mercator);
        let [east, north] = geo.cell_metres();
        assert!((east - 7.371).abs() < 0.005, "{east}");
        assert!((north - 7.342).abs() < 0.005, "{north}");
        // The tiepoint is the north-west corner; our origin is the south-west one.
        assert!((geo.origin[0] - -11858134.818413004).abs() < 1e-6);
        assert!((geo.origin[1] - (4813698.2926443005 - 1024.0 * 9.5546285343)).abs() < 1e-6);
        let band = &map.layers[0];
        assert_eq!(band.name, "band1");
        // The file's first row (north edge) is our last row; 255 is nodata there.
        assert!(band.values[1023 * 1024].is_nan());
        // As tifffile counts them: 124375 cells are not 255.
        let valid = band.values.iter().filter(|v| !v.is_nan()).count();
        assert_eq!(valid, 124_375);
        // File row 312, column 986 holds data and its mirror row 711 does not.
        assert_eq!(band.values[(1023 - 312) * 1024 + 986], 0.0);
        assert!(band.values[312 * 1024 + 986].is_nan());
    }

    #[test]
    fn reads_a_south_up_float_raster_with_nan_nodata() {
        let Some(path) = raster("rasterio_float_nan.tif") else {
            return;
        };
        let map = read_geotiff(&path, "f").unwrap();
        assert_eq!((map.geo.width, map.geo.height), (3, 2));
        assert_eq!(map.geo.resolution, 100.0);
        assert_eq!(map.geo.origin, [0.0, 0.0]);
        // The transformation grows y with the row: the file's row 0 is already south.
        let v = &map.layers[0].values;
        assert_eq!(&v[..2], &[1.41, 1.23]);
        assert!(v[2].is_nan());
        assert_eq!(&v[3..], &[0.32, -0.23, -1.88]);
    }

    #[test]
    fn reads_a_world_image_in_degrees_and_measures_it_in_metres() {
        let Some(path) = raster("rasterio_world.byte.tif") else {
            return;
        };
        let map = read_geotiff(&path, "world").unwrap();
        let geo = &map.geo;
        assert_eq!((geo.width, geo.height), (2880, 1200));
        assert_eq!(geo.frame, "EPSG:4326");
        assert!(geo.degrees);
        assert_eq!(geo.cell_size(), [0.125, 0.125]);
        // Cells of 1/8° are about 13.8 km north-south; the image is centred near the
        // equator, where a degree of longitude is about as long (13.9 km).
        let [east, north] = geo.cell_metres();
        assert!((13_700.0..14_000.0).contains(&north), "{north}");
        assert!((east / north - 1.0).abs() < 0.02, "{east} {north}");
        assert!(geo.scale_variation() > 0.05, "it spans many latitudes");
    }

    /// GeoKeys as the reader looks them up, from (id, value) pairs.
    fn keys(pairs: &'static [(u16, u16)]) -> impl Fn(u16) -> Option<u16> {
        move |id| pairs.iter().find(|(k, _)| *k == id).map(|(_, v)| *v)
    }

    #[test]
    fn heights_in_feet_are_known_by_their_vertical_crs_or_units() {
        let us_foot = 1200.0 / 3937.0;
        // EPSG:2263+6360 as GDAL writes it: NAVD88 height (ftUS), no VerticalUnits.
        let navd88_feet = height_scale(&keys(&[(3072, 2263), (4096, 6360)])).unwrap();
        assert!((navd88_feet - us_foot).abs() < 1e-12);
        assert_eq!(height_scale(&keys(&[(4096, 5703)])).unwrap(), 1.0); // NAVD88 (m)
        assert_eq!(height_scale(&keys(&[(4096, 8228)])).unwrap(), 0.3048);
        assert_eq!(height_scale(&keys(&[(4099, 9002)])).unwrap(), 0.3048);
        assert_eq!(height_scale(&keys(&[(3072, 32616)])).unwrap(), 1.0);
        let odd = height_scale(&keys(&[(4099, 9005)])).unwrap_err();
        assert!(odd.contains("VerticalUnits"), "{odd}");
    }

    #[test]
    fn crs_units_are_metres_feet_or_degrees_and_nothing_else() {
        let projected_feet = crs_units(&keys(&[(1024, 1), (3072, 2263), (3076, 9003)])).unwrap();
        assert!((projected_feet.scale - 0.3048006).abs() < 1e-6 && !projected_feet.degrees);
        // Without ProjLinearUnits, the EPSG code's own unit; metres for a user-defined
        // CRS or a code the registry does not hold.
        let code_alone = crs_units(&keys(&[(1024, 1), (3072, 2263)])).unwrap();
        assert!((code_alone.scale - 0.3048006).abs() < 1e-6);
        assert_eq!(
            crs_units(&keys(&[(1024, 1), (3072, 32633)])).unwrap().scale,
            1.0
        );
        assert_eq!(
            crs_units(&keys(&[(1024, 1), (3072, 32767)])).unwrap().scale,
            1.0
        );
        assert!(
            crs_units(&keys(&[(1024, 2), (2048, 4326)]))
                .unwrap()
                .degrees
        );
        assert!(crs_units(&keys(&[])).unwrap().scale == 1.0);
        // NTF (Paris) in grads: 0.9° each.
        let grads = crs_units(&keys(&[(1024, 2), (2048, 4807), (2054, 9105)])).unwrap();
        assert!(grads.degrees && grads.scale == 0.9);
        let odd = crs_units(&keys(&[(1024, 2), (2054, 9107)])).err().unwrap();
        assert!(odd.contains("9107"), "{odd}");
        let geocentric = crs_units(&keys(&[(1024, 3)])).err().unwrap();
        assert!(geocentric.contains("geocentric"), "{geocentric}");
        let odd = crs_units(&keys(&[(1024, 1), (3076, 9005)])).err().unwrap();
        assert!(
            odd.contains("ProjLinearUnits") && odd.contains("9005"),
            "{odd}"
        );
        let odd = crs_units(&keys(&[(1024, 2), (2054, 9110)])).err().unwrap();
        assert!(odd.contains("GeogAngularUnits"), "{odd}");
    }

    /// The georeference of the GeoTIFF `write_geotiff` wrote at `path` from `geo`: its
    /// CRS is the frame's EPSG code as GeoKeys, and the rest is `geo`'s.
    fn written_georeference(path: &Path, geo: &GeoRef) -> GeoRef {
        let mut back = read_geotiff(path, "g").unwrap().geo;
        let crs = back.tiff_crs.take().unwrap();
        assert_eq!(crs.keys, epsg_keys(geo));
        back
    }

    #[test]
    fn written_geotiffs_read_back_with_their_georeference() {
        let dir = tempfile::tempdir().unwrap();
        let geo = GeoRef {
            width: 3,
            height: 2,
            resolution: 2.5,
            resolution_y: None,
            // On the zone's meridian: a UTM metre there is read as a ground metre.
            origin: [500_000.0, 1000.0],
            frame: "EPSG:32633".into(),
            degrees: false,
            web_mercator: false,
            ground_scale: None,
            tiff_crs: None,
        };
        let values = [1.0, 2.0, f32::NAN, 4.0, 5.0, 6.5];
        let path = dir.path().join("c.tif");
        write_geotiff(&path, &geo, &values).unwrap();
        assert_eq!(written_georeference(&path, &geo), geo);
        // A frame whose EPSG code is in feet is written in metres and says so.
        let feet = GeoRef {
            frame: "EPSG:2263".into(),
            origin: [300_000.0, 1000.0],
            ..geo.clone()
        };
        let feet_path = dir.path().join("feet.tif");
        write_geotiff(&feet_path, &feet, &values).unwrap();
        let back = read_geotiff(&feet_path, "c").unwrap().geo;
        assert_eq!(
            (back.cell_size(), back.origin),
            (feet.cell_size(), feet.origin)
        );
        let map = read_geotiff(&path, "c").unwrap();
        let back = &map.layers[0].values;
        assert_eq!(&back[..2], &values[..2]);
        assert!(back[2].is_nan());
        assert_eq!(&back[3..], &values[3..]);
    }

    #[test]
    fn rectangular_and_geographic_grids_write_and_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let geo = GeoRef {
            resolution_y: Some(0.01),
            degrees: true,
            ..GeoRef::square(3, 2, 0.02, [7.0, 45.0], "EPSG:4326")
        };
        let path = dir.path().join("g.tif");
        write_geotiff(&path, &geo, &[1.0; 6]).unwrap();
        assert_eq!(written_georeference(&path, &geo), geo);
        let mercator = GeoRef {
            web_mercator: true,
            ground_scale: None,
            tiff_crs: None,
            ..GeoRef::square(3, 2, 30.0, [-11_858_134.8, 4_803_914.4], "EPSG:3857")
        };
        write_geotiff(&path, &mercator, &[1.0; 6]).unwrap();
        assert_eq!(written_georeference(&path, &mercator), mercator);
    }

    #[test]
    fn files_that_are_not_tiff_are_input_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.tif");
        std::fs::write(&path, b"not a tiff").unwrap();
        let err = read_geotiff(&path, "x").unwrap_err();
        assert_eq!(err.exit_code(), 2);
        assert!(err.to_string().contains("x.tif"), "{err}");
    }
}
