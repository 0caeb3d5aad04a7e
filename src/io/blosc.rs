//! Blosc (version 1 frames): the compressor Zarr version 2 stores chunks with by
//! default (numcodecs' `Blosc`, LZ4 and byte shuffle). A frame is a 16-byte header
//! (format version, codec version, flags, type size, then the sizes uncompressed, of a
//! block and compressed), the blocks' offsets, and each block compressed whole or in one
//! stream per byte of the type ("split"). LZ4, Zstandard and zlib
//! streams are decoded (by the `lz4`, `zstd` and `flate2` crates), BloscLZ streams by
//! our own decoder, then byte- or bit-unshuffled; Snappy is refused by name.

use std::io::Read;

/// The frame header's flags.
const BYTE_SHUFFLE: u8 = 0x01;
const MEMCPYED: u8 = 0x02;
const BIT_SHUFFLE: u8 = 0x04;
const DONT_SPLIT: u8 = 0x10;
/// Streams split per byte of the type only up to this type size, and only where a
/// block holds this many elements.
const MAX_SPLITS: usize = 16;
const MIN_BUFFER: usize = 128;

/// The bytes Blosc `frame` holds, at most `most` of them; an error says why the frame
/// cannot be decoded.
pub(crate) fn decompress(frame: &[u8], most: usize) -> Result<Vec<u8>, String> {
    let word = |at: usize| -> Result<usize, String> {
        frame
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes(b.try_into().expect("four bytes")) as usize)
            .ok_or_else(|| format!("Blosc frame of {} bytes is cut short", frame.len()))
    };
    let (version, flags) = match frame {
        [version, _, flags, ..] => (*version, *flags),
        _ => return Err("a Blosc frame is shorter than its header".into()),
    };
    let typesize = usize::from(*frame.get(3).ok_or("a Blosc frame lacks its type size")?);
    let (nbytes, blocksize, cbytes) = (word(4)?, word(8)?, word(12)?);
    if !(1..=4).contains(&version) {
        return Err(format!(
            "Blosc frame of format version {version} (1 to 4 are read)"
        ));
    }
    if nbytes > most {
        return Err(format!(
            "Blosc frame of {nbytes} bytes where the chunk holds {most}"
        ));
    }
    if cbytes > frame.len() {
        return Err(format!(
            "Blosc frame of {cbytes} bytes holds {}",
            frame.len()
        ));
    }
    if nbytes == 0 {
        return Ok(Vec::new());
    }
    if flags & MEMCPYED != 0 {
        return frame
            .get(16..16 + nbytes)
            .map(<[u8]>::to_vec)
            .ok_or_else(|| "a stored Blosc frame is cut short".into());
    }
    if blocksize == 0 || typesize == 0 {
        return Err(format!(
            "Blosc frame of blocks of {blocksize} bytes, type {typesize}"
        ));
    }
    let codec = match flags >> 5 {
        0 => Codec::BloscLz,
        1 => Codec::Lz4,
        3 => Codec::Zlib,
        4 => Codec::Zstd,
        other => {
            return Err(format!(
                "Blosc frame of codec {other} (Snappy or unknown), which is not read"
            ));
        }
    };
    let shuffled = flags & BYTE_SHUFFLE != 0 && typesize > 1;
    let bit_shuffled = flags & BIT_SHUFFLE != 0;
    let mut out = vec![0u8; nbytes];
    for (block, chunk) in out.chunks_mut(blocksize).enumerate() {
        let leftover = chunk.len() < blocksize;
        let split = flags & DONT_SPLIT == 0
            && typesize <= MAX_SPLITS
            && blocksize / typesize >= MIN_BUFFER
            && !leftover;
        let streams = if split { typesize } else { 1 };
        let stream_bytes = chunk.len() / streams;
        let mut at = word(16 + 4 * block)?;
        let mut decoded = Vec::with_capacity(chunk.len());
        for _ in 0..streams {
            let length = word(at)?;
            at += 4;
            let source = frame
                .get(at..at.saturating_add(length))
                .ok_or("a Blosc stream runs past its frame")?;
            at += length;
            if length == stream_bytes {
                decoded.extend_from_slice(source);
            } else {
                decoded.extend(codec.decode(source, stream_bytes)?);
            }
        }
        if decoded.len() != chunk.len() {
            return Err("a Blosc block decodes to another size than its own".into());
        }
        // As c-blosc: byte shuffle where both are flagged.
        if shuffled {
            unshuffle(&decoded, typesize, chunk);
        } else if bit_shuffled {
            bit_unshuffle(&decoded, typesize, version, chunk);
        } else {
            chunk.copy_from_slice(&decoded);
        }
    }
    Ok(out)
}

#[derive(Clone, Copy)]
enum Codec {
    BloscLz,
    Lz4,
    Zlib,
    Zstd,
}

impl Codec {
    /// `source` decoded to `size` bytes exactly.
    fn decode(self, source: &[u8], size: usize) -> Result<Vec<u8>, String> {
        let decoded = match self {
            Codec::Lz4 => {
                let size = i32::try_from(size).map_err(|_| "a Blosc stream too large")?;
                lz4::block::decompress(source, Some(size)).map_err(|e| e.to_string())?
            }
            Codec::Zlib => {
                let mut out = Vec::with_capacity(size);
                flate2::read::ZlibDecoder::new(source)
                    .take(size as u64 + 1)
                    .read_to_end(&mut out)
                    .map_err(|e| e.to_string())?;
                out
            }
            Codec::Zstd => zstd::bulk::decompress(source, size).map_err(|e| e.to_string())?,
            Codec::BloscLz => blosclz(source, size)?,
        };
        if decoded.len() == size {
            Ok(decoded)
        } else {
            Err(format!(
                "a Blosc stream decodes to {} bytes, not {size}",
                decoded.len()
            ))
        }
    }
}

/// How far back a BloscLZ match may reach with a one-byte distance; past it, a two-byte
/// distance follows.
const BLOSCLZ_MAX_DISTANCE: usize = 8191;

/// A BloscLZ stream (Blosc's own codec, FastLZ's level 2 format) decoded to at most
/// `size` bytes. Instructions follow one another: a control byte below 32 copies that
/// many plus one literal bytes; above, its top three bits less one are a match's length
/// (7: more bytes follow, added up while they are 255), its low five bits the high
/// byte of its distance, the next byte the low one (255 with a high byte of 31: a
/// two-byte distance past 8191 follows); the match copies its length plus 3 bytes from
/// its distance plus one back. The first byte's top bits hold the level.
fn blosclz(source: &[u8], size: usize) -> Result<Vec<u8>, String> {
    let bad = || "a BloscLZ stream is malformed".to_string();
    let mut out: Vec<u8> = Vec::with_capacity(size);
    let mut at = 0;
    let next = |at: &mut usize| -> Result<usize, String> {
        let byte = *source.get(*at).ok_or_else(bad)?;
        *at += 1;
        Ok(usize::from(byte))
    };
    let Some(first) = source.first() else {
        return Ok(out);
    };
    let mut control = usize::from(first & 31);
    at += 1;
    loop {
        if control < 32 {
            let length = control + 1;
            let literal = source.get(at..at + length).ok_or_else(bad)?;
            if out.len() + length > size {
                return Err(bad());
            }
            out.extend_from_slice(literal);
            at += length;
        } else {
            let mut length = (control >> 5) - 1;
            let high = (control & 31) << 8;
            if length == 6 {
                loop {
                    let more = next(&mut at)?;
                    length += more;
                    if more != 255 {
                        break;
                    }
                }
            }
            let low = next(&mut at)?;
            length += 3;
            let mut distance = high + low;
            if low == 255 && high == 31 << 8 {
                let far = (next(&mut at)? << 8) + next(&mut at)?;
                distance = far + BLOSCLZ_MAX_DISTANCE;
            }
            let from = out.len().checked_sub(distance + 1).ok_or_else(bad)?;
            if out.len() + length > size {
                return Err(bad());
            }
            // Byte by byte: a match may overlap what it writes (a run).
            for i in 0..length {
                let byte = out[from + i];
                out.push(byte);
            }
        }
        if at >= source.len() {
            return Ok(out);
        }
        control = next(&mut at)?;
    }
}

/// Byte-shuffled `source` (every element's first bytes, then their second...) back to
/// whole elements in `out`; bytes past the last whole element stay where they are.
fn unshuffle(source: &[u8], typesize: usize, out: &mut [u8]) {
    let elements = source.len() / typesize;
    for (i, element) in out.chunks_exact_mut(typesize).enumerate() {
        for (j, byte) in element.iter_mut().enumerate() {
            *byte = source[j * elements + i];
        }
    }
    let whole = elements * typesize;
    out[whole..].copy_from_slice(&source[whole..]);
}

/// Bit-shuffled `source` back to whole elements in `out`, as c-blosc's `bitunshuffle`:
/// the elements of the block, a multiple of eight of them, lie as one row per bit of
/// each byte of the type (byte 0's bit 0, its bit 1, ..., byte 1's bit 0, ...), a row
/// holding that bit of every element, element `i` at bit `i % 8` of byte `i / 8`; bytes
/// past them stay where they are. Frames of format version 2 bit-shuffled only blocks
/// of a multiple of eight elements.
fn bit_unshuffle(source: &[u8], typesize: usize, version: u8, out: &mut [u8]) {
    let elements = source.len() / typesize;
    let shuffled = if version == 2 && !elements.is_multiple_of(8) {
        0
    } else {
        elements - elements % 8
    };
    let row = shuffled / 8;
    // Eight elements at a time: byte `j` of each is the 8 × 8 bit matrix of the eight
    // rows' bytes, transposed.
    for (at, group) in out[..shuffled * typesize]
        .chunks_exact_mut(8 * typesize)
        .enumerate()
    {
        for j in 0..typesize {
            let rows = (0..8).fold(0u64, |rows, k| {
                rows | u64::from(source[(j * 8 + k) * row + at]) << (8 * k)
            });
            let bytes = transpose_bits(rows).to_le_bytes();
            for (m, byte) in bytes.into_iter().enumerate() {
                group[m * typesize + j] = byte;
            }
        }
    }
    let whole = shuffled * typesize;
    out[whole..].copy_from_slice(&source[whole..]);
}

/// The 8 × 8 bit matrix whose rows are the bytes of `rows` (the first the lowest),
/// transposed: bit `m` of byte `k` becomes bit `k` of byte `m` (bitshuffle's
/// `TRANS_BIT_8X8`, three swaps of blocks).
fn transpose_bits(mut x: u64) -> u64 {
    let t = (x ^ (x >> 7)) & 0x00AA_00AA_00AA_00AA;
    x ^= t ^ (t << 7);
    let t = (x ^ (x >> 14)) & 0x0000_CCCC_0000_CCCC;
    x ^= t ^ (t << 14);
    let t = (x ^ (x >> 28)) & 0x0000_0000_F0F0_F0F0;
    x ^ t ^ (t << 28)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame of `values` as Blosc writes one uncompressed with byte shuffle, split
    /// into streams: each stream stored as it is (its length equals its size).
    fn frame_of(values: &[u32], blocksize: usize) -> Vec<u8> {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let blocks: Vec<&[u8]> = bytes.chunks(blocksize).collect();
        let mut body = Vec::new();
        let mut starts = Vec::new();
        let header = 16 + 4 * blocks.len();
        for block in &blocks {
            starts.push((header + body.len()) as u32);
            let elements = block.len() / 4;
            let mut shuffled = vec![0u8; block.len()];
            for i in 0..elements {
                for j in 0..4 {
                    shuffled[j * elements + i] = block[4 * i + j];
                }
            }
            let split = block.len() == blocksize && blocksize / 4 >= MIN_BUFFER;
            let streams = if split { 4 } else { 1 };
            for stream in shuffled.chunks(block.len() / streams) {
                body.extend((stream.len() as u32).to_le_bytes());
                body.extend_from_slice(stream);
            }
        }
        let mut frame = vec![2, 1, BYTE_SHUFFLE | (1 << 5), 4];
        frame.extend((bytes.len() as u32).to_le_bytes());
        frame.extend((blocksize as u32).to_le_bytes());
        frame.extend(((header + body.len()) as u32).to_le_bytes());
        for start in starts {
            frame.extend(start.to_le_bytes());
        }
        frame.extend(body);
        frame
    }

    #[test]
    fn shuffled_split_blocks_and_a_leftover_come_back() {
        let values: Vec<u32> = (0..700u32).map(|i| i.wrapping_mul(2_654_435_761)).collect();
        let frame = frame_of(&values, 1024);
        let bytes = decompress(&frame, 2800).unwrap();
        let back: Vec<u32> = bytes
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(back, values);
        assert!(decompress(&frame, 100).unwrap_err().contains("2800"));
    }

    #[test]
    fn lz4_streams_decode() {
        let bytes: Vec<u8> = (0..4096u32).flat_map(|i| (i / 7).to_le_bytes()).collect();
        let stream = lz4::block::compress(&bytes, None, false).unwrap();
        let mut frame = vec![2, 1, DONT_SPLIT | (1 << 5), 4];
        frame.extend((bytes.len() as u32).to_le_bytes());
        frame.extend((bytes.len() as u32).to_le_bytes());
        frame.extend(((24 + stream.len()) as u32).to_le_bytes());
        frame.extend(20u32.to_le_bytes());
        frame.extend((stream.len() as u32).to_le_bytes());
        frame.extend(&stream);
        assert_eq!(decompress(&frame, bytes.len()).unwrap(), bytes);
    }

    #[test]
    fn bit_shuffled_elements_come_back_with_their_leftovers() {
        // 21 three-byte elements and a byte: 16 bit-shuffled, the rest as they lie.
        let values: Vec<u8> = (0..64u32).map(|i| (i * 37 % 251) as u8).collect();
        let (typesize, shuffled) = (3, 16);
        let mut source = vec![0u8; values.len()];
        for i in 0..shuffled {
            for j in 0..typesize {
                for k in 0..8 {
                    let bit = (values[i * typesize + j] >> k) & 1;
                    source[(j * 8 + k) * (shuffled / 8) + i / 8] |= bit << (i % 8);
                }
            }
        }
        source[shuffled * typesize..].copy_from_slice(&values[shuffled * typesize..]);
        let mut out = vec![0u8; values.len()];
        bit_unshuffle(&source, typesize, 3, &mut out);
        assert_eq!(out, values);
        // Format version 2 shuffled no block of other than a multiple of 8 elements.
        bit_unshuffle(&values, typesize, 2, &mut out);
        assert_eq!(out, values);
    }

    proptest::proptest! {
        /// Any bytes taken for a BloscLZ stream decode to at most the size asked for,
        /// or to an error; never a panic.
        #[test]
        fn any_bytes_as_blosclz_are_bounded(
            bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..300),
            size in 0usize..2000,
        ) {
            if let Ok(out) = blosclz(&bytes, size) {
                proptest::prop_assert!(out.len() <= size);
            }
        }
    }

    #[test]
    fn blosclz_literals_runs_and_matches_decode() {
        // "abc", a match of 6 from 3 back, one 'x' and a run of 10 more from 1 back
        // (its length in a second byte).
        let stream = [2, b'a', b'b', b'c', (4 << 5), 2, 0, b'x', (7 << 5), 1, 0];
        let out = blosclz(&stream, 100).unwrap();
        assert_eq!(out, b"abcabcabcxxxxxxxxxxx");
        // A distance past 8191: 8192 bytes, then 3 of them again from the start.
        let mut far: Vec<u8> = Vec::new();
        let literal: Vec<u8> = (0..8192u32).map(|i| (i % 251) as u8).collect();
        for run in literal.chunks(32) {
            far.push(run.len() as u8 - 1);
            far.extend(run);
        }
        far.extend([1 << 5 | 31, 255, 0, 0]);
        let out = blosclz(&far, 9000).unwrap();
        assert_eq!(&out[8192..], &literal[..3]);
        assert!(blosclz(&far, 8193).is_err());
    }

    #[test]
    fn damaged_frames_are_errors() {
        let frame = frame_of(&(0..300).collect::<Vec<u32>>(), 512);
        for cut in 0..frame.len() {
            let _ = decompress(&frame[..cut], 1200);
        }
        // Another codec's streams taken for BloscLZ's: an error or bytes, never a panic.
        let mut blosclz = frame;
        blosclz[2] &= 0x1f;
        let _ = decompress(&blosclz, 1200);
    }
}
