//! `imitate ingest` from robot logs (MCAP) and other map sources, as a user runs it.

mod common;

use std::process::Command;

use common::*;

fn logs() -> Vec<String> {
    (0..4)
        .map(|i| format!("testdata/world/logs/terrain-00{i}.mcap"))
        .collect()
}

fn ingest(args: &[&str]) -> std::process::Output {
    imitate(&repo(), &[&["ingest"], args].concat())
}

#[test]
fn logs_give_the_same_dataset_as_the_parquet_tables() {
    let dir = tempfile::tempdir().unwrap();
    let from_logs = dir.path().join("logs");
    let from_tables = dir.path().join("tables");
    let mut args = vec!["--goal-topic", "/goal", "--split", "goal"];
    let logs = logs();
    for log in &logs {
        args.extend(["--log", log.as_str()]);
    }
    args.extend(["--out", from_logs.to_str().unwrap()]);
    let out = ingest(&args);
    assert!(out.status.success(), "{}", stderr(&out));

    let maps: Vec<String> = (0..4)
        .map(|i| format!("testdata/world/maps/terrain-00{i}.parquet"))
        .collect();
    let mut args = vec!["--demonstrations", "testdata/world/demonstrations.parquet"];
    for map in &maps {
        args.extend(["--map", map.as_str()]);
    }
    args.extend(["--out", from_tables.to_str().unwrap()]);
    let out = ingest(&args);
    assert!(out.status.success(), "{}", stderr(&out));

    // The logs went through GridMap decoding, a /tf_static frame change and goal-topic
    // episode cuts; the maps and cell paths come out byte for byte the same.
    for file in [
        "paths.parquet",
        "maps/terrain-000.parquet",
        "maps/terrain-003.parquet",
    ] {
        assert_eq!(
            std::fs::read(from_logs.join(file)).unwrap(),
            std::fs::read(from_tables.join(file)).unwrap(),
            "{file}"
        );
    }
}

#[test]
fn splitting_on_time_gaps_finds_the_episodes() {
    let dir = tempfile::tempdir().unwrap();
    let out = ingest(&[
        "--log",
        "testdata/world/logs/terrain-001.mcap",
        "--pose-topic",
        "/odom",
        "--split",
        "gap",
        "--gap-seconds",
        "4",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("1 maps, 16 demonstrations"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn topic_mistakes_are_input_errors_that_name_the_topics() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("ds");
    let out_dir = out_dir.to_str().unwrap();
    let log = "testdata/world/logs/terrain-000.mcap";
    // Two pose-typed topics (/goal, /odom) and no choice made.
    let out = ingest(&["--log", log, "--out", out_dir]);
    assert_input_error(&out, &["terrain-000.mcap", "/goal", "/odom", "say which"]);
    let out = ingest(&["--log", log, "--pose-topic", "/odometry", "--out", out_dir]);
    assert_input_error(&out, &["no pose topic /odometry", "/odom"]);
    let out = ingest(&["--log", log, "--pose-topic", "/map", "--out", out_dir]);
    assert_input_error(&out, &["grid_map_msgs/msg/GridMap", "not one of"]);
    let out = ingest(&[
        "--log",
        log,
        "--pose-topic",
        "/odom",
        "--split",
        "goal",
        "--out",
        out_dir,
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("goal topic"), "{}", stderr(&out));
    assert!(!dir.path().join("ds").exists(), "nothing half-written");
}

#[test]
fn the_written_logs_decode_the_same_in_python() {
    let probe = Command::new("python3")
        .args(["-c", "import mcap, mcap_ros2"])
        .output();
    if !probe.is_ok_and(|o| o.status.success()) {
        eprintln!("skipped: Python's mcap and mcap-ros2-support are not installed");
        return;
    }
    let log = repo().join("testdata/world/logs/terrain-002.mcap");
    let ours = imitate(&repo(), &["cat", "--json", log.to_str().unwrap()]);
    assert!(ours.status.success(), "{}", stderr(&ours));
    let script = r#"
import json, sys
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
def plain(o):
    if hasattr(o, "__slots__"): return {k: plain(getattr(o, k)) for k in o.__slots__}
    if isinstance(o, (list, tuple)): return [plain(x) for x in o]
    if isinstance(o, bytes): return list(o)
    return o
reader = make_reader(open(sys.argv[1], "rb"), decoder_factories=[DecoderFactory()])
for schema, channel, message, decoded in reader.iter_decoded_messages():
    print(json.dumps({"topic": channel.topic, "schema": schema.name, "log_time": message.log_time,
                      "sequence": message.sequence, "message": plain(decoded)}))
"#;
    let theirs = Command::new("python3")
        .args(["-c", script, log.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(theirs.status.success(), "{}", stderr(&theirs));
    let parse = |text: String| -> Vec<serde_json::Value> {
        text.lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect()
    };
    let (ours, theirs) = (parse(stdout(&ours)), parse(stdout(&theirs)));
    assert_eq!(ours[0]["topic"], "/map");
    assert_eq!(ours.iter().filter(|m| m["topic"] == "/goal").count(), 16);
    assert_eq!(ours, theirs);
}

#[test]
fn the_ingest_benchmark_runs_on_a_small_log() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bench.mcap");
    let log = log.to_str().unwrap();
    let out = imitate(
        dir.path(),
        &["bench", "ingest", log, "--generate", "--megabytes", "2"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let out = imitate(
        dir.path(),
        &["bench", "ingest", log, "--repeat", "1", "--json"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert!(report["file_bytes"].as_u64().unwrap() >= 2_000_000);
    assert_eq!(report["grid_cells"], 512 * 512);
    // Ten odometry messages per grid.
    assert_eq!(
        report["messages"].as_u64().unwrap() * 10,
        report["poses"].as_u64().unwrap() * 11
    );
}
