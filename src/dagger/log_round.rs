//! A DAgger round from a robot log: the learner drove, the teacher's corrections were
//! recorded on their own topic and not executed. Each observation message becomes a
//! step when an executed-action message and a label message lie within a tolerance of
//! it in time (the nearest of each; an as-of join both ways). Observations without a
//! label or without an executed action are counted, not kept. The join is polars'
//! (`query.rs`).
//!
//! Without an action topic the log is an expert demonstration: the teacher drove, and
//! its label is also the executed action.
//!
//! Messages become numbers by their numeric fields in schema order (a top-level
//! `header` left out), so any message type works: a custom observation message, or
//! `std_msgs/msg/Float64` / `Float32` for the actions.

use std::path::Path;

use super::query::nearest_within;
use super::{Actor, Step};
use crate::error::{Error, Result};
use crate::io::mcap::inspect::{Source, inspect};
use crate::io::mcap::reader::{ChannelInfo, MessageHeader, scan_messages};
use crate::io::mcap::{Decoders, Value};

/// Which topics hold what, and how far apart in time a match may be.
#[derive(Debug, Clone)]
pub struct LogTopics {
    pub observation: String,
    /// The executed action; `None` when the teacher drove (a demonstration).
    pub action: Option<String>,
    pub label: String,
    pub tolerance_ns: u64,
}

/// The steps read from a log, and what could not be matched.
#[derive(Debug, Clone, PartialEq)]
pub struct LogRound {
    pub steps: Vec<Step>,
    /// Per step: seconds since the first observation.
    pub times: Vec<f64>,
    pub observations: usize,
    /// Observations with no label message within the tolerance.
    pub unlabelled: usize,
    /// Observations with no executed-action message within the tolerance.
    pub without_action: usize,
}

/// Appends the numeric leaves of `value` to `out`.
fn numbers(value: &Value, out: &mut Vec<f64>) {
    match value {
        Value::Int(_) | Value::Uint(_) | Value::Float32(_) | Value::Float64(_) => {
            out.extend(value.as_f64())
        }
        Value::Struct { values, .. } => values.iter().for_each(|v| numbers(v, out)),
        Value::List(items) => items.iter().for_each(|v| numbers(v, out)),
        Value::Int8s(v) => out.extend(v.iter().map(|&x| f64::from(x))),
        Value::Uint8s(v) => out.extend(v.iter().map(|&x| f64::from(x))),
        Value::Int16s(v) => out.extend(v.iter().map(|&x| f64::from(x))),
        Value::Uint16s(v) => out.extend(v.iter().map(|&x| f64::from(x))),
        Value::Int32s(v) => out.extend(v.iter().map(|&x| f64::from(x))),
        Value::Uint32s(v) => out.extend(v.iter().map(|&x| f64::from(x))),
        Value::Int64s(v) => out.extend(v.iter().map(|&x| x as f64)),
        Value::Uint64s(v) => out.extend(v.iter().map(|&x| x as f64)),
        Value::Float32s(v) => out.extend(v.iter().map(|&x| f64::from(x))),
        Value::Float64s(v) => out.extend_from_slice(v),
        Value::Null | Value::Bool(_) | Value::String(_) | Value::Bools(_) => {}
    }
}

/// The message's numbers, its top-level `header` (stamps, frame) left out.
fn message_numbers(message: &Value) -> Vec<f64> {
    let mut out = Vec::new();
    match message {
        Value::Struct { names, values } => {
            for (name, value) in names.iter().zip(values) {
                if &**name != "header" {
                    numbers(value, &mut out);
                }
            }
        }
        other => numbers(other, &mut out),
    }
    out
}

/// Reads the round from the log at `path`, whose actions hold `actions` numbers.
pub fn read_log_round(path: &Path, topics: &LogTopics, actions: usize) -> Result<LogRound> {
    let demonstration = topics.action.is_none();
    let action_topic = topics
        .action
        .clone()
        .unwrap_or_else(|| topics.label.clone());
    let wanted = [&topics.observation, &action_topic, &topics.label];
    // The channel list (the summary when there is one) names a missing topic before
    // any message is decoded.
    let seen: std::collections::BTreeSet<String> = inspect(path, Source::Summary, false)?
        .channels
        .into_iter()
        .map(|c| c.topic)
        .collect();
    for topic in wanted {
        if !seen.contains(topic.as_str()) {
            return Err(Error::input(
                path,
                format!(
                    "has no topic {topic} (its topics: {})",
                    seen.iter().cloned().collect::<Vec<_>>().join(", ")
                ),
            ));
        }
    }
    // Messages are decoded on all threads (`scan_messages`) and taken in log order:
    // each as (log time, numbers) for the series it belongs to (observation, action,
    // label; with no action topic the label topic gives the executed action too).
    let decoders = Decoders::default();
    let prepare = |channel: &ChannelInfo, header: &MessageHeader, data: &[u8]| {
        let series: Vec<usize> = (0..3).filter(|&k| *wanted[k] == channel.topic).collect();
        if series.is_empty() {
            return Ok(None);
        }
        let at = |e: String| {
            Error::input(
                path,
                format!("topic {} message {}: {e}", channel.topic, header.sequence),
            )
        };
        let message = decoders
            .get(channel)
            .and_then(|d| d.decode(data))
            .map_err(at)?;
        let values = message_numbers(&message);
        if series.iter().any(|&k| k > 0) && values.len() != actions {
            return Err(at(format!(
                "the dataset's actions hold {actions} numbers, this message has {}",
                values.len()
            )));
        }
        Ok(Some((series, header.log_time, values)))
    };
    let mut series: [Vec<(u64, Vec<f64>)>; 3] = Default::default();
    let consume = |(ks, time, values): (Vec<usize>, u64, Vec<f64>)| {
        if let Some((&last, others)) = ks.split_last() {
            for &k in others {
                series[k].push((time, values.clone()));
            }
            series[last].push((time, values));
        }
        Ok(())
    };
    if let Some(damage) = scan_messages(path, prepare, consume)? {
        return Err(damage.into_error(path));
    }
    for s in &mut series {
        s.sort_by_key(|(t, _)| *t);
    }
    let [observations, executed, labels] = series;
    let times_of = |series: &[(u64, Vec<f64>)]| series.iter().map(|(t, _)| *t).collect::<Vec<_>>();
    let observation_times = times_of(&observations);
    let nearest_label =
        nearest_within(&observation_times, &times_of(&labels), topics.tolerance_ns)?;
    let nearest_action = nearest_within(
        &observation_times,
        &times_of(&executed),
        topics.tolerance_ns,
    )?;
    let (mut steps, mut times, mut unlabelled, mut without_action) = (Vec::new(), Vec::new(), 0, 0);
    let first = observations.first().map_or(0, |(t, _)| *t);
    for (k, (t, observation)) in observations.iter().enumerate() {
        match (nearest_label[k], nearest_action[k]) {
            (None, _) => unlabelled += 1,
            (_, None) => without_action += 1,
            (Some(l), Some(a)) => {
                steps.push(Step {
                    observation: observation.clone(),
                    label: labels[l].1.clone(),
                    executed: executed[a].1.clone(),
                    actor: if demonstration {
                        Actor::Teacher
                    } else {
                        Actor::Learner
                    },
                    failed: false,
                });
                times.push((t - first) as f64 * 1e-9);
            }
        }
    }
    Ok(LogRound {
        steps,
        times,
        observations: observations.len(),
        unlabelled,
        without_action,
    })
}
