//! JPEG XL-compressed GeoTIFFs (GDAL's `COMPRESS=JXL`, tifffile's `JPEGXL`, and DNG
//! 1.7's variant), which the `tiff` crate cannot decode: every strip or tile is one
//! JPEG XL image, lossless (GDAL's default) or lossy, decoded by `jxl-oxide` (pure
//! Rust). GDAL writes 8- and 16-bit unsigned and 32-bit float bands: pixel-interleaved
//! ones as a grey or RGB image whose further bands (alpha among them) are extra
//! channels, band-interleaved ones as one grey image per band and strip or tile.

use std::io::{Read, Seek};

use jxl_oxide::image::BitDepth;
use jxl_oxide::{AllocTracker, JxlImage};
use rayon::prelude::*;

use tiff::decoder::Decoder;

use super::chunks::{Image, Layout};
use crate::error::catch_decoder_panic;

/// TIFF compression code of JPEG XL (GDAL's and libtiff's `COMPRESSION_JXL`).
pub(super) const JXL: u16 = 50002;
/// TIFF compression code of JPEG XL as DNG 1.7 stores it (tifffile's `JPEGXL_DNG`).
pub(super) const JXL_DNG: u16 = 52546;

/// Whether `compression` is one of JPEG XL's codes.
pub(super) fn is_jxl(compression: u16) -> bool {
    matches!(compression, JXL | JXL_DNG)
}

/// The image's samples as `f32`, laid out as the `tiff` crate lays them out (pixel-
/// interleaved, or band after band when band-interleaved). Strips and tiles decode in
/// parallel, a few per thread at a time so that their decoded samples stay few beside
/// the image; each lands where it lies, so the result does not depend on the threads.
/// A panic of the decoder on a damaged strip or tile is an error.
pub(super) fn read<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    image: &Image,
) -> Result<Vec<f32>, String> {
    let layout = Layout::of(decoder, image)?;
    let depth = layout.depth();
    let chunks = layout
        .stored_chunks(image.file)
        .collect::<Result<Vec<_>, _>>()?;
    let mut values = layout.buffer(image.fill);
    for batch in chunks.chunks(4 * rayon::current_num_threads().max(1)) {
        let decoded = batch
            .par_iter()
            .map(|chunk| {
                let in_chunk = |m: String| format!("strip or tile {}: {m}", chunk.index);
                let (samples, width, height) =
                    catch_decoder_panic(|| decode(chunk.bytes, depth, layout.stored_size(chunk)))
                        .unwrap_or_else(|cause| Err(format!("the decoder failed ({cause})")))
                        .map_err(in_chunk)?;
                layout
                    .check_decoded(chunk, width, height)
                    .map_err(in_chunk)?;
                Ok((samples, width, height))
            })
            .collect::<Result<Vec<_>, String>>()?;
        for (chunk, (samples, width, height)) in batch.iter().zip(decoded) {
            layout.place_rows(&mut values, chunk, width, height, &samples);
        }
    }
    Ok(values)
}

/// One strip's or tile's JPEG XL image: its samples, pixel-interleaved, in the
/// values the TIFF's bands hold (0–255 for 8 bits, 0–65535 for 16, floats as they
/// are), and its width and height, which may not pass `stored` (the strip's or tile's
/// size as stored).
fn decode(
    bytes: &[u8],
    depth: usize,
    stored: (usize, usize),
) -> Result<(Vec<f32>, usize, usize), String> {
    // A damaged header could ask for any amount of memory: the decoder may use many
    // times the chunk's samples, not more.
    let samples_bytes = stored.0 * stored.1 * depth * size_of::<f32>();
    let tracker = AllocTracker::with_limit(samples_bytes.saturating_mul(64) + (64 << 20));
    let image = JxlImage::builder()
        .alloc_tracker(tracker)
        .read(bytes)
        .map_err(|e| format!("not a JPEG XL image: {e}"))?;
    let (width, height) = (image.width() as usize, image.height() as usize);
    if width > stored.0 || height > stored.1 {
        return Err(format!(
            "its JPEG XL image is {width}×{height} pixels, more than the {}×{} stored",
            stored.0, stored.1
        ));
    }
    let metadata = &image.image_header().metadata;
    let colour = if metadata.grayscale() { 1 } else { 3 };
    let channels = colour + metadata.ec_info.len();
    if channels != depth {
        return Err(format!(
            "its JPEG XL image holds {channels} channels, not the {depth} bands of the \
             strip or tile"
        ));
    }
    // Each channel's samples come normalised to 0–1 from its own bit depth.
    let scales = std::iter::repeat_n(metadata.bit_depth, colour)
        .chain(metadata.ec_info.iter().map(|ec| ec.bit_depth))
        .map(scale)
        .collect::<Result<Vec<_>, _>>()?;
    if image.num_loaded_keyframes() == 0 {
        return Err("its JPEG XL image holds no frame".into());
    }
    let render = image
        .render_frame(0)
        .map_err(|e| format!("its JPEG XL image cannot be decoded: {e}"))?;
    let frame = render.image_all_channels();
    if frame.channels() != channels {
        return Err(format!(
            "its JPEG XL image decodes to {} channels, not {channels}",
            frame.channels()
        ));
    }
    let mut samples = frame.buf().to_vec();
    for pixel in samples.chunks_exact_mut(channels) {
        for (value, scale) in pixel.iter_mut().zip(&scales) {
            if let Some(max) = scale {
                *value = (*value * max).round().clamp(0.0, *max);
            }
        }
    }
    Ok((samples, frame.width(), frame.height()))
}

/// The largest value of a channel of integer samples, which the decoder's 0–1 samples
/// are multiplied by (`None` for 32-bit floats, decoded as they are). Other widths
/// are refused: integers past 16 bits lose digits in the decoder's `f32`s, and its
/// half floats read zero as 2⁻¹⁵.
fn scale(depth: BitDepth) -> Result<Option<f32>, String> {
    match depth {
        BitDepth::IntegerSample { bits_per_sample } if (1..=16).contains(&bits_per_sample) => {
            Ok(Some(((1u32 << bits_per_sample) - 1) as f32))
        }
        BitDepth::FloatSample {
            bits_per_sample: 32,
            exp_bits: 8,
        } => Ok(None),
        BitDepth::IntegerSample { bits_per_sample } => Err(format!(
            "its JPEG XL image holds {bits_per_sample}-bit integer samples; 1 to 16 bits \
             are read"
        )),
        BitDepth::FloatSample {
            bits_per_sample,
            exp_bits,
        } => Err(format!(
            "its JPEG XL image holds {bits_per_sample}-bit float samples ({exp_bits} \
             exponent bits); 32-bit floats are read"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integer_channels_scale_back_to_their_range_and_floats_stay() {
        assert_eq!(
            scale(BitDepth::IntegerSample { bits_per_sample: 8 }),
            Ok(Some(255.0))
        );
        assert_eq!(
            scale(BitDepth::IntegerSample {
                bits_per_sample: 16
            }),
            Ok(Some(65535.0))
        );
        assert_eq!(
            scale(BitDepth::FloatSample {
                bits_per_sample: 32,
                exp_bits: 8
            }),
            Ok(None)
        );
        assert!(
            scale(BitDepth::IntegerSample {
                bits_per_sample: 24
            })
            .unwrap_err()
            .contains("24-bit")
        );
        assert!(
            scale(BitDepth::FloatSample {
                bits_per_sample: 16,
                exp_bits: 5
            })
            .unwrap_err()
            .contains("16-bit float")
        );
    }

    #[test]
    fn bytes_that_are_not_jpeg_xl_are_an_error_not_a_panic() {
        for bytes in [
            &b""[..],
            b"\xff\x0a",
            b"not a JPEG XL image at all",
            &[0u8; 64],
        ] {
            assert!(decode(bytes, 1, (64, 64)).is_err());
        }
    }
}
