//! The image's samples through the `tiff` crate, for every compression it decodes: the
//! whole image at once, or strip by strip where GDAL left some out (sparse files), with
//! samples of fewer than 8 bits (1-bit masks, 2- to 7-bit classes) unpacked.

use std::io::{Read, Seek};

use rayon::prelude::*;
use tiff::decoder::{Decoder, DecodingResult};
use tiff::tags::Tag;

use super::chunks::{Image, Layout};
use crate::error::catch_decoder_panic;

/// The image's samples as `f32`, pixel-interleaved, or band after band when
/// band-interleaved; strips or tiles the file leaves out hold the image's `fill`.
/// Errors say what cannot be decoded.
pub(super) fn read<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    image: &Image,
) -> Result<Vec<f32>, String> {
    let bits = decoder
        .find_tag_unsigned_vec::<u16>(Tag::BitsPerSample)
        .map_err(|e| e.to_string())?
        .and_then(|b| b.first().copied())
        .unwrap_or(1);
    let photometric = decoder
        .find_tag_unsigned::<u16>(Tag::PhotometricInterpretation)
        .map_err(|e| e.to_string())?;
    let layout = Layout::of(decoder, image)?;
    let depth = layout.depth();
    let mut values = decode(decoder, image, &layout, bits)?;
    if photometric == Some(YCBCR) && depth == 3 && bits == 8 {
        ycbcr_to_rgb(&mut values);
    }
    Ok(values)
}

/// Turns 8-bit CMYK samples, however they were decoded, into the RGBA GDAL reads them
/// to (`cmyk_to_rgba`).
pub(super) fn cmyk_as_gdal_reads<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    values: &mut [f32],
    band_interleaved: bool,
) -> Result<(), String> {
    let photometric = decoder
        .find_tag_unsigned::<u16>(Tag::PhotometricInterpretation)
        .map_err(|e| e.to_string())?;
    let bits = decoder
        .find_tag_unsigned_vec::<u16>(Tag::BitsPerSample)
        .map_err(|e| e.to_string())?
        .unwrap_or_default();
    if photometric == Some(CMYK) && bits == [8; 4] {
        cmyk_to_rgba(values, band_interleaved);
    }
    Ok(())
}

/// TIFF PhotometricInterpretation of ink separations (`PHOTOMETRIC=CMYK`).
const CMYK: u16 = 5;

/// 8-bit CMYK samples as the RGBA GDAL reads them to (libtiff's RGBA interface:
/// each colour (255 − ink)·(255 − black) / 255, rounded down, and an opaque alpha),
/// pixel- or band-interleaved; the bytes read as unsigned whatever their SampleFormat.
fn cmyk_to_rgba(values: &mut [f32], band_interleaved: bool) {
    let pixels = values.len() / 4;
    let at = |pixel: usize, sample: usize| {
        if band_interleaved {
            sample * pixels + pixel
        } else {
            4 * pixel + sample
        }
    };
    let byte = |v: f32| if v < 0.0 { v + 256.0 } else { v };
    for pixel in 0..pixels {
        let black = 255.0 - byte(values[at(pixel, 3)]);
        for ink in 0..3 {
            let i = at(pixel, ink);
            values[i] = ((255.0 - byte(values[i])) * black / 255.0).floor();
        }
        values[at(pixel, 3)] = 255.0;
    }
}

/// TIFF PhotometricInterpretation of YCbCr images (GDAL's JPEG imagery, `PHOTOMETRIC=YCBCR`).
const YCBCR: u16 = 6;

/// YCbCr samples (JPEG's full-range BT.601, what GDAL writes) as RGB, the way libjpeg
/// converts them for GDAL: the `tiff` crate hands JPEG tiles over as YCbCr.
fn ycbcr_to_rgb(values: &mut [f32]) {
    for pixel in values.chunks_exact_mut(3) {
        let (y, cb, cr) = (pixel[0], pixel[1] - 128.0, pixel[2] - 128.0);
        let rgb = [
            y + 1.402 * cr,
            y - 0.344_136 * cb - 0.714_136 * cr,
            y + 1.772 * cb,
        ];
        for (out, v) in pixel.iter_mut().zip(rgb) {
            *out = v.round().clamp(0.0, 255.0);
        }
    }
}

/// The samples of `layout`'s image, decoded by the `tiff` crate.
fn decode<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    image: &Image,
    layout: &Layout,
    bits: u16,
) -> Result<Vec<f32>, String> {
    let depth = layout.depth();
    if !layout.is_sparse() {
        // Into a buffer of the file's sample type, every plane of a band-interleaved
        // file included (`read_image` would read only the first).
        let mut decoded = DecodingResult::U8(Vec::new());
        guarded(|| decoder.read_image_to_buffer(&mut decoded))?;
        let rows = image.height as usize * layout.planes();
        return to_f32(decoded, bits, image.width as usize, rows, depth);
    }
    let mut values = layout.buffer(image.fill);
    for chunk in layout.stored_chunks(image.file) {
        let chunk = chunk?;
        let index = u32::try_from(chunk.index).map_err(|e| e.to_string())?;
        let (w, h) = decoder.chunk_data_dimensions(index);
        let (w, h) = (w as usize, h as usize);
        let decoded = guarded(|| decoder.read_chunk(index))
            .map_err(|e| format!("strip or tile {index}: {e}"))?;
        let samples = to_f32(decoded, bits, w, h, layout.depth())
            .map_err(|e| format!("strip or tile {index}: {e}"))?;
        layout
            .check_decoded(&chunk, w, h)
            .map_err(|e| format!("strip or tile {index}: {e}"))?;
        if samples.len() < w * h * depth {
            return Err(format!(
                "strip or tile {index}: {} samples for {w}×{h} pixels",
                samples.len()
            ));
        }
        layout.place_rows(&mut values, &chunk, w, h, &samples);
    }
    Ok(values)
}

/// Runs one of the `tiff` crate's decodes: its error, or its panic on a damaged file
/// (it asserts on some chunk sizes), as a message.
fn guarded<T>(decode: impl FnOnce() -> tiff::TiffResult<T>) -> Result<T, String> {
    catch_decoder_panic(decode)
        .map_err(|cause| format!("the decoder failed ({cause})"))?
        .map_err(|e| e.to_string())
}

/// Decoded samples as `f32`. Samples of fewer than 8 bits come packed, each row of
/// `width` pixels of `depth` samples starting on a byte; they are unpacked (most
/// significant bits first, TIFF's default FillOrder).
fn to_f32(
    decoded: DecodingResult,
    bits: u16,
    width: usize,
    rows: usize,
    depth: usize,
) -> Result<Vec<f32>, String> {
    Ok(match decoded {
        DecodingResult::U8(v) if bits < 8 => unpack(&v, bits, width * depth, rows)?,
        DecodingResult::U8(v) => widened(&v, f32::from),
        DecodingResult::U16(v) => widened(&v, f32::from),
        DecodingResult::U32(v) => widened(&v, |x| x as f32),
        DecodingResult::U64(v) => widened(&v, |x| x as f32),
        DecodingResult::I8(v) => widened(&v, f32::from),
        DecodingResult::I16(v) => widened(&v, f32::from),
        DecodingResult::I32(v) => widened(&v, |x| x as f32),
        DecodingResult::I64(v) => widened(&v, |x| x as f32),
        DecodingResult::F16(v) => widened(&v, f32::from),
        DecodingResult::F32(v) => v,
        DecodingResult::F64(v) => widened(&v, |x| x as f32),
    })
}

/// Samples converted to `f32` in parallel (a large image's hundreds of millions).
fn widened<T: Copy + Sync>(samples: &[T], convert: impl Fn(T) -> f32 + Sync) -> Vec<f32> {
    samples.par_iter().map(|&x| convert(x)).collect()
}

/// `rows` rows of `per_row` unsigned samples of `bits` bits each (1 to 32: GDAL's
/// `NBITS`), packed most significant bits first, every row starting on a byte.
pub(super) fn unpack(
    bytes: &[u8],
    bits: u16,
    per_row: usize,
    rows: usize,
) -> Result<Vec<f32>, String> {
    if !(1..=32).contains(&bits) {
        return Err(format!("samples of {bits} bits (tag BitsPerSample)"));
    }
    let bits = usize::from(bits);
    let row_bytes = (per_row * bits).div_ceil(8);
    if bytes.len() < row_bytes * rows {
        return Err(format!(
            "{} bytes do not hold {rows} rows of {per_row} {bits}-bit samples",
            bytes.len()
        ));
    }
    let mask = (1u64 << bits) - 1;
    let mut out = Vec::with_capacity(per_row * rows);
    for row in bytes.chunks_exact(row_bytes).take(rows) {
        out.extend((0..per_row).map(|i| {
            // The (at most five) bytes holding bits [first, first + bits), big-endian.
            let first = i * bits;
            let last = (first + bits - 1) / 8;
            let word = row[first / 8..=last]
                .iter()
                .fold(0u64, |w, &b| (w << 8) | u64::from(b));
            let shift = 8 * (last + 1) - first - bits;
            ((word >> shift) & mask) as f32
        }));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cmyk_reads_as_libtiffs_rgba_either_interleave() {
        // No ink is white; full black is black whatever the inks; half cyan under a
        // quarter black: (255 − 128)·(255 − 64) / 255 = 95.01 → 95.
        let pixels = [
            [0.0, 0.0, 0.0, 0.0],
            [10.0, 200.0, 30.0, 255.0],
            [128.0, 0.0, 0.0, 64.0],
        ];
        let rgba = [
            [255.0; 4],
            [0.0, 0.0, 0.0, 255.0],
            [95.0, 191.0, 191.0, 255.0],
        ];
        let mut interleaved: Vec<f32> = pixels.concat();
        cmyk_to_rgba(&mut interleaved, false);
        assert_eq!(interleaved, rgba.concat());
        let mut by_band: Vec<f32> = (0..4).flat_map(|b| pixels.map(|p| p[b])).collect();
        cmyk_to_rgba(&mut by_band, true);
        let expected: Vec<f32> = (0..4).flat_map(|b| rgba.map(|p| p[b])).collect();
        assert_eq!(by_band, expected);
        // Signed bytes (SampleFormat 2) are the same bytes: −128 is 128.
        let mut signed = vec![-128.0, 0.0, 0.0, 64.0];
        cmyk_to_rgba(&mut signed, false);
        assert_eq!(signed, rgba[2]);
    }

    #[test]
    fn packed_samples_unpack_most_significant_bits_first() {
        // Two rows of 3 one-bit samples, each row padded to a byte.
        assert_eq!(
            unpack(&[0b1010_0000, 0b0110_0000], 1, 3, 2).unwrap(),
            [1.0, 0.0, 1.0, 0.0, 1.0, 1.0]
        );
        // 4-bit classes: 0xA, 0x3, then 0x7 alone in the second byte.
        assert_eq!(unpack(&[0xA3, 0x70], 4, 3, 1).unwrap(), [10.0, 3.0, 7.0]);
        assert_eq!(
            unpack(&[0b1110_0100], 2, 4, 1).unwrap(),
            [3.0, 2.0, 1.0, 0.0]
        );
        // 3 bits: 101 011 1|10, the third sample across the byte boundary.
        assert_eq!(
            unpack(&[0b1010_1111, 0b0000_0000], 3, 3, 1).unwrap(),
            [5.0, 3.0, 6.0]
        );
        // GDAL's NBITS=12: 0xABC, 0xDEF in three bytes, then a row padded to a byte.
        assert_eq!(
            unpack(&[0xAB, 0xCD, 0xEF, 0x12, 0x30], 12, 2, 1).unwrap(),
            [2748.0, 3567.0]
        );
        assert_eq!(
            unpack(&[0x12, 0x30, 0xFF, 0xF0], 12, 1, 2).unwrap(),
            [291.0, 4095.0]
        );
        // 31 bits, starting mid-byte in the second sample.
        let two = (((1u64 << 31) - 2) << 33) | (12_345u64 << 2);
        assert_eq!(
            unpack(&two.to_be_bytes(), 31, 2, 1).unwrap(),
            [2_147_483_646.0, 12_345.0]
        );
        assert!(unpack(&[0xFF], 1, 9, 1).is_err());
        assert!(unpack(&[0xFF; 8], 33, 1, 1).is_err());
        assert!(unpack(&[0xFF; 8], 0, 1, 1).is_err());
    }
}
