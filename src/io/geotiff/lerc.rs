//! LERC-compressed GeoTIFFs (GDAL's `COMPRESS=LERC`, `LERC_DEFLATE`, `LERC_ZSTD`),
//! which the `tiff` crate cannot decode: every strip or tile is read raw, unwrapped
//! from the Deflate or ZSTD layer that the `LercParameters` tag names, and decoded by
//! `lerc-reader` (pure Rust). Pixels a blob marks invalid become NaN, our nodata.

use std::io::{Read, Seek};

use tiff::decoder::Decoder;
use tiff::tags::Tag;

use super::chunks::{Image, Layout};

/// GDAL's LercParameters tag: [LERC version, additional compression (0 none, 1
/// Deflate, 2 ZSTD)].
const LERC_PARAMETERS: u16 = 50674;

/// The image's samples as `f32`, laid out as the `tiff` crate lays them out (pixel-
/// interleaved, or band after band when `planar`).
pub(super) fn read<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    image: &Image,
) -> Result<Vec<f32>, String> {
    let layout = Layout::of(decoder, image)?;
    let extra = decoder
        .find_tag_unsigned_vec::<u32>(Tag::Unknown(LERC_PARAMETERS))
        .map_err(|e| e.to_string())?
        .and_then(|p| p.get(1).copied())
        .unwrap_or(0);
    let depth = layout.depth();
    let mut values = layout.buffer(image.fill);
    for chunk in layout.stored_chunks(image.file) {
        let chunk = chunk?;
        let in_chunk = |m: String| format!("strip or tile {}: {m}", chunk.index);
        let blob = unwrap(chunk.bytes, extra).map_err(in_chunk)?;
        let decoded =
            lerc_reader::decode_first_to_f64(&blob).map_err(|e| in_chunk(e.to_string()))?;
        let info = &decoded.info;
        let (bw, bh) = (info.width as usize, info.height as usize);
        if decoded.pixels.len() < bw * bh * depth
            || decoded.mask.as_ref().is_some_and(|m| m.len() < bw * bh)
        {
            return Err(in_chunk(
                "the blob holds fewer samples than it declares".into(),
            ));
        }
        if info.depth as usize != depth {
            return Err(in_chunk(format!(
                "it holds {} samples per pixel, not {depth}",
                info.depth
            )));
        }
        layout.check_decoded(&chunk, bw, bh).map_err(in_chunk)?;
        layout.place(&mut values, &chunk, bw, bh, |pixel, d| {
            if decoded.mask.as_ref().is_none_or(|m| m[pixel] != 0) {
                decoded.pixels[pixel * depth + d] as f32
            } else {
                f32::NAN
            }
        });
    }
    Ok(values)
}

/// The LERC blob inside a chunk: as it is, or inflated from Deflate (zlib) or ZSTD.
fn unwrap(raw: &[u8], extra: u32) -> Result<Vec<u8>, String> {
    match extra {
        0 => Ok(raw.to_vec()),
        1 => {
            let mut out = Vec::new();
            flate2::read::ZlibDecoder::new(raw)
                .read_to_end(&mut out)
                .map_err(|e| format!("the Deflate layer: {e}"))?;
            Ok(out)
        }
        2 => zstd::decode_all(raw).map_err(|e| format!("the ZSTD layer: {e}")),
        other => Err(format!(
            "additional compression {other} in tag LercParameters is not one of 0, 1, 2"
        )),
    }
}
