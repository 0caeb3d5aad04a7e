//! What an MCAP file holds: channels, schemas, message counts, time range, chunks. Read
//! from the summary section when the file has one with statistics, else by scanning.

use std::collections::BTreeMap;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use mcap::records::Record;
use serde::Serialize;

use super::reader::{Damage, Event, scan, scan_until_damage};
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

/// Reports on `path`, from its summary section when `use_summary` and the file has one
/// (scanning gives the same report, slower; it is for files whose summary is suspect).
/// With `allow_damage`, a damaged file reports what precedes the damage instead of failing.
pub fn inspect(path: &Path, use_summary: bool, allow_damage: bool) -> Result<McapReport> {
    let bytes = open_input(path)?
        .metadata()
        .map_err(|e| Error::io(format!("reading {}", path.display()), e))?
        .len();
    let (profile, library) = read_header(path)?;
    let summary = if use_summary {
        read_summary(path, bytes)?
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
    match mcap::read::LinearReader::sans_magic(&start[mcap::MAGIC.len()..]).next() {
        Some(Ok(Record::Header(header))) => Ok((header.profile, header.library)),
        _ => Err(Error::input(
            path,
            "the file does not start with a header record",
        )),
    }
}

const FOOTER_RECORD: u64 = 1 + 8 + 20;

/// The report from the summary section, or `None` when there is none with statistics.
fn read_summary(path: &Path, bytes: u64) -> Result<Option<McapReport>> {
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
    let Ok(Record::Footer(footer)) = mcap::parse_record(tail[0], &tail[9..29]) else {
        return Ok(None);
    };
    if footer.summary_start == 0 || footer.summary_start >= footer_at {
        return Ok(None);
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
    for record in mcap::read::LinearReader::sans_magic(&summary) {
        let Ok(record) = record else {
            return Ok(None);
        };
        match record {
            Record::Schema { header, .. } => {
                schemas.insert(header.id, (header.name, header.encoding));
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
                report.chunks.compressed_bytes += index.compressed_size;
                report.chunks.uncompressed_bytes += index.uncompressed_size;
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
            let (schema, schema_encoding) = schemas.get(&c.schema_id).cloned().unwrap_or_default();
            ChannelReport {
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
