//! Demonstrations from a robot log: which topic is the map and which the pose (found by
//! message type when not given), poses brought into the map's frame (`/tf`, `/tf_static`
//! or a fixed transform), cut into episodes per file, on time gaps or on a goal topic.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::frames::{FrameTree, Planar};
use super::inspect::describe_damage;
use super::reader::{ChannelInfo, MessageHeader, scan_messages};
use super::ros2::{self, GRID_TYPES, POSE_TYPES, StampedPose};
use super::{Decoders, Value};
use crate::error::{Error, Result};
use crate::grid::{Demonstration, Map, Pose};

/// How a log's poses are cut into episodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Split {
    /// The whole log is one episode.
    File,
    /// A new episode after a silence longer than the gap.
    Gap,
    /// A new episode at each message on the goal topic.
    Goal,
}

/// Which topics mean what, and how to cut episodes.
#[derive(Debug, Clone)]
pub struct TopicMapping {
    pub map_topic: Option<String>,
    pub pose_topic: Option<String>,
    pub goal_topic: Option<String>,
    pub split: Split,
    pub gap_seconds: f64,
    /// Pose frame into map frame, used when the log has no /tf linking them.
    pub transform: Option<Planar>,
    /// Keep what precedes damage in a log (warning on stderr) instead of failing.
    pub allow_truncated: bool,
}

/// What a log gives: its map (the last one on the map topic) and its episodes.
pub struct LogContents {
    pub map: Option<Map>,
    pub demonstrations: Vec<Demonstration>,
}

const TF_TOLERANCE_NS: u64 = 500_000_000;

/// A topic given by name, or the one channel whose type is among `types` (other than
/// the `taken` one: a goal topic of a pose type is not the pose topic).
fn pick_topic<'a>(
    given: Option<&'a str>,
    channels: &'a [(String, String)],
    types: &[&str],
    what: &str,
    taken: Option<&str>,
) -> std::result::Result<Option<&'a str>, String> {
    if let Some(topic) = given {
        return match channels.iter().find(|(t, _)| t == topic) {
            Some((_, schema)) if types.contains(&schema.as_str()) => Ok(Some(topic)),
            Some((_, schema)) => Err(format!(
                "{what} topic {topic} has type {schema}, not one of {}",
                types.join(", ")
            )),
            None => Err(format!(
                "no {what} topic {topic} (topics: {})",
                channels
                    .iter()
                    .map(|c| c.0.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        };
    }
    let candidates: Vec<&str> = channels
        .iter()
        .filter(|(topic, schema)| types.contains(&schema.as_str()) && Some(topic.as_str()) != taken)
        .map(|(t, _)| t.as_str())
        .collect();
    match candidates.as_slice() {
        [] => Ok(None),
        [one] => Ok(Some(one)),
        many => Err(format!(
            "several {what} topics ({}); say which",
            many.join(", ")
        )),
    }
}

/// Reads the log at `path`. A map in the log is named after the file (its stem); without
/// one, episodes lie on `fallback` (map name, frame). Episodes are named after the file
/// What one message of a log gives the demonstrations.
enum Found {
    Poses(Vec<StampedPose>),
    Map(Box<Map>),
    Goal(u64),
    Transforms {
        transforms: Vec<ros2::FrameTransform>,
        fixed: bool,
        /// Topic and message, for errors.
        at: String,
    },
}

/// too: `<stem>-demo-NNN`.
pub fn read_log(
    path: &Path,
    mapping: &TopicMapping,
    fallback: Option<(&str, &str)>,
) -> Result<LogContents> {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let problem = |message: String| Error::input(path, message);
    // First pass over the channel list (summary when present, else a scan) to find topics.
    let report = super::inspect::inspect(
        path,
        super::inspect::Source::Summary,
        mapping.allow_truncated,
    )?;
    let channels: Vec<(String, String)> = report
        .channels
        .iter()
        .map(|c| {
            (
                c.topic.clone(),
                ros2::canonical_type(&c.schema).into_owned(),
            )
        })
        .collect();
    let pose_topic = pick_topic(
        mapping.pose_topic.as_deref(),
        &channels,
        &POSE_TYPES,
        "pose",
        mapping.goal_topic.as_deref(),
    )
    .map_err(problem)?
    .ok_or_else(|| {
        problem(format!(
            "no pose topic: no channel has one of the types {}",
            POSE_TYPES.join(", ")
        ))
    })?
    .to_string();
    let map_topic = pick_topic(
        mapping.map_topic.as_deref(),
        &channels,
        &GRID_TYPES,
        "map",
        None,
    )
    .map_err(problem)?
    .map(str::to_string);
    let goal_topic = mapping.goal_topic.clone();
    if mapping.split == Split::Goal && goal_topic.is_none() {
        return Err(Error::Usage(
            "split on goal needs a goal topic (goal_topic)".into(),
        ));
    }
    if let Some(goal) = &goal_topic
        && !channels.iter().any(|(t, _)| t == goal)
    {
        return Err(problem(format!("no goal topic {goal} in the log")));
    }

    // Messages are decoded on all threads (`scan_messages`) and taken in log order.
    let decoders = Decoders::default();
    let decode = |channel: &ChannelInfo, sequence: u32, data: &[u8]| {
        decoders
            .get(channel)
            .and_then(|d| d.decode(data))
            .map_err(|e| problem(format!("topic {} message {sequence}: {e}", channel.topic)))
    };
    let prepare = |channel: &ChannelInfo, header: &MessageHeader, data: &[u8]| {
        let topic = channel.topic.as_str();
        let schema = ros2::canonical_type(channel.schema_name());
        let schema = schema.as_ref();
        let at = |e: String| problem(format!("topic {topic} message {}: {e}", header.sequence));
        Ok(Some(if topic == pose_topic {
            let message = decode(channel, header.sequence, data)?;
            Found::Poses(ros2::poses(schema, &message, header.log_time).map_err(at)?)
        } else if Some(topic) == map_topic.as_deref() {
            let message = decode(channel, header.sequence, data)?;
            Found::Map(Box::new(ros2::grid(schema, &message, &stem).map_err(at)?))
        } else if Some(topic) == goal_topic.as_deref() {
            Found::Goal(header.log_time)
        } else if (topic == "/tf" || topic == "/tf_static") && schema == "tf2_msgs/msg/TFMessage" {
            let message: Value = decode(channel, header.sequence, data)?;
            let transforms = ros2::transforms(&message, header.log_time).map_err(at)?;
            Found::Transforms {
                transforms,
                fixed: topic == "/tf_static",
                at: format!("topic {topic} message {}", header.sequence),
            }
        } else {
            return Ok(None);
        }))
    };
    let mut map = None;
    let mut poses: Vec<StampedPose> = Vec::new();
    let mut goals: Vec<u64> = Vec::new();
    let mut frames = FrameTree::default();
    let consume = |found: Found| {
        match found {
            Found::Poses(more) => poses.extend(more),
            Found::Map(grid) => map = Some(*grid),
            Found::Goal(time) => goals.push(time),
            Found::Transforms {
                transforms,
                fixed,
                at,
            } => {
                for transform in transforms {
                    frames
                        .add(transform, fixed)
                        .map_err(|e| problem(format!("{at}: {e}")))?;
                }
            }
        }
        Ok(())
    };
    if let Some(damage) = scan_messages(path, prepare, consume)? {
        if !mapping.allow_truncated {
            return Err(damage.into_error(path));
        }
        tracing::warn!(
            "{}: {}; ingesting what came before it",
            path.display(),
            describe_damage(&damage)
        );
    }
    frames.finish();

    let (map_name, target) = match (&map, fallback) {
        (Some(map), _) => (stem.as_str(), map.geo.frame.clone()),
        (None, Some((name, frame))) => (name, frame.to_string()),
        (None, None) => {
            return Err(problem(format!(
                "no map topic in the log (types {}) and no map given for it",
                GRID_TYPES.join(", ")
            )));
        }
    };
    let target = target.trim_start_matches('/').to_string();
    // Stable sort: poses of equal time keep log order.
    poses.sort_by_key(|p| p.time);
    for pose in &mut poses {
        let frame = pose.frame.trim_start_matches('/');
        if frame == target || frame.is_empty() {
            continue;
        }
        let transform = if !frames.is_empty() {
            frames
                .lookup(frame, &target, pose.time, TF_TOLERANCE_NS)
                .or_else(|e| mapping.transform.ok_or(e))
        } else {
            mapping.transform.ok_or_else(|| {
                "the log has no /tf or /tf_static and no fixed transform was given".to_string()
            })
        }
        .map_err(|e| {
            problem(format!(
                "poses on {pose_topic} are in frame '{frame}', the map is in frame '{target}': {e}"
            ))
        })?;
        let moved = transform.then_in(&Planar {
            x: pose.x,
            y: pose.y,
            yaw: pose.yaw,
        });
        (pose.x, pose.y, pose.yaw) = (moved.x, moved.y, moved.yaw);
    }

    let episodes = split(&poses, mapping, &goals);
    let mut demonstrations = Vec::with_capacity(episodes.len());
    for (i, episode) in episodes.into_iter().enumerate() {
        let name = format!("{stem}-demo-{i:03}");
        if episode.len() < 2 {
            return Err(problem(format!(
                "episode {name} (from {:.3} s) has {} pose(s); an episode needs at least 2",
                episode.first().map_or(0.0, |p| p.time as f64 * 1e-9),
                episode.len()
            )));
        }
        let start = episode[0].time;
        demonstrations.push(Demonstration {
            episode: name,
            map: map_name.to_string(),
            poses: episode
                .iter()
                .map(|p| Pose {
                    t: (p.time - start) as f64 * 1e-9,
                    x: p.x,
                    y: p.y,
                    yaw: Some(p.yaw),
                })
                .collect(),
        });
    }
    if demonstrations.is_empty() {
        return Err(problem(format!("no poses on {pose_topic}")));
    }
    Ok(LogContents {
        map,
        demonstrations,
    })
}

/// Cuts time-sorted poses into episodes.
fn split<'a>(
    poses: &'a [StampedPose],
    mapping: &TopicMapping,
    goals: &[u64],
) -> Vec<&'a [StampedPose]> {
    if poses.is_empty() {
        return Vec::new();
    }
    let mut cuts = vec![0];
    match mapping.split {
        Split::File => {}
        Split::Gap => {
            let gap = (mapping.gap_seconds * 1e9) as u64;
            for i in 1..poses.len() {
                if poses[i].time - poses[i - 1].time > gap {
                    cuts.push(i);
                }
            }
        }
        Split::Goal => {
            // Poses before the first goal belong to no episode.
            let mut goals = goals.to_vec();
            goals.sort_unstable();
            cuts = goals
                .iter()
                .map(|&g| poses.partition_point(|p| p.time < g))
                .collect();
            cuts.dedup();
        }
    }
    cuts.push(poses.len());
    cuts.windows(2)
        .map(|w| &poses[w[0]..w[1]])
        .filter(|episode| !episode.is_empty())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(time: u64) -> StampedPose {
        StampedPose {
            time,
            frame: "map".into(),
            x: 0.0,
            y: 0.0,
            yaw: 0.0,
        }
    }

    fn mapping(split: Split) -> TopicMapping {
        TopicMapping {
            map_topic: None,
            pose_topic: None,
            goal_topic: None,
            split,
            gap_seconds: 1.0,
            transform: None,
            allow_truncated: false,
        }
    }

    /// A log of odometry in frame `odom` with no /tf at all.
    fn odometry_log(dir: &Path) -> std::path::PathBuf {
        let path = dir.join("drive.mcap");
        super::super::writer::write_log(&path, |log| {
            let odom = log.channel("/odom", "nav_msgs/msg/Odometry", &ros2::schemas::odometry())?;
            for k in 0..5u64 {
                let t = 1_000_000_000 * (k + 1);
                let message = ros2::odometry(t, "odom", "base_link", k as f64, 0.0, 0.0);
                log.write(odom, t, &message)?;
            }
            Ok(())
        })
        .unwrap();
        path
    }

    #[test]
    fn poses_in_another_frame_need_tf_or_a_fixed_transform() {
        let dir = tempfile::tempdir().unwrap();
        let path = odometry_log(dir.path());
        let err = read_log(&path, &mapping(Split::File), Some(("field", "map")))
            .err()
            .unwrap()
            .to_string();
        assert!(
            err.contains("drive.mcap") && err.contains("'odom'") && err.contains("'map'"),
            "{err}"
        );
        let mut shifted = mapping(Split::File);
        shifted.transform = Some(Planar {
            x: 10.0,
            y: 0.0,
            yaw: std::f64::consts::FRAC_PI_2,
        });
        let contents = read_log(&path, &shifted, Some(("field", "map"))).unwrap();
        let demo = &contents.demonstrations[0];
        assert_eq!(demo.episode, "drive-demo-000");
        assert_eq!(demo.map, "field");
        // odom (3, 0) turned a quarter and shifted: map (10, 3).
        let p = demo.poses[3];
        assert!(
            (p.x - 10.0).abs() < 1e-9 && (p.y - 3.0).abs() < 1e-9,
            "{p:?}"
        );
        assert!((p.t - 3.0).abs() < 1e-9);
    }

    #[test]
    fn topics_ingest_does_not_need_are_never_decoded() {
        // Odometry beside messages that cannot be decoded: ROS 1 strings cut short and a
        // rosbag2 service event whose bytes do not match its schema.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("mixed.mcap");
        super::super::writer::write_log(&path, |log| {
            let odom = log.channel("/odom", "nav_msgs/msg/Odometry", &ros2::schemas::odometry())?;
            let ros1 = log.raw_channel(
                "/chatter",
                "std_msgs/String",
                "ros1msg",
                b"string data",
                "ros1",
            )?;
            let event = log.raw_channel(
                "/add/_service_event",
                "example_interfaces/srv/AddTwoInts_Event",
                "ros2msg",
                b"service_msgs/ServiceEventInfo info\nAddTwoInts_Request[<=1] request",
                "cdr",
            )?;
            for k in 0..5u64 {
                let t = 1_000_000_000 * (k + 1);
                log.write(
                    odom,
                    t,
                    &ros2::odometry(t, "map", "base_link", k as f64, 0.0, 0.0),
                )?;
                log.write_raw(ros1, t, &[9, 0, 0, 0, b'a'])?;
                log.write_raw(event, t, &[0xff; 3])?;
            }
            Ok(())
        })
        .unwrap();
        let contents = read_log(&path, &mapping(Split::File), Some(("field", "map"))).unwrap();
        assert_eq!(contents.demonstrations.len(), 1);
        assert_eq!(contents.demonstrations[0].poses.len(), 5);
    }

    #[test]
    fn splits_per_file_on_gaps_and_on_goals() {
        let s = 1_000_000_000;
        let poses: Vec<_> = [0, s / 2, s, 3 * s, 3 * s + 1, 10 * s].map(pose).to_vec();
        let lengths = |split: Split, goals: &[u64]| -> Vec<usize> {
            super::split(&poses, &mapping(split), goals)
                .iter()
                .map(|e| e.len())
                .collect()
        };
        assert_eq!(lengths(Split::File, &[]), vec![6]);
        assert_eq!(lengths(Split::Gap, &[]), vec![3, 2, 1]);
        assert_eq!(lengths(Split::Goal, &[s / 4, 3 * s]), vec![2, 3]);
    }
}
