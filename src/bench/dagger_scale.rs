//! `imitate bench dagger-scale`: a DAgger dataset of many steps on disk; the time to
//! append one more round, and to retrain a ridge policy on all of it (one streaming pass
//! over the rounds, memory bounded by a round). Steps are synthetic (seeded observations,
//! a linear teacher with noise): this measures storage and training, not control.
//! Peak memory of the retraining alone: `/usr/bin/time -f %M imitate dagger train DIR
//! --out P` on the dataset this leaves behind.

use std::path::PathBuf;
use std::time::Instant;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::cli::emit;
use crate::dagger::dataset::{Dataset, DatasetInfo, NewRound};
use crate::dagger::{Actor, PolicyLearner, Step};
use crate::error::{Error, Result};
use crate::sim::track::gaussian;

#[derive(Debug, clap::Args)]
pub struct DaggerScaleArgs {
    /// The dataset folder (made when absent, reused when present).
    #[arg(long, value_name = "DIR")]
    pub dataset: PathBuf,
    #[arg(long, default_value_t = 10_000_000)]
    pub steps: u64,
    #[arg(long, default_value_t = 250_000)]
    pub round_steps: usize,
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct DaggerScaleReport {
    schema: &'static str,
    rounds: usize,
    steps: u64,
    build_seconds: Option<f64>,
    append_round_steps: usize,
    append_seconds: f64,
    retrain_seconds: f64,
    retrain_steps_per_second: f64,
    disk_bytes: u64,
}

const DIMS: usize = 5;

/// One round of synthetic steps: observations N(0, 1), label = a fixed linear rule
/// plus noise, every other step the learner's.
fn synthetic_round(seed: u64, steps: usize) -> Vec<Step> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let rule = [0.4, -0.3, 0.2, 0.1, -0.05];
    (0..steps)
        .map(|i| {
            let observation: Vec<f64> = (0..DIMS).map(|_| gaussian(&mut rng)).collect();
            let label = observation
                .iter()
                .zip(rule)
                .map(|(x, w)| x * w)
                .sum::<f64>()
                + 0.01 * gaussian(&mut rng);
            let actor = if i % 2 == 0 {
                Actor::Teacher
            } else {
                Actor::Learner
            };
            Step {
                executed: if actor == Actor::Teacher {
                    vec![label]
                } else {
                    vec![rng.random::<f64>()]
                },
                observation,
                label: vec![label],
                actor,
                failed: false,
            }
        })
        .collect()
}

fn append(ds: &mut Dataset, seed: u64, steps: usize) -> Result<()> {
    let episodes = [synthetic_round(seed, steps)];
    ds.append(&NewRound {
        source: format!("synthetic seed={seed} steps={steps}"),
        beta: 0.5,
        policy: String::new(),
        teacher: "linear".into(),
        period: 0.2,
        timestamps: None,
        episodes: &episodes,
    })?;
    Ok(())
}

fn folder_bytes(dir: &std::path::Path) -> u64 {
    std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|entry| match entry.file_type() {
            Ok(t) if t.is_dir() => folder_bytes(&entry.path()),
            _ => entry.metadata().map(|m| m.len()).unwrap_or(0),
        })
        .sum()
}

pub fn run(args: DaggerScaleArgs) -> Result<()> {
    if args.round_steps == 0 || args.steps == 0 {
        return Err(Error::Usage(
            "--steps and --round-steps must be at least 1".into(),
        ));
    }
    let mut build_seconds = None;
    let mut ds = if args.dataset.join("meta/info.json").exists() {
        Dataset::open(&args.dataset)?
    } else {
        let started = Instant::now();
        let mut ds = Dataset::create(
            &args.dataset,
            DatasetInfo {
                schema: "imitate.dagger-dataset/1".into(),
                observation_names: (0..DIMS).map(|j| format!("x{j}")).collect(),
                action_names: Vec::new(),
                environment: "synthetic".into(),
                costs: None,
            },
        )?;
        let mut seed = 0;
        while ds.steps() < args.steps {
            let left = (args.steps - ds.steps()).min(args.round_steps as u64) as usize;
            append(&mut ds, seed, left)?;
            seed += 1;
        }
        build_seconds = Some(started.elapsed().as_secs_f64());
        ds
    };
    let started = Instant::now();
    let next_seed = 1_000_000 + ds.rounds.len() as u64;
    append(&mut ds, next_seed, args.round_steps)?;
    let append_seconds = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let learner = PolicyLearner::Ridge { lambda: 1e-3 };
    let _policy = ds.aggregate(&learner)?.fit(&learner);
    let retrain_seconds = started.elapsed().as_secs_f64();
    let report = DaggerScaleReport {
        schema: "imitate.bench-dagger-scale/1",
        rounds: ds.rounds.len(),
        steps: ds.steps(),
        build_seconds,
        append_round_steps: args.round_steps,
        append_seconds,
        retrain_seconds,
        retrain_steps_per_second: ds.steps() as f64 / retrain_seconds,
        disk_bytes: folder_bytes(&args.dataset),
    };
    emit(&report, args.json, |r| {
        format!(
            "dataset: {} rounds, {} steps, {:.1} MB on disk{}\n\
             append a round of {} steps: {:.3} s\n\
             retrain a ridge policy on all of it: {:.2} s ({:.1} M steps/s)",
            r.rounds,
            r.steps,
            r.disk_bytes as f64 / 1e6,
            r.build_seconds
                .map(|s| format!(" (written in {s:.1} s)"))
                .unwrap_or_default(),
            r.append_round_steps,
            r.append_seconds,
            r.retrain_seconds,
            r.retrain_steps_per_second / 1e6
        )
    });
    Ok(())
}
