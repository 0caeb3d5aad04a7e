//! Names in a classic netCDF header that are not UTF-8 (a Latin-1 `µ` in an attribute
//! name, as netCDF libraries before 4.0 let writers store them; xarray-spatial's
//! Sentinel-2 sample bands hold one): `netcdf-reader` refuses such a file, where
//! netCDF-C and GDAL read it. Each byte that is not UTF-8 becomes `?` in a copy of the
//! file, so that names keep their length and every offset in the header holds, and the
//! file is read from that copy.

/// Makes the names in the classic (CDF-1, CDF-2, CDF-5) header at the start of `file`
/// UTF-8, each invalid byte `?`; the number of names changed, or `None` where `file`
/// does not start with a classic header or the header ends early.
pub(super) fn make_names_utf8(file: &mut [u8]) -> Option<usize> {
    let version = match file.get(..4)? {
        [b'C', b'D', b'F', version @ (1 | 2 | 5)] => *version,
        _ => return None,
    };
    let mut header = Header {
        bytes: file,
        at: 4,
        wide_counts: version == 5,
        wide_offsets: version != 1,
        changed: 0,
    };
    header.count()?; // the number of records
    header.list(|header| {
        header.name()?;
        header.count().map(drop)
    })?;
    header.attributes()?;
    header.list(|header| {
        header.name()?;
        for _ in 0..header.count()? {
            header.count()?; // a dimension's index
        }
        header.attributes()?;
        header.take(4)?; // the type
        header.count()?; // the size
        header
            .take(if header.wide_offsets { 8 } else { 4 })
            .map(drop)
    })?;
    Some(header.changed)
}

/// A cursor over a classic header.
struct Header<'a> {
    bytes: &'a mut [u8],
    at: usize,
    /// CDF-5's 8-byte counts, and CDF-2's and CDF-5's 8-byte offsets.
    wide_counts: bool,
    wide_offsets: bool,
    changed: usize,
}

impl Header<'_> {
    /// The next `n` bytes' place.
    fn take(&mut self, n: usize) -> Option<std::ops::Range<usize>> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&end| end <= self.bytes.len())?;
        let range = self.at..end;
        self.at = end;
        Some(range)
    }

    fn number(&mut self, width: usize) -> Option<usize> {
        let range = self.take(width)?;
        let value = self.bytes[range]
            .iter()
            .fold(0u64, |value, &byte| (value << 8) | u64::from(byte));
        usize::try_from(value).ok()
    }

    fn count(&mut self) -> Option<usize> {
        self.number(if self.wide_counts { 8 } else { 4 })
    }

    /// A name: its length, its bytes padded to 4; bytes that are not UTF-8 made `?`.
    fn name(&mut self) -> Option<()> {
        let length = self.count()?;
        let range = self.take(length)?;
        self.take((4 - length % 4) % 4)?;
        let name = &mut self.bytes[range];
        let mut changed = false;
        let mut from = 0;
        while let Err(error) = std::str::from_utf8(&name[from..]) {
            let bad = from + error.valid_up_to();
            let length = error.error_len().unwrap_or(name.len() - bad);
            name[bad..bad + length].fill(b'?');
            from = bad + length;
            changed = true;
        }
        self.changed += usize::from(changed);
        Some(())
    }

    /// A list: its tag (4 bytes, 0 where absent), its count, then each element.
    fn list(&mut self, mut element: impl FnMut(&mut Self) -> Option<()>) -> Option<()> {
        self.take(4)?;
        for _ in 0..self.count()? {
            element(self)?;
        }
        Some(())
    }

    /// An attribute list: each a name, a type, a count of values and the values
    /// padded to 4 bytes.
    fn attributes(&mut self) -> Option<()> {
        self.list(|header| {
            header.name()?;
            let kind = header.number(4)?;
            let size = match kind {
                1 | 2 | 7 => 1,
                3 | 8 => 2,
                4 | 5 | 9 => 4,
                6 | 10 | 11 => 8,
                _ => return None,
            };
            let bytes = header.count()?.checked_mul(size)?;
            header
                .take(bytes.checked_add((4 - bytes % 4) % 4)?)
                .map(drop)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A CDF-1 header: dimension `x` (3), global attribute `title`, variable `v` on `x`
    /// with an attribute named `name` (bytes as given) holding one float.
    fn header(attribute_name: &[u8]) -> Vec<u8> {
        let mut h = b"CDF\x01".to_vec();
        let word = |h: &mut Vec<u8>, n: u32| h.extend(n.to_be_bytes());
        let name = |h: &mut Vec<u8>, name: &[u8]| {
            word(h, name.len() as u32);
            h.extend(name);
            h.extend(std::iter::repeat_n(0, (4 - name.len() % 4) % 4));
        };
        word(&mut h, 0);
        word(&mut h, 0x0A);
        word(&mut h, 1);
        name(&mut h, b"x");
        word(&mut h, 3);
        word(&mut h, 0x0C);
        word(&mut h, 1);
        name(&mut h, b"title");
        word(&mut h, 2);
        word(&mut h, 5);
        h.extend(b"hello\0\0\0");
        word(&mut h, 0x0B);
        word(&mut h, 1);
        name(&mut h, b"v");
        word(&mut h, 1);
        word(&mut h, 0);
        word(&mut h, 0x0C);
        word(&mut h, 1);
        name(&mut h, attribute_name);
        word(&mut h, 5);
        word(&mut h, 1);
        h.extend(1f32.to_be_bytes());
        word(&mut h, 5);
        word(&mut h, 12);
        let begin = h.len() as u32 + 4;
        word(&mut h, begin);
        h.extend([0u8; 12]);
        h
    }

    #[test]
    fn latin1_names_become_question_marks_in_place() {
        let mut latin1 = header(b"Wavelength (\xb5m)");
        let before = latin1.len();
        assert_eq!(make_names_utf8(&mut latin1), Some(1));
        assert_eq!(latin1.len(), before);
        assert_eq!(latin1, header(b"Wavelength (?m)"));
        let mut utf8 = header("Wavelength (µm)".as_bytes());
        let same = utf8.clone();
        assert_eq!(make_names_utf8(&mut utf8), Some(0));
        assert_eq!(utf8, same);
        // And netcdf-reader then reads it.
        let file = netcdf_reader::NcFile::from_vec(latin1).unwrap();
        let v = file.variable("v").unwrap();
        assert!(v.attribute("Wavelength (?m)").is_some());
    }

    proptest::proptest! {
        /// A damaged header (bytes overwritten anywhere) is walked without a panic,
        /// and nothing but name bytes changes: each changed byte becomes `?`.
        #[test]
        fn damaged_headers_change_only_name_bytes(
            at in 0usize..150,
            bytes in proptest::collection::vec(proptest::num::u8::ANY, 1..12),
        ) {
            let mut damaged = header(b"Wavelength (\xb5m)");
            for (i, byte) in bytes.iter().enumerate() {
                if let Some(b) = damaged.get_mut(at + i) {
                    *b = *byte;
                }
            }
            let before = damaged.clone();
            make_names_utf8(&mut damaged);
            proptest::prop_assert_eq!(damaged.len(), before.len());
            for (after, before) in damaged.iter().zip(&before) {
                proptest::prop_assert!(after == before || *after == b'?');
            }
        }
    }

    #[test]
    fn what_is_not_a_classic_header_is_left_alone() {
        assert_eq!(make_names_utf8(&mut b"\x89HDF\r\n\x1a\n".to_vec()), None);
        let whole = header(b"name");
        for cut in 0..whole.len() - 16 {
            let mut short = whole[..cut].to_vec();
            assert_eq!(make_names_utf8(&mut short), None, "{cut}");
        }
    }
}
