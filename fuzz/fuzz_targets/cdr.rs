//! The CDR decoder on arbitrary bytes, against a fixed set of real ROS 2 schemas and
//! against schemas the fuzzer writes itself (input = schema text, NUL, message), which
//! also drive the ROS 1 decoder.
#![no_main]

use std::sync::OnceLock;

use imitate::io::mcap::ros2::schemas;
use imitate::io::mcap::ros2msg::{Schema, parse, parse_ros1};
use imitate::io::mcap::{cdr, ros2};
use libfuzzer_sys::fuzz_target;

fn fixed() -> &'static [(&'static str, Schema)] {
    static SCHEMAS: OnceLock<Vec<(&'static str, Schema)>> = OnceLock::new();
    SCHEMAS.get_or_init(|| {
        [
            ("nav_msgs/msg/Odometry", schemas::odometry()),
            ("nav_msgs/msg/OccupancyGrid", schemas::occupancy_grid()),
            ("grid_map_msgs/msg/GridMap", schemas::grid_map()),
            ("tf2_msgs/msg/TFMessage", schemas::tf_message()),
            (
                "fuzz_msgs/msg/Mixed",
                "wstring w\nstring<=4[<=3] s\nbool[2] b\nInner[] i\nuint64 u\n\
                 ===\nMSG: fuzz_msgs/Inner\nfloat32[] f\nchar c\n"
                    .to_string(),
            ),
        ]
        .into_iter()
        .map(|(name, text)| (name, parse(name, &text).expect("built-in schemas parse")))
        .collect()
    })
}

fuzz_target!(|data: &[u8]| {
    let Some((&selector, message)) = data.split_first() else {
        return;
    };
    let schemas = fixed();
    if let Some((name, schema)) = schemas.get(usize::from(selector) % (schemas.len() + 1)) {
        if let Ok(value) = cdr::decode(schema, message) {
            // Whatever decodes must also convert without panicking.
            let _ = ros2::poses(name, &value, 0);
            let _ = ros2::grid(name, &value, "fuzz");
            let _ = serde_json::to_string(&value);
        }
    } else if let Some(split) = message.iter().position(|&b| b == 0) {
        let (text, bytes) = message.split_at(split);
        let Ok(text) = std::str::from_utf8(text) else {
            return;
        };
        if let Ok(schema) = parse("fuzz_msgs/msg/Root", text) {
            let _ = cdr::decode(&schema, &bytes[1..]);
        }
        if let Ok(schema) = parse_ros1("fuzz_msgs/Root", text) {
            let _ = cdr::decode_ros1(&schema, &bytes[1..]);
        }
    }
});
