//! Damaged and malformed MCAP files: each ends with exit code 2 and a message naming the
//! file, the topic and message where it can, and what was expected; never a panic, never
//! a silent partial result.

mod common;

use std::io::BufWriter;
use std::path::{Path, PathBuf};

use common::*;

const STRING_SCHEMA: &str = "string data\n";

/// CDR of a `std_msgs/msg/String`.
fn string_message(text: &str) -> Vec<u8> {
    let mut data = vec![0, 1, 0, 0];
    data.extend_from_slice(&(text.len() as u32 + 1).to_le_bytes());
    data.extend_from_slice(text.as_bytes());
    data.push(0);
    data
}

struct Channel<'a> {
    topic: &'a str,
    schema: &'a str,
    schema_encoding: &'a str,
    schema_text: &'a str,
    message_encoding: &'a str,
}

const CHATTER: Channel = Channel {
    topic: "/chatter",
    schema: "std_msgs/msg/String",
    schema_encoding: "ros2msg",
    schema_text: STRING_SCHEMA,
    message_encoding: "cdr",
};

/// Writes an MCAP file with the `mcap` crate itself (uncompressed 4 KiB chunks, chunk
/// CRCs).
fn write_mcap(path: &Path, channel: &Channel, messages: &[Vec<u8>]) {
    let file = std::fs::File::create(path).unwrap();
    let mut writer = mcap::WriteOptions::new()
        .compression(None)
        .chunk_size(Some(4096))
        .profile("ros2")
        .create(BufWriter::new(file))
        .unwrap();
    let schema = writer
        .add_schema(
            channel.schema,
            channel.schema_encoding,
            channel.schema_text.as_bytes(),
        )
        .unwrap();
    let id = writer
        .add_channel(
            schema,
            channel.topic,
            channel.message_encoding,
            &Default::default(),
        )
        .unwrap();
    for (i, data) in messages.iter().enumerate() {
        let header = mcap::records::MessageHeader {
            channel_id: id,
            sequence: i as u32,
            log_time: 1_000 + i as u64,
            publish_time: 1_000 + i as u64,
        };
        writer.write_to_known_channel(&header, data).unwrap();
    }
    writer.finish().unwrap();
}

fn chatter(dir: &Path, name: &str, count: usize) -> PathBuf {
    let path = dir.join(name);
    let messages: Vec<_> = (0..count)
        .map(|i| string_message(&format!("hello number {i:04}")))
        .collect();
    write_mcap(&path, &CHATTER, &messages);
    path
}

fn cat(dir: &Path, file: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["cat", "--json", file.to_str().unwrap()];
    args.extend_from_slice(extra);
    imitate(dir, &args)
}

#[test]
fn a_well_formed_crafted_file_reads() {
    let dir = tempfile::tempdir().unwrap();
    let file = chatter(dir.path(), "ok.mcap", 3);
    let out = cat(dir.path(), &file, &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(stdout(&out).lines().count(), 3);
    assert!(stdout(&out).contains("hello number 0002"));
}

#[test]
fn a_corrupt_chunk_fails_its_crc() {
    let dir = tempfile::tempdir().unwrap();
    let file = chatter(dir.path(), "flipped.mcap", 3);
    let mut bytes = std::fs::read(&file).unwrap();
    let at = bytes
        .windows(17)
        .position(|w| w == b"hello number 0001")
        .unwrap();
    bytes[at] = b'j';
    std::fs::write(&file, bytes).unwrap();
    let out = cat(dir.path(), &file, &[]);
    assert_input_error(&out, &["flipped.mcap", "CRC mismatch"]);
    assert!(
        stdout(&out).is_empty(),
        "no message of a corrupt chunk is printed"
    );
    // Plain inspect reads the summary, which does not vouch for the chunks: the data
    // section's CRC does.
    let out = imitate(dir.path(), &["inspect", "flipped.mcap"]);
    assert_input_error(&out, &["flipped.mcap", "data section fails its CRC"]);
    let out = imitate(dir.path(), &["inspect", "--scan", "flipped.mcap"]);
    assert_input_error(&out, &["flipped.mcap", "CRC mismatch"]);
}

#[test]
fn an_empty_file_is_not_mcap_for_every_reader() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("empty.mcap"), b"").unwrap();
    for args in [
        vec!["cat", "empty.mcap"],
        vec!["inspect", "empty.mcap"],
        vec!["inspect", "--scan", "empty.mcap"],
        vec!["ingest", "--log", "empty.mcap", "--out", "ds"],
    ] {
        let out = imitate(dir.path(), &args);
        assert_input_error(&out, &["empty.mcap", "not an MCAP file"]);
    }
}

#[test]
fn a_cut_file_fails_unless_truncation_is_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let whole = chatter(dir.path(), "whole.mcap", 2000);
    // Small chunks: cut inside the data section, after some complete chunks.
    let bytes = std::fs::read(&whole).unwrap();
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() * 6 / 10]).unwrap();
    let out = cat(dir.path(), &cut, &[]);
    assert_input_error(&out, &["cut.mcap", "at byte"]);

    let out = cat(dir.path(), &cut, &["--allow-truncated"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let printed = stdout(&out).lines().count();
    assert!(
        printed > 0 && printed < 2000,
        "{printed}: the chunks before the cut"
    );
    let err = stderr(&out);
    assert!(err.contains("warning") && err.contains("cut.mcap"), "{err}");
    assert!(
        err.contains(&format!("printed the {printed} messages")),
        "{err}"
    );
    assert!(err.contains("bytes were not read"), "{err}");
}

/// A file whose one message is in an encoding imitate does not decode (CBOR).
fn cbor_file(dir: &Path) -> PathBuf {
    let file = dir.join("cbor.mcap");
    let channel = Channel {
        message_encoding: "cbor",
        ..CHATTER
    };
    write_mcap(&file, &channel, &[vec![1, 2, 3]]);
    file
}

#[test]
fn an_unknown_encoding_names_the_topic_and_the_encoding() {
    let dir = tempfile::tempdir().unwrap();
    let file = cbor_file(dir.path());
    let out = cat(dir.path(), &file, &["--strict"]);
    assert_input_error(&out, &["cbor.mcap", "/chatter", "message 0", "'cbor'"]);
}

#[test]
fn a_schema_that_does_not_parse_names_the_schema_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("schema.mcap");
    let channel = Channel {
        schema_text: "string data\nint32[0] broken\n",
        ..CHATTER
    };
    write_mcap(&file, &channel, &[string_message("x")]);
    let out = cat(dir.path(), &file, &["--strict"]);
    assert_input_error(
        &out,
        &[
            "schema.mcap",
            "std_msgs/msg/String",
            "line 2",
            "invalid size",
        ],
    );
}

#[test]
fn a_message_shorter_than_its_schema_names_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("short.mcap");
    let mut short = string_message("hello");
    short.truncate(9);
    write_mcap(&file, &CHATTER, &[string_message("fine"), short]);
    let out = cat(dir.path(), &file, &["--strict"]);
    assert_input_error(
        &out,
        &[
            "short.mcap",
            "/chatter",
            "message 1",
            "field data",
            "does not fit",
        ],
    );
}

/// A ROS 1 `std_msgs/String`: the byte count, then the bytes.
fn ros1_string(text: &str) -> Vec<u8> {
    let mut data = (text.len() as u32).to_le_bytes().to_vec();
    data.extend_from_slice(text.as_bytes());
    data
}

const ROS1_CHATTER: Channel = Channel {
    topic: "/chatter",
    schema: "std_msgs/String",
    schema_encoding: "ros1msg",
    schema_text: STRING_SCHEMA,
    message_encoding: "ros1",
};

/// A channel, how its messages are serialised, and where to cut one inside its text.
type Wire<'a> = (&'a Channel<'a>, fn(&str) -> Vec<u8>, usize);

#[test]
fn a_message_that_cannot_be_decoded_is_an_error_record_and_the_rest_is_printed() {
    // ROS 2 (CDR) and ROS 1 strings, the middle one cut inside its text.
    let wires: [Wire; 2] = [
        (&CHATTER, string_message, 9),
        (&ROS1_CHATTER, ros1_string, 6),
    ];
    for (channel, message, cut) in wires {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("mixed.mcap");
        let mut short = message("hello");
        short.truncate(cut);
        write_mcap(&file, channel, &[message("first"), short, message("third")]);
        let out = cat(dir.path(), &file, &[]);
        assert!(out.status.success(), "{}", stderr(&out));
        let lines: Vec<serde_json::Value> = stdout(&out)
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(lines.len(), 3);
        assert_eq!(lines[0]["message"]["data"], "first");
        assert_eq!(lines[1]["topic"], "/chatter");
        assert_eq!(lines[1]["sequence"], 1);
        let error = lines[1]["error"].as_str().unwrap_or_default();
        assert!(
            error.contains("field data") && error.contains("does not fit"),
            "{}",
            lines[1]
        );
        assert_eq!(lines[2]["message"]["data"], "third");
        let err = stderr(&out);
        assert!(
            err.contains("1 messages could not be decoded") && err.contains("/chatter: 1"),
            "{err}"
        );
        let out = cat(dir.path(), &file, &["--strict"]);
        assert_input_error(&out, &["mixed.mcap", "/chatter", "message 1", "field data"]);
    }
}

#[test]
fn a_ros1_schema_that_does_not_parse_names_the_schema_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("schema.mcap");
    let channel = Channel {
        schema_text: "string data\nint32 count 5\n",
        ..ROS1_CHATTER
    };
    write_mcap(&file, &channel, &[ros1_string("x")]);
    let out = cat(dir.path(), &file, &["--strict"]);
    let expected = ["std_msgs/String", "line 2", "no default value"];
    assert_input_error(
        &out,
        &[&["schema.mcap", "/chatter"][..], &expected].concat(),
    );
    let out = imitate(dir.path(), &["inspect", "--json", "schema.mcap"]);
    let report: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    let why = report["channels"][0]["undecodable"]
        .as_str()
        .unwrap_or_default();
    assert!(expected.iter().all(|e| why.contains(e)), "{report}");
}

#[test]
fn inspect_says_which_topics_cannot_be_decoded() {
    let dir = tempfile::tempdir().unwrap();
    cbor_file(dir.path());
    let ok = chatter(dir.path(), "ok.mcap", 1);
    for scan in [false, true] {
        let mut args = vec!["inspect", "--json", "cbor.mcap"];
        if scan {
            args.push("--scan");
        }
        let out = imitate(dir.path(), &args);
        assert!(out.status.success(), "{}", stderr(&out));
        let report: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
        let why = report["channels"][0]["undecodable"]
            .as_str()
            .unwrap_or_default();
        assert!(why.contains("cbor"), "scan {scan}: {report}");
        let out = imitate(dir.path(), &["inspect", "--json", ok.to_str().unwrap()]);
        let report: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
        assert!(
            report["channels"][0].get("undecodable").is_none(),
            "{report}"
        );
    }
    let text = stdout(&imitate(dir.path(), &["inspect", "cbor.mcap"]));
    assert!(text.contains("cannot decode"), "{text}");
}

#[test]
fn bad_magic_is_not_mcap() {
    let dir = tempfile::tempdir().unwrap();
    let file = chatter(dir.path(), "magic.mcap", 1);
    let mut bytes = std::fs::read(&file).unwrap();
    bytes[1] = b'X';
    std::fs::write(&file, bytes).unwrap();
    for command in ["cat", "inspect"] {
        let out = imitate(dir.path(), &[command, "magic.mcap"]);
        assert_input_error(&out, &["magic.mcap", "not an MCAP file"]);
    }
}

#[test]
fn a_footer_that_contradicts_itself_is_read_by_scanning() {
    let dir = tempfile::tempdir().unwrap();
    let file = chatter(dir.path(), "footer.mcap", 3);
    let mut bytes = std::fs::read(&file).unwrap();
    // Footer body (20 bytes) before the closing magic: summary start, summary offset
    // start, CRC. Point the offsets before the summary.
    let body = bytes.len() - 8 - 20;
    bytes[body + 8..body + 16].copy_from_slice(&1u64.to_le_bytes());
    std::fs::write(&file, bytes).unwrap();
    let out = imitate(dir.path(), &["inspect", "--json", "footer.mcap"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(report["source"], "scan");
    assert_eq!(report["message_count"], 3);
}

/// The byte offset of the first chunk's `uncompressed_size` field: magic, the header
/// record (opcode, length, body), then the chunk's opcode, length and two times.
fn first_chunk_size_field(bytes: &[u8]) -> usize {
    let header_len = u64::from_le_bytes(bytes[9..17].try_into().unwrap()) as usize;
    let chunk = 8 + 9 + header_len;
    assert_eq!(bytes[chunk], 0x06, "a chunk follows the header");
    chunk + 9 + 16
}

#[test]
fn a_chunk_claiming_more_memory_than_exists_is_refused_not_a_crash() {
    let dir = tempfile::tempdir().unwrap();
    let file = chatter(dir.path(), "huge.mcap", 3);
    let bytes = std::fs::read(&file).unwrap();
    let at = first_chunk_size_field(&bytes);
    for claim in [u64::MAX, 1 << 50, (4 << 30) + 1] {
        let mut damaged = bytes.clone();
        damaged[at..at + 8].copy_from_slice(&claim.to_le_bytes());
        std::fs::write(&file, &damaged).unwrap();
        let claims = format!("claims {claim} uncompressed bytes");
        for (args, expected) in [
            (vec!["cat", "huge.mcap"], claims.as_str()),
            (vec!["inspect", "--scan", "huge.mcap"], &claims),
            // Plain inspect reads the summary; the data section's CRC finds the damage.
            (vec!["inspect", "huge.mcap"], "fails its CRC"),
        ] {
            let out = imitate(dir.path(), &args);
            assert_input_error(&out, &["huge.mcap", expected]);
        }
        assert!(!dir.path().join("ds").exists(), "nothing written");
    }
    // Ingest of a real log (the quickstart's) with the same damage.
    let mut log = std::fs::read(repo().join("testdata/world/logs/terrain-000.mcap")).unwrap();
    let at_log = first_chunk_size_field(&log);
    log[at_log..at_log + 8].copy_from_slice(&(1u64 << 50).to_le_bytes());
    std::fs::write(dir.path().join("log.mcap"), &log).unwrap();
    let out = imitate(
        dir.path(),
        &[
            "ingest",
            "--log",
            "log.mcap",
            "--pose-topic",
            "/odom",
            "--out",
            "ds",
        ],
    );
    assert_input_error(
        &out,
        &["log.mcap", "claims 1125899906842624 uncompressed bytes"],
    );
    assert!(!dir.path().join("ds").exists(), "nothing written");
    // A stored chunk whose header disagrees with the bytes it holds.
    let mut damaged = bytes.clone();
    let stored = u64::from_le_bytes(damaged[at..at + 8].try_into().unwrap());
    damaged[at..at + 8].copy_from_slice(&(stored + 1000).to_le_bytes());
    std::fs::write(&file, &damaged).unwrap();
    let out = imitate(dir.path(), &["cat", "huge.mcap"]);
    assert_input_error(&out, &["huge.mcap", "whose header says"]);
}
