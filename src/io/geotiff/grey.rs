//! Palette, mask and WhiteIsZero images read as grey. Palette (colour-mapped) GeoTIFFs are how
//! land-cover and classification rasters come (NLCD, ESA WorldCover, CORINE): their
//! samples are class codes and the colour map only draws them, so a layer holds the
//! codes. GDAL's internal nodata masks are images flagged as transparency masks. The
//! `tiff` crate refuses to decode either, and inverts WhiteIsZero samples where GDAL
//! reads them as stored, so every such image of the file is relabelled grey
//! (BlackIsZero) in our copy of its bytes before decoding: the samples are the same.

/// TIFF tag PhotometricInterpretation and the values it takes here.
const PHOTOMETRIC: u16 = 262;
const WHITE_IS_ZERO: u16 = 0;
const BLACK_IS_ZERO: u16 = 1;
const PALETTE: u16 = 3;
const TRANSPARENCY_MASK: u16 = 4;

/// Directories followed at most (a COG has two per overview level).
const MAX_IMAGES: usize = 4096;

/// Relabels every palette, mask or WhiteIsZero image of `file` grey; whether its first image was a
/// palette image. Files that are not TIFFs, or malformed ones, are left as they are
/// from where they stop making sense (the decoder then says what is wrong).
pub(super) fn relabel_grey(file: &mut [u8]) -> bool {
    let Some(layout) = Layout::of(file) else {
        return false;
    };
    let mut first_was_palette = false;
    let mut ifd = layout.first_ifd(file);
    for image in 0..MAX_IMAGES {
        let Some(at) = ifd else { break };
        let Some(entries) = layout.entries(file, at) else {
            break;
        };
        if let Some(value_at) = entries
            .clone()
            .find(|&e| layout.u16(file, e) == Some(PHOTOMETRIC))
            .filter(|&e| layout.is_one_short(file, e))
            .map(|e| e + layout.value_offset)
        {
            let value = layout.u16(file, value_at);
            if value == Some(PALETTE)
                || value == Some(TRANSPARENCY_MASK)
                || value == Some(WHITE_IS_ZERO)
            {
                first_was_palette |= image == 0 && value == Some(PALETTE);
                let bytes = if layout.big_endian {
                    BLACK_IS_ZERO.to_be_bytes()
                } else {
                    BLACK_IS_ZERO.to_le_bytes()
                };
                file[value_at..value_at + 2].copy_from_slice(&bytes);
            }
        }
        ifd = layout.next_ifd(file, at, entries.len());
    }
    first_was_palette
}

/// Classic TIFF (2-byte entry counts, 12-byte entries, 4-byte offsets) or BigTIFF
/// (8-byte counts, 20-byte entries, 8-byte offsets), in either byte order.
struct Layout {
    big_endian: bool,
    big_tiff: bool,
    entry_size: usize,
    /// Where an entry's value (or its offset) starts within the entry.
    value_offset: usize,
}

impl Layout {
    fn of(file: &[u8]) -> Option<Layout> {
        let big_endian = match file.get(..2)? {
            b"II" => false,
            b"MM" => true,
            _ => return None,
        };
        let mut layout = Layout {
            big_endian,
            big_tiff: false,
            entry_size: 12,
            value_offset: 8,
        };
        match layout.u16(file, 2)? {
            42 => {}
            43 => {
                layout.big_tiff = true;
                layout.entry_size = 20;
                layout.value_offset = 12;
            }
            _ => return None,
        }
        Some(layout)
    }

    fn first_ifd(&self, file: &[u8]) -> Option<usize> {
        self.offset(file, if self.big_tiff { 8 } else { 4 })
    }

    /// Where each entry of the directory at `ifd` starts (those inside the file).
    fn entries(
        &self,
        file: &[u8],
        ifd: usize,
    ) -> Option<impl ExactSizeIterator<Item = usize> + Clone + use<>> {
        let (count, first) = if self.big_tiff {
            (usize::try_from(self.u64(file, ifd)?).ok()?, ifd + 8)
        } else {
            (usize::from(self.u16(file, ifd)?), ifd + 2)
        };
        let end = first.checked_add(count.checked_mul(self.entry_size)?)?;
        (end <= file.len()).then_some(())?;
        let size = self.entry_size;
        Some((0..count).map(move |i| first + i * size))
    }

    fn next_ifd(&self, file: &[u8], ifd: usize, entries: usize) -> Option<usize> {
        let header = if self.big_tiff { 8 } else { 2 };
        let next = self.offset(file, ifd + header + entries * self.entry_size)?;
        // Directories follow one another forward in every file GDAL writes; this also
        // stops a loop.
        (next > ifd).then_some(next)
    }

    /// Whether the entry at `entry` holds one SHORT (its value then lies in the entry).
    fn is_one_short(&self, file: &[u8], entry: usize) -> bool {
        let count = if self.big_tiff {
            self.u64(file, entry + 4)
        } else {
            self.u32(file, entry + 4).map(u64::from)
        };
        self.u16(file, entry + 2) == Some(3) && count == Some(1)
    }

    fn offset(&self, file: &[u8], at: usize) -> Option<usize> {
        let offset = if self.big_tiff {
            self.u64(file, at)?
        } else {
            u64::from(self.u32(file, at)?)
        };
        usize::try_from(offset).ok().filter(|&o| o != 0)
    }

    fn bytes<const N: usize>(&self, file: &[u8], at: usize) -> Option<[u8; N]> {
        let mut b: [u8; N] = file.get(at..at.checked_add(N)?)?.try_into().ok()?;
        if self.big_endian {
            b.reverse();
        }
        Some(b)
    }

    fn u16(&self, file: &[u8], at: usize) -> Option<u16> {
        self.bytes(file, at).map(u16::from_le_bytes)
    }

    fn u32(&self, file: &[u8], at: usize) -> Option<u32> {
        self.bytes(file, at).map(u32::from_le_bytes)
    }

    fn u64(&self, file: &[u8], at: usize) -> Option<u64> {
        self.bytes(file, at).map(u64::from_le_bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A little-endian classic TIFF of two directories, each holding one entry:
    /// PhotometricInterpretation = `first`, then `second`.
    fn two_images(first: u16, second: u16) -> Vec<u8> {
        let mut f = b"II".to_vec();
        f.extend(42u16.to_le_bytes());
        f.extend(8u32.to_le_bytes());
        for (value, next) in [(first, 26u32), (second, 0)] {
            f.extend(1u16.to_le_bytes());
            f.extend(PHOTOMETRIC.to_le_bytes());
            f.extend(3u16.to_le_bytes());
            f.extend(1u32.to_le_bytes());
            f.extend(value.to_le_bytes());
            f.extend([0, 0]);
            f.extend(next.to_le_bytes());
        }
        f
    }

    #[test]
    fn palette_and_mask_images_are_relabelled_grey_and_nothing_else_changes() {
        let mut file = two_images(PALETTE, TRANSPARENCY_MASK);
        assert!(relabel_grey(&mut file));
        assert_eq!(file, two_images(BLACK_IS_ZERO, BLACK_IS_ZERO));
        // RGB with a mask: the mask is relabelled, the image is not.
        let mut file = two_images(2, TRANSPARENCY_MASK);
        assert!(!relabel_grey(&mut file));
        assert_eq!(file, two_images(2, BLACK_IS_ZERO));
        // Cut short inside the first entry (which ends at byte 22), or not a TIFF: left
        // alone, no panic.
        for len in 0..22 {
            let mut cut = two_images(PALETTE, PALETTE)[..len].to_vec();
            assert!(!relabel_grey(&mut cut), "{len}");
            assert_eq!(cut, two_images(PALETTE, PALETTE)[..len], "{len}");
        }
        assert!(!relabel_grey(&mut b"MM\0\x2a not a directory".to_vec()));
        // A directory that points back at itself stops the walk.
        let mut looped = two_images(PALETTE, PALETTE);
        looped[22..26].copy_from_slice(&8u32.to_le_bytes());
        assert!(relabel_grey(&mut looped));
    }
}
