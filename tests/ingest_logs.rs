//! `imitate ingest` from robot logs (MCAP) and other map sources, as a user runs it.

mod common;

use std::path::Path;

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

/// A ROS 1 log written by Foxglove's `mcap-ros1-support` with the drive of a ROS 2 log
/// (nav_msgs/Odometry, PoseStamped goals, tf/tfMessage on /tf_static, tf2_msgs/TFMessage
/// on /tf, an OccupancyGrid map, and a message type using every ROS 1 field kind):
/// `cat` reads every message as Foxglove's decoder does, and ingest finds the same
/// demonstrations and cell paths as from the ROS 2 log.
#[test]
fn a_ros1_log_decodes_as_foxglove_does_and_ingests_as_its_ros2_twin() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("ros1")).unwrap();
    let ros2_log = repo().join("testdata/world/logs/terrain-002.mcap");
    let ros1_log = dir.path().join("ros1/terrain-002.mcap");
    let Some(theirs) = python_script(
        "foxglove_mcap.py",
        &[Path::new("convert-ros1"), &ros2_log, &ros1_log],
    ) else {
        return;
    };
    let out = imitate(dir.path(), &["cat", "--json", "ros1/terrain-002.mcap"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let ours: Vec<serde_json::Value> = stdout(&out)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(ours.len(), theirs.len());
    assert_eq!(
        ours.iter().filter(|m| m["topic"] == "/everything").count(),
        3
    );
    for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
        assert_eq!(a, b, "message {i}");
    }

    assert_ingest_finds_the_same_drive(dir.path(), &ros1_log, &ros2_log);
}

/// Two logs of one drive, each in its own folder under the same file name (the name goes
/// into the datasets): ingest, split on the goals, writes the same paths and
/// demonstrations from both, byte for byte.
fn assert_ingest_finds_the_same_drive(dir: &Path, log: &Path, twin: &Path) {
    let split = ["--goal-topic", "/goal", "--split", "goal"];
    for (log, out_dir) in [(log, "from-log"), (twin, "from-twin")] {
        let log = log.to_str().unwrap();
        let out = imitate(
            dir,
            &[&["ingest", "--log", log], &split[..], &["--out", out_dir]].concat(),
        );
        assert!(out.status.success(), "{}", stderr(&out));
    }
    for file in ["paths.parquet", "demonstrations.parquet"] {
        assert_eq!(
            std::fs::read(dir.join("from-log").join(file)).unwrap(),
            std::fs::read(dir.join("from-twin").join(file)).unwrap(),
            "{file}"
        );
    }
}

/// The same ROS 2 log with its schemas stored as `ros2idl` (the IDL `rosidl_adapter`
/// generates, rewritten by Foxglove's `mcap` writer: `tests/python/ros2idl_bag.py`):
/// ingest gives the demonstrations and paths of the `ros2msg` log, byte for byte.
#[test]
fn a_log_with_ros2idl_schemas_ingests_as_its_ros2msg_twin() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("idl")).unwrap();
    let msg_log = repo().join("testdata/world/logs/terrain-002.mcap");
    let idl_log = dir.path().join("idl/terrain-002.mcap");
    let Some(converted) = python_script("ros2idl_bag.py", &[&msg_log, &idl_log]) else {
        return;
    };
    assert_eq!(converted[0]["schemas"], 4);
    assert_ingest_finds_the_same_drive(dir.path(), &idl_log, &msg_log);
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
    let log = repo().join("testdata/world/logs/terrain-002.mcap");
    let Some(theirs) = python_script("foxglove_mcap.py", &[Path::new("decode"), &log]) else {
        return;
    };
    let ours = imitate(&repo(), &["cat", "--json", log.to_str().unwrap()]);
    assert!(ours.status.success(), "{}", stderr(&ours));
    let ours: Vec<serde_json::Value> = stdout(&ours)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
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
