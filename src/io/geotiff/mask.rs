//! GDAL's internal nodata masks (`GDAL_TIFF_INTERNAL_MASK`, and the masks of COGs): a
//! further image in the file, flagged as a transparency mask, that marks which cells of
//! the full-resolution image hold data. Imagery compressed with JPEG carries one
//! instead of a nodata value, since lossy compression moves the values.

use std::io::{Read, Seek};

use tiff::decoder::Decoder;
use tiff::tags::{PlanarConfiguration, Tag};

use super::chunks::Image;
use super::{samples, unpack};

/// NewSubfileType bits: a reduced-resolution image (an overview) and a mask.
const REDUCED_RESOLUTION: u32 = 1;
const TRANSPARENCY_MASK: u32 = 4;

/// Which cells of the `width` × `height` first image hold data (in the file's row
/// order), from the first mask of that size after it; `None` where there is none.
pub(super) fn read<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    image: &Image,
) -> Result<Option<Vec<bool>>, String> {
    let (width, height) = (image.width, image.height);
    while decoder.more_images() {
        decoder.next_image().map_err(|e| e.to_string())?;
        let kind = decoder
            .find_tag_unsigned::<u32>(Tag::NewSubfileType)
            .map_err(|e| e.to_string())?
            .unwrap_or(0);
        let full_size = decoder.dimensions().map_err(|e| e.to_string())? == (width, height);
        if kind & TRANSPARENCY_MASK != 0 && kind & REDUCED_RESOLUTION == 0 && full_size {
            let mask = Image {
                planar: PlanarConfiguration::Chunky,
                fill: 0.0,
                ..*image
            };
            // GDAL writes masks of 1 bit per cell with PhotometricInterpretation
            // TransparencyMask, which the `tiff` crate refuses: read them here.
            let compression = decoder
                .find_tag_unsigned::<u16>(Tag::Compression)
                .map_err(|e| e.to_string())?
                .unwrap_or(1);
            let values = if unpack::decompresses(compression) {
                unpack::read(decoder, &mask, compression)
            } else {
                samples::read(decoder, &mask)
            }
            .map_err(|e| format!("its nodata mask: {e}"))?;
            if values.len() != width as usize * height as usize {
                return Err(format!(
                    "its nodata mask holds {} samples for {width}×{height} cells",
                    values.len()
                ));
            }
            return Ok(Some(values.into_iter().map(|v| v != 0.0).collect()));
        }
    }
    Ok(None)
}
