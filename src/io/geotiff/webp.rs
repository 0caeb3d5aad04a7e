//! WebP-compressed GeoTIFFs (GDAL's `COMPRESS=WEBP`, a common choice for RGB(A) COGs),
//! which the `tiff` crate cannot decode: every strip or tile is one WebP image, lossy
//! or lossless, decoded by `image-webp` (pure Rust). GDAL writes them for 8-bit,
//! pixel-interleaved images of 3 or 4 bands only.

use std::io::{Cursor, Read, Seek};

use tiff::decoder::Decoder;
use tiff::tags::{PlanarConfiguration, Tag};

use super::chunks::{Image, Layout};

/// TIFF compression code of WebP.
pub(super) const WEBP: u16 = 50001;

/// The image's samples as `f32`, pixel-interleaved (as the `tiff` crate lays them out).
pub(super) fn read<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    image: &Image,
) -> Result<Vec<f32>, String> {
    let bits = decoder
        .find_tag_unsigned_vec::<u16>(Tag::BitsPerSample)
        .map_err(|e| e.to_string())?
        .unwrap_or_else(|| vec![1]);
    if bits.iter().any(|&b| b != 8) {
        return Err(format!(
            "WebP holds 8-bit samples, but tag BitsPerSample is {bits:?}"
        ));
    }
    let layout = Layout::of(decoder, image)?;
    let depth = layout.depth();
    if image.planar == PlanarConfiguration::Planar || !(3..=4).contains(&depth) {
        return Err(format!(
            "WebP holds 3 or 4 pixel-interleaved bands, not {depth} per strip or tile"
        ));
    }
    let mut values = layout.buffer(image.fill);
    for chunk in layout.stored_chunks(image.file) {
        let chunk = chunk?;
        let in_chunk = |m: String| format!("strip or tile {}: {m}", chunk.index);
        let mut image = image_webp::WebPDecoder::new(Cursor::new(chunk.bytes))
            .map_err(|e| in_chunk(e.to_string()))?;
        let (bw, bh) = image.dimensions();
        let (bw, bh) = (bw as usize, bh as usize);
        layout.check_decoded(&chunk, bw, bh).map_err(in_chunk)?;
        // RGBA where the WebP image has alpha, RGB otherwise (libwebp leaves out an
        // alpha that is opaque everywhere: the band then reads 255).
        let channels = if image.has_alpha() { 4 } else { 3 };
        let size = image
            .output_buffer_size()
            .filter(|&n| n == bw * bh * channels)
            .ok_or_else(|| in_chunk("its decoded size overflows".into()))?;
        let mut pixels = vec![0u8; size];
        image
            .read_image(&mut pixels)
            .map_err(|e| in_chunk(e.to_string()))?;
        layout.place(&mut values, &chunk, bw, bh, |pixel, d| {
            if d < channels {
                f32::from(pixels[pixel * channels + d])
            } else {
                255.0
            }
        });
    }
    Ok(values)
}
