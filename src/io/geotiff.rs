//! GeoTIFF map layers through the `tiff` crate: every band becomes a layer (`band1`, ...),
//! cells equal to the GDAL nodata value become NaN (our nodata mask), and the
//! georeference comes from the pixel-scale + tiepoint tags or the transformation matrix.
//! Rasters stored north-up (row 0 at the top) are flipped to our south-first rows.

use std::io::Cursor;
use std::path::Path;

use tiff::decoder::{Decoder, DecodingResult};
use tiff::tags::Tag;

use crate::error::{Error, Result, read_input};
use crate::grid::{GeoRef, Layer, Map};

/// GeoKey ids (GeoTIFF 1.1): raster type and the EPSG codes of the CRS.
const GT_RASTER_TYPE: u16 = 1025;
const PROJECTED_CRS: u16 = 3072;
const GEOGRAPHIC_CRS: u16 = 2048;
const PIXEL_IS_POINT: u16 = 2;

/// Reads the GeoTIFF at `path` as the map `name`.
pub fn read_geotiff(path: &Path, name: &str) -> Result<Map> {
    let bytes = read_input(path)?;
    let problem = |message: String| Error::input(path, message);
    let tiff_error = |e: tiff::TiffError| problem(format!("not a readable TIFF: {e}"));
    let mut decoder = Decoder::new(Cursor::new(bytes)).map_err(tiff_error)?;
    let (width, height) = decoder.dimensions().map_err(tiff_error)?;
    let image = decoder.read_image().map_err(tiff_error)?;
    let values: Vec<f32> = match image {
        DecodingResult::U8(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::U16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::U32(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::U64(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::I8(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::I16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::I32(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::I64(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::F16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::F32(v) => v,
        DecodingResult::F64(v) => v.into_iter().map(|x| x as f32).collect(),
    };
    let cells = width as usize * height as usize;
    if cells == 0 || !values.len().is_multiple_of(cells) {
        return Err(problem(format!(
            "{} samples do not fill {width}×{height} cells",
            values.len()
        )));
    }
    let bands = values.len() / cells;

    let keys = decoder
        .find_tag_unsigned_vec::<u16>(Tag::GeoKeyDirectoryTag)
        .map_err(tiff_error)?
        .unwrap_or_default();
    let key = |id: u16| {
        keys.get(4..)
            .unwrap_or_default()
            .chunks_exact(4)
            .find(|k| k[0] == id && k[1] == 0)
            .map(|k| k[3])
    };
    let point = key(GT_RASTER_TYPE) == Some(PIXEL_IS_POINT);
    let frame = key(PROJECTED_CRS)
        .or(key(GEOGRAPHIC_CRS))
        .filter(|&code| code != 0 && code != 32767)
        .map_or_else(|| "map".to_string(), |code| format!("EPSG:{code}"));

    // World x = a·col + b·row + c, y = d·col + e·row + f (GDAL's geotransform).
    let [a, b, c, d, e, f] = geotransform(&mut decoder).map_err(problem)?;
    if b != 0.0 || d != 0.0 {
        return Err(problem(
            "the raster is rotated; only axis-aligned rasters are supported".into(),
        ));
    }
    if a <= 0.0 || (a - e.abs()).abs() > 1e-9 * a {
        return Err(problem(format!(
            "cells of {a} × {} are not square with x growing east",
            e.abs()
        )));
    }
    // Tiepoints of PixelIsPoint rasters are cell centres; move them to corners.
    let (c, f) = if point {
        (c - a / 2.0, f - e / 2.0)
    } else {
        (c, f)
    };
    let north_up = e < 0.0;
    let geo = GeoRef {
        width,
        height,
        resolution: a,
        origin: [
            c,
            if north_up {
                f + e * f64::from(height)
            } else {
                f
            },
        ],
        frame,
    };
    geo.validate().map_err(problem)?;

    let nodata = decoder
        .find_tag(Tag::GdalNodata)
        .map_err(tiff_error)?
        .and_then(|v| v.into_string().ok())
        .and_then(|s| s.trim_end_matches('\0').trim().parse::<f64>().ok());
    let is_nodata = |v: f32| match nodata {
        Some(n) if n.is_nan() => v.is_nan(),
        Some(n) => f64::from(v) == n,
        None => false,
    };
    let layers = (0..bands)
        .map(|band| {
            let mut layer = vec![0f32; cells];
            for row in 0..height as usize {
                let source_row = if north_up {
                    height as usize - 1 - row
                } else {
                    row
                };
                for col in 0..width as usize {
                    let v = values[(source_row * width as usize + col) * bands + band];
                    layer[row * width as usize + col] = if is_nodata(v) { f32::NAN } else { v };
                }
            }
            Layer {
                name: format!("band{}", band + 1),
                values: layer,
            }
        })
        .collect();
    Ok(Map {
        name: name.to_string(),
        geo,
        layers,
    })
}

fn geotransform<R: std::io::Read + std::io::Seek>(
    decoder: &mut Decoder<R>,
) -> std::result::Result<[f64; 6], String> {
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
        return Ok([m[0], m[1], m[3], m[4], m[5], m[7]]);
    }
    let scale = tag(decoder, Tag::ModelPixelScaleTag)?;
    let tie = tag(decoder, Tag::ModelTiepointTag)?;
    match (scale, tie) {
        (Some(s), Some(t)) if s.len() >= 2 && t.len() >= 6 => {
            // Tiepoint (i, j) ↔ (x, y); pixel scale y is positive for north-up rasters.
            let (i, j, x, y) = (t[0], t[1], t[3], t[4]);
            Ok([s[0], 0.0, x - i * s[0], 0.0, -s[1], y + j * s[1]])
        }
        _ => Err(
            "no georeference: neither ModelTransformationTag nor ModelPixelScaleTag with \
             ModelTiepointTag"
                .into(),
        ),
    }
}

/// Writes one float32 band as a north-up GeoTIFF: pixel scale and tiepoint tags, the
/// EPSG code when the frame is `EPSG:<code>`, and NaN as the GDAL nodata value.
pub fn write_geotiff(path: &Path, geo: &GeoRef, values: &[f32]) -> Result<()> {
    let (width, height) = (geo.width as usize, geo.height as usize);
    // Our row 0 is the south edge; GeoTIFF rows run from the north.
    let mut north_up = Vec::with_capacity(values.len());
    for row in (0..height).rev() {
        north_up.extend_from_slice(&values[row * width..(row + 1) * width]);
    }
    let top = geo.origin[1] + geo.resolution * f64::from(geo.height);
    let epsg = geo
        .frame
        .strip_prefix("EPSG:")
        .and_then(|code| code.parse::<u16>().ok());
    // GeoKeyDirectory: header (version 1.1.0, key count), then (id, location, count, value).
    let mut keys: Vec<u16> = vec![1, 1, 0, 0];
    keys.extend_from_slice(&[1024, 0, 1, if epsg.is_some() { 1 } else { 0 }]); // model type
    keys.extend_from_slice(&[GT_RASTER_TYPE, 0, 1, 1]); // PixelIsArea
    if let Some(code) = epsg {
        keys.extend_from_slice(&[PROJECTED_CRS, 0, 1, code]);
    }
    keys[3] = (keys.len() / 4 - 1) as u16;
    let failed = |e: tiff::TiffError| Error::Failed(format!("writing {}: {e}", path.display()));
    crate::io::fs::write_atomic_seekable(path, |out| {
        let mut encoder = tiff::encoder::TiffEncoder::new(out).map_err(failed)?;
        let mut image = encoder
            .new_image::<tiff::encoder::colortype::Gray32Float>(geo.width, geo.height)
            .map_err(failed)?;
        let tags = image.encoder();
        tags.write_tag(
            Tag::ModelPixelScaleTag,
            &[geo.resolution, geo.resolution, 0.0][..],
        )
        .map_err(failed)?;
        tags.write_tag(
            Tag::ModelTiepointTag,
            &[0.0, 0.0, 0.0, geo.origin[0], top, 0.0][..],
        )
        .map_err(failed)?;
        tags.write_tag(Tag::GeoKeyDirectoryTag, &keys[..])
            .map_err(failed)?;
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
    fn written_geotiffs_read_back_with_their_georeference() {
        let dir = tempfile::tempdir().unwrap();
        let geo = GeoRef {
            width: 3,
            height: 2,
            resolution: 2.5,
            origin: [500.0, 1000.0],
            frame: "EPSG:32633".into(),
        };
        let values = [1.0, 2.0, f32::NAN, 4.0, 5.0, 6.5];
        let path = dir.path().join("c.tif");
        write_geotiff(&path, &geo, &values).unwrap();
        let map = read_geotiff(&path, "c").unwrap();
        assert_eq!(map.geo, geo);
        let back = &map.layers[0].values;
        assert_eq!(&back[..2], &values[..2]);
        assert!(back[2].is_nan());
        assert_eq!(&back[3..], &values[3..]);
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
