//! `dagger`: N rounds of DAgger (or behaviour cloning) against a built-in simulator
//! (`track`, or `gridnav` on a costmap another stage or file provides), in a pipeline.
//! Out comes a policy artifact: the selected policy (`policy.json`), every round's policy
//! (`policies/round-NNN.json`), the aggregated dataset the rounds wrote (`dataset/`, the
//! layout of `imitate dagger`), and per round the labels gathered and the validation:
//! falls per lap on the track, success rate and path-cost ratio on gridnav, in
//! metrics.json and charted against the teacher's in validation.png.

use std::path::PathBuf;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::{StageParams, StageReport, commit_artifact};
use crate::artifact::{ArtifactBuilder, load_costs};
use crate::dagger::dataset::{Dataset, DatasetInfo, NewRound};
use crate::dagger::{
    Aggregate, BetaSchedule, Policy, PolicyKind, PolicyLearner, Step, forward_training,
    gridnav_round, track_round,
};
use crate::error::{Error, Result};
use crate::grid::{Cell, Grid};
use crate::io::fs::{to_json_bytes, write_bytes_atomic};
use crate::io::png::{Rgb, write_png};
use crate::report::chart::{Chart, Legend, Series};
use crate::report::picture::side_by_side;
use crate::sim::gridnav::{self, evaluate, random_episode};
use crate::sim::{Track, TrackConfig, TrackSim, track};

pub const KIND: &str = "dagger";
/// 2: episodes per round, each from its own random stream; gridnav; forward training;
/// metrics/2. 3: validation.png.
const VERSION: u32 = 3;

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
    pub fn validation_pairs() -> usize {
        20
    }
}

/// Parameters of `uses: dagger`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DaggerParams {
    /// The simulator: `track` (continuous steering) or `gridnav` (8 moves on `costs`).
    pub env: String,
    /// For gridnav: the true costmap (as `imitate plan` takes it); a
    /// dependency, so the stage reruns when it changes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub costs: Option<PathBuf>,
    /// For gridnav and an artifact of several maps: which one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map: Option<String>,
    #[serde(default = "defaults::rounds")]
    pub rounds: usize,
    /// Episodes per round, driven in parallel (each from its own seeded stream, so the
    /// round is the same at any thread count).
    #[serde(default = "defaults::episodes")]
    pub episodes: usize,
    /// Track: laps per episode (the teacher labels every step). A gridnav episode
    /// walks from a random start to a random goal.
    #[serde(default = "defaults::laps")]
    pub laps: usize,
    /// β schedule: {kind: first-round}, {kind: linear, rounds: N}, {kind: exponential, p: P}.
    #[serde(default = "defaults::beta")]
    pub beta: BetaSchedule,
    /// Behaviour cloning instead of DAgger: the teacher drives every round.
    #[serde(default)]
    pub supervised: bool,
    /// Forward training instead (track only): one policy per step of a lap from the start
    /// line, step t's fitted on the states `episodes` episodes driven by the earlier
    /// steps' policies reach at t. Round t of the dataset holds step t's labels; the
    /// policy is the sequence (`rounds`, `beta` and `selection` do not apply).
    #[serde(default)]
    pub forward: bool,
    #[serde(default = "defaults::learner")]
    pub learner: PolicyKind,
    #[serde(default = "defaults::depth")]
    pub depth: usize,
    #[serde(default = "defaults::lambda")]
    pub lambda: f64,
    #[serde(default = "defaults::selection")]
    pub selection: Selection,
    /// Track: laps each round's policy drives for validation.
    #[serde(default = "defaults::validation_laps")]
    pub validation_laps: usize,
    /// Gridnav: start/goal pairs each round's policy walks for validation.
    #[serde(default = "defaults::validation_pairs")]
    pub validation_pairs: usize,
    #[serde(default)]
    pub seed: u64,
    pub out: PathBuf,
}

/// How well a policy drove its validation episodes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(untagged)]
enum Validation {
    Track {
        validation_falls_per_lap: f64,
    },
    Gridnav {
        validation_success_rate: f64,
        /// Mean path cost over the teacher's on the pairs reached (NaN when none).
        validation_cost_ratio: f64,
    },
}

impl Validation {
    /// Smaller is better: falls; or failures, then path cost.
    fn key(&self) -> (f64, f64) {
        match *self {
            Validation::Track {
                validation_falls_per_lap,
            } => (validation_falls_per_lap, 0.0),
            Validation::Gridnav {
                validation_success_rate,
                validation_cost_ratio,
            } => (
                -validation_success_rate,
                if validation_cost_ratio.is_nan() {
                    f64::INFINITY
                } else {
                    validation_cost_ratio
                },
            ),
        }
    }

    /// The expected validation of the uniform mixture (each episode runs one member).
    fn mean(all: &[Validation]) -> Validation {
        let mean = |values: &[f64]| values.iter().sum::<f64>() / values.len() as f64;
        let (mut falls, mut rates, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
        for validation in all {
            match *validation {
                Validation::Track {
                    validation_falls_per_lap,
                } => falls.push(validation_falls_per_lap),
                Validation::Gridnav {
                    validation_success_rate,
                    validation_cost_ratio,
                } => {
                    rates.push(validation_success_rate);
                    // Members that reached no goal have no cost ratio.
                    if validation_cost_ratio.is_finite() {
                        ratios.push(validation_cost_ratio);
                    }
                }
            }
        }
        if rates.is_empty() {
            Validation::Track {
                validation_falls_per_lap: mean(&falls),
            }
        } else {
            Validation::Gridnav {
                validation_success_rate: mean(&rates),
                validation_cost_ratio: mean(&ratios),
            }
        }
    }
}

/// The validation of every round's policy as charts, the teacher's as a flat line:
/// falls per lap on the track; share of goals reached and path cost on gridnav.
fn validation_charts(rounds: &[RoundMetrics], teacher: &Validation) -> Result<Rgb> {
    let per_round = |value: fn(&Validation) -> f64| -> Vec<(f64, f64)> {
        (rounds.iter())
            .map(|m| (m.round as f64, value(&m.validation)))
            .collect()
    };
    let flat = |value: f64| -> Vec<(f64, f64)> {
        rounds.iter().map(|m| (m.round as f64, value)).collect()
    };
    let chart = |title: &str, y_label: &str, value: fn(&Validation) -> f64, legend| {
        Chart {
            title: title.into(),
            x_label: "DAgger round".into(),
            y_label: y_label.into(),
            series: vec![
                Series {
                    name: "the round's policy".into(),
                    points: per_round(value),
                    colour: [200, 30, 30],
                },
                Series {
                    name: "teacher".into(),
                    points: flat(value(teacher)),
                    colour: [40, 80, 200],
                },
            ],
            legend,
        }
        .draw(420, 280)
        .map_err(Error::Failed)
    };
    Ok(match teacher {
        Validation::Track { .. } => chart(
            "Falls on the validation laps",
            "falls per lap",
            |v| v.key().0,
            Legend::UpperRight,
        )?,
        Validation::Gridnav { .. } => side_by_side(
            &[
                &chart(
                    "Goals reached on validation pairs",
                    "share of pairs reached",
                    |v| -v.key().0,
                    Legend::LowerRight,
                )?,
                &chart(
                    "Path cost on the pairs reached",
                    "path cost / teacher's",
                    |v| match *v {
                        Validation::Gridnav {
                            validation_cost_ratio,
                            ..
                        } => validation_cost_ratio,
                        Validation::Track { .. } => f64::NAN,
                    },
                    Legend::UpperRight,
                )?,
            ],
            12,
        ),
    })
}

impl std::fmt::Display for Validation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Validation::Track {
                validation_falls_per_lap,
            } => write!(f, "{validation_falls_per_lap:.2} falls per lap"),
            Validation::Gridnav {
                validation_success_rate,
                validation_cost_ratio,
            } => write!(
                f,
                "{:.0} % reached, path cost {validation_cost_ratio:.3}× the teacher's",
                100.0 * validation_success_rate
            ),
        }
    }
}

#[derive(Serialize)]
struct RoundMetrics {
    round: usize,
    beta: f64,
    steps: u64,
    learner_steps: u64,
    falls_while_gathering: u64,
    #[serde(flatten)]
    validation: Validation,
}

/// The simulator a run drives, with what it needs.
enum World {
    Track(Track),
    Gridnav {
        costs: Grid<f32>,
        /// The validation pairs, the same for every round.
        pairs: Vec<(Cell, Cell)>,
    },
}

impl World {
    fn name(&self) -> &'static str {
        match self {
            World::Track(_) => "track",
            World::Gridnav { .. } => "gridnav",
        }
    }

    fn observation_names(&self) -> Vec<String> {
        match self {
            World::Track(_) => track::OBSERVATION_NAMES.map(String::from).to_vec(),
            World::Gridnav { .. } => gridnav::OBSERVATION_NAMES.map(String::from).to_vec(),
        }
    }

    /// The teacher's name and the control period (s).
    fn teacher(&self) -> (&'static str, f64) {
        match self {
            World::Track(track) => ("pure-pursuit", track.config.period),
            World::Gridnav { .. } => ("planner", 1.0),
        }
    }

    fn round(
        &self,
        params: &DaggerParams,
        driver: Option<&Policy>,
        beta: f64,
        round: usize,
    ) -> Result<Vec<Vec<Step>>> {
        let (episodes, seed) = (params.episodes, params.seed);
        match self {
            World::Track(track) => Ok(track_round(
                track,
                driver,
                beta,
                params.laps,
                episodes,
                seed,
                round,
            )),
            World::Gridnav { costs, .. } => {
                gridnav_round(costs, driver, beta, episodes, seed, round).ok_or_else(|| {
                    Error::Failed("dagger: the costmap has no reachable pair".into())
                })
            }
        }
    }

    /// `drive` (observation → action) on the validation episodes.
    fn validate(&self, params: &DaggerParams, drive: impl Fn(&[f64]) -> f64) -> Validation {
        let seed = params.seed.wrapping_add(0x5eed);
        match self {
            World::Track(track) => Validation::Track {
                validation_falls_per_lap: track
                    .falls_per_lap(params.validation_laps, seed, |s| drive(&s.observation())),
            },
            World::Gridnav { costs, pairs } => {
                let reached = evaluate(costs, pairs, |x| drive(x).round().clamp(0.0, 7.0) as usize);
                Validation::Gridnav {
                    validation_success_rate: reached.success_rate,
                    validation_cost_ratio: reached.cost_ratio,
                }
            }
        }
    }

    /// The teacher on the validation episodes.
    fn validate_teacher(&self, params: &DaggerParams) -> Validation {
        match self {
            World::Track(track) => Validation::Track {
                validation_falls_per_lap: track.falls_per_lap(
                    params.validation_laps,
                    params.seed.wrapping_add(0x5eed),
                    |s| s.teacher(),
                ),
            },
            // The teacher is the planner: it reaches every goal at the optimal cost.
            World::Gridnav { .. } => Validation::Gridnav {
                validation_success_rate: 1.0,
                validation_cost_ratio: 1.0,
            },
        }
    }
}

impl DaggerParams {
    fn validate(&self) -> Result<()> {
        let bad = |what: &str| Err(Error::Usage(format!("dagger: {what}")));
        match self.env.as_str() {
            "track" if self.costs.is_some() || self.map.is_some() => {
                return bad("costs and map go with env gridnav");
            }
            "track" if self.learner.discrete() => {
                return bad("the track's steering is continuous: learner ridge, tree or mlp");
            }
            "gridnav" if self.costs.is_none() => {
                return bad("env gridnav needs costs (a costmap table or artifact)");
            }
            "gridnav" if !self.learner.discrete() => {
                return bad("gridnav's moves are classes: learner logistic or class-tree");
            }
            "gridnav" if self.forward => {
                return bad("forward training needs a fixed horizon: env track");
            }
            _ if self.forward && self.supervised => {
                return bad("forward and supervised are two different algorithms: choose one");
            }
            "track" | "gridnav" => {}
            other => {
                return bad(&format!(
                    "env '{other}' is not a simulator imitate has (track, gridnav)"
                ));
            }
        }
        if self.rounds == 0
            || self.episodes == 0
            || self.laps == 0
            || self.validation_laps == 0
            || self.validation_pairs == 0
        {
            return bad(
                "rounds, episodes, laps, validation_laps and validation_pairs must be at least 1",
            );
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
        self.learner
            .learner(self.depth, self.lambda, gridnav::MOVES.len())
    }

    fn world(&self) -> Result<World> {
        match &self.costs {
            None => Ok(World::Track(Track::new(TrackConfig::default()))),
            Some(path) => {
                let (_, costs) = load_costs(path, self.map.as_deref())?;
                let mut rng = ChaCha8Rng::seed_from_u64(self.seed.wrapping_add(0x5eed));
                let pairs = (0..self.validation_pairs)
                    .map(|_| random_episode(&costs, &mut rng).map(|nav| (nav.position, nav.goal)))
                    .collect::<Option<Vec<_>>>()
                    .ok_or_else(|| {
                        Error::input(
                            path,
                            "has no reachable start and goal a third of the map apart",
                        )
                    })?;
                Ok(World::Gridnav { costs, pairs })
            }
        }
    }
}

/// The dataset the rounds go to, inside the artifact (`dataset/`).
fn create_dataset(out: &mut ArtifactBuilder, world: &World) -> Result<Dataset> {
    let dataset_dir = out
        .file("dataset/meta/info.json", "dataset-info")?
        .parent()
        .and_then(|meta| meta.parent())
        .expect("dataset/meta/info.json has two parents")
        .to_path_buf();
    Dataset::create(
        &dataset_dir,
        DatasetInfo {
            schema: "imitate.dagger-dataset/1".into(),
            observation_names: world.observation_names(),
            action_names: Vec::new(),
            environment: world.name().into(),
            costs: None,
        },
    )
}

/// Lists the dataset's files in the artifact's manifest.
fn list_dataset(out: &mut ArtifactBuilder, dataset: &Dataset) -> Result<()> {
    for file in ["manifest.json", "meta/rounds.parquet"] {
        out.file(&format!("dataset/{file}"), "dataset")?;
    }
    for info in &dataset.rounds {
        out.file(
            &format!("dataset/data/round={:03}/part-000.parquet", info.round),
            "dataset",
        )?;
    }
    Ok(())
}

impl DaggerParams {
    /// Forward training on the track: one round per step of a lap.
    fn run_forward(
        &self,
        track: &Track,
        learner: &PolicyLearner,
        mut out: ArtifactBuilder,
        mut dataset: Dataset,
        extra_deps: &[PathBuf],
    ) -> Result<StageReport> {
        let horizon = track.lap_steps();
        let trained = forward_training(learner, horizon, self.episodes, self.seed, |_| {
            TrackSim::new(track, 0.0)
        });
        let period = track.config.period;
        for (t, reached) in trained.labels.iter().enumerate() {
            // Each episode gives one step: the state it reached at step t.
            let episodes: Vec<Vec<Step>> = reached.iter().map(|s| vec![s.clone()]).collect();
            let times = vec![t as f64 * period; episodes.len()];
            dataset.append(&NewRound {
                source: format!("step {t}"),
                beta: 1.0,
                policy: String::new(),
                teacher: "pure-pursuit".into(),
                period,
                timestamps: Some(&times),
                episodes: &episodes,
            })?;
        }
        list_dataset(&mut out, &dataset)?;
        write_bytes_atomic(
            &out.file("policy.json", "policy")?,
            &to_json_bytes(&trained.policy),
        )?;
        let seed = self.seed.wrapping_add(0x5eed);
        let laps = self.validation_laps;
        let validation = Validation::Track {
            validation_falls_per_lap: track.lap_falls_per_lap(laps, seed, |t, s| {
                trained.policy.act_at(t, &s.observation())
            }),
        };
        let teacher = Validation::Track {
            validation_falls_per_lap: track.lap_falls_per_lap(laps, seed, |_, s| s.teacher()),
        };
        let summary_metrics = serde_json::json!({
            "env": "track",
            "algorithm": "forward-training",
            "horizon": horizon,
            "labels": dataset.steps(),
            "validation_falls_per_lap": validation.key().0,
            "teacher": teacher,
        });
        let rounds: Vec<_> = (dataset.rounds.iter())
            .map(|r| serde_json::json!({"round": r.round, "steps": r.steps}))
            .collect();
        write_bytes_atomic(
            &out.file("metrics.json", "metrics")?,
            &to_json_bytes(&serde_json::json!({
                "schema": "imitate.dagger-metrics/2",
                "summary": summary_metrics,
                "rounds": rounds,
            })),
        )?;
        let summary = format!(
            "forward training, {horizon} steps, {} labels: {validation} on {laps} validation laps \
             from the start line (teacher: {teacher})",
            dataset.steps()
        );
        commit_artifact(self, extra_deps, out, "policy", summary_metrics, summary)
    }
}

impl StageParams for DaggerParams {
    const KIND: &'static str = KIND;
    const VERSION: u32 = VERSION;

    fn deps(&self) -> Vec<PathBuf> {
        self.costs.iter().cloned().collect()
    }

    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport> {
        self.validate()?;
        let learner = self.learner();
        let world = self.world()?;
        let mut out = ArtifactBuilder::new(&self.out)?;
        let mut dataset = create_dataset(&mut out, &world)?;
        if let (true, World::Track(track)) = (self.forward, &world) {
            return self.run_forward(track, &learner, out, dataset, extra_deps);
        }
        let mut aggregate = Aggregate::new(
            dataset.info.observation_names.len(),
            dataset.info.action_dims(),
            &learner,
        );
        let (teacher, period) = world.teacher();
        let mut policies: Vec<Policy> = Vec::new();
        let mut metrics = Vec::new();
        let progress = super::progress_bar(self.rounds, "dagger rounds");
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
            let episodes = world.round(self, driver, beta, round)?;
            let number = dataset.append(&NewRound {
                source: format!("round {round}"),
                beta,
                policy: String::new(),
                teacher: teacher.into(),
                period,
                timestamps: None,
                episodes: &episodes,
            })?;
            // Train on what the dataset holds (as `imitate dagger train` would).
            let written = dataset.round_steps(number)?;
            for i in 0..written.len() {
                aggregate.add(written.observation(i), written.label(i));
            }
            let policy = aggregate.fit(&learner);
            let info = &dataset.rounds[number as usize];
            metrics.push(RoundMetrics {
                round,
                beta,
                steps: info.steps,
                learner_steps: info.learner_steps,
                falls_while_gathering: info.failures,
                validation: world.validate(self, |x| policy.act(x)),
            });
            write_bytes_atomic(
                &out.file(&format!("policies/round-{round:03}.json"), "round-policy")?,
                &to_json_bytes(&policy),
            )?;
            policies.push(policy);
            progress.inc(1);
        }
        progress.finish_and_clear();
        list_dataset(&mut out, &dataset)?;
        let validations: Vec<Validation> = metrics.iter().map(|m| m.validation).collect();
        let (selected, selected_validation, chosen_round) = match self.selection {
            Selection::Last => (
                policies[policies.len() - 1].clone(),
                validations[validations.len() - 1],
                Some(policies.len() - 1),
            ),
            Selection::Best => {
                let best = (0..validations.len())
                    .rev()
                    .min_by(|&a, &b| {
                        let (ka, kb) = (validations[a].key(), validations[b].key());
                        ka.0.total_cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
                    })
                    .expect("at least one round");
                (policies[best].clone(), validations[best], Some(best))
            }
            Selection::Mixture => (
                Policy::Mixture {
                    members: policies.clone(),
                },
                Validation::mean(&validations),
                None,
            ),
        };
        write_bytes_atomic(
            &out.file("policy.json", "policy")?,
            &to_json_bytes(&selected),
        )?;
        let teacher_validation = world.validate_teacher(self);
        write_png(
            &out.file("validation.png", "picture")?,
            &validation_charts(&metrics, &teacher_validation)?,
        )?;
        let mut summary_metrics = serde_json::json!({
            "env": world.name(),
            "selection": self.selection,
            "selected_round": chosen_round,
            "labels": dataset.steps(),
            "teacher": teacher_validation,
        });
        if let (Some(summary), serde_json::Value::Object(selected)) = (
            summary_metrics.as_object_mut(),
            serde_json::to_value(selected_validation).expect("plain numbers"),
        ) {
            summary.extend(selected);
        }
        let all_metrics = serde_json::json!({
            "schema": "imitate.dagger-metrics/2",
            "summary": summary_metrics,
            "rounds": metrics,
        });
        write_bytes_atomic(
            &out.file("metrics.json", "metrics")?,
            &to_json_bytes(&all_metrics),
        )?;
        let summary = format!(
            "{} rounds, {} labels; {} policy{}: {selected_validation} on validation (teacher: {teacher_validation})",
            self.rounds,
            dataset.steps(),
            serde_json::to_value(self.selection)
                .expect("names")
                .as_str()
                .unwrap_or(""),
            chosen_round
                .map(|r| format!(" (round {r})"))
                .unwrap_or_default(),
        );
        commit_artifact(self, extra_deps, out, "policy", summary_metrics, summary)
    }
}
