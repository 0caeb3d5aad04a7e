//! What an MCAP file holds: channels, schemas, message counts, time range, chunks. Read
//! from the summary section when the file has one with statistics, else by scanning.

use std::collections::BTreeMap;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use mcap::records::Record;
use serde::Serialize;

use super::reader::{Damage, Event, parse_record, records, scan, scan_until_damage};
use crate::error::{Error, Result, open_input};

#[derive(Debug, Default, Serialize, PartialEq)]
pub struct ChunkReport {
    pub count: u64,
    /// Chunks per compression ("" is stored uncompressed, shown as "none").
    pub compression: BTreeMap<String, u64>,
    pub compressed_bytes: u64,
    pub uncompressed_bytes: u64,
}

#[derive(Debug, Serialize, PartialEq)]
pub struct ChannelReport {
    pub id: u16,
    pub topic: String,
    pub message_encoding: String,
    pub schema: String,
    pub schema_encoding: String,
    pub message_count: u64,
    /// Why this channel's messages cannot be decoded (unknown encoding, a schema that
    /// does not parse), when they cannot.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub undecodable: Option<String>,
}

/// Whether messages of `channel` can be decoded: `None`, or why not.
fn undecodable(channel: &super::ChannelInfo) -> Option<String> {
    super::MessageDecoder::for_channel(channel).err()
}

#[derive(Debug, Serialize, PartialEq)]
pub struct McapReport {
    pub schema_version: u32,
    pub file: String,
    pub bytes: u64,
    pub profile: String,
    pub library: String,
    /// "summary" when read from the summary section, "scan" when every record was read.
    pub source: &'static str,
    pub message_count: u64,
    /// Log times in nanoseconds; absent when the file has no messages.
    pub start_time: Option<u64>,
    pub end_time: Option<u64>,
    pub chunks: ChunkReport,
    pub channels: Vec<ChannelReport>,
    pub attachments: u64,
    pub metadata: u64,
    /// Where the file is damaged, when inspected with damage allowed; the report covers
    /// what comes before it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub damage: Option<String>,
}

fn compression_name(compression: &str) -> String {
    if compression.is_empty() {
        "none".to_string()
    } else {
        compression.to_string()
    }
}

/// Where a report comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// Every record, chunk CRCs checked: slow, for files whose summary is suspect.
    Scan,
    /// The summary section when there is one, and the data section's CRC checked (one
    /// read of the file), so that the report never vouches for damaged data.
    VerifiedSummary,
    /// The summary section only: for callers that scan the chunks (and their CRCs)
    /// afterwards anyway.
    Summary,
}

/// Reports on `path` from `source` (a file without a summary is scanned whatever the
/// source). With `allow_damage`, a damaged file reports what precedes the damage
/// instead of failing.
pub fn inspect(path: &Path, source: Source, allow_damage: bool) -> Result<McapReport> {
    let bytes = open_input(path)?
        .metadata()
        .map_err(|e| Error::io(format!("reading {}", path.display()), e))?
        .len();
    let (profile, library) = read_header(path)?;
    let summary = if source != Source::Scan {
        read_summary(path, bytes, source == Source::VerifiedSummary)?
    } else {
        None
    };
    let mut report = match summary {
        Some(report) => report,
        None => scan_report(path, allow_damage)?,
    };
    report.file = path.display().to_string();
    report.bytes = bytes;
    report.profile = profile;
    report.library = library;
    Ok(report)
}

fn empty_report(source: &'static str) -> McapReport {
    McapReport {
        schema_version: 1,
        file: String::new(),
        bytes: 0,
        profile: String::new(),
        library: String::new(),
        source,
        message_count: 0,
        start_time: None,
        end_time: None,
        chunks: ChunkReport::default(),
        channels: Vec::new(),
        attachments: 0,
        metadata: 0,
        damage: None,
    }
}

/// The profile and library of the header record, the file's first.
fn read_header(path: &Path) -> Result<(String, String)> {
    let mut start = Vec::new();
    open_input(path)?
        .take(1 << 16)
        .read_to_end(&mut start)
        .map_err(|e| Error::io(format!("reading {}", path.display()), e))?;
    if !start.starts_with(mcap::MAGIC) {
        return Err(Error::input(path, "not an MCAP file (bad magic bytes)"));
    }
    match records(&start[mcap::MAGIC.len()..]).next() {
        Some(Ok(Record::Header(header))) => Ok((header.profile, header.library)),
        _ => Err(Error::input(
            path,
            "the file does not start with a header record",
        )),
    }
}

const FOOTER_RECORD: u64 = 1 + 8 + 20;

/// The Data End record (opcode, length 4, CRC) that closes the data section.
const DATA_END_RECORD: u64 = 1 + 8 + 4;

/// Checks the data section against the CRC its Data End record holds (when the writer
/// stored one): the summary describes the file without reading its chunks, so this is
/// what keeps a summary-based report from vouching for damaged data. CRC-32 runs at
/// several GB/s, so it costs one read of the file.
fn check_data_section_crc(path: &Path, file: &mut std::fs::File, summary_start: u64) -> Result<()> {
    let io = |e| Error::io(format!("reading {}", path.display()), e);
    let Some(data_end) = summary_start.checked_sub(DATA_END_RECORD) else {
        return Ok(());
    };
    let mut record = [0u8; DATA_END_RECORD as usize];
    file.seek(SeekFrom::Start(data_end)).map_err(io)?;
    file.read_exact(&mut record).map_err(io)?;
    let length = u64::from_le_bytes(record[1..9].try_into().expect("8 bytes"));
    let stored = u32::from_le_bytes(record[9..13].try_into().expect("4 bytes"));
    if record[0] != mcap::records::op::DATA_END || length != 4 || stored == 0 {
        return Ok(());
    }
    file.seek(SeekFrom::Start(0)).map_err(io)?;
    let mut hasher = crc32fast::Hasher::new();
    let mut buffer = vec![0u8; 1 << 20];
    let mut left = data_end;
    while left > 0 {
        let n = buffer
            .len()
            .min(usize::try_from(left).unwrap_or(usize::MAX));
        file.read_exact(&mut buffer[..n]).map_err(io)?;
        hasher.update(&buffer[..n]);
        left -= n as u64;
    }
    let computed = hasher.finalize();
    if computed != stored {
        return Err(Error::input(
            path,
            format!(
                "the data section fails its CRC (stored {stored:#010x}, computed \
                 {computed:#010x}): the file is damaged; `imitate inspect --scan` names the \
                 damaged chunk"
            ),
        ));
    }
    Ok(())
}

/// The report from the summary section, or `None` when there is none with statistics.
fn read_summary(path: &Path, bytes: u64, verify: bool) -> Result<Option<McapReport>> {
    let magic = mcap::MAGIC.len() as u64;
    if bytes < 2 * magic + FOOTER_RECORD {
        return Ok(None);
    }
    let io = |e| Error::io(format!("reading {}", path.display()), e);
    let mut file = open_input(path)?;
    let footer_at = bytes - magic - FOOTER_RECORD;
    let mut tail = vec![0u8; (FOOTER_RECORD + magic) as usize];
    file.seek(SeekFrom::Start(footer_at)).map_err(io)?;
    file.read_exact(&mut tail).map_err(io)?;
    if tail[0] != mcap::records::op::FOOTER || &tail[FOOTER_RECORD as usize..] != mcap::MAGIC {
        return Ok(None);
    }
    let Ok(Record::Footer(footer)) = parse_record(tail[0], &tail[9..29]) else {
        return Ok(None);
    };
    if footer.summary_start == 0 || footer.summary_start >= footer_at {
        return Ok(None);
    }
    if verify {
        check_data_section_crc(path, &mut file, footer.summary_start)?;
    }
    let end = match footer.summary_offset_start {
        0 => footer_at,
        offset => offset.min(footer_at),
    };
    if end <= footer.summary_start {
        return Ok(None); // a footer that contradicts itself: scan instead
    }
    let mut summary = vec![0u8; (end - footer.summary_start) as usize];
    file.seek(SeekFrom::Start(footer.summary_start))
        .map_err(io)?;
    file.read_exact(&mut summary).map_err(io)?;

    let mut report = empty_report("summary");
    let mut schemas = BTreeMap::new();
    let mut channels = Vec::new();
    let mut statistics = None;
    for record in records(&summary) {
        let Ok(record) = record else {
            return Ok(None);
        };
        match record {
            Record::Schema { header, data } => {
                schemas.insert(header.id, (header.name, header.encoding, data.into_owned()));
            }
            Record::Channel(channel) => channels.push(channel),
            Record::Statistics(stats) => statistics = Some(stats),
            Record::ChunkIndex(index) => {
                report.chunks.count += 1;
                *report
                    .chunks
                    .compression
                    .entry(compression_name(&index.compression))
                    .or_default() += 1;
                report.chunks.compressed_bytes =
                    (report.chunks.compressed_bytes).saturating_add(index.compressed_size);
                report.chunks.uncompressed_bytes =
                    (report.chunks.uncompressed_bytes).saturating_add(index.uncompressed_size);
            }
            _ => {}
        }
    }
    let Some(stats) = statistics else {
        return Ok(None);
    };
    report.message_count = stats.message_count;
    if stats.message_count > 0 {
        report.start_time = Some(stats.message_start_time);
        report.end_time = Some(stats.message_end_time);
    }
    report.attachments = stats.attachment_count.into();
    report.metadata = stats.metadata_count.into();
    report.channels = channels
        .into_iter()
        .map(|c| {
            let (schema, schema_encoding, data) =
                schemas.get(&c.schema_id).cloned().unwrap_or_default();
            let info = super::ChannelInfo {
                id: c.id,
                topic: c.topic.clone(),
                message_encoding: c.message_encoding.clone(),
                schema: (c.schema_id != 0).then(|| {
                    std::sync::Arc::new(super::reader::SchemaInfo {
                        id: c.schema_id,
                        name: schema.clone(),
                        encoding: schema_encoding.clone(),
                        data,
                    })
                }),
                metadata: Default::default(),
            };
            ChannelReport {
                undecodable: undecodable(&info),
                id: c.id,
                message_count: stats
                    .channel_message_counts
                    .get(&c.id)
                    .copied()
                    .unwrap_or(0),
                topic: c.topic,
                message_encoding: c.message_encoding,
                schema,
                schema_encoding,
            }
        })
        .collect();
    report.channels.sort_by_key(|c| c.id);
    Ok(Some(report))
}

/// The report from reading every record.
fn scan_report(path: &Path, allow_damage: bool) -> Result<McapReport> {
    let mut report = empty_report("scan");
    let mut counts: BTreeMap<u16, u64> = BTreeMap::new();
    let visit = |event: Event<'_>| {
        match event {
            Event::Channel(channel) => {
                report.channels.push(ChannelReport {
                    id: channel.id,
                    topic: channel.topic.clone(),
                    message_encoding: channel.message_encoding.clone(),
                    schema: channel.schema_name().to_string(),
                    schema_encoding: channel
                        .schema
                        .as_ref()
                        .map(|s| s.encoding.clone())
                        .unwrap_or_default(),
                    message_count: 0,
                    undecodable: undecodable(channel),
                });
            }
            Event::Message {
                channel, header, ..
            } => {
                *counts.entry(channel.id).or_default() += 1;
                report.message_count += 1;
                let t = header.log_time;
                report.start_time = Some(report.start_time.map_or(t, |s| s.min(t)));
                report.end_time = Some(report.end_time.map_or(t, |e| e.max(t)));
            }
            Event::Chunk {
                compression,
                compressed,
                uncompressed,
            } => {
                report.chunks.count += 1;
                *report
                    .chunks
                    .compression
                    .entry(compression_name(compression))
                    .or_default() += 1;
                report.chunks.compressed_bytes += compressed;
                report.chunks.uncompressed_bytes += uncompressed;
            }
            Event::Attachment { .. } => report.attachments += 1,
            Event::Metadata { .. } => report.metadata += 1,
            Event::Header { .. } => {}
        }
        Ok(())
    };
    if allow_damage {
        let damage = scan_until_damage(path, visit)?;
        report.damage = damage.map(|d| describe_damage(&d));
    } else {
        scan(path, visit)?;
    }
    for channel in &mut report.channels {
        channel.message_count = counts.get(&channel.id).copied().unwrap_or(0);
    }
    report.channels.sort_by_key(|c| c.id);
    Ok(report)
}

/// One line about damage: where, what, and how much of the file lies beyond it.
pub fn describe_damage(damage: &Damage) -> String {
    format!(
        "at byte {}: {}; the last {} of {} bytes were not read",
        damage.offset,
        damage.problem,
        damage.file_bytes.saturating_sub(damage.offset),
        damage.file_bytes
    )
}
