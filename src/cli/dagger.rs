//! `imitate dagger init | add | train | rollout | status`: DAgger rounds on disk with the
//! built-in `track` simulator. A round is one or more laps driven by the teacher or by a
//! policy artifact (mixed with the teacher with probability β per step), labelled by
//! the teacher; `train` fits a policy on every round so far and writes a policy
//! artifact.

use std::path::{Path, PathBuf};

use clap::Subcommand;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::emit;
use crate::artifact::load_costs;
use crate::dagger::dataset::{CostsSource, Dataset, DatasetInfo, NewRound, RoundInfo};
use crate::dagger::demo_round::{Appended, DemoColumns, append_demonstrations};
use crate::dagger::log_round::{LogTopics, read_log_round};
use crate::dagger::query::RoundStatistics;
use crate::dagger::train::{TrainOptions, train_policy};
use crate::dagger::{gridnav_round, load_policy_artifact, track_round};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::io::demo_tables::{lerobot_feature_names, lerobot_files, lerobot_picture_features};
use crate::io::fs::file_digest;
use crate::sim::gridnav::{self, Evaluation, evaluate, random_episode};
use crate::sim::track::OBSERVATION_NAMES;
use crate::sim::{Track, TrackConfig};

/// The simulators rounds can come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Env {
    /// The lane-keeping circuit with a pure-pursuit teacher.
    Track,
    /// A reactive walker on a costmap (--costs) with the planner as teacher; moves
    /// are discrete (train with --learner logistic or tree).
    Gridnav,
    /// Robot logs (`add --log`): the observations are named with --observations.
    Log,
}

// Parsed once per run: the size of the largest variant does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Subcommand)]
pub enum DaggerCommand {
    /// Create an empty dataset for an environment.
    Init {
        dataset: PathBuf,
        #[arg(long, value_enum, default_value = "track")]
        env: Env,
        /// With --env log: the observation's values, comma-separated, in the order
        /// the log's observation messages hold them.
        #[arg(long, value_delimiter = ',')]
        observations: Vec<String>,
        /// With --env log: the action's values when it holds several (a robot's
        /// joints), comma-separated, in the order the label messages hold them.
        #[arg(long, value_delimiter = ',')]
        actions: Vec<String>,
        /// A dataset for this LeRobot folder's demonstrations: the observation and
        /// action names (and sizes) from its `meta/info.json` (`observation.state`,
        /// `action`).
        #[arg(long, value_name = "DIR", conflicts_with_all = ["observations", "actions", "costs"])]
        lerobot: Option<PathBuf>,
        /// With --env gridnav: the true costmap (artifact folder, costmap table, GeoTIFF or
        /// MovingAI `.map`).
        #[arg(long, value_name = "PATH")]
        costs: Option<PathBuf>,
        /// With --env gridnav and an artifact of several maps: which one.
        #[arg(long)]
        map: Option<String>,
    },
    /// Drive laps (the teacher, or --policy mixed with the teacher at --beta), label
    /// every step with the teacher's action and append them as a round.
    Add {
        dataset: PathBuf,
        /// A policy artifact (from `dagger train`); without it the teacher drives.
        #[arg(long, value_name = "DIR")]
        policy: Option<PathBuf>,
        /// Probability that the teacher acts at a step (default: 1 without a policy,
        /// 0 with one).
        #[arg(long)]
        beta: Option<f64>,
        /// Episodes, driven in parallel from random starts (the same round at any
        /// thread count).
        #[arg(long, default_value_t = 1)]
        episodes: usize,
        /// Laps per episode.
        #[arg(long, default_value_t = 1)]
        laps: usize,
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Instead of the simulator: robot logs (MCAP) where the learner drove and the
        /// teacher's labels were recorded on --label-topic; each log is a round.
        #[arg(long, value_name = "FILE", num_args = 1.., requires_all = ["observation_topic", "label_topic"])]
        log: Vec<PathBuf>,
        #[arg(long)]
        observation_topic: Option<String>,
        /// The executed action (its message's numbers). Without it the log is an
        /// expert demonstration: the label topic is what the expert did.
        #[arg(long)]
        action_topic: Option<String>,
        /// The teacher's label (its message's numbers).
        #[arg(long)]
        label_topic: Option<String>,
        /// How far apart in time an observation and its action and label may be.
        #[arg(long, default_value_t = 50.0)]
        tolerance_ms: f64,
        /// Instead: expert demonstrations from Parquet tables (a round the teacher drove).
        #[arg(long = "demonstrations", value_name = "FILE", conflicts_with_all = ["log", "lerobot"])]
        demonstrations: Vec<PathBuf>,
        /// Instead: expert demonstrations from LeRobot dataset folders (v2 or v3), one
        /// round of all their episodes.
        #[arg(long, value_name = "DIR", num_args = 1.., conflicts_with = "log")]
        lerobot: Vec<PathBuf>,
        /// With --demonstrations or --lerobot: observation columns, in order (a list
        /// column gives all its elements, `name[i]` one).
        #[arg(long = "observation", value_name = "COLUMN", default_values_t = ["observation.state".to_string()])]
        observation_columns: Vec<String>,
        /// With --demonstrations or --lerobot: the action column, the teacher's (a
        /// number, a list, or `name[i]`).
        #[arg(long = "action", value_name = "COLUMN", default_value = "action")]
        action_column: String,
        /// With --demonstrations: the action that was executed, when the learner (your
        /// own policy, run outside imitate, e.g. its ONNX export) drove and the teacher
        /// only labelled: the round is then a DAgger round (β 0), each row the
        /// learner's step where it differs from the label.
        #[arg(long = "executed", value_name = "COLUMN", conflicts_with = "lerobot")]
        executed_column: Option<String>,
        /// With --demonstrations or --lerobot: the episode column.
        #[arg(
            long = "episode",
            value_name = "COLUMN",
            default_value = "episode_index"
        )]
        episode_column: String,
    },
    /// Fit a policy on every round of the dataset and write a policy artifact.
    Train {
        dataset: PathBuf,
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        #[command(flatten)]
        options: TrainOptions,
    },
    /// Drive a policy artifact on the track and report falls per lap, or with
    /// --dataset of a gridnav dataset, on its costmap between random start/goal pairs
    /// and report the success rate and path-cost ratio.
    Rollout {
        policy: PathBuf,
        /// A gridnav dataset whose costmap to walk.
        #[arg(long, value_name = "DIR")]
        dataset: Option<PathBuf>,
        #[arg(long, default_value_t = 3)]
        laps: usize,
        /// With --dataset: start/goal pairs.
        #[arg(long, default_value_t = 30)]
        pairs: usize,
        #[arg(long, default_value_t = 0)]
        seed: u64,
        #[arg(long)]
        json: bool,
    },
    /// The dataset's rounds.
    Status {
        dataset: PathBuf,
        #[arg(long)]
        json: bool,
    },
}

/// A round in `dagger status`: what `meta/rounds.parquet` lists and what its steps say.
#[derive(Serialize)]
struct RoundStatus<'a> {
    #[serde(flatten)]
    info: &'a RoundInfo,
    #[serde(flatten)]
    statistics: &'a RoundStatistics,
}

/// Digest of a grid's size and costs (what a gridnav dataset's rounds depend on).
fn grid_digest(grid: &Grid<f32>) -> String {
    let mut hasher = blake3::Hasher::new();
    hasher.update(&grid.geo.width.to_le_bytes());
    hasher.update(&grid.geo.height.to_le_bytes());
    for c in &grid.data {
        hasher.update(&c.to_le_bytes());
    }
    format!("blake3:{}", hasher.finalize().to_hex())
}

/// The costmap of a gridnav dataset, refused if it changed since `dagger init`.
fn gridnav_costs(dataset: &Path, source: &CostsSource) -> Result<Grid<f32>> {
    let (_, grid) = load_costs(&source.path, source.map.as_deref())?;
    if grid_digest(&grid) != source.digest {
        return Err(Error::input(
            &source.path,
            format!(
                "changed since the dataset {} was created on it (its rounds would not agree)",
                dataset.display()
            ),
        ));
    }
    Ok(grid)
}

fn track() -> Track {
    Track::new(TrackConfig::default())
}

fn add(
    dataset: &Path,
    policy: Option<&Path>,
    beta: Option<f64>,
    episodes: usize,
    laps: usize,
    seed: u64,
) -> Result<()> {
    let mut ds = Dataset::open(dataset)?;
    let costs = match (ds.info.environment.as_str(), &ds.info.costs) {
        ("track", _) => None,
        ("gridnav", Some(source)) => Some(gridnav_costs(dataset, source)?),
        (other, _) => {
            return Err(Error::input(
                dataset,
                format!(
                    "holds '{other}' data: add rounds with --log, --lerobot or --demonstrations"
                ),
            ));
        }
    };
    let loaded = policy.map(load_policy_artifact).transpose()?;
    let beta = beta.unwrap_or(if loaded.is_some() { 0.0 } else { 1.0 });
    if !(0.0..=1.0).contains(&beta) {
        return Err(Error::Usage("--beta must be in [0, 1]".into()));
    }
    if laps == 0 || episodes == 0 {
        return Err(Error::Usage(
            "--laps and --episodes must be at least 1".into(),
        ));
    }
    if costs.is_some() && laps != 1 {
        return Err(Error::Usage(
            "--laps is for the track: a gridnav episode walks from a start to a goal".into(),
        ));
    }
    let digest = loaded.as_ref().map(|(_, d)| d.clone()).unwrap_or_default();
    let source = match costs {
        None => {
            format!("track episodes={episodes} laps={laps} seed={seed} beta={beta} policy={digest}")
        }
        Some(_) => format!("gridnav episodes={episodes} seed={seed} beta={beta} policy={digest}"),
    };
    if let Some(existing) = ds.rounds.iter().find(|r| r.source == source) {
        outln!("round {} already holds {source}", existing.round);
        return Ok(());
    }
    let track = track();
    let driver = loaded.as_ref().map(|(p, _)| p);
    let (episodes, teacher, period) = match &costs {
        None => (
            track_round(&track, driver, beta, laps, episodes, seed, 0),
            "pure-pursuit",
            track.config.period,
        ),
        Some(costs) => (
            gridnav_round(costs, driver, beta, episodes, seed, 0).ok_or_else(|| {
                Error::input(dataset, "its costmap has no reachable start/goal pair")
            })?,
            "planner",
            1.0,
        ),
    };
    let round = ds.append(&NewRound {
        source,
        beta,
        policy: digest,
        teacher: teacher.into(),
        period,
        timestamps: None,
        episodes: &episodes,
    })?;
    let info = &ds.rounds[round as usize];
    outln!(
        "round {round}: {} steps ({} by the learner), {} falls",
        info.steps,
        info.learner_steps,
        info.failures
    );
    Ok(())
}

/// Appends one round of the tables in `groups` and says what it holds.
fn add_demonstrations(
    dataset: &Path,
    groups: &[Vec<PathBuf>],
    columns: &DemoColumns,
) -> Result<()> {
    match append_demonstrations(dataset, groups, columns)? {
        Appended::Already { round } => outln!("round {round} already holds these demonstrations"),
        Appended::New {
            round,
            steps,
            episodes,
        } => outln!("round {round}: {steps} steps in {episodes} episodes"),
    }
    Ok(())
}

/// Appends the round a robot log holds.
fn add_log(dataset: &Path, log: &Path, topics: &LogTopics) -> Result<()> {
    let mut ds = Dataset::open(dataset)?;
    let (digest, _) = file_digest(log)?;
    let source = format!(
        "log {digest} observation={} action={} label={} tolerance_ns={}",
        topics.observation,
        topics.action.as_deref().unwrap_or("-"),
        topics.label,
        topics.tolerance_ns
    );
    if let Some(existing) = ds.rounds.iter().find(|r| r.source == source) {
        outln!("round {} already holds {}", existing.round, log.display());
        return Ok(());
    }
    let round = read_log_round(log, topics, ds.info.action_dims())?;
    if round.steps.is_empty() {
        return Err(Error::input(
            log,
            format!(
                "no observation on {} has a label and an executed action within the tolerance \
                 ({} observations: {} without a label, {} without an action)",
                topics.observation, round.observations, round.unlabelled, round.without_action
            ),
        ));
    }
    let number = ds.append(&NewRound {
        source,
        beta: if topics.action.is_none() { 1.0 } else { 0.0 },
        policy: String::new(),
        teacher: topics.label.clone(),
        period: 0.0,
        timestamps: Some(&round.times),
        episodes: std::slice::from_ref(&round.steps),
    })?;
    outln!(
        "round {number}: {} steps from {}; skipped {} observations without a label and {} without an executed action",
        round.steps.len(),
        log.display(),
        round.unlabelled,
        round.without_action
    );
    Ok(())
}

#[derive(Serialize)]
struct GridnavRolloutReport {
    schema: &'static str,
    policy: String,
    pairs: usize,
    /// The policy's success rate and mean cost ratio; the teacher's are 1 and 1.
    learner: Evaluation,
}

/// Walks a (discrete-move) policy between `pairs` random start/goal pairs of a gridnav
/// dataset's costmap.
fn rollout_gridnav(
    policy: &Path,
    dataset: &Path,
    pairs: usize,
    seed: u64,
    json: bool,
) -> Result<()> {
    if pairs == 0 {
        return Err(Error::Usage("--pairs must be at least 1".into()));
    }
    let ds = Dataset::open(dataset)?;
    let source = match (ds.info.environment.as_str(), &ds.info.costs) {
        ("gridnav", Some(source)) => source,
        (other, _) => {
            return Err(Error::input(
                dataset,
                format!("holds '{other}' data, not gridnav (track rollouts need no --dataset)"),
            ));
        }
    };
    let costs = gridnav_costs(dataset, source)?;
    let (loaded, digest) = load_policy_artifact(policy)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let loaded = loaded.for_episode(&mut rng).clone();
    let chosen = (0..pairs)
        .map(|_| random_episode(&costs, &mut rng).map(|nav| (nav.position, nav.goal)))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| Error::input(&source.path, "has no reachable start/goal pair"))?;
    let report = GridnavRolloutReport {
        schema: "imitate.dagger-gridnav-rollout/1",
        policy: digest,
        pairs,
        learner: evaluate(&costs, &chosen, |x| {
            loaded.act(x).round().clamp(0.0, 7.0) as usize
        }),
    };
    emit(&report, json, |r| {
        format!(
            "{} start/goal pairs: {:.0} % reached, path cost {:.3}× the teacher's",
            r.pairs,
            100.0 * r.learner.success_rate,
            r.learner.cost_ratio
        )
    });
    Ok(())
}

#[derive(Serialize)]
struct RolloutReport {
    schema: &'static str,
    policy: String,
    laps: usize,
    falls_per_lap: f64,
    teacher_falls_per_lap: f64,
}

pub fn run(command: DaggerCommand) -> Result<()> {
    match command {
        DaggerCommand::Init {
            dataset,
            env,
            observations,
            actions,
            lerobot,
            costs,
            map,
        } => {
            if costs.is_some() != (env == Env::Gridnav) || (map.is_some() && costs.is_none()) {
                return Err(Error::Usage(
                    "--env gridnav needs --costs (and only it takes --costs and --map)".into(),
                ));
            }
            if !actions.is_empty() && env != Env::Log {
                return Err(Error::Usage(
                    "--actions goes with --env log (the simulators' actions are one number)".into(),
                ));
            }
            let (names, environment) = match env {
                _ if lerobot.is_some() => (Vec::new(), "lerobot"),
                Env::Track | Env::Gridnav if !observations.is_empty() => {
                    return Err(Error::Usage(
                        "--observations goes with --env log (the simulators' are fixed)".into(),
                    ));
                }
                Env::Track => (OBSERVATION_NAMES.map(String::from).to_vec(), "track"),
                Env::Gridnav => (
                    gridnav::OBSERVATION_NAMES.map(String::from).to_vec(),
                    "gridnav",
                ),
                Env::Log if observations.is_empty() => {
                    return Err(Error::Usage(
                        "--env log needs --observations NAME,NAME,...".into(),
                    ));
                }
                Env::Log => (observations, "log"),
            };
            let costs = match costs {
                Some(path) => {
                    let (_, grid) = load_costs(&path, map.as_deref())?;
                    if random_episode(&grid, &mut ChaCha8Rng::seed_from_u64(0)).is_none() {
                        return Err(Error::input(
                            &path,
                            "has no reachable start and goal a third of the map apart",
                        ));
                    }
                    let path = std::path::absolute(&path)
                        .map_err(|e| Error::io(format!("resolving {}", path.display()), e))?;
                    Some(CostsSource {
                        path,
                        map,
                        digest: grid_digest(&grid),
                    })
                }
                None => None,
            };
            let (names, actions) = match &lerobot {
                Some(folder) => {
                    for (feature, dtype) in lerobot_picture_features(folder)? {
                        tracing::warn!(
                            "{}: feature {feature} ({dtype}) is not used: policies here \
                             see observation.state",
                            folder.display()
                        );
                    }
                    (
                        lerobot_feature_names(folder, "observation.state")?,
                        lerobot_feature_names(folder, "action")?,
                    )
                }
                None => (names, actions),
            };
            // One action is the simulators' case and keeps no names.
            let actions = if actions.len() == 1 {
                Vec::new()
            } else {
                actions
            };
            Dataset::create(
                &dataset,
                DatasetInfo {
                    schema: "imitate.dagger-dataset/1".into(),
                    observation_names: names,
                    action_names: actions,
                    environment: environment.into(),
                    costs,
                },
            )?;
            outln!("{}: an empty {environment} dataset", dataset.display());
            Ok(())
        }
        DaggerCommand::Add {
            dataset,
            log,
            observation_topic,
            action_topic,
            label_topic,
            tolerance_ms,
            ..
        } if !log.is_empty() => {
            let topics = LogTopics {
                observation: observation_topic.unwrap_or_default(),
                action: action_topic,
                label: label_topic.unwrap_or_default(),
                tolerance_ns: (tolerance_ms.max(0.0) * 1e6) as u64,
            };
            log.iter()
                .try_for_each(|log| add_log(&dataset, log, &topics))
        }
        DaggerCommand::Add {
            dataset,
            demonstrations,
            lerobot,
            observation_columns,
            action_column,
            executed_column,
            episode_column,
            ..
        } if !demonstrations.is_empty() || !lerobot.is_empty() => {
            let columns = DemoColumns::parse(
                &episode_column,
                &observation_columns,
                &action_column,
                executed_column.as_deref(),
            )
            .map_err(Error::Usage)?;
            // Episode ids are a folder's own: each LeRobot folder is read apart.
            let groups = if lerobot.is_empty() {
                vec![demonstrations]
            } else {
                lerobot
                    .iter()
                    .map(|folder| lerobot_files(folder))
                    .collect::<Result<Vec<_>>>()?
            };
            add_demonstrations(&dataset, &groups, &columns)
        }
        DaggerCommand::Add {
            dataset,
            policy,
            beta,
            episodes,
            laps,
            seed,
            ..
        } => add(&dataset, policy.as_deref(), beta, episodes, laps, seed),
        DaggerCommand::Train {
            dataset,
            out,
            options,
        } => {
            let manifest = train_policy(&dataset, &out, &options)?;
            outln!("{}\t{}", out.display(), manifest.digest);
            Ok(())
        }
        DaggerCommand::Rollout {
            policy,
            dataset: Some(dataset),
            pairs,
            seed,
            json,
            ..
        } => rollout_gridnav(&policy, &dataset, pairs, seed, json),
        DaggerCommand::Rollout {
            policy,
            laps,
            seed,
            json,
            ..
        } => {
            if laps == 0 {
                return Err(Error::Usage("--laps must be at least 1".into()));
            }
            let (loaded, digest) = load_policy_artifact(&policy)?;
            // A mixture is rolled out with one member, drawn from the seed.
            let loaded = loaded
                .for_episode(&mut ChaCha8Rng::seed_from_u64(seed))
                .clone();
            let track = track();
            let report = RolloutReport {
                schema: "imitate.dagger-rollout/1",
                policy: digest,
                laps,
                falls_per_lap: track.falls_per_lap(laps, seed, |s| loaded.act(&s.observation())),
                teacher_falls_per_lap: track.falls_per_lap(laps, seed, |s| s.teacher()),
            };
            emit(&report, json, |r| {
                format!(
                    "{} laps: {:.2} falls per lap (the teacher: {:.2})",
                    r.laps, r.falls_per_lap, r.teacher_falls_per_lap
                )
            });
            Ok(())
        }
        DaggerCommand::Status { dataset, json } => {
            let ds = Dataset::open(&dataset)?;
            let statistics = ds.statistics()?;
            let rounds: Vec<RoundStatus> = (ds.rounds.iter())
                .zip(&statistics)
                .map(|(info, statistics)| RoundStatus { info, statistics })
                .collect();
            emit(&rounds, json, |rounds| {
                let mut text = format!(
                    "{}: {} rounds, {} steps ({})\n\
                     round  steps  learner  disagree  falls  beta  source\n",
                    dataset.display(),
                    rounds.len(),
                    ds.steps(),
                    ds.info.environment
                );
                for RoundStatus {
                    info: r,
                    statistics,
                } in rounds
                {
                    let disagreement = statistics
                        .learner_disagreement
                        .map_or("-".to_string(), |d| format!("{d:.3}"));
                    text += &format!(
                        "{:>5}  {:>5}  {:>7}  {:>8}  {:>5}  {:>4.2}  {}\n",
                        r.round,
                        r.steps,
                        r.learner_steps,
                        disagreement,
                        r.failures,
                        r.beta,
                        r.source
                    );
                }
                text.trim_end().to_string()
            });
            Ok(())
        }
    }
}
