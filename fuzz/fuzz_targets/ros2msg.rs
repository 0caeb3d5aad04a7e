//! The ros2msg, ros1msg and ros2idl schema parsers on arbitrary text: errors are fine, panics
//! are not.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = imitate::io::mcap::ros2msg::parse("fuzz_msgs/msg/Root", text);
        let _ = imitate::io::mcap::ros2msg::parse_ros1("fuzz_msgs/Root", text);
        let _ = imitate::io::mcap::ros2idl::parse("fuzz_msgs/msg/Root", text);
    }
});
