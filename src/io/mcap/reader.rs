//! Streaming MCAP reading: one pass from the start, memory bounded by the largest chunk,
//! so it works on files of any size and on files without a summary section (a recorder
//! that crashed). Chunks are decompressed here (zstd, lz4) rather than by the `mcap`
//! crate so that callers see each chunk's compression and sizes.

use std::collections::HashMap;
use std::io::Read;
use std::ops::ControlFlow;
use std::path::Path;
use std::sync::Arc;

use mcap::records::{MessageHeader, Record};
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

/// Reads `path` from start to end, calling `visit` for each record of interest (channels
/// that only the summary section declares included). Damage is an input error naming
/// the file and the byte offset.
pub fn scan(path: &Path, visit: impl FnMut(Event<'_>) -> Result<()>) -> Result<()> {
    match scan_inner(path, visit)? {
        None => Ok(()),
        Some(damage) => Err(Error::input(
            path,
            format!("at byte {}: {}", damage.offset, damage.problem),
        )),
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

fn scan_inner(
    path: &Path,
    mut visit: impl FnMut(Event<'_>) -> Result<()>,
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
    let mut registry = Registry::default();
    let mut decompressors = Decompressors::default();
    let mut chunk = Vec::new();
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
        let flow = match record {
            Record::Chunk { header, data } => {
                let decompressed =
                    check_chunk_size(&header.compression, data.len(), header.uncompressed_size)
                        .and_then(|size| {
                            decompressors.decompress(&header.compression, &data, size, &mut chunk)
                        });
                if let Err(e) = decompressed {
                    return damage(offset, format!("chunk (record {records}): {e}"));
                }
                if header.uncompressed_crc != 0 {
                    let computed = crc32fast::hash(&chunk);
                    if computed != header.uncompressed_crc {
                        return damage(
                            offset,
                            format!(
                                "chunk (record {records}) CRC mismatch: stored {:#010x}, \
                                 computed {computed:#010x}",
                                header.uncompressed_crc
                            ),
                        );
                    }
                }
                visit(Event::Chunk {
                    compression: &header.compression,
                    compressed: header.compressed_size,
                    uncompressed: header.uncompressed_size,
                })?;
                let mut flow = ControlFlow::Continue(());
                for inner in self::records(&chunk) {
                    let inner = match inner {
                        Ok(inner) => inner,
                        Err(e) => {
                            return damage(
                                offset,
                                format!("inside the chunk of record {records}: {e}"),
                            );
                        }
                    };
                    flow = registry.handle(inner, &mut visit);
                    if !matches!(flow, ControlFlow::Continue(())) {
                        break;
                    }
                }
                flow
            }
            other => registry.handle(other, &mut visit),
        };
        match flow {
            ControlFlow::Continue(()) => {}
            ControlFlow::Break(Stop::End) => return Ok(None),
            ControlFlow::Break(Stop::Visit(error)) => return Err(error),
            ControlFlow::Break(Stop::Damage(problem)) => return damage(offset, problem),
        }
    }
    Ok(None)
}

/// Why handling records stops early: the summary's footer, the visitor's own error, or
/// a problem of the file.
enum Stop {
    End,
    Visit(Error),
    Damage(String),
}

/// One record parsed by the `mcap` crate, whose parser can panic on some damaged
/// records (an attachment shorter than its header): the panic is a message like any
/// other parse error.
pub(super) fn parse_record(opcode: u8, data: &[u8]) -> std::result::Result<Record<'_>, String> {
    catch_decoder_panic(|| mcap::parse_record(opcode, data))?.map_err(|e| describe(&e))
}

/// The records of a run of bytes (a chunk's inside, the summary section, the file
/// after its magic), each parsed as [`parse_record`] does.
pub(super) fn records(
    bytes: &[u8],
) -> impl Iterator<Item = std::result::Result<Record<'_>, String>> {
    let mut inner = mcap::read::LinearReader::sans_magic(bytes);
    std::iter::from_fn(move || match catch_decoder_panic(|| inner.next()) {
        Ok(next) => next.map(|r| r.map_err(|e| describe(&e))),
        Err(panic) => Some(Err(panic)),
    })
    .scan(false, |failed, item| {
        // After an error the reader's position is unknown: stop there.
        if *failed {
            return None;
        }
        *failed = item.is_err();
        Some(item)
    })
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
    /// Registers schemas and channels and hands events to `visit`; breaks at the footer.
    fn handle(
        &mut self,
        record: Record<'_>,
        visit: &mut impl FnMut(Event<'_>) -> Result<()>,
    ) -> ControlFlow<Stop> {
        match self.register(record, visit) {
            Ok(()) => ControlFlow::Continue(()),
            Err(stop) => ControlFlow::Break(stop),
        }
    }

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
                let channel = self.channels.get(&header.channel_id).ok_or_else(|| {
                    Stop::Damage(format!(
                        "a message on channel {} before that channel's record",
                        header.channel_id
                    ))
                })?;
                visit(Event::Message {
                    channel,
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
