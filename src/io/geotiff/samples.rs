//! The image's samples through the `tiff` crate, for every compression it decodes: the
//! whole image at once, or strip by strip where GDAL left some out (sparse files), with
//! samples of fewer than 8 bits (1-bit masks, 2- and 4-bit classes) unpacked.

use std::io::{Read, Seek};

use tiff::decoder::{Decoder, DecodingResult};
use tiff::tags::Tag;

use super::chunks::{Image, Layout};

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
        decoder
            .read_image_to_buffer(&mut decoded)
            .map_err(|e| e.to_string())?;
        let rows = image.height as usize * layout.planes();
        return to_f32(decoded, bits, image.width as usize, rows, depth);
    }
    let mut values = layout.buffer(image.fill);
    for chunk in layout.stored_chunks(image.file) {
        let chunk = chunk?;
        let index = u32::try_from(chunk.index).map_err(|e| e.to_string())?;
        let (w, h) = decoder.chunk_data_dimensions(index);
        let (w, h) = (w as usize, h as usize);
        let decoded = decoder
            .read_chunk(index)
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

/// Decoded samples as `f32`. Samples of 1, 2 or 4 bits come packed, each row of
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
    })
}

/// `rows` rows of `per_row` samples of `bits` bits each, every row starting on a byte.
pub(super) fn unpack(
    bytes: &[u8],
    bits: u16,
    per_row: usize,
    rows: usize,
) -> Result<Vec<f32>, String> {
    if !matches!(bits, 1 | 2 | 4) {
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
    let mask = (1u8 << bits) - 1;
    let mut out = Vec::with_capacity(per_row * rows);
    for row in bytes.chunks_exact(row_bytes).take(rows) {
        out.extend((0..per_row).map(|i| {
            let bit = i * bits;
            let shift = 8 - bits - bit % 8;
            f32::from((row[bit / 8] >> shift) & mask)
        }));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert!(unpack(&[0xFF], 1, 9, 1).is_err());
        assert!(unpack(&[0xFF], 3, 2, 1).is_err());
    }
}
