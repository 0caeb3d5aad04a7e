//! Writing MCAP logs of ROS 2 messages (CDR, zstd chunks), as rosbag2 records them.

use std::collections::BTreeMap;
use std::io::{BufWriter, Seek, Write};
use std::path::Path;

use tempfile::NamedTempFile;

use super::cdr;
use super::ros2msg::{self, Schema};
use super::value::Value;
use crate::error::{Error, Result};
use crate::io::fs::write_atomic_seekable;

pub struct LogWriter<W: Write + Seek> {
    inner: mcap::Writer<W>,
    /// Per channel: id, the ros2msg schema when the channel is CDR, next sequence.
    channels: Vec<(u16, Option<Schema>, u32)>,
    path: String,
}

fn failed(path: &str, e: impl std::fmt::Display) -> Error {
    Error::Failed(format!("writing {path}: {e}"))
}

impl<W: Write + Seek> LogWriter<W> {
    fn new(out: W, path: &Path) -> Result<Self> {
        let path = path.display().to_string();
        let options = mcap::WriteOptions::new()
            .profile("ros2")
            .library(format!("imitate {}", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            .chunk_size(Some(1 << 20));
        let inner = options.create(out).map_err(|e| failed(&path, e))?;
        Ok(LogWriter {
            inner,
            channels: Vec::new(),
            path,
        })
    }

    /// Declares a topic of ROS 2 type `type_name` (e.g. `nav_msgs/msg/Odometry`) with its
    /// schema text; returns the handle to write to it.
    pub fn channel(&mut self, topic: &str, type_name: &str, schema_text: &str) -> Result<usize> {
        let schema = ros2msg::parse(type_name, schema_text)
            .map_err(|e| Error::Failed(format!("built-in schema {type_name}: {e}")))?;
        let schema_id = self
            .inner
            .add_schema(type_name, "ros2msg", schema_text.as_bytes())
            .map_err(|e| failed(&self.path, e))?;
        let id = self
            .inner
            .add_channel(schema_id, topic, "cdr", &BTreeMap::new())
            .map_err(|e| failed(&self.path, e))?;
        self.channels.push((id, Some(schema), 0));
        Ok(self.channels.len() - 1)
    }

    /// Declares a topic whose messages the caller encodes (e.g. protobuf).
    pub fn raw_channel(
        &mut self,
        topic: &str,
        schema_name: &str,
        schema_encoding: &str,
        schema_data: &[u8],
        message_encoding: &str,
    ) -> Result<usize> {
        let schema_id = self
            .inner
            .add_schema(schema_name, schema_encoding, schema_data)
            .map_err(|e| failed(&self.path, e))?;
        let id = self
            .inner
            .add_channel(schema_id, topic, message_encoding, &BTreeMap::new())
            .map_err(|e| failed(&self.path, e))?;
        self.channels.push((id, None, 0));
        Ok(self.channels.len() - 1)
    }

    /// Encodes and writes one message of a CDR channel; `log_time` in nanoseconds.
    pub fn write(&mut self, channel: usize, log_time: u64, message: &Value) -> Result<()> {
        let Some(schema) = &self.channels[channel].1 else {
            return Err(Error::Failed(format!(
                "writing {}: channel {channel} takes encoded messages",
                self.path
            )));
        };
        let data = cdr::encode(schema, message)
            .map_err(|e| Error::Failed(format!("encoding for {}: {e}", schema.root().name)))?;
        self.write_raw(channel, log_time, &data)
    }

    /// Writes one already encoded message.
    pub fn write_raw(&mut self, channel: usize, log_time: u64, data: &[u8]) -> Result<()> {
        let (id, _, sequence) = &mut self.channels[channel];
        let header = mcap::records::MessageHeader {
            channel_id: *id,
            sequence: *sequence,
            log_time,
            publish_time: log_time,
        };
        *sequence += 1;
        self.inner
            .write_to_known_channel(&header, data)
            .map_err(|e| failed(&self.path, e))
    }

    fn finish(mut self) -> Result<()> {
        self.inner.finish().map_err(|e| failed(&self.path, e))?;
        Ok(())
    }
}

/// Writes the log at `path` atomically: `fill` declares channels and writes messages.
pub fn write_log(
    path: &Path,
    fill: impl FnOnce(&mut LogWriter<&mut BufWriter<NamedTempFile>>) -> Result<()>,
) -> Result<()> {
    write_atomic_seekable(path, |out| {
        let mut writer = LogWriter::new(out, path)?;
        fill(&mut writer)?;
        writer.finish()
    })
}

/// How [`write_demonstration_log`] lays out a log.
pub struct DemonstrationLog {
    /// Log time of the first message, nanoseconds.
    pub start_ns: u64,
    /// Silence between episodes, nanoseconds.
    pub gap_ns: u64,
    /// Odometry frame; when it differs from the map's, a `/tf_static` transform
    /// `map_to_odom` (odom's pose in the map frame) relates them.
    pub odom_frame: String,
    pub map_to_odom: super::frames::Planar,
}

/// Writes `map` and its demonstrations as a ROS 2 log, the way a robot would record
/// them: `/map` (grid_map_msgs/msg/GridMap) once, then per episode a `/goal`
/// (geometry_msgs/msg/PoseStamped, the episode's last pose) and its poses on `/odom`
/// (nav_msgs/msg/Odometry) at their times, in `odom_frame`.
pub fn write_demonstration_log(
    path: &Path,
    map: &crate::grid::Map,
    demonstrations: &[&crate::grid::Demonstration],
    layout: &DemonstrationLog,
) -> Result<()> {
    use super::ros2;
    let map_frame = map.geo.frame.clone();
    write_log(path, |log| {
        let map_channel = log.channel(
            "/map",
            "grid_map_msgs/msg/GridMap",
            &ros2::schemas::grid_map(),
        )?;
        let goal_channel = log.channel(
            "/goal",
            "geometry_msgs/msg/PoseStamped",
            &ros2::schemas::pose_stamped(),
        )?;
        let odom_channel =
            log.channel("/odom", "nav_msgs/msg/Odometry", &ros2::schemas::odometry())?;
        let mut now = layout.start_ns;
        log.write(map_channel, now, &ros2::grid_map(now, map))?;
        if layout.odom_frame != map_frame {
            let tf = log.channel(
                "/tf_static",
                "tf2_msgs/msg/TFMessage",
                &ros2::schemas::tf_message(),
            )?;
            let m = layout.map_to_odom;
            let message = ros2::tf_message(now, &map_frame, &layout.odom_frame, m.x, m.y, m.yaw);
            log.write(tf, now, &message)?;
        }
        let odom_from_map = layout.map_to_odom.inverse();
        for demo in demonstrations {
            now += layout.gap_ns;
            let goal = demo.poses.last().expect("demonstrations have poses");
            let goal_message =
                ros2::pose_stamped(now, &map_frame, goal.x, goal.y, goal.yaw.unwrap_or(0.0));
            log.write(goal_channel, now, &goal_message)?;
            let start = now;
            for pose in &demo.poses {
                let t = start + (pose.t * 1e9).round() as u64;
                let p = odom_from_map.then_in(&super::frames::Planar {
                    x: pose.x,
                    y: pose.y,
                    yaw: pose.yaw.unwrap_or(0.0),
                });
                let message = ros2::odometry(t, &layout.odom_frame, "base_link", p.x, p.y, p.yaw);
                log.write(odom_channel, t, &message)?;
                now = now.max(t);
            }
        }
        Ok(())
    })
}
