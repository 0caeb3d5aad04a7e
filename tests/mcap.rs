//! `imitate inspect` and `imitate cat` on real ROS 2 bags (../shared/data/mcap), checked
//! against what Foxglove's Python decoder produces for the same files.

mod common;

use std::path::Path;

use common::*;

const BAGS: [&str; 4] = ["cdr_test_0", "talker", "multiple_files_2", "only_topics"];

fn json_lines(text: &str) -> Vec<serde_json::Value> {
    text.lines()
        .map(|line| serde_json::from_str(line).expect("a JSON line"))
        .collect()
}

#[test]
fn cat_decodes_every_bag_exactly_as_the_reference_decoder() {
    let Some(dir) = shared_data("mcap") else {
        return;
    };
    for bag in BAGS {
        let file = dir.join(format!("{bag}.mcap"));
        let out = imitate(&repo(), &["cat", "--json", file.to_str().unwrap()]);
        assert!(out.status.success(), "{bag}: {}", stderr(&out));
        let expected = std::fs::read_to_string(dir.join(format!("expected/{bag}.ndjson"))).unwrap();
        let (ours, theirs) = (json_lines(&stdout(&out)), json_lines(&expected));
        assert_eq!(ours.len(), theirs.len(), "{bag}");
        for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
            assert_eq!(a, b, "{bag}: message {i}");
        }
    }
}

#[test]
fn cat_filters_topics_and_rejects_unknown_ones() {
    let Some(dir) = shared_data("mcap") else {
        return;
    };
    let file = dir.join("talker.mcap");
    let file = file.to_str().unwrap();
    let out = imitate(&repo(), &["cat", "--json", "--topic", "/topic", file]);
    assert!(out.status.success(), "{}", stderr(&out));
    let lines = json_lines(&stdout(&out));
    assert_eq!(lines.len(), 10);
    assert!(lines.iter().all(|l| l["topic"] == "/topic"));
    assert_eq!(lines[3]["message"]["data"], "Hello, world! 3");

    let out = imitate(&repo(), &["cat", "--topic", "/nope", file]);
    assert_input_error(&out, &["talker.mcap", "/nope", "/rosout"]);
}

fn inspect(file: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["inspect", "--json", file.to_str().unwrap()];
    args.extend_from_slice(extra);
    let out = imitate(&repo(), &args);
    assert!(out.status.success(), "{}", stderr(&out));
    serde_json::from_str(&stdout(&out)).unwrap()
}

#[test]
fn inspect_reads_the_summary_and_a_scan_agrees() {
    let Some(dir) = shared_data("mcap") else {
        return;
    };
    for bag in BAGS {
        let file = dir.join(format!("{bag}.mcap"));
        let mut summary = inspect(&file, &[]);
        let mut scan = inspect(&file, &["--scan"]);
        assert_eq!(summary["source"], "summary", "{bag}");
        assert_eq!(scan["source"], "scan", "{bag}");
        summary["source"] = "".into();
        scan["source"] = "".into();
        assert_eq!(summary, scan, "{bag}");
    }
    let talker = inspect(&dir.join("talker.mcap"), &[]);
    assert_eq!(talker["message_count"], 20);
    assert_eq!(talker["chunks"]["compression"]["zstd"], 1);
    assert_eq!(talker["channels"][0]["topic"], "/rosout");
    assert_eq!(talker["channels"][0]["schema"], "rcl_interfaces/msg/Log");
    assert_eq!(talker["channels"][0]["message_count"], 10);
}

#[test]
fn a_file_cut_short_is_an_input_error_naming_where() {
    let Some(dir) = shared_data("mcap") else {
        return;
    };
    let file = dir.join("truncated_chunk_not_closed.mcap");
    for command in ["inspect", "cat"] {
        let out = imitate(&repo(), &[command, file.to_str().unwrap()]);
        assert_input_error(
            &out,
            &["truncated_chunk_not_closed.mcap", "byte 48", "chunk"],
        );
    }
}

#[test]
fn files_that_are_not_mcap_are_input_errors() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("notes.mcap");
    std::fs::write(&file, b"this is not a log").unwrap();
    for command in ["inspect", "cat"] {
        let out = imitate(dir.path(), &[command, "notes.mcap"]);
        assert_input_error(&out, &["notes.mcap", "not an MCAP file"]);
        let out = imitate(dir.path(), &[command, "missing.mcap"]);
        assert_input_error(&out, &["missing.mcap", "no such file"]);
    }
}
