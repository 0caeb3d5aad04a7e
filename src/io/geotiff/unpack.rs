//! Strips and tiles decompressed here, their predictor undone and their samples read
//! in the file's byte order: LZW and LZMA ones always, others where the `tiff` crate
//! refuses their samples. LZMA because the crate has no LZMA; LZW because its
//! streaming LZW reader fails on edge tiles of some tiled files GDAL writes ("no lzw
//! end code found", image-rs/image-tiff#395), where a whole-chunk decode of the same
//! bytes is exact; GDAL's `NBITS` widths (9 to 15, 17 to 31 bits) and half floats
//! because the crate has no colour type for them.

use std::io::{Read, Seek, Write};

use tiff::decoder::Decoder;
use tiff::tags::{ByteOrder, Tag};

use super::chunks::{Image, Layout};

/// TIFF compression codes decompressed here.
const NONE: u16 = 1;
const LZW: u16 = 5;
const DEFLATE: u16 = 8;
const PACKBITS: u16 = 32773;
const ADOBE_DEFLATE: u16 = 32946;
const LZMA: u16 = 34925;
const ZSTD: u16 = 50000;

/// Whether this module reads the image rather than the `tiff` crate: LZW and LZMA
/// always, and the lossless compressions where the crate has no colour type for the
/// samples (more than 8 bits but not 16, 32 or 64: GDAL's `NBITS`).
pub(super) fn reads<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    compression: u16,
) -> Result<bool, String> {
    if matches!(compression, LZW | LZMA) {
        return Ok(true);
    }
    let bits = decoder
        .find_tag_unsigned_vec::<u16>(Tag::BitsPerSample)
        .map_err(|e| e.to_string())?
        .and_then(|b| b.first().copied())
        .unwrap_or(1);
    Ok(matches!(
        compression,
        NONE | DEFLATE | ADOBE_DEFLATE | PACKBITS | ZSTD
    ) && bits > 8
        && !matches!(bits, 16 | 32 | 64))
}

/// Whether `decompress` reads strips or tiles of this compression.
pub(super) fn decompresses(compression: u16) -> bool {
    matches!(
        compression,
        NONE | LZW | DEFLATE | ADOBE_DEFLATE | PACKBITS | LZMA | ZSTD
    )
}

/// How the samples are stored: their type and width, samples per pixel in a strip or
/// tile, the predictor and byte order.
#[derive(Clone, Copy, Debug)]
struct Encoding {
    format: Format,
    bits: usize,
    depth: usize,
    predictor: u16,
    big_endian: bool,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Format {
    Unsigned,
    Signed,
    Float,
}

/// The image's samples as `f32`, pixel-interleaved, or band after band when
/// band-interleaved; strips or tiles the file leaves out hold the image's `fill`.
pub(super) fn read<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    image: &Image,
    compression: u16,
) -> Result<Vec<f32>, String> {
    let layout = Layout::of(decoder, image)?;
    let depth = layout.depth();
    let encoding = Encoding::of(decoder, depth)?;
    let mut values = layout.buffer(image.fill);
    for chunk in layout.stored_chunks(image.file) {
        let chunk = chunk?;
        let in_chunk = |m: String| format!("strip or tile {}: {m}", chunk.index);
        let (chunk_width, rows) = layout.stored_size(&chunk);
        let row_bytes = (chunk_width * depth * encoding.bits).div_ceil(8);
        let mut bytes = decompress(compression, chunk.bytes, row_bytes * rows).map_err(in_chunk)?;
        let mut samples = Vec::with_capacity(chunk_width * depth * rows);
        for row in bytes.chunks_exact_mut(row_bytes) {
            encoding
                .row_values(row, chunk_width * depth, &mut samples)
                .map_err(in_chunk)?;
        }
        layout.place_rows(&mut values, &chunk, chunk_width, rows, &samples);
    }
    Ok(values)
}

/// The first `expected` bytes a strip or tile decompresses to (libtiff reads no
/// further either); an error where it holds fewer.
fn decompress(compression: u16, stream: &[u8], expected: usize) -> Result<Vec<u8>, String> {
    let bounded = |reader: &mut dyn Read, name: &str| -> Result<Vec<u8>, String> {
        let mut out = Vec::with_capacity(expected);
        reader
            .take(expected as u64)
            .read_to_end(&mut out)
            .map_err(|e| format!("the {name} stream: {e}"))?;
        short(out, expected, name)
    };
    match compression {
        LZW => lzw(stream, expected),
        LZMA => lzma(stream, expected),
        NONE => short(
            stream[..stream.len().min(expected)].to_vec(),
            expected,
            "stored",
        ),
        DEFLATE | ADOBE_DEFLATE => bounded(&mut flate2::read::ZlibDecoder::new(stream), "Deflate"),
        ZSTD => bounded(
            &mut zstd::stream::read::Decoder::with_buffer(stream)
                .map_err(|e| format!("the ZSTD stream: {e}"))?,
            "ZSTD",
        ),
        PACKBITS => short(packbits(stream, expected), expected, "PackBits"),
        other => Err(format!("compression {other} is not decompressed here")),
    }
}

/// `bytes` if they are the `expected` bytes of the chunk's pixels.
fn short(bytes: Vec<u8>, expected: usize, name: &str) -> Result<Vec<u8>, String> {
    if bytes.len() < expected {
        return Err(format!(
            "the {name} stream holds {} bytes, not the {expected} of its pixels",
            bytes.len()
        ));
    }
    Ok(bytes)
}

/// At most `expected` bytes of a PackBits stream (TIFF 6.0, section 9): a header byte
/// n then n + 1 literal bytes (n ≥ 0) or one byte repeated 1 − n times (n < 0; −128
/// is no operation). A stream cut short yields what it holds.
fn packbits(stream: &[u8], expected: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(expected);
    let mut at = 0;
    while out.len() < expected && at < stream.len() {
        let n = stream[at] as i8;
        at += 1;
        match n {
            0.. => {
                let literal = &stream[at..stream.len().min(at + n as usize + 1)];
                out.extend_from_slice(literal);
                at += literal.len();
            }
            -128 => {}
            _ => {
                let Some(&byte) = stream.get(at) else { break };
                at += 1;
                out.extend(std::iter::repeat_n(byte, (1 - i32::from(n)) as usize));
            }
        }
    }
    out.truncate(expected);
    out
}

/// `expected` bytes of a TIFF LZW stream (most significant bits first, code widths
/// switching one code early), or of the old-style LZW of TIFFs written before
/// libtiff 5 (least significant bits first, widths switching on time, as GIF's), which
/// libtiff tells by their first clear code: a zero byte, then one whose lowest bit is
/// set. Like libtiff, stops once it has them.
fn lzw(stream: &[u8], expected: usize) -> Result<Vec<u8>, String> {
    let old_style = stream.len() >= 2 && stream[0] == 0 && stream[1] & 1 == 1;
    let mut decoder = if old_style {
        weezl::decode::Decoder::new(weezl::BitOrder::Lsb, 8)
    } else {
        weezl::decode::Decoder::with_tiff_size_switch(weezl::BitOrder::Msb, 8)
    };
    let mut out = vec![0u8; expected];
    let (mut read, mut written) = (0, 0);
    // weezl may return without progress while it settles its state; a few such calls
    // in a row mean the stream is spent.
    let mut idle = 0;
    while written < expected && idle < 4 {
        let result = decoder.decode_bytes(&stream[read..], &mut out[written..]);
        read += result.consumed_in;
        written += result.consumed_out;
        idle = if result.consumed_in + result.consumed_out == 0 {
            idle + 1
        } else {
            0
        };
        match result.status {
            Ok(weezl::LzwStatus::Ok) => {}
            Ok(_) => break,
            Err(e) => return Err(format!("the LZW stream: {e}")),
        }
    }
    if written < expected {
        return Err(format!(
            "the LZW stream holds {written} bytes, not the {expected} of its pixels"
        ));
    }
    Ok(out)
}

/// `expected` bytes of an xz stream: libtiff's LZMA codec writes xz with a filter
/// chain of delta (a sample's width apart) then LZMA2. `lzma-rs` decodes LZMA2 but not
/// the delta filter, so the container is read here: each block's header names its
/// filters, LZMA2 runs to the block's end marker, and the delta is added back.
fn lzma(stream: &[u8], expected: usize) -> Result<Vec<u8>, String> {
    const MAGIC: &[u8] = b"\xFD7zXZ\0";
    let truncated = || "the LZMA stream (xz) is cut short".to_string();
    if stream.get(..6) != Some(MAGIC) {
        return Err("the LZMA stream is not xz (no xz magic)".into());
    }
    let check_type = *stream.get(7).ok_or_else(truncated)? & 0x0F;
    let check_size = match check_type {
        0 => 0,
        t => 4 << ((t - 1) / 3),
    };
    let mut at = 12;
    let mut out = Bounded {
        bytes: Vec::with_capacity(expected),
        limit: expected,
    };
    loop {
        let size_byte = *stream.get(at).ok_or_else(truncated)?;
        if size_byte == 0 {
            break; // the index: no more blocks
        }
        let header = stream
            .get(at..at + (usize::from(size_byte) + 1) * 4)
            .ok_or_else(truncated)?;
        let delta = block_delta(header)?;
        let start = out.bytes.len();
        let mut data = &stream[at + header.len()..];
        let before = data.len();
        lzma_rs::lzma2_decompress(&mut data, &mut out)
            .map_err(|e| format!("the LZMA stream: {e}"))?;
        if let Some(distance) = delta {
            let block = &mut out.bytes[start..];
            for i in distance..block.len() {
                block[i] = block[i].wrapping_add(block[i - distance]);
            }
        }
        // The block's data is padded to four bytes, then its check.
        let block_len = header.len() + (before - data.len());
        at += block_len.next_multiple_of(4) + check_size;
    }
    if out.bytes.len() < expected {
        return Err(format!(
            "the LZMA stream holds {} bytes, not the {expected} of its pixels",
            out.bytes.len()
        ));
    }
    Ok(out.bytes)
}

/// The delta distance a block header's filter chain starts with (`None` where it is
/// LZMA2 alone); an error for any other filter.
fn block_delta(header: &[u8]) -> Result<Option<usize>, String> {
    const DELTA: u64 = 0x03;
    const LZMA2: u64 = 0x21;
    let flags = header[1];
    let mut at = 2;
    let vli = |at: &mut usize| -> Result<u64, String> {
        let mut value = 0u64;
        for shift in (0..63).step_by(7) {
            let byte = *header.get(*at).ok_or("an xz block header is cut short")?;
            *at += 1;
            value |= u64::from(byte & 0x7F) << shift;
            if byte & 0x80 == 0 {
                return Ok(value);
            }
        }
        Err("an xz block header holds an overlong number".into())
    };
    for present in [0x40, 0x80] {
        if flags & present != 0 {
            vli(&mut at)?; // compressed or uncompressed size
        }
    }
    let mut delta = None;
    let filters = usize::from(flags & 0x03) + 1;
    for index in 0..filters {
        let id = vli(&mut at)?;
        let size = usize::try_from(vli(&mut at)?).map_err(|e| e.to_string())?;
        let properties = header
            .get(at..at + size)
            .ok_or("an xz block header is cut short")?;
        at += size;
        match (id, index + 1 == filters) {
            (LZMA2, true) => {}
            (DELTA, false) if size == 1 => delta = Some(usize::from(properties[0]) + 1),
            _ => {
                return Err(format!(
                    "xz filter {id:#x} is not read (libtiff writes delta, then LZMA2)"
                ));
            }
        }
    }
    Ok(delta)
}

/// A buffer that refuses bytes past its limit, so that a corrupt stream cannot
/// decompress without end.
struct Bounded {
    bytes: Vec<u8>,
    limit: usize,
}

impl Write for Bounded {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.bytes.len() + buf.len() > self.limit {
            return Err(std::io::Error::other(format!(
                "it decompresses to more than the {} bytes of its pixels",
                self.limit
            )));
        }
        self.bytes.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Encoding {
    fn of<R: Read + Seek>(decoder: &mut Decoder<R>, depth: usize) -> Result<Encoding, String> {
        let e = |e: tiff::TiffError| e.to_string();
        let first = |v: Option<Vec<u16>>, default: u16| {
            v.and_then(|v| v.first().copied()).unwrap_or(default)
        };
        let bits = first(
            decoder
                .find_tag_unsigned_vec(Tag::BitsPerSample)
                .map_err(e)?,
            1,
        );
        let format = match first(
            decoder
                .find_tag_unsigned_vec(Tag::SampleFormat)
                .map_err(e)?,
            1,
        ) {
            1 => Format::Unsigned,
            2 => Format::Signed,
            3 => Format::Float,
            other => return Err(format!("tag SampleFormat {other} is not read")),
        };
        let predictor = decoder
            .find_tag_unsigned::<u16>(Tag::Predictor)
            .map_err(e)?
            .unwrap_or(1);
        let encoding = Encoding {
            format,
            bits: usize::from(bits),
            depth,
            predictor,
            big_endian: decoder.byte_order() == ByteOrder::BigEndian,
        };
        if !supported(format, bits, predictor) {
            return Err(format!(
                "samples of {bits} bits, SampleFormat {format:?}, Predictor {predictor} \
                 are not read"
            ));
        }
        Ok(encoding)
    }

    /// Appends the `count` samples of one stored row to `out`, the predictor undone
    /// (in place, for the floating-point one).
    fn row_values(&self, row: &mut [u8], count: usize, out: &mut Vec<f32>) -> Result<(), String> {
        if self.format == Format::Unsigned && !matches!(self.bits, 8 | 16 | 32 | 64) {
            out.extend(super::samples::unpack(row, self.bits as u16, count, 1)?);
            return Ok(());
        }
        let samples = &mut row[..count * self.bits / 8];
        let (horizontal, big_endian) = match self.predictor {
            2 if self.format == Format::Float => {
                undo_horizontal_on_words(samples, self.bits / 8, self.depth, self.big_endian);
                (false, self.big_endian)
            }
            3 => {
                undo_floating_point_predictor(samples, self.bits / 8, self.depth);
                // The predictor leaves the bytes of each sample most significant first.
                (false, true)
            }
            2 => (true, self.big_endian),
            _ => (false, self.big_endian),
        };
        let read = RowReading {
            big_endian,
            horizontal,
            depth: self.depth,
        };
        match (self.format, self.bits) {
            (Format::Unsigned, 8) => read.append::<u8>(samples, out),
            (Format::Unsigned, 16) => read.append::<u16>(samples, out),
            (Format::Unsigned, 32) => read.append::<u32>(samples, out),
            (Format::Unsigned, _) => read.append::<u64>(samples, out),
            (Format::Signed, 8) => read.append::<i8>(samples, out),
            (Format::Signed, 16) => read.append::<i16>(samples, out),
            (Format::Signed, 32) => read.append::<i32>(samples, out),
            (Format::Signed, _) => read.append::<i64>(samples, out),
            (Format::Float, 16) => read.append::<half::f16>(samples, out),
            (Format::Float, 32) => read.append::<f32>(samples, out),
            (Format::Float, _) => read.append::<f64>(samples, out),
        }
        Ok(())
    }
}

/// Whether samples of this format and width are read under this predictor.
fn supported(format: Format, bits: u16, predictor: u16) -> bool {
    match (format, bits) {
        (Format::Unsigned | Format::Signed, 8 | 16 | 32 | 64) => predictor <= 2,
        // Packed widths: libtiff's horizontal predictor is for whole bytes only.
        (Format::Unsigned, 1..=32) => predictor == 1,
        (Format::Float, 16 | 32 | 64) => (1..=3).contains(&predictor),
        _ => false,
    }
}

/// How one row's samples are read: their byte order, and whether each is a difference
/// from the sample a pixel (`depth` samples) before it.
struct RowReading {
    big_endian: bool,
    horizontal: bool,
    depth: usize,
}

impl RowReading {
    fn append<T: Sample>(&self, bytes: &[u8], out: &mut Vec<f32>) {
        let samples = bytes
            .chunks_exact(T::SIZE)
            .map(|b| T::from_bytes(b, self.big_endian));
        if !self.horizontal {
            out.extend(samples.map(T::to_f32));
            return;
        }
        let mut values: Vec<T> = samples.collect();
        for i in self.depth..values.len() {
            values[i] = values[i].wrapping_add(values[i - self.depth]);
        }
        out.extend(values.into_iter().map(T::to_f32));
    }
}

/// A stored sample type.
trait Sample: Copy {
    const SIZE: usize;
    fn from_bytes(bytes: &[u8], big_endian: bool) -> Self;
    /// The horizontal predictor's sum (integers only; never called on floats).
    fn wrapping_add(self, other: Self) -> Self;
    fn to_f32(self) -> f32;
}

macro_rules! sample {
    ($($t:ty => $add:expr),* $(,)?) => {$(
        impl Sample for $t {
            const SIZE: usize = std::mem::size_of::<$t>();
            fn from_bytes(bytes: &[u8], big_endian: bool) -> Self {
                let array = bytes.try_into().expect("chunks of SIZE bytes");
                if big_endian {
                    <$t>::from_be_bytes(array)
                } else {
                    <$t>::from_le_bytes(array)
                }
            }
            fn wrapping_add(self, other: Self) -> Self {
                $add(self, other)
            }
            fn to_f32(self) -> f32 {
                self as f32
            }
        }
    )*};
}

sample!(
    u8 => u8::wrapping_add, u16 => u16::wrapping_add, u32 => u32::wrapping_add,
    u64 => u64::wrapping_add, i8 => i8::wrapping_add, i16 => i16::wrapping_add,
    i32 => i32::wrapping_add, i64 => i64::wrapping_add,
    f32 => |a: f32, b: f32| a + b, f64 => |a: f64, b: f64| a + b,
);

/// Half floats (GDAL's Float32 with `NBITS=16`).
impl Sample for half::f16 {
    const SIZE: usize = 2;
    fn from_bytes(bytes: &[u8], big_endian: bool) -> Self {
        let array = bytes.try_into().expect("chunks of SIZE bytes");
        if big_endian {
            half::f16::from_be_bytes(array)
        } else {
            half::f16::from_le_bytes(array)
        }
    }
    fn wrapping_add(self, other: Self) -> Self {
        self + other
    }
    fn to_f32(self) -> f32 {
        f32::from(self)
    }
}

/// Undoes the horizontal predictor on float samples, in place: libtiff differences
/// their bit patterns as unsigned words `depth` samples apart, whatever they hold (GDAL
/// writes it for floats asked for `PREDICTOR=2`).
fn undo_horizontal_on_words(row: &mut [u8], size: usize, depth: usize, big_endian: bool) {
    let mask = u64::MAX >> (64 - 8 * size);
    let word = |bytes: &[u8]| -> u64 {
        let fold = |w: u64, &b: &u8| (w << 8) | u64::from(b);
        if big_endian {
            bytes.iter().fold(0, fold)
        } else {
            bytes.iter().rev().fold(0, fold)
        }
    };
    for i in depth..row.len() / size {
        let sum = word(&row[i * size..][..size])
            .wrapping_add(word(&row[(i - depth) * size..][..size]))
            & mask;
        for (k, byte) in row[i * size..][..size].iter_mut().enumerate() {
            let shift = if big_endian {
                8 * (size - 1 - k)
            } else {
                8 * k
            };
            *byte = (sum >> shift) as u8;
        }
    }
}

/// Undoes the floating-point predictor (TIFF Technical Note 3, libtiff's `fpAcc`) on
/// one row: its bytes were differenced `depth` apart, after each sample's bytes were
/// spread into planes, most significant byte first. Leaves each sample's bytes most
/// significant first.
fn undo_floating_point_predictor(row: &mut [u8], size: usize, depth: usize) {
    for i in depth..row.len() {
        row[i] = row[i].wrapping_add(row[i - depth]);
    }
    let planes = row.to_vec();
    let count = row.len() / size;
    for sample in 0..count {
        for byte in 0..size {
            row[sample * size + byte] = planes[byte * count + sample];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The samples `e.row_values` appends for a row of `count`.
    fn read_row(e: &Encoding, bytes: &mut [u8], count: usize) -> Vec<f32> {
        let mut out = Vec::new();
        e.row_values(bytes, count, &mut out).unwrap();
        out
    }

    fn encoding(
        format: Format,
        bits: usize,
        depth: usize,
        predictor: u16,
        big_endian: bool,
    ) -> Encoding {
        Encoding {
            format,
            bits,
            depth,
            predictor,
            big_endian,
        }
    }

    #[test]
    fn horizontal_differences_add_back_per_band_with_wrapping() {
        // Two pixels of two little-endian u16 bands: (1000, 7), then differences
        // (+5, -8 as 65528): the second pixel is (1005, 65535).
        let mut row: Vec<u8> = [1000u16, 7, 5, 65528]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let e = encoding(Format::Unsigned, 16, 2, 2, false);
        assert_eq!(read_row(&e, &mut row, 4), [1000.0, 7.0, 1005.0, 65535.0]);
        // Big-endian signed: -3, then +5 → 2.
        let mut row: Vec<u8> = [-3i32, 5].iter().flat_map(|v| v.to_be_bytes()).collect();
        let e = encoding(Format::Signed, 32, 1, 2, true);
        assert_eq!(read_row(&e, &mut row, 2), [-3.0, 2.0]);
    }

    #[test]
    fn the_horizontal_predictor_on_floats_adds_bit_patterns() {
        // libtiff's horDiff32 on two pixels of two f32 bands: the second pixel's words
        // minus the first's, wrapping.
        let pixels = [1.5f32, -2.0, 1e-3, 3.25e7];
        let words: Vec<u32> = pixels.iter().map(|f| f.to_bits()).collect();
        let differenced = [
            words[0],
            words[1],
            words[2].wrapping_sub(words[0]),
            words[3].wrapping_sub(words[1]),
        ];
        for big_endian in [false, true] {
            let mut row: Vec<u8> = differenced
                .iter()
                .flat_map(|w| {
                    if big_endian {
                        w.to_be_bytes()
                    } else {
                        w.to_le_bytes()
                    }
                })
                .collect();
            let e = encoding(Format::Float, 32, 2, 2, big_endian);
            assert_eq!(read_row(&e, &mut row, 4), pixels);
        }
        // Half floats, one band.
        let halves = [half::f16::from_f32(0.5), half::f16::from_f32(-7.0)];
        let diff = halves[1].to_bits().wrapping_sub(halves[0].to_bits());
        let mut row: Vec<u8> = [halves[0].to_bits(), diff]
            .iter()
            .flat_map(|w| w.to_le_bytes())
            .collect();
        let e = encoding(Format::Float, 16, 1, 2, false);
        assert_eq!(read_row(&e, &mut row, 2), [0.5, -7.0]);
    }

    #[test]
    fn the_floating_point_predictor_is_undone() {
        // Encode three f32 as libtiff does: bytes most significant first, spread into
        // planes, then differenced a sample apart.
        let floats = [1.5f32, -2.25, 1e-3];
        let count = floats.len();
        let big: Vec<[u8; 4]> = floats.iter().map(|f| f.to_be_bytes()).collect();
        let mut row: Vec<u8> = (0..4)
            .flat_map(|byte| big.iter().map(move |b| b[byte]))
            .collect();
        for i in (1..row.len()).rev() {
            row[i] = row[i].wrapping_sub(row[i - 1]);
        }
        for big_endian in [false, true] {
            let e = encoding(Format::Float, 32, 1, 3, big_endian);
            assert_eq!(read_row(&e, &mut row.clone(), count), floats);
        }
    }

    #[test]
    fn samples_read_in_either_byte_order_and_width() {
        let e = encoding(Format::Signed, 16, 1, 1, true);
        assert_eq!(read_row(&e, &mut [0xFF, 0xFE, 0x00, 0x02], 2), [-2.0, 2.0]);
        let e = encoding(Format::Float, 64, 1, 1, false);
        assert_eq!(
            read_row(&e, &mut (-0.5f64).to_le_bytes().to_vec(), 1),
            [-0.5]
        );
        let e = encoding(Format::Unsigned, 4, 1, 1, false);
        assert_eq!(read_row(&e, &mut [0xA3, 0x70], 3), [10.0, 3.0, 7.0]);
    }

    #[test]
    fn lzw_streams_decode_to_their_pixels_and_no_further() {
        let pixels: Vec<u8> = (0..3000u32).map(|i| (i % 7 * 30) as u8).collect();
        let mut encoder = weezl::encode::Encoder::with_tiff_size_switch(weezl::BitOrder::Msb, 8);
        let stream = encoder.encode(&pixels).unwrap();
        assert_eq!(lzw(&stream, pixels.len()).unwrap(), pixels);
        // Bytes after the pixels are not read (libtiff stops there too).
        let mut padded = stream.clone();
        padded.extend([0xAB; 16]);
        assert_eq!(lzw(&padded, pixels.len()).unwrap(), pixels);
        // Too short a stream, or garbage: an error, not a panic.
        assert!(lzw(&stream[..stream.len() / 2], pixels.len()).is_err());
        assert!(lzw(&[0xFF; 64], pixels.len()).is_err());
    }

    #[test]
    fn old_style_lzw_streams_decode_as_libtiff_reads_them() {
        // Before libtiff 5: codes least significant bits first, widths switching on
        // time (GIF's LZW), told by the first clear code's bytes 0x00, 0bxxxxxxx1.
        let pixels: Vec<u8> = (0..5000u32).map(|i| (i * i % 251) as u8).collect();
        let stream = weezl::encode::Encoder::new(weezl::BitOrder::Lsb, 8)
            .encode(&pixels)
            .unwrap();
        assert_eq!((stream[0], stream[1] & 1), (0, 1));
        assert_eq!(lzw(&stream, pixels.len()).unwrap(), pixels);
        // A new-style stream starts 0x80: the clear code's top bit first.
        let new_style = weezl::encode::Encoder::with_tiff_size_switch(weezl::BitOrder::Msb, 8)
            .encode(&pixels)
            .unwrap();
        assert_eq!(new_style[0], 0x80);
    }

    #[test]
    fn packbits_runs_and_literals_decode_to_their_pixels() {
        // Three literals, a run of four 0xAA, a no-op, a run of two 0x01.
        let stream = [2, 7, 8, 9, 0xFD, 0xAA, 0x80, 0xFF, 0x01];
        let pixels = [7, 8, 9, 0xAA, 0xAA, 0xAA, 0xAA, 1, 1];
        assert_eq!(packbits(&stream, 9), pixels);
        assert_eq!(packbits(&stream, 5), pixels[..5]);
        // Cut short (a literal past the end, a run without its byte): what it holds.
        assert_eq!(packbits(&[5, 1, 2], 6), [1, 2]);
        assert_eq!(packbits(&[0xFE], 3), Vec::<u8>::new());
        assert!(decompress(PACKBITS, &[5, 1, 2], 6).is_err());
    }

    #[test]
    fn every_lossless_compression_decompresses_to_the_chunks_bytes() {
        use std::io::Write;
        let pixels: Vec<u8> = (0..4000u32).map(|i| (i * 13 % 97) as u8).collect();
        let mut zlib = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        zlib.write_all(&pixels).unwrap();
        let zlib = zlib.finish().unwrap();
        let zstd = zstd::encode_all(&pixels[..], 3).unwrap();
        for (code, stream) in [
            (NONE, &pixels),
            (DEFLATE, &zlib),
            (ADOBE_DEFLATE, &zlib),
            (ZSTD, &zstd),
        ] {
            assert_eq!(decompress(code, stream, pixels.len()).unwrap(), pixels);
            // Fewer bytes asked: the first ones; more: an error naming the shortfall.
            assert_eq!(decompress(code, stream, 10).unwrap(), pixels[..10]);
            let err = decompress(code, stream, pixels.len() + 1).unwrap_err();
            assert!(err.contains("4000 bytes"), "{code}: {err}");
        }
        assert!(decompress(DEFLATE, &zlib[..zlib.len() / 2], pixels.len()).is_err());
        assert!(decompress(ZSTD, &[0xFF; 16], pixels.len()).is_err());
    }

    #[test]
    fn half_floats_and_packed_widths_read_from_rows() {
        let halves: Vec<u8> = [1.5f32, -0.25]
            .iter()
            .flat_map(|&f| half::f16::from_f32(f).to_le_bytes())
            .collect();
        let e = encoding(Format::Float, 16, 1, 1, false);
        assert_eq!(read_row(&e, &mut halves.clone(), 2), [1.5, -0.25]);
        let e = encoding(Format::Unsigned, 12, 1, 1, false);
        assert_eq!(read_row(&e, &mut [0xAB, 0xCD, 0xEF], 2), [2748.0, 3567.0]);
        // Packed widths with the horizontal predictor are refused, not misread.
        assert!(!supported(Format::Unsigned, 12, 2));
        assert!(!supported(Format::Signed, 12, 1));
        assert!(supported(Format::Float, 16, 3));
    }

    #[test]
    fn lzma_streams_decode_and_stop_at_the_pixels() {
        // An xz stream of LZMA2 alone (lzma-rs's writer; libtiff's adds a delta
        // filter, which tests/geotiff_variants.rs reads from rasterio's files).
        let pixels: Vec<u8> = (0..5000u32).map(|i| (i * 7 % 251) as u8).collect();
        let mut stream = Vec::new();
        lzma_rs::xz_compress(&mut &pixels[..], &mut stream).unwrap();
        assert_eq!(lzma(&stream, pixels.len()).unwrap(), pixels);
        assert!(lzma(&stream, pixels.len() - 1).is_err());
        assert!(lzma(&stream, pixels.len() + 1).is_err());
        for cut in [3, 12, 14, stream.len() / 2] {
            assert!(lzma(&stream[..cut], pixels.len()).is_err(), "{cut}");
        }
    }

    #[test]
    fn xz_block_headers_name_delta_then_lzma2() {
        // Size byte, flags (two filters), delta (id 3, one property: distance 2),
        // LZMA2 (id 0x21, one property), padding, CRC32.
        let header = [
            3, 0x01, 0x03, 0x01, 0x01, 0x21, 0x01, 0x16, 0, 0, 0, 0, 0, 0, 0, 0,
        ];
        assert_eq!(block_delta(&header).unwrap(), Some(2));
        let lzma2_alone = [2, 0x00, 0x21, 0x01, 0x16, 0, 0, 0, 0, 0, 0, 0];
        assert_eq!(block_delta(&lzma2_alone).unwrap(), None);
        let bcj_x86 = [2, 0x01, 0x04, 0x00, 0x21, 0x01, 0x16, 0, 0, 0, 0, 0];
        assert!(block_delta(&bcj_x86).unwrap_err().contains("0x4"));
        assert!(block_delta(&[0, 0x01, 0x03]).is_err());
    }
}
