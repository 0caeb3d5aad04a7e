//! Checks of a Parquet file's thrift structures (the footer and every page header)
//! against the file's bytes and a memory budget, made before the `parquet` crate reads
//! them. The crate trusts the lengths it finds: a damaged footer can make its thrift
//! reader loop for seconds over list counts the bytes cannot hold, and a damaged page
//! header can make it allocate what the header claims (gigabytes for an 8 KB file).
//!
//! The walker reads the thrift compact protocol generically (every value skipped, lists
//! and maps checked against the bytes left, since each element takes a byte at least;
//! nesting bounded), so work is linear in the file's size whatever it claims.

use parquet::basic::Compression;

/// The most bytes a page may decompress to here. Writers cut pages at about 1 MiB
/// (arrow, pyarrow, polars, parquet-mr); fastparquet writes one page per column chunk,
/// hundreds of MiB at its default row-group size.
pub const PAGE_LIMIT: i64 = 1 << 30;

/// Thrift structs nest a few levels in Parquet (schema elements are a flat list).
const MAX_DEPTH: usize = 64;

// Thrift compact protocol type codes.
const BOOL_TRUE: u8 = 1;
const BOOL_FALSE: u8 = 2;
const I8: u8 = 3;
const I16: u8 = 4;
const I32: u8 = 5;
const I64: u8 = 6;
const DOUBLE: u8 = 7;
const BINARY: u8 = 8;
const LIST: u8 = 9;
const SET: u8 = 10;
const MAP: u8 = 11;
const STRUCT: u8 = 12;

/// Receives the integer and bool fields of the structs walked, with their path of field
/// ids from the outer struct (values inside lists and maps are not reported).
type Visit<'v> = dyn FnMut(&[i16], i64) + 'v;

struct Compact<'a> {
    data: &'a [u8],
    pos: usize,
}

impl Compact<'_> {
    fn fail<T>(&self, problem: impl std::fmt::Display) -> Result<T, String> {
        Err(format!("{problem} at byte {}", self.pos))
    }

    fn left(&self) -> usize {
        self.data.len() - self.pos
    }

    fn byte(&mut self) -> Result<u8, String> {
        match self.data.get(self.pos) {
            Some(&b) => {
                self.pos += 1;
                Ok(b)
            }
            None => self.fail("the structure ends early"),
        }
    }

    fn skip(&mut self, count: usize) -> Result<(), String> {
        if count > self.left() {
            return self.fail(format!(
                "{count} bytes are claimed where {} are left",
                self.left()
            ));
        }
        self.pos += count;
        Ok(())
    }

    fn varint(&mut self) -> Result<u64, String> {
        let mut value = 0u64;
        for shift in (0..70).step_by(7) {
            let b = self.byte()?;
            value |= u64::from(b & 0x7f) << shift.min(63);
            if b & 0x80 == 0 {
                return Ok(value);
            }
        }
        self.fail("a varint runs past 10 bytes")
    }

    fn zigzag(&mut self) -> Result<i64, String> {
        let v = self.varint()?;
        Ok((v >> 1) as i64 ^ -((v & 1) as i64))
    }

    /// A count of elements that take a byte each at least.
    fn count(&mut self, count: u64, per_element: usize) -> Result<usize, String> {
        match usize::try_from(count) {
            Ok(n) if n.saturating_mul(per_element) <= self.left() => Ok(n),
            _ => self.fail(format!(
                "{count} elements are claimed where {} bytes are left",
                self.left()
            )),
        }
    }

    fn walk_struct(
        &mut self,
        path: &mut Vec<i16>,
        depth: usize,
        visit: &mut Visit<'_>,
    ) -> Result<(), String> {
        if depth > MAX_DEPTH {
            return self.fail("structures nest too deeply");
        }
        let mut last_id = 0i16;
        loop {
            let header = self.byte()?;
            if header == 0 {
                return Ok(());
            }
            let delta = header >> 4;
            let id = if delta == 0 {
                i16::try_from(self.zigzag()?)
                    .or_else(|_| self.fail("a field id is out of range"))?
            } else {
                last_id.wrapping_add(i16::from(delta))
            };
            last_id = id;
            path.push(id);
            let result = self.walk_value(header & 0x0f, path, depth, visit);
            path.pop();
            result?;
        }
    }

    fn walk_value(
        &mut self,
        kind: u8,
        path: &mut Vec<i16>,
        depth: usize,
        visit: &mut Visit<'_>,
    ) -> Result<(), String> {
        match kind {
            BOOL_TRUE | BOOL_FALSE => visit(path, i64::from(kind == BOOL_TRUE)),
            I16 | I32 | I64 => {
                let value = self.zigzag()?;
                visit(path, value);
            }
            STRUCT => self.walk_struct(path, depth + 1, visit)?,
            _ => self.skip_element(kind, depth)?,
        }
        Ok(())
    }

    /// Skips one value of `kind` inside a list, set or map (where a bool is a byte).
    fn skip_element(&mut self, kind: u8, depth: usize) -> Result<(), String> {
        match kind {
            BOOL_TRUE | BOOL_FALSE | I8 => self.skip(1),
            I16 | I32 | I64 => self.varint().map(drop),
            DOUBLE => self.skip(8),
            BINARY => {
                let length = self.varint()?;
                let length = self.count(length, 1)?;
                self.skip(length)
            }
            LIST | SET => {
                let header = self.byte()?;
                let mut size = u64::from(header >> 4);
                if size == 15 {
                    size = self.varint()?;
                }
                let size = self.count(size, 1)?;
                for _ in 0..size {
                    self.skip_element(header & 0x0f, depth + 1)?;
                }
                Ok(())
            }
            MAP => {
                let size = self.varint()?;
                let size = self.count(size, 2)?;
                if size > 0 {
                    let kinds = self.byte()?;
                    for _ in 0..size {
                        self.skip_element(kinds >> 4, depth + 1)?;
                        self.skip_element(kinds & 0x0f, depth + 1)?;
                    }
                }
                Ok(())
            }
            STRUCT => self.walk_struct(&mut Vec::new(), depth + 1, &mut |_, _| {}),
            other => self.fail(format!("unknown thrift type {other}")),
        }
    }
}

/// Checks the footer (the thrift `FileMetaData` before the closing length and `PAR1`):
/// every list, string and nesting fits in its bytes. Files too short to hold a footer,
/// or with an encrypted one, are left to the `parquet` crate, which refuses them.
pub fn check_footer(file: &[u8]) -> Result<(), String> {
    let Some(tail) = file.len().checked_sub(8).map(|at| &file[at..]) else {
        return Ok(());
    };
    if &tail[4..] != b"PAR1" {
        return Ok(());
    }
    let length = u32::from_le_bytes(tail[..4].try_into().expect("4 bytes")) as usize;
    let Some(start) = (file.len() - 8).checked_sub(length) else {
        return Ok(());
    };
    let mut reader = Compact {
        data: &file[start..file.len() - 8],
        pos: 0,
    };
    reader
        .walk_struct(&mut Vec::new(), 0, &mut |_, _| {})
        .map_err(|e| format!("its footer is damaged: {e} of the footer"))
}

/// How many bytes a codec can make of one at most (with a margin), where that is known.
fn max_ratio(codec: Compression) -> Option<i64> {
    match codec {
        Compression::UNCOMPRESSED => Some(1),
        // A 3-byte copy element gives 64 bytes.
        Compression::SNAPPY => Some(32),
        // Each further length byte adds 255.
        Compression::LZ4 | Compression::LZ4_RAW => Some(256),
        // Deflate's most is 1032:1.
        Compression::GZIP(_) => Some(1100),
        _ => None,
    }
}

/// What a page header says about the page.
#[derive(Debug, Default)]
struct PageHeader {
    uncompressed: Option<i64>,
    compressed: Option<i64>,
    values: Vec<i64>,
}

/// Walks the page headers of one column chunk (`chunk`: its bytes, pages back to back)
/// and checks each page against what follows it and against the memory budget.
pub fn check_pages(chunk: &[u8], codec: Compression) -> Result<(), String> {
    let mut pos = 0usize;
    let mut page = 0usize;
    while pos < chunk.len() {
        let mut reader = Compact {
            data: &chunk[pos..],
            pos: 0,
        };
        let mut header = PageHeader::default();
        reader
            .walk_struct(
                &mut Vec::new(),
                0,
                &mut |path: &[i16], value: i64| match path {
                    [2] => header.uncompressed = Some(value),
                    [3] => header.compressed = Some(value),
                    // num_values of data, dictionary and data-v2 page headers.
                    [5, 1] | [7, 1] | [8, 1] => header.values.push(value),
                    _ => {}
                },
            )
            .map_err(|e| format!("page {page}: its header is damaged: {e} of the header"))?;
        let (Some(uncompressed), Some(compressed)) = (header.uncompressed, header.compressed)
        else {
            return Err(format!("page {page}: its header gives no page sizes"));
        };
        let at = pos + reader.pos;
        if compressed < 0 || uncompressed < 0 || header.values.iter().any(|&v| v < 0) {
            return Err(format!(
                "page {page}: its header claims negative sizes ({compressed} bytes, \
                 {uncompressed} uncompressed)"
            ));
        }
        if compressed as u64 > (chunk.len() - at) as u64 {
            return Err(format!(
                "page {page} claims {compressed} bytes where the column chunk holds {} more",
                chunk.len() - at
            ));
        }
        if uncompressed > PAGE_LIMIT {
            return Err(format!(
                "page {page} claims to decompress to {uncompressed} bytes, more than the \
                 {PAGE_LIMIT} a page may hold here"
            ));
        }
        if let Some(ratio) = max_ratio(codec)
            && uncompressed > compressed.saturating_mul(ratio).saturating_add(1024)
        {
            return Err(format!(
                "page {page} claims {uncompressed} bytes from {compressed} compressed with \
                 {codec}, more than {codec} can give"
            ));
        }
        pos = at + compressed as usize;
        page += 1;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A compact-protocol page header: type, sizes, and a data page header with
    /// `num_values`.
    fn page_header(uncompressed: i32, compressed: i32, values: i32) -> Vec<u8> {
        let zigzag = |v: i32| -> Vec<u8> {
            let mut z = ((v << 1) ^ (v >> 31)) as u32;
            let mut out = Vec::new();
            loop {
                let b = (z & 0x7f) as u8;
                z >>= 7;
                if z == 0 {
                    out.push(b);
                    return out;
                }
                out.push(b | 0x80);
            }
        };
        let mut h = vec![0x15];
        h.extend(zigzag(0)); // 1: type DATA_PAGE
        h.push(0x15);
        h.extend(zigzag(uncompressed)); // 2
        h.push(0x15);
        h.extend(zigzag(compressed)); // 3
        h.push(0x2c); // 5: struct DataPageHeader
        h.push(0x15);
        h.extend(zigzag(values)); // 5.1 num_values
        h.push(0x15);
        h.extend(zigzag(0)); // 5.2 encoding
        h.push(0x00); // end of DataPageHeader
        h.push(0x00); // end of PageHeader
        h
    }

    fn chunk(pages: &[(i32, i32, i32, usize)]) -> Vec<u8> {
        let mut out = Vec::new();
        for &(uncompressed, compressed, values, body) in pages {
            out.extend(page_header(uncompressed, compressed, values));
            out.extend(std::iter::repeat_n(7u8, body));
        }
        out
    }

    #[test]
    fn pages_that_fit_pass_and_lying_ones_are_named() {
        let good = chunk(&[(100, 40, 10, 40), (300, 20, 30, 20)]);
        check_pages(&good, Compression::SNAPPY).unwrap();
        let inflated = chunk(&[(100, 40, 10, 40), (5000, 40, 10, 40)]);
        let err = check_pages(&inflated, Compression::UNCOMPRESSED).unwrap_err();
        assert!(err.starts_with("page 1 claims 5000 bytes from 40"), "{err}");
        check_pages(&inflated, Compression::LZ4_RAW).unwrap();
        let err = check_pages(
            &chunk(&[(10, 10, 1, 10), (10, 500, 1, 10)]),
            Compression::SNAPPY,
        )
        .unwrap_err();
        assert!(err.contains("page 1 claims 500 bytes"), "{err}");
        let huge = chunk(&[(i32::MAX, 64, 1, 64)]);
        let err = check_pages(&huge, Compression::ZSTD(Default::default())).unwrap_err();
        assert!(err.contains("more than the 1073741824"), "{err}");
        let err = check_pages(&chunk(&[(10, 10, -1, 10)]), Compression::SNAPPY).unwrap_err();
        assert!(err.contains("negative"), "{err}");
        let mut cut = chunk(&[(10, 10, 1, 10)]);
        cut.truncate(3);
        let err = check_pages(&cut, Compression::SNAPPY).unwrap_err();
        assert!(err.contains("header is damaged"), "{err}");
    }

    #[test]
    fn list_counts_are_held_to_the_bytes_left() {
        // A struct whose field 1 is a list claiming 2^40 i32 elements.
        let mut footer = vec![0x19, 0xf5];
        footer.extend([0x80, 0x80, 0x80, 0x80, 0x80, 0x20]);
        footer.extend([0u8; 16]);
        let length = footer.len() as u32;
        let mut file = b"PAR1".to_vec();
        file.extend(&footer);
        file.extend(length.to_le_bytes());
        file.extend(b"PAR1");
        let err = check_footer(&file).unwrap_err();
        assert!(err.contains("elements are claimed"), "{err}");
    }

    proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(data in prop::collection::vec(any::<u8>(), 0..300)) {
            let _ = check_pages(&data, Compression::SNAPPY);
            let mut file = data.clone();
            file.extend((data.len() as u32).to_le_bytes());
            file.extend(b"PAR1");
            let _ = check_footer(&file);
        }
    }
}
