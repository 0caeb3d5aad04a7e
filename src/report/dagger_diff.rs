//! What changed between two policies (their actions on the same states, and their
//! falls on the same laps) and between two DAgger datasets (rounds, steps, schema).

use std::collections::BTreeMap;
use std::path::Path;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::dagger::Policy;
use crate::dagger::dataset::Dataset;
use crate::error::Result;
use crate::sim::track::OBSERVATION_NAMES;
use crate::sim::{Track, TrackConfig, TrackSim};

#[derive(Debug, Clone, Serialize)]
pub struct PolicyDiff {
    /// The states both policies were asked about.
    pub states: usize,
    pub mean_abs_action: f64,
    pub max_abs_action: f64,
    /// Share of states where the actions differ by more than the tolerance.
    pub disagreement_share: f64,
    /// Falls per lap of each on the same laps (track policies only).
    pub old_falls_per_lap: Option<f64>,
    pub new_falls_per_lap: Option<f64>,
}

/// The observations of a lap the teacher drives (seeded noise): the states a lane
/// keeper is asked about.
fn track_states(track: &Track) -> Vec<Vec<f64>> {
    let mut sim = TrackSim::new(track, 0.0);
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let mut states = Vec::new();
    while sim.laps() < 1.0 && states.len() < track.step_cap(1.0) {
        states.push(sim.observation().to_vec());
        let u = sim.teacher();
        sim.step(u, &mut rng);
    }
    states
}

/// Compares two track policies (observations as `OBSERVATION_NAMES`): their actions on
/// a teacher's lap, and their falls per lap on 3 laps.
pub fn policy_diff(old: &Policy, new: &Policy, tolerance: f64) -> PolicyDiff {
    let track = Track::new(TrackConfig::default());
    let states = track_states(&track);
    let differences: Vec<f64> = states
        .iter()
        .map(|x| (old.act(x) - new.act(x)).abs())
        .collect();
    let n = differences.len().max(1) as f64;
    let falls = |p: &Policy| {
        let member = p.for_episode(&mut ChaCha8Rng::seed_from_u64(0));
        track.falls_per_lap(3, 23, |s| member.act(&s.observation()))
    };
    PolicyDiff {
        states: states.len(),
        mean_abs_action: differences.iter().sum::<f64>() / n,
        max_abs_action: differences.iter().cloned().fold(0.0, f64::max),
        disagreement_share: differences.iter().filter(|&&d| d > tolerance).count() as f64 / n,
        old_falls_per_lap: Some(falls(old)),
        new_falls_per_lap: Some(falls(new)),
    }
}

/// Whether a policy reads track observations (and can be compared on the track).
pub fn is_track_policy(dir: &Path) -> bool {
    let metrics = std::fs::read(dir.join("metrics.json"))
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok());
    match metrics {
        Some(m) if m.get("observation_names").is_some() => {
            m["observation_names"] == serde_json::json!(OBSERVATION_NAMES)
        }
        // The dagger stage's artifacts: version 1 drove only the track, version 2 says.
        Some(m) => match m.get("schema").and_then(|s| s.as_str()) {
            Some("imitate.dagger-metrics/1") => true,
            Some("imitate.dagger-metrics/2") => m["summary"]["env"] == "track",
            _ => false,
        },
        None => false,
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct DatasetDiff {
    pub old_rounds: usize,
    pub new_rounds: usize,
    /// Sources in the new dataset and not the old (by round number in the new).
    pub rounds_added: Vec<u32>,
    /// Sources in the old dataset and not the new.
    pub rounds_removed: Vec<u32>,
    pub old_steps: u64,
    pub new_steps: u64,
    pub schema_changed: bool,
}

pub fn dataset_diff(old_dir: &Path, new_dir: &Path) -> Result<DatasetDiff> {
    let (old, new) = (Dataset::open(old_dir)?, Dataset::open(new_dir)?);
    let sources = |d: &Dataset| -> BTreeMap<String, u32> {
        d.rounds
            .iter()
            .map(|r| (r.source.clone(), r.round))
            .collect()
    };
    let (a, b) = (sources(&old), sources(&new));
    Ok(DatasetDiff {
        old_rounds: old.rounds.len(),
        new_rounds: new.rounds.len(),
        rounds_added: b
            .iter()
            .filter(|(s, _)| !a.contains_key(*s))
            .map(|(_, r)| *r)
            .collect(),
        rounds_removed: a
            .iter()
            .filter(|(s, _)| !b.contains_key(*s))
            .map(|(_, r)| *r)
            .collect(),
        old_steps: old.steps(),
        new_steps: new.steps(),
        schema_changed: old.info.observation_names != new.info.observation_names,
    })
}

/// The numbers thresholds can test (`--fail-if`), by name.
pub fn dagger_summary(
    policies: Option<&PolicyDiff>,
    datasets: Option<&DatasetDiff>,
    out: &mut BTreeMap<String, f64>,
) {
    if let Some(p) = policies {
        out.insert("policy_mean_abs_action".into(), p.mean_abs_action);
        out.insert("policy_max_abs_action".into(), p.max_abs_action);
        out.insert("policy_disagreement_share".into(), p.disagreement_share);
        if let (Some(a), Some(b)) = (p.old_falls_per_lap, p.new_falls_per_lap) {
            out.insert("delta_falls_per_lap".into(), b - a);
        }
    }
    if let Some(d) = datasets {
        out.insert("rounds_added".into(), d.rounds_added.len() as f64);
        out.insert("rounds_removed".into(), d.rounds_removed.len() as f64);
        out.insert(
            "steps_added".into(),
            d.new_steps as f64 - d.old_steps as f64,
        );
        out.insert(
            "schema_changed".into(),
            f64::from(u8::from(d.schema_changed)),
        );
    }
}
