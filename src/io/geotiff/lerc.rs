//! LERC-compressed GeoTIFFs (GDAL's `COMPRESS=LERC`, `LERC_DEFLATE`, `LERC_ZSTD`),
//! which the `tiff` crate cannot decode: every strip or tile is read raw, unwrapped
//! from the Deflate or ZSTD layer that the `LercParameters` tag names, and decoded by
//! `lerc-reader` (pure Rust). Pixels a blob marks invalid become NaN, our nodata.

use std::io::{Read, Seek};

use tiff::decoder::Decoder;
use tiff::tags::{PlanarConfiguration, Tag};

/// GDAL's LercParameters tag: [LERC version, additional compression (0 none, 1
/// Deflate, 2 ZSTD)].
const LERC_PARAMETERS: u16 = 50674;

/// One strip or tile: where it lies in the file and in the image.
struct Chunk {
    offset: u64,
    length: u64,
    plane: usize,
    row0: usize,
    col0: usize,
}

/// The image's samples as `f32`, laid out as the `tiff` crate lays them out (pixel-
/// interleaved, or band after band when `planar`).
pub(super) fn read<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    file: &[u8],
    width: u32,
    height: u32,
    planar: PlanarConfiguration,
) -> Result<Vec<f32>, String> {
    let e = |e: tiff::TiffError| e.to_string();
    let (w, h) = (width as usize, height as usize);
    let samples = decoder
        .find_tag_unsigned::<u16>(Tag::SamplesPerPixel)
        .map_err(e)?
        .unwrap_or(1) as usize;
    let planes = if planar == PlanarConfiguration::Planar {
        samples
    } else {
        1
    };
    let depth = samples / planes;
    let extra = decoder
        .find_tag_unsigned_vec::<u32>(Tag::Unknown(LERC_PARAMETERS))
        .map_err(e)?
        .and_then(|p| p.get(1).copied())
        .unwrap_or(0);
    let u64s = |decoder: &mut Decoder<R>, tag: Tag| -> Result<Vec<u64>, String> {
        decoder
            .find_tag_unsigned_vec::<u64>(tag)
            .map_err(e)?
            .ok_or_else(|| format!("tag {tag:?} is missing"))
    };
    let tile_width = decoder
        .find_tag_unsigned::<u32>(Tag::TileWidth)
        .map_err(e)?;
    let (chunk_width, chunk_height, offsets, lengths) = match tile_width {
        Some(tw) => {
            let th = decoder
                .find_tag_unsigned::<u32>(Tag::TileLength)
                .map_err(e)?
                .ok_or("tag TileLength is missing")?;
            (
                tw as usize,
                th as usize,
                u64s(decoder, Tag::TileOffsets)?,
                u64s(decoder, Tag::TileByteCounts)?,
            )
        }
        None => {
            let rows = decoder
                .find_tag_unsigned::<u32>(Tag::RowsPerStrip)
                .map_err(e)?
                .map_or(h, |r| (r as usize).min(h));
            (
                w,
                rows,
                u64s(decoder, Tag::StripOffsets)?,
                u64s(decoder, Tag::StripByteCounts)?,
            )
        }
    };
    if chunk_width == 0 || chunk_height == 0 {
        return Err("strips or tiles of zero size".into());
    }
    let (across, down) = (w.div_ceil(chunk_width), h.div_ceil(chunk_height));
    let expected = across * down * planes;
    if offsets.len() != expected || lengths.len() != expected {
        return Err(format!(
            "{} offsets and {} byte counts for {expected} strips or tiles",
            offsets.len(),
            lengths.len()
        ));
    }
    let chunks = (0..expected).map(|i| Chunk {
        offset: offsets[i],
        length: lengths[i],
        plane: i / (across * down),
        row0: (i % (across * down)) / across * chunk_height,
        col0: i % across * chunk_width,
    });
    let cells = w * h;
    let mut values = vec![0f32; cells * samples];
    for (index, chunk) in chunks.enumerate() {
        let raw = usize::try_from(chunk.offset)
            .ok()
            .zip(usize::try_from(chunk.length).ok())
            .and_then(|(start, len)| file.get(start..start.checked_add(len)?))
            .ok_or_else(|| format!("strip or tile {index} lies beyond the end of the file"))?;
        let blob = unwrap(raw, extra).map_err(|m| format!("strip or tile {index}: {m}"))?;
        let decoded = lerc_reader::decode_first_to_f64(&blob)
            .map_err(|m| format!("strip or tile {index}: {m}"))?;
        let info = &decoded.info;
        let (bw, bh) = (info.width as usize, info.height as usize);
        if decoded.pixels.len() < bw * bh * depth
            || decoded.mask.as_ref().is_some_and(|m| m.len() < bw * bh)
        {
            return Err(format!(
                "strip or tile {index}: the blob holds fewer samples than it declares"
            ));
        }
        if info.depth as usize != depth || bw < (w - chunk.col0).min(chunk_width) {
            return Err(format!(
                "strip or tile {index} holds {bw}×{bh}×{} samples, not {chunk_width} wide × {depth}",
                info.depth
            ));
        }
        for r in 0..bh.min(h.saturating_sub(chunk.row0)) {
            for c in 0..bw.min(w - chunk.col0) {
                let pixel = r * bw + c;
                let valid = decoded.mask.as_ref().is_none_or(|m| m[pixel] != 0);
                let (row, col) = (chunk.row0 + r, chunk.col0 + c);
                for d in 0..depth {
                    let v = if valid {
                        decoded.pixels[pixel * depth + d] as f32
                    } else {
                        f32::NAN
                    };
                    let at = if planes > 1 {
                        chunk.plane * cells + row * w + col
                    } else {
                        (row * w + col) * samples + d
                    };
                    values[at] = v;
                }
            }
        }
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
