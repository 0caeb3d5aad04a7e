//! `imitate bench track`: the seed's case study. Behaviour cloning against DAgger on the
//! lane-keeping circuit with the same number of teacher labels per iteration (one lap),
//! falls per lap of each iteration's policy, over seeds, with the teacher's own falls.

use std::cell::Cell;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use crate::cli::emit;
use crate::dagger::{BetaSchedule, Learning, Policy, PolicyKind, forward_training, learn};
use crate::error::{Error, Result};
use crate::sim::{Track, TrackConfig, TrackSim};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum BenchSelection {
    Latest,
    Best,
}

#[derive(Debug, clap::Args)]
pub struct TrackBenchArgs {
    /// Iterations (one lap of teacher labels each).
    #[arg(long, default_value_t = 20)]
    pub iterations: usize,
    #[arg(long, default_value_t = 3)]
    pub seeds: u64,
    /// Laps each policy is evaluated on.
    #[arg(long, default_value_t = 3)]
    pub eval_laps: usize,
    /// The policy: a regression tree or ridge regression.
    #[arg(long, value_enum, default_value = "tree")]
    pub learner: PolicyKind,
    /// Depth of the tree policy: 3 (8 leaves) cannot copy pure pursuit exactly.
    #[arg(long, default_value_t = 3)]
    pub depth: usize,
    /// Which policy each iteration is scored by: its latest, or as the seed's DAgger
    /// returns, the best so far on validation laps (other noise than the evaluation's).
    #[arg(long, value_enum, default_value = "latest")]
    pub selection: BenchSelection,
    /// Forward training: episodes per time step (0 leaves it out).
    #[arg(long, default_value_t = 10)]
    pub forward_episodes: usize,
    /// Ridge penalty of the linear policy (standardised observations).
    #[arg(long, default_value_t = 1e-3)]
    pub lambda: f64,
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Curve {
    learning: &'static str,
    /// Per iteration: mean over seeds of falls per lap.
    falls_per_lap: Vec<f64>,
    /// Per iteration: per seed.
    per_seed: Vec<Vec<f64>>,
    /// Teacher labels per iteration, mean over seeds.
    labels_per_iteration: f64,
}

/// Forward training's result: one policy per step of a lap.
#[derive(Serialize)]
struct Forward {
    episodes_per_step: usize,
    horizon: usize,
    labels: usize,
    /// Mean over seeds.
    falls_per_lap: f64,
}

#[derive(Serialize)]
struct TrackBenchReport {
    schema: &'static str,
    config: TrackConfig,
    track_length: f64,
    seeds: u64,
    eval_laps: usize,
    selection: BenchSelection,
    teacher_falls_per_lap: f64,
    curves: Vec<Curve>,
    #[serde(skip_serializing_if = "Option::is_none")]
    forward_training: Option<Forward>,
}

pub fn run(args: TrackBenchArgs) -> Result<()> {
    if args.iterations == 0 || args.seeds == 0 || args.eval_laps == 0 {
        return Err(Error::Usage(
            "bench track needs --iterations, --seeds and --eval-laps of at least 1".into(),
        ));
    }
    if args.learner.discrete() {
        return Err(Error::Usage(
            "the track's steering is continuous: --learner ridge or tree".into(),
        ));
    }
    let learner = args.learner.learner(args.depth, args.lambda, 0);
    let track = Track::new(TrackConfig::default());
    let evaluation_seed = |seed: u64| seed.wrapping_mul(7919).wrapping_add(1);
    let validation_seed = |seed: u64| seed.wrapping_mul(104_729).wrapping_add(3);
    let teacher = (1..=args.seeds)
        .map(|seed| track.falls_per_lap(args.eval_laps, evaluation_seed(seed), |s| s.teacher()))
        .sum::<f64>()
        / args.seeds as f64;
    let mut curves = Vec::new();
    for (name, learning) in [
        ("behaviour-cloning", Learning::Supervised),
        ("dagger", Learning::Dagger(BetaSchedule::FirstRound)),
    ] {
        // Seeds run in parallel; results are gathered in seed order.
        let runs: Vec<(Vec<f64>, usize)> = (1..=args.seeds)
            .into_par_iter()
            .map(|seed| {
                // Each iteration's lap starts somewhere else on the circuit.
                let mut starts = ChaCha8Rng::seed_from_u64(seed);
                let steps = Cell::new(0usize);
                let cap = track.step_cap(1.0);
                let (mut falls, mut labels) = (Vec::new(), 0usize);
                let mut best: Option<(f64, Policy)> = None;
                learn(
                    learning,
                    &learner,
                    args.iterations,
                    seed,
                    |_| {
                        steps.set(0);
                        TrackSim::new(&track, starts.random::<f64>() * track.length())
                    },
                    |sim| {
                        steps.set(steps.get() + 1);
                        sim.laps() >= 1.0 || steps.get() > cap
                    },
                    |_, policy: &Policy| {
                        labels += steps.get() - 1;
                        let scored = match args.selection {
                            BenchSelection::Latest => policy,
                            BenchSelection::Best => {
                                let validation = track.falls_per_lap(
                                    args.eval_laps,
                                    validation_seed(seed),
                                    |s| policy.act(&s.observation()),
                                );
                                // The later round on ties, as the dagger stage.
                                if best.as_ref().is_none_or(|(v, _)| validation <= *v) {
                                    best = Some((validation, policy.clone()));
                                }
                                &best.as_ref().expect("just set").1
                            }
                        };
                        falls.push(track.falls_per_lap(
                            args.eval_laps,
                            evaluation_seed(seed),
                            |s| scored.act(&s.observation()),
                        ));
                    },
                );
                (falls, labels)
            })
            .collect();
        let labels: usize = runs.iter().map(|r| r.1).sum();
        let per_iteration: Vec<Vec<f64>> = (0..args.iterations)
            .map(|i| runs.iter().map(|r| r.0[i]).collect())
            .collect();
        curves.push(Curve {
            learning: name,
            falls_per_lap: per_iteration
                .iter()
                .map(|v| v.iter().sum::<f64>() / v.len() as f64)
                .collect(),
            per_seed: per_iteration,
            labels_per_iteration: labels as f64 / (args.seeds as usize * args.iterations) as f64,
        });
    }
    let forward_training = (args.forward_episodes > 0).then(|| {
        let horizon = track.lap_steps();
        let falls = (1..=args.seeds)
            .into_par_iter()
            .map(|seed| {
                let trained =
                    forward_training(&learner, horizon, args.forward_episodes, seed, |_| {
                        TrackSim::new(&track, 0.0)
                    });
                track.lap_falls_per_lap(args.eval_laps, evaluation_seed(seed), |t, sim| {
                    trained.policy.act_at(t, &sim.observation())
                })
            })
            // Summed in seed order, so the figure does not depend on the thread count.
            .collect::<Vec<f64>>()
            .iter()
            .sum::<f64>()
            / args.seeds as f64;
        Forward {
            episodes_per_step: args.forward_episodes,
            horizon,
            labels: horizon * args.forward_episodes,
            falls_per_lap: falls,
        }
    });
    let report = TrackBenchReport {
        schema: "imitate.bench-track/1",
        config: track.config,
        track_length: track.length(),
        seeds: args.seeds,
        eval_laps: args.eval_laps,
        selection: args.selection,
        teacher_falls_per_lap: teacher,
        curves,
        forward_training,
    };
    emit(&report, args.json, |r| {
        let mut text = format!(
            "track: falls per lap of the {:?} policy (mean of {} seeds, {} evaluation laps each); teacher: {:.2}\n\
             iteration  {}\n",
            r.selection,
            r.seeds,
            r.eval_laps,
            r.teacher_falls_per_lap,
            r.curves
                .iter()
                .map(|c| format!("{:>18}", c.learning))
                .collect::<String>()
        );
        let n = r.curves[0].falls_per_lap.len();
        for i in 0..n {
            if i == 0 || (i + 1) % 5 == 0 || i + 1 == n {
                text += &format!("{:>9}  ", i + 1);
                for c in &r.curves {
                    text += &format!("{:>18.2}", c.falls_per_lap[i]);
                }
                text.push('\n');
            }
        }
        if let Some(f) = &r.forward_training {
            text += &format!(
                "forward training ({} steps x {} episodes = {} labels): {:.2} falls per lap\n",
                f.horizon, f.episodes_per_step, f.labels, f.falls_per_lap
            );
        }
        text += &format!(
            "labels per iteration: {}",
            r.curves
                .iter()
                .map(|c| format!("{} {:.0}", c.learning, c.labels_per_iteration))
                .collect::<Vec<_>>()
                .join(", ")
        );
        text
    });
    Ok(())
}
