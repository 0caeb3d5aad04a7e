//! `imitate inspect FILE.mcap` (or a raster, an artifact or a DAgger dataset folder)
//! and `imitate cat FILE.mcap`.

use std::collections::BTreeSet;
use std::io::Write;
use std::path::PathBuf;

use serde::Serialize;

use crate::error::{Error, Result};
use crate::io::mcap::inspect::{McapReport, Source, describe_damage, inspect};
use crate::io::mcap::reader::{ChannelInfo, MessageHeader, scan_messages};
use crate::io::mcap::{Decoders, Value};

#[derive(Debug, clap::Args)]
pub struct InspectArgs {
    /// An MCAP file, a raster (any map file `ingest` reads: its grid, CRS, cell size
    /// on the ground and each layer's range as imitate reads them), or an artifact or
    /// DAgger dataset folder.
    pub file: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// Read every record even when the file has a summary section.
    #[arg(long)]
    pub scan: bool,
    /// On a damaged file (cut short, corrupt chunk), report what precedes the damage.
    #[arg(long)]
    pub allow_truncated: bool,
}

#[derive(Debug, clap::Args)]
pub struct CatArgs {
    /// An MCAP file.
    pub file: PathBuf,
    /// Only messages on this topic (repeat for several).
    #[arg(long = "topic", value_name = "TOPIC")]
    pub topics: Vec<String>,
    /// One JSON object per line: topic, schema, log_time, sequence, message.
    #[arg(long)]
    pub json: bool,
    /// On a damaged file (cut short, corrupt chunk), print the messages before the damage
    /// and say on stderr what was dropped.
    #[arg(long)]
    pub allow_truncated: bool,
    /// Stop with exit code 2 at the first message that cannot be decoded, instead of
    /// printing an error record for it and going on.
    #[arg(long)]
    pub strict: bool,
}

pub fn inspect_command(args: InspectArgs) -> Result<()> {
    if crate::io::is_raster(&args.file) {
        let report = crate::io::raster_report::describe(&args.file)?;
        return print_report(&report, args.json, crate::io::raster_report::render);
    }
    if args.file.is_dir() {
        let report = super::inspect_artifact::inspect_folder(&args.file)?;
        return print_report(&report, args.json, super::inspect_artifact::render);
    }
    if !is_mcap(&args.file)? {
        return Err(Error::input(
            &args.file,
            format!(
                "is not a file `inspect` reads: neither an MCAP log (it does not start with \
                 MCAP's magic bytes) nor a raster by its extension ({}), an artifact or a \
                 DAgger dataset folder",
                crate::io::RASTER_EXTENSIONS
                    .map(|e| format!(".{e}"))
                    .join(", ")
            ),
        ));
    }
    let report = inspect(
        &args.file,
        if args.scan {
            Source::Scan
        } else {
            Source::VerifiedSummary
        },
        args.allow_truncated,
    )?;
    print_report(&report, args.json, render_report)
}

/// Whether `path` is named `.mcap` or starts with MCAP's magic bytes (a log under
/// another name): what `inspect` reads as a log, and reports the damage of.
fn is_mcap(path: &std::path::Path) -> Result<bool> {
    use std::io::Read;
    let named = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"));
    let mut start = Vec::new();
    crate::error::open_input(path)?
        .take(mcap::MAGIC.len() as u64)
        .read_to_end(&mut start)
        .map_err(|e| Error::io(format!("reading {}", path.display()), e))?;
    Ok(named || start == mcap::MAGIC)
}

/// Prints a report to stdout as pretty JSON or as `render` writes it.
fn print_report<T: Serialize>(report: &T, json: bool, render: fn(&T) -> String) -> Result<()> {
    let mut out = std::io::stdout().lock();
    let written = if json {
        serde_json::to_writer_pretty(&mut out, report)
            .map_err(std::io::Error::from)
            .and_then(|()| writeln!(out))
    } else {
        out.write_all(render(report).as_bytes())
    };
    written.map_err(|e| Error::io("writing to stdout", e))
}

fn seconds(ns: u64) -> String {
    format!("{}.{:09}", ns / 1_000_000_000, ns % 1_000_000_000)
}

fn render_report(report: &McapReport) -> String {
    let mut text = format!(
        "file:      {} ({} bytes)\nprofile:   {}\nlibrary:   {}\nread from: {}\nmessages:  {}\n",
        report.file,
        report.bytes,
        report.profile,
        report.library,
        report.source,
        report.message_count
    );
    if let (Some(start), Some(end)) = (report.start_time, report.end_time) {
        text += &format!(
            "time:      {} .. {} ({:.3} s)\n",
            seconds(start),
            seconds(end),
            (end - start) as f64 * 1e-9
        );
    }
    let compression: Vec<String> = report
        .chunks
        .compression
        .iter()
        .map(|(name, count)| format!("{name}: {count}"))
        .collect();
    text += &format!(
        "chunks:    {} ({}), {} bytes compressed, {} uncompressed\n",
        report.chunks.count,
        compression.join(", "),
        report.chunks.compressed_bytes,
        report.chunks.uncompressed_bytes
    );
    text += &format!(
        "other:     {} attachments, {} metadata records\n",
        report.attachments, report.metadata
    );
    if let Some(damage) = &report.damage {
        text += &format!("damage:    {damage}\n");
    }
    text += "channels:\n";
    let topic_width = report
        .channels
        .iter()
        .map(|c| c.topic.len())
        .max()
        .unwrap_or(5);
    for c in &report.channels {
        text += &format!(
            "  {:>3}  {:<topic_width$}  {:>8} msgs  {} / {} ({})\n",
            c.id, c.topic, c.message_count, c.message_encoding, c.schema, c.schema_encoding
        );
        if let Some(why) = &c.undecodable {
            text += &format!("       cannot decode: {why}\n");
        }
    }
    text
}

/// The line of `cat --json` for a message that cannot be decoded.
#[derive(Serialize)]
struct CatError<'a> {
    topic: &'a str,
    schema: &'a str,
    log_time: u64,
    sequence: u32,
    error: &'a str,
}

/// One line of `cat --json`; the field names are the ones of Foxglove's Python tools.
#[derive(Serialize)]
struct CatLine<'a> {
    topic: &'a str,
    schema: &'a str,
    log_time: u64,
    sequence: u32,
    message: &'a Value,
}

/// One message of `cat` as printed: its line, and when it could not be decoded (it is
/// then printed as an error record) its topic and why.
struct CatMessage {
    line: Vec<u8>,
    undecodable: Option<(String, String)>,
}

/// A message decoded and written as `cat` prints it (a line of text or of JSON).
fn cat_message(
    decoders: &Decoders,
    channel: &ChannelInfo,
    header: &MessageHeader,
    data: &[u8],
    json: bool,
) -> std::result::Result<CatMessage, String> {
    let decoded = decoders
        .get(channel)
        .and_then(|decoder| decoder.decode(data));
    let mut line = Vec::new();
    let written = match (&decoded, json) {
        (Ok(message), true) => serde_json::to_writer(
            &mut line,
            &CatLine {
                topic: &channel.topic,
                schema: channel.schema_name(),
                log_time: header.log_time,
                sequence: header.sequence,
                message,
            },
        ),
        (Ok(message), false) => {
            line.extend(format!("{} {} ", seconds(header.log_time), channel.topic).bytes());
            serde_json::to_writer(&mut line, message)
        }
        // As Foxglove's tools do: say what could not be decoded, and go on.
        (Err(e), true) => serde_json::to_writer(
            &mut line,
            &CatError {
                topic: &channel.topic,
                schema: channel.schema_name(),
                log_time: header.log_time,
                sequence: header.sequence,
                error: e,
            },
        ),
        (Err(e), false) => {
            let text = format!("{} {} error: {e}", seconds(header.log_time), channel.topic);
            line.extend(text.bytes());
            Ok(())
        }
    };
    written.map_err(|e| e.to_string())?;
    line.push(b'\n');
    Ok(CatMessage {
        line,
        undecodable: decoded.err().map(|e| (channel.topic.clone(), e)),
    })
}

/// Prints a log's messages in file order. They are decoded and formatted on all
/// threads, chunk by chunk (`scan_messages`), and written in order: the same output
/// at any thread count.
pub fn cat_command(args: CatArgs) -> Result<()> {
    let wanted: BTreeSet<&str> = args.topics.iter().map(String::as_str).collect();
    if !wanted.is_empty() {
        // Refused before anything is printed: a topic no channel carries.
        let report = inspect(&args.file, Source::Summary, args.allow_truncated)?;
        let topics: BTreeSet<&str> = report.channels.iter().map(|c| c.topic.as_str()).collect();
        let missing: Vec<&str> = wanted.difference(&topics).copied().collect();
        if !missing.is_empty() {
            return Err(Error::input(
                &args.file,
                format!(
                    "no channel on topic {} (topics: {})",
                    missing.join(", "),
                    topics.into_iter().collect::<Vec<_>>().join(", ")
                ),
            ));
        }
    }
    let decoders = Decoders::default();
    let prepare = |channel: &ChannelInfo, header: &MessageHeader, data: &[u8]| {
        if !wanted.is_empty() && !wanted.contains(channel.topic.as_str()) {
            return Ok(None);
        }
        let problem = |message: String| {
            Error::input(
                &args.file,
                format!(
                    "topic {} message {} (log time {}): {message}",
                    channel.topic, header.sequence, header.log_time
                ),
            )
        };
        let message = cat_message(&decoders, channel, header, data, args.json).map_err(problem)?;
        match &message.undecodable {
            Some((_, why)) if args.strict => Err(problem(why.clone())),
            _ => Ok(Some(message)),
        }
    };
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let write_error = |e: std::io::Error| Error::io("writing to stdout", e);
    let mut printed = 0u64;
    let mut undecodable: std::collections::BTreeMap<String, u64> = Default::default();
    let consume = |message: CatMessage| {
        match message.undecodable {
            Some((topic, _)) => *undecodable.entry(topic).or_insert(0u64) += 1,
            None => printed += 1,
        }
        out.write_all(&message.line).map_err(write_error)
    };
    let damage = scan_messages(&args.file, prepare, consume)?;
    out.flush().map_err(write_error)?;
    if let Some(damage) = damage {
        if !args.allow_truncated {
            return Err(damage.into_error(&args.file));
        }
        eprintln!(
            "warning: {}: {}; printed the {printed} messages before it",
            args.file.display(),
            describe_damage(&damage)
        );
    }
    if !undecodable.is_empty() {
        let total: u64 = undecodable.values().sum();
        let topics: Vec<String> = undecodable
            .iter()
            .map(|(topic, n)| format!("{topic}: {n}"))
            .collect();
        eprintln!(
            "warning: {}: {total} messages could not be decoded ({}); printed as error \
             records (--strict stops at the first)",
            args.file.display(),
            topics.join(", ")
        );
    }
    Ok(())
}
