//! Georeferenced PNG and JPEG images (`.png`, `.jpg`, `.jpeg`): orthophotos and map
//! exports as mapping agencies, QGIS and GDAL hand them out. The pixels carry no
//! georeference; it lies beside them, where GDAL looks for it: the PAM sidecar
//! (`.aux.xml`, where GDAL and rasterio write a PNG's or JPEG's CRS and grid), then a
//! world file (`x.pgw`, `x.pngw`, `x.jgw`, `x.jpgw`, `x.wld`: the grid with no CRS).
//!
//! Bands are as GDAL gives them: a PNG's grey, grey and alpha, RGB or RGBA samples at
//! their own depth (1 to 16 bits, not scaled), a palette PNG's indices (class codes, as
//! a palette GeoTIFF's); a JPEG's grey or RGB (YCbCr and CMYK converted, as libjpeg
//! does). Nodata is marked as GDAL's masks mark it: GDAL's bit mask appended to a JPEG
//! (how it keeps a JPEG's nodata), else a band's nodata value (the sidecar's, a grey
//! PNG's transparent value, a palette's one transparent entry), else the sidecar's
//! `NODATA_VALUES` (an RGB PNG's transparent colour), else the alpha band.

use std::io::{Cursor, Read};
use std::path::Path;

use super::FileOrder;
use super::geotiff::{Georeferencing, georeference, pam_georeference, world_file_transform};
use super::sidecar_bands::{self, FileMasks, Samples};
use crate::error::{Error, Result, read_input};
use crate::grid::Map;

/// The most bytes a decoded image may take (as a GeoTIFF's samples may).
const MAX_DECODED_BYTES: usize = 16 << 30;

/// The georeferenced PNG or JPEG image at `path` as map `name`, with whether its rows
/// ran from the north.
pub fn read_picture_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let bytes = read_input(path)?;
    let image = if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        decode_png(&bytes, ::png::Transformations::IDENTITY)
            .map_err(|e| problem(format!("not a readable PNG: {e}")))?
    } else if bytes.starts_with(&[0xff, 0xd8]) {
        decode_jpeg(&bytes).map_err(|e| problem(format!("not a readable JPEG: {e}")))?
    } else {
        return Err(problem(
            "neither a PNG nor a JPEG image (its first bytes are neither's signature)".into(),
        ));
    };
    let (width, height) = (image.width, image.height);
    let pam = pam_georeference(path).map_err(problem)?;
    let transform = match pam.transform {
        Some(transform) => transform,
        None => world_file_transform(path)
            .map_err(problem)?
            .ok_or_else(|| {
                problem(
                    "no georeference: no GDAL sidecar (.aux.xml) with a <GeoTransform>, \
                     nor a world file (.pgw, .jgw, .wld) beside it"
                        .into(),
                )
            })?,
    };
    let keys = pam.keys.transpose().map_err(problem)?.unwrap_or_default();
    let (geo, heights) = georeference(
        path,
        width,
        height,
        Georeferencing::of_grid(transform, &keys, pam.citation),
    )?;
    let order = FileOrder::of_transform(&transform);
    let bands = image.bands;
    let samples = Samples {
        width,
        height,
        bands,
        order,
        heights,
        sample: |band: usize, cell: usize| image.samples[cell * bands + band],
    };
    sidecar_bands::map(path, name, geo, samples, &image.masks)
}

/// A decoded image as GDAL presents it.
#[derive(Debug, Default, Clone)]
pub(super) struct Picture {
    pub width: u32,
    pub height: u32,
    pub bands: usize,
    /// Band-interleaved samples, row by row from the top.
    pub samples: Vec<f32>,
    /// What the file says of its cells: its alpha band, palette, transparent values,
    /// GDAL's mask appended to a JPEG.
    pub masks: FileMasks,
}

/// An output buffer of `len` bytes, or an error where the image is too large to hold.
fn buffer(len: usize) -> std::result::Result<Vec<u8>, String> {
    let mut out = Vec::new();
    if len > MAX_DECODED_BYTES || out.try_reserve_exact(len).is_err() {
        return Err(format!(
            "its decoded image would take {len} bytes, more than can be held"
        ));
    }
    out.resize(len, 0);
    Ok(out)
}

/// Decodes a PNG's samples: as they are stored with `IDENTITY` (no palette expansion, no
/// scaling of low bit depths), as GDAL reads a PNG; with `EXPAND` as 8- or 16-bit grey
/// or colour, a palette's colours and a transparent value as alpha, as GDAL reads a
/// GeoPackage's tiles.
pub(super) fn decode_png(
    bytes: &[u8],
    transformations: ::png::Transformations,
) -> std::result::Result<Picture, String> {
    let mut decoder = ::png::Decoder::new_with_limits(
        Cursor::new(bytes),
        ::png::Limits {
            bytes: MAX_DECODED_BYTES,
        },
    );
    decoder.set_transformations(transformations);
    let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
    let info = reader.info();
    let (width, height) = (info.width, info.height);
    let (colour, depth) = reader.output_color_type();
    let depth = depth as u8;
    let trns = info.trns.as_ref().map(|t| t.to_vec());
    let palette_len = info.palette.as_ref().map_or(0, |p| p.len() / 3);
    let size = reader
        .output_buffer_size()
        .ok_or("its size overflows memory")?;
    let mut raw = buffer(size)?;
    let frame = reader.next_frame(&mut raw).map_err(|e| e.to_string())?;
    let bands = colour.samples();
    let line = frame.line_size;
    let mut samples = Vec::new();
    samples
        .try_reserve_exact(width as usize * height as usize * bands)
        .map_err(|_| "its samples are more than can be held".to_string())?;
    for row in raw.chunks_exact(line).take(height as usize) {
        let per_row = width as usize * bands;
        match depth {
            16 => samples.extend(
                row.chunks_exact(2)
                    .take(per_row)
                    .map(|b| f32::from(u16::from_be_bytes([b[0], b[1]]))),
            ),
            8 => samples.extend(row[..per_row].iter().map(|&b| f32::from(b))),
            bits => {
                // 1, 2 or 4 bits a sample, the first in the byte's high bits.
                let bits = usize::from(bits);
                let mask = (1u8 << bits) - 1;
                samples.extend((0..per_row).map(|i| {
                    let at = i * bits;
                    f32::from((row[at / 8] >> (8 - bits - at % 8)) & mask)
                }));
            }
        }
    }
    // The png crate keeps a transparent grey or colour as one byte a sample below 16
    // bits, two (big-endian) at 16.
    let transparent = |t: &[u8], i: usize| {
        if depth == 16 {
            t.get(2 * i..2 * i + 2)
                .map(|b| f32::from(u16::from_be_bytes([b[0], b[1]])))
        } else {
            t.get(i).map(|&b| f32::from(b))
        }
    };
    let mut picture = Picture {
        width,
        height,
        bands,
        samples,
        masks: FileMasks {
            nodata: vec![None; bands],
            ..FileMasks::default()
        },
    };
    match colour {
        ::png::ColorType::GrayscaleAlpha | ::png::ColorType::Rgba => {
            picture.masks.alpha = Some(bands - 1)
        }
        ::png::ColorType::Indexed => {
            picture.masks.classes = vec![true];
            // GDAL's nodata is the palette's one fully transparent entry, if it has
            // exactly one.
            if let Some(alphas) = &trns {
                let clear: Vec<usize> = (0..palette_len)
                    .filter(|&i| alphas.get(i).is_some_and(|&a| a == 0))
                    .collect();
                if let [only] = clear[..] {
                    picture.masks.nodata[0] = Some(only as f32);
                }
            }
        }
        ::png::ColorType::Grayscale => {
            picture.masks.nodata[0] = trns.as_deref().and_then(|t| transparent(t, 0))
        }
        ::png::ColorType::Rgb => {
            picture.masks.nodata_values = trns.as_deref().and_then(|t| {
                (0..3)
                    .map(|i| transparent(t, i))
                    .collect::<Option<Vec<f32>>>()
            });
        }
    }
    Ok(picture)
}

/// Decodes a JPEG as GDAL's libjpeg does (grey stays grey, YCbCr and CMYK become RGB),
/// with the bit mask GDAL appends after the image where it has one.
pub(super) fn decode_jpeg(bytes: &[u8]) -> std::result::Result<Picture, String> {
    use zune_jpeg::zune_core::colorspace::ColorSpace;
    use zune_jpeg::zune_core::options::DecoderOptions;
    let options = DecoderOptions::default()
        .set_max_width(usize::from(u16::MAX))
        .set_max_height(usize::from(u16::MAX));
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(Cursor::new(bytes), options);
    decoder.decode_headers().map_err(|e| e.to_string())?;
    let grey = decoder.input_colorspace() == Some(ColorSpace::Luma);
    let out = if grey {
        ColorSpace::Luma
    } else {
        ColorSpace::RGB
    };
    decoder.set_options(options.jpeg_set_out_colorspace(out));
    decoder.decode_headers().map_err(|e| e.to_string())?;
    let info = decoder.info().ok_or("it has no frame header")?;
    let (width, height) = (u32::from(info.width), u32::from(info.height));
    let size = decoder
        .output_buffer_size()
        .ok_or("its size overflows memory")?;
    let mut raw = buffer(size)?;
    decoder.decode_into(&mut raw).map_err(|e| e.to_string())?;
    let bands = out.num_components();
    let mask = gdal_mask(bytes, width as usize * height as usize)?;
    Ok(Picture {
        width,
        height,
        bands,
        samples: raw.iter().map(|&b| f32::from(b)).collect(),
        masks: FileMasks {
            mask,
            ..FileMasks::default()
        },
    })
}

/// The bit mask GDAL appends to a JPEG it writes with nodata or a mask: after the
/// image's end marker, the mask's bits (one a cell, row after row, the first cell in a
/// byte's low bit, 1 where there is data) deflated with zlib, then the image's length
/// as a little-endian u32. `None` where the file ends with its image.
fn gdal_mask(bytes: &[u8], cells: usize) -> std::result::Result<Option<Vec<bool>>, String> {
    let Some(tail) = bytes.len().checked_sub(4).map(|at| &bytes[at..]) else {
        return Ok(None);
    };
    let image_len = u32::from_le_bytes([tail[0], tail[1], tail[2], tail[3]]) as usize;
    // GDAL's own test: a plausible image length, an end-of-image marker right before.
    let plausible = image_len >= bytes.len() / 2
        && image_len <= bytes.len() - 4
        && image_len >= 2
        && bytes[image_len - 2..image_len] == [0xff, 0xd9];
    if !plausible {
        return Ok(None);
    }
    let mut bits = Vec::new();
    flate2::read::ZlibDecoder::new(&bytes[image_len..bytes.len() - 4])
        .take(cells.div_ceil(8) as u64)
        .read_to_end(&mut bits)
        .map_err(|e| format!("GDAL's mask after the image cannot be inflated: {e}"))?;
    if bits.len() * 8 < cells {
        return Err(format!(
            "GDAL's mask after the image holds {} bits for {cells} cells",
            bits.len() * 8
        ));
    }
    Ok(Some(
        (0..cells)
            .map(|i| bits[i / 8] >> (i % 8) & 1 == 1)
            .collect(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn png(
        width: u32,
        height: u32,
        colour: ::png::ColorType,
        depth: ::png::BitDepth,
        data: &[u8],
    ) -> Vec<u8> {
        png_with(width, height, colour, depth, data, |_| {})
    }

    fn png_with(
        width: u32,
        height: u32,
        colour: ::png::ColorType,
        depth: ::png::BitDepth,
        data: &[u8],
        extra: impl FnOnce(&mut ::png::Encoder<&mut Vec<u8>>),
    ) -> Vec<u8> {
        let mut out = Vec::new();
        {
            let mut encoder = ::png::Encoder::new(&mut out, width, height);
            encoder.set_color(colour);
            encoder.set_depth(depth);
            extra(&mut encoder);
            let mut writer = encoder.write_header().unwrap();
            writer.write_image_data(data).unwrap();
        }
        out
    }

    #[test]
    fn png_samples_are_read_as_stored_at_every_depth() {
        // Two rows of 3 cells, 2 bits each: 0 1 2 / 3 0 1, padded to a byte a row.
        let grey = png(
            3,
            2,
            ::png::ColorType::Grayscale,
            ::png::BitDepth::Two,
            &[0b0001_1000, 0b1100_0100],
        );
        let picture = decode_png(&grey, ::png::Transformations::IDENTITY).unwrap();
        assert_eq!(picture.samples, [0.0, 1.0, 2.0, 3.0, 0.0, 1.0]);
        let wide = png(
            2,
            1,
            ::png::ColorType::Grayscale,
            ::png::BitDepth::Sixteen,
            &[0x12, 0x34, 0xff, 0xfe],
        );
        assert_eq!(
            decode_png(&wide, ::png::Transformations::IDENTITY)
                .unwrap()
                .samples,
            [4660.0, 65534.0]
        );
        let rgba = png(
            1,
            1,
            ::png::ColorType::Rgba,
            ::png::BitDepth::Eight,
            &[1, 2, 3, 0],
        );
        let picture = decode_png(&rgba, ::png::Transformations::IDENTITY).unwrap();
        assert_eq!((picture.bands, picture.masks.alpha), (4, Some(3)));
    }

    #[test]
    fn transparent_values_become_nodata_as_gdal_sets_it() {
        let grey = png_with(
            2,
            1,
            ::png::ColorType::Grayscale,
            ::png::BitDepth::Eight,
            &[7, 9],
            |e| {
                e.set_trns(vec![0, 9]);
            },
        );
        assert_eq!(
            decode_png(&grey, ::png::Transformations::IDENTITY)
                .unwrap()
                .masks
                .nodata,
            [Some(9.0)]
        );
        let rgb = png_with(
            1,
            1,
            ::png::ColorType::Rgb,
            ::png::BitDepth::Eight,
            &[1, 2, 3],
            |e| {
                e.set_trns(vec![0, 5, 0, 5, 0, 5]);
            },
        );
        assert_eq!(
            decode_png(&rgb, ::png::Transformations::IDENTITY)
                .unwrap()
                .masks
                .nodata_values,
            Some(vec![5.0; 3])
        );
        // One clear entry is nodata; two are not (GDAL sets none).
        for (alphas, nodata) in [(vec![255, 0, 255], Some(1.0)), (vec![0, 0, 255], None)] {
            let indexed = png_with(
                1,
                1,
                ::png::ColorType::Indexed,
                ::png::BitDepth::Eight,
                &[1],
                |e| {
                    e.set_palette(vec![0; 9]);
                    e.set_trns(alphas);
                },
            );
            let picture = decode_png(&indexed, ::png::Transformations::IDENTITY).unwrap();
            assert_eq!(picture.masks.classes, vec![true]);
            assert_eq!(picture.masks.nodata, [nodata]);
        }
    }

    #[test]
    fn gdals_jpeg_mask_is_read_and_anything_else_after_the_image_is_not_a_mask() {
        let mut image = vec![0xff, 0xd8];
        image.extend([7; 36]);
        image.extend([0xff, 0xd9]);
        // Cells 0..10: data everywhere but cells 1 and 9.
        let bits: [u8; 2] = [0b1111_1101, 0b0000_0001];
        let mut zlib = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        zlib.write_all(&bits).unwrap();
        let mut file = image.clone();
        file.extend(zlib.finish().unwrap());
        file.extend((image.len() as u32).to_le_bytes());
        let mask = gdal_mask(&file, 10).unwrap().unwrap();
        assert_eq!(
            mask,
            [true, false, true, true, true, true, true, true, true, false]
        );
        assert_eq!(gdal_mask(&image, 10).unwrap(), None);
        assert!(
            gdal_mask(&file, 100)
                .unwrap_err()
                .contains("16 bits for 100 cells")
        );
    }

    #[test]
    fn bytes_that_are_neither_image_are_an_error_not_a_panic() {
        for bytes in [
            &b"\x89PNG\r\n\x1a\nxx"[..],
            &[0xff, 0xd8, 0xff],
            &[0xff, 0xd8, 0xff, 0xd9, 0, 0, 0, 0],
        ] {
            let result = if bytes[0] == 0x89 {
                decode_png(bytes, ::png::Transformations::IDENTITY).map(|_| ())
            } else {
                decode_jpeg(bytes).map(|_| ())
            };
            assert!(result.is_err());
        }
    }

    proptest::proptest! {
        /// Any bytes after a PNG's or a JPEG's signature, and any tail after a JPEG's
        /// end marker, decode or give an error: never a panic.
        #[test]
        fn any_bytes_decode_or_are_refused(
            body in proptest::collection::vec(proptest::num::u8::ANY, 0..600),
            tail in proptest::collection::vec(proptest::num::u8::ANY, 0..40),
        ) {
            let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
            png.extend(&body);
            let _ = decode_png(&png, ::png::Transformations::IDENTITY);
            let mut jpeg = vec![0xff, 0xd8];
            jpeg.extend(&body);
            jpeg.extend([0xff, 0xd9]);
            jpeg.extend(&tail);
            let _ = decode_jpeg(&jpeg);
            let _ = gdal_mask(&jpeg, body.len());
        }
    }
}
