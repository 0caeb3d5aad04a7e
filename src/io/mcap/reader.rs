//! Streaming MCAP reading: one pass from the start, memory bounded by the largest chunk,
//! so it works on files of any size and on files without a summary section (a recorder
//! that crashed). Chunks are decompressed here (zstd, lz4) rather than by the `mcap`
//! crate so that callers see each chunk's compression and sizes.

use std::borrow::Cow;
use std::collections::HashMap;
use std::io::Read;
use std::path::Path;
use std::sync::Arc;

pub use mcap::records::MessageHeader;
use mcap::records::Record;
use rayon::prelude::*;

use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};

use crate::error::{Error, Result, catch_decoder_panic, open_input};

#[derive(Debug)]
pub struct SchemaInfo {
    pub id: u16,
    pub name: String,
    pub encoding: String,
    pub data: Vec<u8>,
}

#[derive(Debug)]
pub struct ChannelInfo {
    pub id: u16,
    pub topic: String,
    pub message_encoding: String,
    /// `None` for schemaless channels (schema id 0).
    pub schema: Option<Arc<SchemaInfo>>,
    pub metadata: std::collections::BTreeMap<String, String>,
}

impl ChannelInfo {
    pub fn schema_name(&self) -> &str {
        self.schema.as_ref().map_or("", |s| s.name.as_str())
    }
}

/// What a pass over the file meets, in file order.
pub enum Event<'a> {
    Header {
        profile: &'a str,
        library: &'a str,
    },
    Channel(&'a Arc<ChannelInfo>),
    Message {
        channel: &'a Arc<ChannelInfo>,
        header: &'a MessageHeader,
        data: &'a [u8],
    },
    Chunk {
        compression: &'a str,
        compressed: u64,
        uncompressed: u64,
    },
    Attachment {
        name: &'a str,
    },
    Metadata {
        name: &'a str,
    },
}

/// Schemas and channels seen so far: messages refer to them by id.
#[derive(Default)]
struct Registry {
    schemas: HashMap<u16, Arc<SchemaInfo>>,
    channels: HashMap<u16, Arc<ChannelInfo>>,
}

/// The most a chunk may decompress to. Real recorders write chunks of kilobytes to a
/// few megabytes; a header claiming more than this is damage, refused before any
/// allocation (a claim of 2^50 bytes would otherwise abort the process).
pub const CHUNK_MEMORY_BUDGET: u64 = 4 << 30;

/// Checks a chunk's claimed uncompressed size against the budget and, for a stored
/// chunk, against the bytes it holds.
fn check_chunk_size(
    compression: &str,
    compressed: usize,
    claimed: u64,
) -> std::result::Result<usize, String> {
    if claimed > CHUNK_MEMORY_BUDGET {
        return Err(format!(
            "its header claims {claimed} uncompressed bytes (from {compressed} compressed), \
             more than the {} GiB a chunk may hold",
            CHUNK_MEMORY_BUDGET >> 30
        ));
    }
    let size =
        usize::try_from(claimed).map_err(|_| format!("{claimed} bytes do not fit in memory"))?;
    if compression.is_empty() && size != compressed {
        return Err(format!(
            "an uncompressed chunk of {compressed} bytes whose header says {size}"
        ));
    }
    Ok(size)
}

/// A decompressor per compression, reused across chunks.
#[derive(Default)]
struct Decompressors {
    zstd: Option<zstd::bulk::Decompressor<'static>>,
}

impl Decompressors {
    fn decompress(
        &mut self,
        compression: &str,
        data: &[u8],
        size: usize,
        out: &mut Vec<u8>,
    ) -> std::result::Result<(), String> {
        out.clear();
        out.try_reserve_exact(size)
            .map_err(|_| format!("cannot hold its {size} uncompressed bytes in memory"))?;
        match compression {
            "" => out.extend_from_slice(data),
            "zstd" => {
                let zstd = match &mut self.zstd {
                    Some(z) => z,
                    None => self
                        .zstd
                        .insert(zstd::bulk::Decompressor::new().map_err(|e| e.to_string())?),
                };
                zstd.decompress_to_buffer(data, out)
                    .map_err(|e| format!("zstd: {e}"))?;
            }
            "lz4" => {
                // `take` keeps a lying header from growing the buffer past its claim.
                lz4::Decoder::new(data)
                    .and_then(|d| d.take(size as u64 + 1).read_to_end(out))
                    .map_err(|e| format!("lz4: {e}"))?;
            }
            other => return Err(format!("unsupported chunk compression '{other}'")),
        }
        if out.len() != size {
            return Err(format!(
                "chunk decompresses to {} bytes, its header says {size}",
                out.len()
            ));
        }
        Ok(())
    }
}

/// Where and how a file is damaged (cut short, corrupt chunk, ...).
#[derive(Debug, Clone, PartialEq)]
pub struct Damage {
    /// Byte offset of the damaged record (approximately: where reading stopped).
    pub offset: u64,
    pub file_bytes: u64,
    pub problem: String,
}

impl Damage {
    /// The input error for damage in `path`.
    pub fn into_error(self, path: &Path) -> Error {
        Error::input(path, format!("at byte {}: {}", self.offset, self.problem))
    }
}

/// Reads `path` from start to end, calling `visit` for each record of interest (channels
/// that only the summary section declares included). Damage is an input error naming
/// the file and the byte offset.
pub fn scan(path: &Path, visit: impl FnMut(Event<'_>) -> Result<()>) -> Result<()> {
    match scan_inner(path, visit)? {
        None => Ok(()),
        Some(damage) => Err(damage.into_error(path)),
    }
}

/// As [`scan`], but damage ends the pass quietly: every record before it was visited
/// (whole chunks only), and the damage is returned for the caller to report.
pub fn scan_until_damage(
    path: &Path,
    visit: impl FnMut(Event<'_>) -> Result<()>,
) -> Result<Option<Damage>> {
    scan_inner(path, visit)
}

/// Where a top-level record lies: for damage reports.
#[derive(Debug, Clone, Copy)]
struct Position {
    /// Bytes read so far.
    offset: u64,
    /// Records read so far, this one included.
    record: u64,
}

/// Reads `path` from start to end, handing each top-level record to `handle` in file
/// order, with memory bounded by the largest record. Stops at the end of the file, at
/// damage, or where `handle` breaks.
fn for_each_record(
    path: &Path,
    mut handle: impl FnMut(Record<'_>, Position) -> std::result::Result<(), Stop>,
) -> Result<Option<Damage>> {
    let mut file = open_input(path)?;
    let file_bytes = file
        .metadata()
        .map_err(|e| Error::io(format!("reading {}", path.display()), e))?
        .len();
    if file_bytes < mcap::MAGIC.len() as u64 {
        return Err(Error::input(
            path,
            format!("is not an MCAP file: {file_bytes} bytes, shorter than the magic"),
        ));
    }
    // No record can be longer than the file; the limit also keeps the `mcap` crate from
    // overflowing on the garbage lengths of a cut-off file.
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_emit_chunks(true)
            .with_skip_end_magic(true)
            .with_record_length_limit(usize::try_from(file_bytes).unwrap_or(usize::MAX)),
    );
    let mut offset: u64 = 0;
    let mut records = 0u64;
    let damage = |offset: u64, problem: String| {
        Ok(Some(Damage {
            offset,
            file_bytes,
            problem,
        }))
    };
    loop {
        let event = match catch_decoder_panic(|| reader.next_event()) {
            Ok(None) => break,
            Ok(Some(Ok(event))) => event,
            Ok(Some(Err(e))) => {
                return damage(
                    offset,
                    format!(
                        "{} (after {records} records; the file may be cut short or not MCAP)",
                        describe(&e)
                    ),
                );
            }
            Err(panic) => {
                return damage(offset, format!("record {}: {panic}", records + 1));
            }
        };
        let record = match event {
            LinearReadEvent::ReadRequest(need) => {
                let read = file
                    .read(reader.insert(need))
                    .map_err(|e| Error::io(format!("reading {}", path.display()), e))?;
                reader.notify_read(read);
                offset += read as u64;
                continue;
            }
            LinearReadEvent::Record { opcode, data } => {
                records += 1;
                match parse_record(opcode, data) {
                    Ok(record) => record,
                    Err(e) => return damage(offset, format!("record {records}: {e}")),
                }
            }
        };
        let at = Position {
            offset,
            record: records,
        };
        match handle(record, at) {
            Ok(()) => {}
            Err(Stop::End) => return Ok(None),
            Err(Stop::Visit(error)) => return Err(error),
            Err(Stop::Damage(problem)) => return damage(offset, problem),
            Err(Stop::DamageAt(at, problem)) => return damage(at, problem),
        }
    }
    Ok(None)
}

/// A chunk's bytes, decompressed and checked against its CRC.
fn unpack_chunk(
    header: &mcap::records::ChunkHeader,
    data: &[u8],
    decompressors: &mut Decompressors,
    out: &mut Vec<u8>,
) -> std::result::Result<(), String> {
    let size = check_chunk_size(&header.compression, data.len(), header.uncompressed_size)?;
    decompressors.decompress(&header.compression, data, size, out)?;
    if header.uncompressed_crc != 0 {
        let computed = crc32fast::hash(out);
        if computed != header.uncompressed_crc {
            return Err(format!(
                "CRC mismatch: stored {:#010x}, computed {computed:#010x}",
                header.uncompressed_crc
            ));
        }
    }
    Ok(())
}

fn scan_inner(
    path: &Path,
    mut visit: impl FnMut(Event<'_>) -> Result<()>,
) -> Result<Option<Damage>> {
    let mut registry = Registry::default();
    let mut decompressors = Decompressors::default();
    let mut chunk = Vec::new();
    for_each_record(path, |record, at| match record {
        Record::Chunk { header, data } => {
            unpack_chunk(&header, &data, &mut decompressors, &mut chunk)
                .map_err(|e| Stop::Damage(format!("chunk (record {}): {e}", at.record)))?;
            let chunk_event = Event::Chunk {
                compression: &header.compression,
                compressed: header.compressed_size,
                uncompressed: header.uncompressed_size,
            };
            visit(chunk_event).map_err(Stop::Visit)?;
            for inner in self::records(&chunk) {
                let inner = inner.map_err(|e| {
                    Stop::Damage(format!("inside the chunk of record {}: {e}", at.record))
                })?;
                registry.register(inner, &mut visit)?;
            }
            Ok(())
        }
        other => registry.register(other, &mut visit),
    })
}

/// How many chunks `scan_messages` holds at once per thread: enough to keep every
/// thread busy while the reading thread fills the next batch.
const CHUNKS_PER_THREAD: usize = 2;

/// What the reading thread of `scan_messages` hands on, in file order.
enum Sent {
    /// A chunk as stored (compressed).
    Chunk {
        header: mcap::records::ChunkHeader,
        data: Vec<u8>,
        at: Position,
    },
    /// A schema, channel or message outside any chunk.
    Loose(Record<'static>, Position),
}

/// As [`scan_until_damage`], for messages only, on all threads: one thread reads the
/// file while batches of a few chunks per thread are decompressed and their messages
/// turned into `T` by `prepare` in parallel; `consume` then gets them one by one in
/// file order, so the result is the sequential pass's whatever the number of threads.
/// Memory is bounded by two batches. `prepare` returning `None` skips a message; the
/// first error in file order ends the pass, as in the sequential one.
pub fn scan_messages<T: Send>(
    path: &Path,
    prepare: impl Fn(&ChannelInfo, &MessageHeader, &[u8]) -> Result<Option<T>> + Sync,
    mut consume: impl FnMut(T) -> Result<()>,
) -> Result<Option<Damage>> {
    let batch_size = CHUNKS_PER_THREAD * rayon::current_num_threads().max(1);
    std::thread::scope(|scope| {
        let (sender, receiver) = std::sync::mpsc::sync_channel::<Sent>(batch_size);
        let reader = scope.spawn(move || {
            for_each_record(path, |record, at| {
                let read = match record {
                    Record::Chunk { header, data } => Sent::Chunk {
                        header,
                        data: data.into_owned(),
                        at,
                    },
                    Record::Message { .. } | Record::Channel(_) | Record::Schema { .. } => {
                        Sent::Loose(record.into_owned(), at)
                    }
                    Record::Footer(_) => return Err(Stop::End),
                    // Indexes and the rest say nothing about messages.
                    _ => return Ok(()),
                };
                // A closed channel: the consuming side stopped at an error of its own.
                sender.send(read).map_err(|_| Stop::End)
            })
        });
        let mut registry = Registry::default();
        let mut unpacked: Vec<Vec<u8>> = Vec::new();
        let mut batch = Vec::with_capacity(batch_size);
        let mut stop = None;
        for read in receiver.iter() {
            let loose = match read {
                Sent::Chunk { header, data, at } => {
                    batch.push((header, data, at));
                    None
                }
                Sent::Loose(record, at) => Some((record, at)),
            };
            if batch.len() >= batch_size || loose.is_some() {
                let batch_stop = process_batch(
                    &mut batch,
                    &mut unpacked,
                    &mut registry,
                    &prepare,
                    &mut consume,
                );
                if let Err(e) = batch_stop {
                    stop = Some(e);
                    break;
                }
            }
            if let Some((record, at)) = loose {
                let done = match record {
                    Record::Message { header, data } => registry
                        .channel_of(&header)
                        .map_err(|e| Stop::DamageAt(at.offset, e))
                        .and_then(|channel| {
                            match prepare(&channel, &header, &data).map_err(Stop::Visit)? {
                                Some(item) => consume(item).map_err(Stop::Visit),
                                None => Ok(()),
                            }
                        }),
                    other => registry
                        .register(other, &mut |_| Ok(()))
                        .map_err(|stop| match stop {
                            Stop::Damage(e) => Stop::DamageAt(at.offset, e),
                            other => other,
                        }),
                };
                if let Err(e) = done {
                    stop = Some(e);
                    break;
                }
            }
        }
        if stop.is_none() {
            // What the reader sent before it stopped lies before where it stopped.
            stop = process_batch(
                &mut batch,
                &mut unpacked,
                &mut registry,
                &prepare,
                &mut consume,
            )
            .err();
        }
        drop(receiver);
        let read = reader
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))?;
        match stop {
            None | Some(Stop::End | Stop::Damage(_)) => Ok(read),
            Some(Stop::Visit(error)) => Err(error),
            Some(Stop::DamageAt(offset, problem)) => Ok(Some(Damage {
                offset,
                file_bytes: std::fs::metadata(path).map_or(offset, |m| m.len()),
                problem,
            })),
        }
    })
}

/// Decompresses a batch of chunks and prepares their messages on all threads, then
/// registers their channels and consumes the messages in file order; damage is
/// reported at its chunk's offset. Empties the batch.
fn process_batch<T: Send>(
    batch: &mut Vec<(mcap::records::ChunkHeader, Vec<u8>, Position)>,
    unpacked: &mut Vec<Vec<u8>>,
    registry: &mut Registry,
    prepare: &(impl Fn(&ChannelInfo, &MessageHeader, &[u8]) -> Result<Option<T>> + Sync),
    consume: &mut impl FnMut(T) -> Result<()>,
) -> std::result::Result<(), Stop> {
    // Buffers are kept from batch to batch rather than allocated per chunk.
    unpacked.resize_with(unpacked.len().max(batch.len()), Vec::new);
    let outcome: Vec<std::result::Result<(), String>> = batch
        .par_iter()
        .zip(unpacked.par_iter_mut())
        .map_init(
            Decompressors::default,
            |decompressors, ((header, data, _), out)| {
                unpack_chunk(header, data, decompressors, out)
            },
        )
        .collect();
    // In file order: register channels and gather messages, up to the first damage.
    let mut messages: Vec<(Arc<ChannelInfo>, MessageHeader, Cow<'_, [u8]>)> = Vec::new();
    let mut stop = None;
    'chunks: for (((_, _, at), bytes), outcome) in batch.iter().zip(unpacked.iter()).zip(outcome) {
        if let Err(e) = outcome {
            let problem = format!("chunk (record {}): {e}", at.record);
            stop = Some(Stop::DamageAt(at.offset, problem));
            break;
        }
        for inner in self::records(bytes) {
            let found = inner
                .map_err(|e| format!("inside the chunk of record {}: {e}", at.record))
                .and_then(|inner| match inner {
                    Record::Message { header, data } => {
                        messages.push((registry.channel_of(&header)?, header, data));
                        Ok(())
                    }
                    other => match registry.register(other, &mut |_| Ok(())) {
                        Err(Stop::Damage(e)) => Err(e),
                        _ => Ok(()),
                    },
                });
            if let Err(e) = found {
                stop = Some(Stop::DamageAt(at.offset, e));
                break 'chunks;
            }
        }
    }
    let prepared: Vec<Result<Option<T>>> = messages
        .par_iter()
        .map(|(channel, header, data)| prepare(channel, header, data))
        .collect();
    drop(messages);
    batch.clear();
    for item in prepared {
        if let Some(item) = item.map_err(Stop::Visit)? {
            consume(item).map_err(Stop::Visit)?;
        }
    }
    stop.map_or(Ok(()), Err)
}

/// Why handling records stops early: the summary's footer, the visitor's own error, or
/// a problem of the file.
enum Stop {
    End,
    Visit(Error),
    /// Damage where reading stands.
    Damage(String),
    /// Damage at an earlier byte offset (a chunk of a batch).
    DamageAt(u64, String),
}

/// One record parsed by the `mcap` crate, whose parser can panic on some damaged
/// records (an attachment shorter than its header): the panic is a message like any
/// other parse error.
pub(super) fn parse_record(opcode: u8, data: &[u8]) -> std::result::Result<Record<'_>, String> {
    catch_decoder_panic(|| mcap::parse_record(opcode, data))?.map_err(|e| describe(&e))
}

/// The records of a run of bytes (a chunk's inside, the summary section, the file
/// after its magic), each parsed as [`parse_record`] does and borrowing from `bytes`
/// (the `mcap` crate's own iterator copies every message). After an error the rest is
/// not read: where the next record starts is unknown.
pub(super) fn records(
    bytes: &[u8],
) -> impl Iterator<Item = std::result::Result<Record<'_>, String>> {
    let mut rest = bytes;
    std::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        let record = split_record(rest).and_then(|(opcode, body, after)| {
            rest = after;
            parse_record(opcode, body)
        });
        if record.is_err() {
            rest = &[];
        }
        Some(record)
    })
}

/// The opcode, body and what follows of the record at the start of `bytes`.
fn split_record(bytes: &[u8]) -> std::result::Result<(u8, &[u8], &[u8]), String> {
    let Some((&opcode, rest)) = bytes.split_first() else {
        return Err("no record where one was expected".into());
    };
    let Some((length, rest)) = rest.split_first_chunk::<8>() else {
        return Err(format!(
            "a {} record is cut short in its length ({} of 8 bytes)",
            record_name(opcode),
            rest.len()
        ));
    };
    let length = u64::from_le_bytes(*length);
    match usize::try_from(length) {
        Ok(length) if length <= rest.len() => {
            let (body, after) = rest.split_at(length);
            Ok((opcode, body, after))
        }
        _ => Err(format!(
            "a {} record claims {length} bytes, more than the {} that follow",
            record_name(opcode),
            rest.len()
        )),
    }
}

fn describe(error: &mcap::McapError) -> String {
    match error {
        mcap::McapError::UnexpectedEof | mcap::McapError::UnexpectedEoc => {
            "the file ends in the middle of a record".to_string()
        }
        mcap::McapError::BadMagic => "not an MCAP file (bad magic bytes)".to_string(),
        mcap::McapError::RecordTooLarge { opcode, len } => format!(
            "a {} record claims {len} bytes, more than the file holds",
            record_name(*opcode)
        ),
        other => other.to_string(),
    }
}

fn record_name(opcode: u8) -> String {
    use mcap::records::op;
    match opcode {
        op::HEADER => "header".into(),
        op::SCHEMA => "schema".into(),
        op::CHANNEL => "channel".into(),
        op::MESSAGE => "message".into(),
        op::CHUNK => "chunk".into(),
        op::ATTACHMENT => "attachment".into(),
        op::METADATA => "metadata".into(),
        other => format!("opcode {other:#04x}"),
    }
}

impl Registry {
    /// The channel a message is on, which must have appeared before it.
    fn channel_of(&self, header: &MessageHeader) -> std::result::Result<Arc<ChannelInfo>, String> {
        self.channels
            .get(&header.channel_id)
            .cloned()
            .ok_or_else(|| {
                format!(
                    "a message on channel {} before that channel's record",
                    header.channel_id
                )
            })
    }

    /// Registers schemas and channels and hands events to `visit`; stops at the footer.
    fn register(
        &mut self,
        record: Record<'_>,
        visit: &mut impl FnMut(Event<'_>) -> Result<()>,
    ) -> std::result::Result<(), Stop> {
        let mut visit = |event: Event<'_>| visit(event).map_err(Stop::Visit);
        match record {
            Record::Header(header) => visit(Event::Header {
                profile: &header.profile,
                library: &header.library,
            })?,
            Record::Schema { header, data } => {
                self.schemas.entry(header.id).or_insert_with(|| {
                    Arc::new(SchemaInfo {
                        id: header.id,
                        name: header.name,
                        encoding: header.encoding,
                        data: data.into_owned(),
                    })
                });
            }
            Record::Channel(channel) => {
                if self.channels.contains_key(&channel.id) {
                    return Ok(());
                }
                let schema = match channel.schema_id {
                    0 => None,
                    id => Some(self.schemas.get(&id).cloned().ok_or_else(|| {
                        Stop::Damage(format!(
                            "channel {} ('{}') refers to schema {id}, which has not appeared",
                            channel.id, channel.topic
                        ))
                    })?),
                };
                let info = Arc::new(ChannelInfo {
                    id: channel.id,
                    topic: channel.topic,
                    message_encoding: channel.message_encoding,
                    schema,
                    metadata: channel.metadata,
                });
                visit(Event::Channel(&info))?;
                self.channels.insert(info.id, info);
            }
            Record::Message { header, data } => {
                let channel = self.channel_of(&header).map_err(Stop::Damage)?;
                visit(Event::Message {
                    channel: &channel,
                    header: &header,
                    data: &data,
                })?;
            }
            Record::Attachment { header, .. } => visit(Event::Attachment { name: &header.name })?,
            Record::Metadata(metadata) => visit(Event::Metadata {
                name: &metadata.name,
            })?,
            Record::Footer(_) => return Err(Stop::End),
            _ => {}
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::mcap::writer::write_log;

    /// A log of several 1 MiB chunks on two topics, messages of incompressible bytes.
    fn several_chunks(path: &Path) {
        write_log(path, |log| {
            let a = log.raw_channel("/a", "A", "", b"", "raw")?;
            let b = log.raw_channel("/b", "B", "", b"", "raw")?;
            let mut state = 7u64;
            for i in 0..120u64 {
                let data: Vec<u8> = (0..30_000)
                    .map(|_| {
                        state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
                        (state >> 56) as u8
                    })
                    .collect();
                log.write_raw(if i % 3 == 0 { b } else { a }, i * 1000, &data)?;
            }
            Ok(())
        })
        .unwrap();
    }

    type Seen = Vec<(String, u32, u64, u32)>;

    fn sequential(path: &Path) -> (Seen, Option<Damage>) {
        let mut seen = Vec::new();
        let damage = scan_until_damage(path, |event| {
            if let Event::Message {
                channel,
                header,
                data,
            } = event
            {
                let crc = crc32fast::hash(data);
                seen.push((channel.topic.clone(), header.sequence, header.log_time, crc));
            }
            Ok(())
        })
        .unwrap();
        (seen, damage)
    }

    fn parallel(path: &Path, threads: usize) -> (Seen, Option<Damage>) {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut seen = Vec::new();
        let damage = pool
            .install(|| {
                scan_messages(
                    path,
                    |channel, header, data| {
                        let crc = crc32fast::hash(data);
                        Ok(Some((
                            channel.topic.clone(),
                            header.sequence,
                            header.log_time,
                            crc,
                        )))
                    },
                    |item| {
                        seen.push(item);
                        Ok(())
                    },
                )
            })
            .unwrap();
        (seen, damage)
    }

    #[test]
    fn the_parallel_pass_sees_what_the_sequential_one_sees() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.mcap");
        several_chunks(&path);
        let (seen, damage) = sequential(&path);
        assert!(damage.is_none());
        assert_eq!(seen.len(), 120);
        for threads in [1, 2, 3, 8] {
            let (found, damage) = parallel(&path, threads);
            assert!(damage.is_none());
            assert_eq!(found, seen, "{threads} threads");
        }
    }

    #[test]
    fn damage_in_a_middle_chunk_stops_both_passes_at_the_same_place() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.mcap");
        several_chunks(&path);
        let mut bytes = std::fs::read(&path).unwrap();
        // Somewhere inside the second half of the file's chunks.
        let at = bytes.len() / 2;
        for b in &mut bytes[at..at + 64] {
            *b ^= 0x5a;
        }
        std::fs::write(&path, &bytes).unwrap();
        let (seen, damage) = sequential(&path);
        let damage = damage.expect("the flipped bytes are damage");
        assert!(!seen.is_empty() && seen.len() < 120);
        for threads in [1, 2, 8] {
            let (found, found_damage) = parallel(&path, threads);
            assert_eq!(found, seen, "{threads} threads");
            assert_eq!(found_damage.as_ref(), Some(&damage), "{threads} threads");
        }
    }

    #[test]
    fn an_error_of_prepare_ends_the_pass_in_file_order() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.mcap");
        several_chunks(&path);
        let mut consumed = 0;
        let error = scan_messages(
            &path,
            |_, header, _| match header.log_time {
                50_000 | 90_000 => Err(Error::Failed(format!("bad {}", header.log_time))),
                _ => Ok(Some(())),
            },
            |()| {
                consumed += 1;
                Ok(())
            },
        )
        .unwrap_err();
        assert!(error.to_string().contains("bad 50000"), "{error}");
        assert_eq!(consumed, 50);
    }
}
