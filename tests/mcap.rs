//! `imitate inspect` and `imitate cat` on real ROS 2 bags (../shared/data/mcap) and real
//! ROS 1 logs (the `mcap` crate's test files), checked against what Foxglove's Python
//! decoders produce for the same files.

mod common;

use std::path::{Path, PathBuf};

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
        assert_cat_reads_the_expected_messages(&dir.join(format!("{bag}.mcap")), &dir, bag);
    }
}

/// `imitate cat` on `file` prints, message for message, what Foxglove's decoder read from
/// bag `bag` (`expected/BAG.ndjson` in `dir`).
fn assert_cat_reads_the_expected_messages(file: &Path, dir: &Path, bag: &str) {
    let out = imitate(&repo(), &["cat", "--json", file.to_str().unwrap()]);
    assert!(out.status.success(), "{bag}: {}", stderr(&out));
    let expected = std::fs::read_to_string(dir.join(format!("expected/{bag}.ndjson"))).unwrap();
    let (ours, theirs) = (json_lines(&stdout(&out)), json_lines(&expected));
    assert_eq!(ours.len(), theirs.len(), "{bag}");
    for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
        assert_eq!(a, b, "{bag}: message {i}");
    }
}

/// The same bags with every schema stored as `ros2idl` (rosbag2's form for types with an
/// `.idl` file and no `.msg`), the IDL as `rosidl_adapter` generates it, rewritten by
/// Foxglove's `mcap` writer: every message decodes as Foxglove decodes the `ros2msg`
/// original.
#[test]
fn cat_decodes_every_bag_with_ros2idl_schemas_as_the_reference_decoder_reads_its_msg_twin() {
    let Some(dir) = shared_data("mcap") else {
        return;
    };
    let out_dir = tempfile::tempdir().unwrap();
    for bag in BAGS {
        let original = dir.join(format!("{bag}.mcap"));
        let file = out_dir.path().join(format!("{bag}.mcap"));
        let Some(converted) = python_script("ros2idl_bag.py", &[&original, &file]) else {
            return;
        };
        assert!(converted[0]["schemas"].as_u64().unwrap() > 0, "{bag}");
        assert_cat_reads_the_expected_messages(&file, &dir, bag);
        let report = inspect(&file, &[]);
        for channel in report["channels"].as_array().unwrap() {
            assert!(channel["undecodable"].is_null(), "{bag}: {channel}");
        }
    }
}

/// The `mcap` crate's own test data, where cargo unpacked the locked version of the crate
/// to build it: a car's `/tf` and `/diagnostics` (DiagnosticArray, nested arrays of
/// strings), a ROS 1 bag converted by the Go `mcap` tool, compressed and not.
fn mcap_crate_test_data() -> PathBuf {
    let lock = std::fs::read_to_string(repo().join("Cargo.lock")).unwrap();
    let version = lock
        .split("[[package]]")
        .find_map(|entry| {
            entry
                .contains("name = \"mcap\"\n")
                .then(|| entry.split("version = \"").nth(1)?.split('"').next())
                .flatten()
        })
        .expect("Cargo.lock locks the mcap crate");
    let cargo_home = std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(std::env::var_os("HOME").unwrap()).join(".cargo"));
    std::fs::read_dir(cargo_home.join("registry/src"))
        .unwrap()
        .map(|index| {
            index
                .unwrap()
                .path()
                .join(format!("mcap-{version}/tests/data"))
        })
        .find(|dir| dir.is_dir())
        .expect("cargo unpacked the mcap crate to build it")
}

#[test]
fn cat_decodes_ros1_logs_exactly_as_foxgloves_ros1_decoder() {
    for name in ["compressed.mcap", "uncompressed.mcap"] {
        let file = mcap_crate_test_data().join(name);
        let Some(theirs) = python_script("foxglove_mcap.py", &[Path::new("decode"), &file]) else {
            return;
        };
        let out = imitate(&repo(), &["cat", "--json", file.to_str().unwrap()]);
        assert!(out.status.success(), "{name}: {}", stderr(&out));
        let ours = json_lines(&stdout(&out));
        assert_eq!(ours.len(), 826, "{name}");
        assert_eq!(ours.len(), theirs.len(), "{name}");
        for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
            assert_eq!(a, b, "{name}: message {i}");
        }
        // 413 chunks, decoded on all threads: the same bytes at any thread count.
        for threads in ["1", "3"] {
            let args = ["cat", "--json", file.to_str().unwrap()];
            let again = imitate_env(&repo(), &args, &[("RAYON_NUM_THREADS", threads)]);
            assert_eq!(again.stdout, out.stdout, "{name} at {threads} threads");
        }
        let report = inspect(&file, &[]);
        assert_eq!(report["profile"], "ros1");
        for channel in report["channels"].as_array().unwrap() {
            assert!(channel["undecodable"].is_null(), "{channel}");
        }
    }
}

/// A rosbag2 recording of a service (Jazzy on): the schema holds the `.srv` text as
/// rosbag2's message-definition source writes it, the message the CDR of the event type
/// rosidl generates. The bytes are laid out by hand here, not by our encoder.
#[test]
fn cat_decodes_service_events_from_the_srv_text_rosbag2_stores() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("services.mcap");
    let srv = format!(
        "{0}\nSRV: example_interfaces/srv/AddTwoInts\nint64 a\nint64 b\n---\nint64 sum\n",
        "=".repeat(80)
    );
    let mut event = vec![0, 1, 0, 0]; // CDR, little endian
    event.push(1); // info.event_type: REQUEST_RECEIVED
    event.extend_from_slice(&[0; 3]); // align 4
    event.extend_from_slice(&7i32.to_le_bytes()); // info.stamp.sec
    event.extend_from_slice(&9u32.to_le_bytes()); // info.stamp.nanosec
    event.extend_from_slice(&[3; 16]); // info.client_gid
    event.extend_from_slice(&[0; 4]); // align 8
    event.extend_from_slice(&42i64.to_le_bytes()); // info.sequence_number
    event.extend_from_slice(&1u32.to_le_bytes()); // one request
    event.extend_from_slice(&[0; 4]); // align 8
    event.extend_from_slice(&2i64.to_le_bytes()); // request.a
    event.extend_from_slice(&40i64.to_le_bytes()); // request.b
    event.extend_from_slice(&0u32.to_le_bytes()); // no response
    {
        let out = std::io::BufWriter::new(std::fs::File::create(&file).unwrap());
        let mut writer = mcap::WriteOptions::new()
            .profile("ros2")
            .create(out)
            .unwrap();
        let schema = writer
            .add_schema(
                "example_interfaces/srv/AddTwoInts_Event",
                "ros2msg",
                srv.as_bytes(),
            )
            .unwrap();
        let channel = writer
            .add_channel(
                schema,
                "/add_two_ints/_service_event",
                "cdr",
                &Default::default(),
            )
            .unwrap();
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: 0,
            log_time: 5,
            publish_time: 5,
        };
        writer.write_to_known_channel(&header, &event).unwrap();
        writer.finish().unwrap();
    }
    let out = imitate(
        &repo(),
        &["cat", "--json", "--strict", file.to_str().unwrap()],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let lines = json_lines(&stdout(&out));
    let message = &lines[0]["message"];
    assert_eq!(message["info"]["event_type"], 1);
    assert_eq!(message["info"]["stamp"]["sec"], 7);
    assert_eq!(message["info"]["sequence_number"], 42);
    assert_eq!(message["request"][0]["a"], 2);
    assert_eq!(message["request"][0]["b"], 40);
    assert_eq!(message["response"], serde_json::json!([]));
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
    // A file of a format `inspect` does not read (a NITF image) is named as such,
    // with what it does read, not taken for a damaged log.
    std::fs::write(dir.path().join("scene.ntf"), b"NITF02.10").unwrap();
    let out = imitate(dir.path(), &["inspect", "scene.ntf"]);
    assert_input_error(
        &out,
        &["scene.ntf", "not a file `inspect` reads", ".tif", ".zarr"],
    );
    // A log under another name is still read as a log.
    let log = std::fs::read(mcap_crate_test_data().join("compressed.mcap")).unwrap();
    std::fs::write(dir.path().join("demos.log"), log).unwrap();
    let out = imitate(dir.path(), &["inspect", "demos.log"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
