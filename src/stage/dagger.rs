//! `dagger`: N rounds of DAgger (or behaviour cloning) against a built-in simulator, in
//! a pipeline. Out comes a policy artifact: the selected policy (`policy.json`), every
//! round's policy (`policies/round-NNN.json`), the aggregated dataset the rounds wrote
//! (`dataset/`, the layout of `imitate dagger`), and per round the labels gathered and
//! the falls per lap on validation laps.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::{Stage, StageReport, commit_artifact, resolved};
use crate::artifact::ArtifactBuilder;
use crate::dagger::dataset::{Dataset, DatasetInfo, NewRound};
use crate::dagger::{Aggregate, BetaSchedule, Policy, PolicyKind, PolicyLearner, track_round};
use crate::error::{Error, Result};
use crate::io::fs::{to_json_bytes, write_bytes_atomic};
use crate::sim::track::OBSERVATION_NAMES;
use crate::sim::{Track, TrackConfig};

pub const KIND: &str = "dagger";
/// 2: episodes per round, each from its own random stream.
const VERSION: u32 = 2;

/// Which policy the artifact returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Selection {
    /// The round's policy with the fewest falls per lap on the validation laps (the
    /// later round on ties).
    Best,
    /// The uniform mixture of every round's policy.
    Mixture,
    /// The last round's policy.
    Last,
}

mod defaults {
    pub fn rounds() -> usize {
        10
    }
    pub fn episodes() -> usize {
        1
    }
    pub fn laps() -> usize {
        1
    }
    pub fn beta() -> crate::dagger::BetaSchedule {
        crate::dagger::BetaSchedule::FirstRound
    }
    pub fn learner() -> crate::dagger::PolicyKind {
        crate::dagger::PolicyKind::Tree
    }
    pub fn depth() -> usize {
        3
    }
    pub fn lambda() -> f64 {
        1e-3
    }
    pub fn selection() -> super::Selection {
        super::Selection::Best
    }
    pub fn validation_laps() -> usize {
        3
    }
}

/// Parameters of `uses: dagger`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DaggerParams {
    /// The simulator: `track`.
    pub env: String,
    #[serde(default = "defaults::rounds")]
    pub rounds: usize,
    /// Episodes per round, driven in parallel (each from its own seeded stream, so the
    /// round is the same at any thread count).
    #[serde(default = "defaults::episodes")]
    pub episodes: usize,
    /// Laps per episode (the teacher labels every step).
    #[serde(default = "defaults::laps")]
    pub laps: usize,
    /// β schedule: {kind: first-round}, {kind: linear, rounds: N}, {kind: exponential, p: P}.
    #[serde(default = "defaults::beta")]
    pub beta: BetaSchedule,
    /// Behaviour cloning instead of DAgger: the teacher drives every round.
    #[serde(default)]
    pub supervised: bool,
    #[serde(default = "defaults::learner")]
    pub learner: PolicyKind,
    #[serde(default = "defaults::depth")]
    pub depth: usize,
    #[serde(default = "defaults::lambda")]
    pub lambda: f64,
    #[serde(default = "defaults::selection")]
    pub selection: Selection,
    #[serde(default = "defaults::validation_laps")]
    pub validation_laps: usize,
    #[serde(default)]
    pub seed: u64,
    pub out: PathBuf,
}

#[derive(Serialize)]
struct RoundMetrics {
    round: usize,
    beta: f64,
    steps: u64,
    learner_steps: u64,
    falls_while_gathering: u64,
    validation_falls_per_lap: f64,
}

impl DaggerParams {
    fn validate(&self) -> Result<()> {
        let bad = |what: &str| Err(Error::Usage(format!("dagger: {what}")));
        if self.env != "track" {
            return bad(&format!(
                "env '{}' is not a simulator imitate has (track)",
                self.env
            ));
        }
        if self.rounds == 0 || self.episodes == 0 || self.laps == 0 || self.validation_laps == 0 {
            return bad("rounds, episodes, laps and validation_laps must be at least 1");
        }
        if self.learner == PolicyKind::Logistic {
            return bad("the track's steering is continuous: learner ridge or tree");
        }
        if !(1..=16).contains(&self.depth) {
            return bad("depth must be in 1..=16");
        }
        if !(self.lambda.is_finite() && self.lambda >= 0.0) {
            return bad("lambda must be >= 0");
        }
        if let BetaSchedule::Exponential { p } = self.beta
            && !(0.0..=1.0).contains(&p)
        {
            return bad("beta p must be in [0, 1]");
        }
        Ok(())
    }

    fn learner(&self) -> PolicyLearner {
        self.learner.learner(self.depth, self.lambda, 0)
    }
}

impl Stage for DaggerParams {
    fn kind(&self) -> &'static str {
        KIND
    }

    fn version(&self) -> u32 {
        VERSION
    }

    fn params(&self) -> serde_json::Value {
        resolved(self)
    }

    fn deps(&self) -> Vec<PathBuf> {
        Vec::new()
    }

    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport> {
        self.validate()?;
        let learner = self.learner();
        let track = Track::new(TrackConfig::default());
        let mut out = ArtifactBuilder::new(&self.out)?;
        let dataset_dir = out
            .file("dataset/meta/info.json", "dataset-info")?
            .parent()
            .and_then(|meta| meta.parent())
            .expect("dataset/meta/info.json has two parents")
            .to_path_buf();
        let mut dataset = Dataset::create(
            &dataset_dir,
            DatasetInfo {
                schema: "imitate.dagger-dataset/1".into(),
                observation_names: OBSERVATION_NAMES.map(String::from).to_vec(),
                environment: "track".into(),
                costs: None,
            },
        )?;
        let mut aggregate = Aggregate::new(OBSERVATION_NAMES.len(), &learner);
        let mut policies: Vec<Policy> = Vec::new();
        let mut metrics = Vec::new();
        let validation_seed = self.seed.wrapping_add(0x5eed);
        for round in 0..self.rounds {
            let beta = if self.supervised {
                1.0
            } else {
                self.beta.beta(round)
            };
            let driver = if self.supervised {
                None
            } else {
                policies.last()
            };
            let episodes = track_round(
                &track,
                driver,
                beta,
                self.laps,
                self.episodes,
                self.seed,
                round,
            );
            let number = dataset.append(&NewRound {
                source: format!("round {round}"),
                beta,
                policy: String::new(),
                teacher: "pure-pursuit".into(),
                period: track.config.period,
                timestamps: None,
                episodes: &episodes,
            })?;
            // Train on what the dataset holds (as `imitate dagger train` would).
            let written = dataset.round_steps(number)?;
            for i in 0..written.len() {
                aggregate.add(written.observation(i), written.labels[i]);
            }
            let policy = aggregate.fit(&learner);
            let info = &dataset.rounds[number as usize];
            metrics.push(RoundMetrics {
                round,
                beta,
                steps: info.steps,
                learner_steps: info.learner_steps,
                falls_while_gathering: info.failures,
                validation_falls_per_lap: track.falls_per_lap(
                    self.validation_laps,
                    validation_seed,
                    |s| policy.act(&s.observation()),
                ),
            });
            write_bytes_atomic(
                &out.file(&format!("policies/round-{round:03}.json"), "round-policy")?,
                &to_json_bytes(&policy),
            )?;
            policies.push(policy);
        }
        for file in ["manifest.json", "meta/rounds.parquet"] {
            out.file(&format!("dataset/{file}"), "dataset")?;
        }
        for info in &dataset.rounds {
            out.file(
                &format!("dataset/data/round={:03}/part-000.parquet", info.round),
                "dataset",
            )?;
        }
        let falls: Vec<f64> = metrics.iter().map(|m| m.validation_falls_per_lap).collect();
        let (selected, selected_falls, chosen_round) = match self.selection {
            Selection::Last => (
                policies[policies.len() - 1].clone(),
                falls[falls.len() - 1],
                Some(policies.len() - 1),
            ),
            Selection::Best => {
                let best = (0..falls.len())
                    .rev()
                    .min_by(|&a, &b| falls[a].total_cmp(&falls[b]))
                    .expect("at least one round");
                (policies[best].clone(), falls[best], Some(best))
            }
            // Each episode runs one member drawn uniformly: its expected falls per lap
            // are the members' mean.
            Selection::Mixture => (
                Policy::Mixture {
                    members: policies.clone(),
                },
                falls.iter().sum::<f64>() / falls.len() as f64,
                None,
            ),
        };
        write_bytes_atomic(
            &out.file("policy.json", "policy")?,
            &to_json_bytes(&selected),
        )?;
        let teacher = track.falls_per_lap(self.validation_laps, validation_seed, |s| s.teacher());
        let summary_metrics = serde_json::json!({
            "selection": self.selection,
            "selected_round": chosen_round,
            "validation_falls_per_lap": selected_falls,
            "teacher_falls_per_lap": teacher,
            "labels": dataset.steps(),
        });
        let all_metrics = serde_json::json!({
            "schema": "imitate.dagger-metrics/1",
            "summary": summary_metrics,
            "rounds": metrics,
        });
        write_bytes_atomic(
            &out.file("metrics.json", "metrics")?,
            &to_json_bytes(&all_metrics),
        )?;
        let summary = format!(
            "{} rounds, {} labels; {} policy{}: {:.2} falls per lap on {} validation laps (teacher {:.2})",
            self.rounds,
            dataset.steps(),
            serde_json::to_value(self.selection)
                .expect("names")
                .as_str()
                .unwrap_or(""),
            chosen_round
                .map(|r| format!(" (round {r})"))
                .unwrap_or_default(),
            selected_falls,
            self.validation_laps,
            teacher
        );
        commit_artifact(self, extra_deps, out, "policy", summary_metrics, summary)
    }
}
