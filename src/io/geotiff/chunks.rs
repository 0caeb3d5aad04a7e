//! The strips or tiles of a TIFF image: where each lies in the file and in the image,
//! and where its decoded pixels land among the image's samples. Read raw for the
//! compressions and sample widths the `tiff` crate cannot decode (LERC, WebP, LZMA,
//! `NBITS`), and one by one where GDAL left some out (sparse files).

use std::io::{Read, Seek};

use tiff::decoder::Decoder;
use tiff::tags::{PlanarConfiguration, Tag};

/// The image a reader decodes: the file's bytes, its size, how its bands are
/// interleaved, and what the strips or tiles a sparse file leaves out hold.
#[derive(Clone, Copy)]
pub(super) struct Image<'f> {
    pub file: &'f [u8],
    pub width: u32,
    pub height: u32,
    pub planar: PlanarConfiguration,
    pub fill: f32,
}

/// How the image is cut into strips or tiles, and how its samples are laid out.
pub(super) struct Layout {
    width: usize,
    height: usize,
    /// Samples per pixel, over all planes.
    samples: usize,
    /// 1 for pixel-interleaved images, `samples` for band-interleaved ones.
    planes: usize,
    /// Tiles (stored whole, padding included), not strips.
    tiled: bool,
    chunk_width: usize,
    chunk_height: usize,
    offsets: Vec<u64>,
    lengths: Vec<u64>,
}

/// One strip or tile: its raw bytes and where it lies in the image.
pub(super) struct Chunk<'f> {
    /// Its index among the image's strips or tiles (the `tiff` crate's chunk index).
    pub index: usize,
    pub bytes: &'f [u8],
    plane: usize,
    row0: usize,
    col0: usize,
}

impl Layout {
    pub fn of<R: Read + Seek>(decoder: &mut Decoder<R>, image: &Image) -> Result<Layout, String> {
        let e = |e: tiff::TiffError| e.to_string();
        let (w, h) = (image.width as usize, image.height as usize);
        let samples = decoder
            .find_tag_unsigned::<u16>(Tag::SamplesPerPixel)
            .map_err(e)?
            .unwrap_or(1) as usize;
        if samples == 0 {
            return Err("tag SamplesPerPixel is 0".into());
        }
        let planes = if image.planar == PlanarConfiguration::Planar {
            samples
        } else {
            1
        };
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
        let layout = Layout {
            width: w,
            height: h,
            samples,
            planes,
            tiled: tile_width.is_some(),
            chunk_width,
            chunk_height,
            offsets,
            lengths,
        };
        let expected = layout.across() * layout.down() * planes;
        if layout.offsets.len() != expected || layout.lengths.len() != expected {
            return Err(format!(
                "{} offsets and {} byte counts for {expected} strips or tiles",
                layout.offsets.len(),
                layout.lengths.len()
            ));
        }
        Ok(layout)
    }

    fn across(&self) -> usize {
        self.width.div_ceil(self.chunk_width)
    }

    fn down(&self) -> usize {
        self.height.div_ceil(self.chunk_height)
    }

    /// 1 for pixel-interleaved images, the number of bands for band-interleaved ones.
    pub fn planes(&self) -> usize {
        self.planes
    }

    /// Samples of one pixel within one strip or tile (all of them, or one band's).
    pub fn depth(&self) -> usize {
        self.samples / self.planes
    }

    /// The image's samples, `fill` until chunks are placed: pixel-interleaved, or band
    /// after band when band-interleaved (as the `tiff` crate lays them out).
    pub fn buffer(&self, fill: f32) -> Vec<f32> {
        vec![fill; self.width * self.height * self.samples]
    }

    /// Whether some strips or tiles are left out (byte count 0): GDAL's sparse files
    /// (`SPARSE_OK`) skip blocks that hold only nodata, which read as the nodata value
    /// (0 where there is none).
    pub fn is_sparse(&self) -> bool {
        self.lengths.contains(&0)
    }

    /// Every strip or tile the file holds (not those left out: see `is_sparse`), in
    /// file order, or why one lies beyond the end of `file`.
    pub fn stored_chunks<'f>(
        &self,
        file: &'f [u8],
    ) -> impl Iterator<Item = Result<Chunk<'f>, String>> + use<'_, 'f> {
        self.chunks(file)
            .filter(|chunk| chunk.as_ref().map_or(true, |c| !c.bytes.is_empty()))
    }

    /// Every strip or tile in file order, or why one lies beyond the end of `file`. A
    /// strip or tile left out has no bytes.
    fn chunks<'f>(
        &self,
        file: &'f [u8],
    ) -> impl Iterator<Item = Result<Chunk<'f>, String>> + use<'_, 'f> {
        let per_plane = self.across() * self.down();
        (0..self.offsets.len()).map(move |i| {
            let bytes = if self.lengths[i] == 0 {
                Some(&file[..0])
            } else {
                usize::try_from(self.offsets[i])
                    .ok()
                    .zip(usize::try_from(self.lengths[i]).ok())
                    .and_then(|(start, len)| file.get(start..start.checked_add(len)?))
            }
            .ok_or_else(|| format!("strip or tile {i} lies beyond the end of the file"))?;
            Ok(Chunk {
                index: i,
                bytes,
                plane: i / per_plane,
                row0: (i % per_plane) / self.across() * self.chunk_height,
                col0: i % self.across() * self.chunk_width,
            })
        })
    }

    /// Pixels per row and rows a strip or tile holds as stored: a tile its full size
    /// (padding included), a strip the image's width and its rows (the last one may
    /// hold fewer).
    pub fn stored_size(&self, chunk: &Chunk) -> (usize, usize) {
        if self.tiled {
            (self.chunk_width, self.chunk_height)
        } else {
            (self.width, self.chunk_height.min(self.height - chunk.row0))
        }
    }

    /// Checks that a decoded chunk of `width` × `height` pixels covers the image cells
    /// its strip or tile stands for.
    pub fn check_decoded(&self, chunk: &Chunk, width: usize, height: usize) -> Result<(), String> {
        let needed_width = (self.width - chunk.col0).min(self.chunk_width);
        let needed_height = (self.height - chunk.row0).min(self.chunk_height);
        if width < needed_width || height < needed_height {
            return Err(format!(
                "it decodes to {width}×{height} pixels, fewer than the {needed_width}×\
                 {needed_height} of the image it covers"
            ));
        }
        Ok(())
    }

    /// Copies a decoded chunk's `samples` (`width` pixels per row, `depth` samples
    /// each, rows one after another) into `values`, row by row; what lies past the
    /// image's right or bottom edge is left out.
    pub fn place_rows(
        &self,
        values: &mut [f32],
        chunk: &Chunk,
        width: usize,
        height: usize,
        samples: &[f32],
    ) {
        let depth = self.depth();
        let used = width.min(self.width - chunk.col0) * depth;
        let plane = if self.planes > 1 {
            chunk.plane * self.width * self.height
        } else {
            0
        };
        for r in 0..height.min(self.height.saturating_sub(chunk.row0)) {
            let at = plane + ((chunk.row0 + r) * self.width + chunk.col0) * depth;
            let from = r * width * depth;
            values[at..at + used].copy_from_slice(&samples[from..from + used]);
        }
    }

    /// Writes a decoded chunk of `width` pixels per row into `values`: `sample(pixel, d)`
    /// is the d-th sample (of `depth`) of the chunk's pixel `pixel` (row-major). Pixels
    /// past the image's right or bottom edge are left out.
    pub fn place(
        &self,
        values: &mut [f32],
        chunk: &Chunk,
        width: usize,
        height: usize,
        sample: impl Fn(usize, usize) -> f32,
    ) {
        let cells = self.width * self.height;
        let depth = self.depth();
        for r in 0..height.min(self.height.saturating_sub(chunk.row0)) {
            for c in 0..width.min(self.width - chunk.col0) {
                let pixel = r * width + c;
                let (row, col) = (chunk.row0 + r, chunk.col0 + c);
                for d in 0..depth {
                    let at = if self.planes > 1 {
                        chunk.plane * cells + row * self.width + col
                    } else {
                        (row * self.width + col) * self.samples + d
                    };
                    values[at] = sample(pixel, d);
                }
            }
        }
    }
}
