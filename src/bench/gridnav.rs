//! `imitate bench gridnav`: behaviour cloning against DAgger on `gridnav` with the same
//! teacher labels per iteration: success rate and path-cost ratio (learner over
//! teacher) of each iteration's policy on start/goal pairs of an unseen map.

use std::cell::RefCell;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use crate::cli::emit;
use crate::dagger::{BetaSchedule, Environment, Learning, Policy, PolicyKind, learn};
use crate::error::{Error, Result};
use crate::grid::{Cell, Grid};
use crate::sim::gridnav::{Evaluation, GridNav, MOVES, evaluate, random_episode, random_pair};
use crate::sim::{WorldConfig, generate_world};

#[derive(Debug, clap::Args)]
pub struct GridnavBenchArgs {
    #[arg(long, default_value_t = 10)]
    pub iterations: usize,
    /// Teacher labels per iteration (episodes are chained until this many steps).
    #[arg(long, default_value_t = 400)]
    pub labels: usize,
    #[arg(long, default_value_t = 3)]
    pub seeds: u64,
    /// Start/goal pairs on the evaluation map.
    #[arg(long, default_value_t = 30)]
    pub evaluation_pairs: usize,
    /// A learner for discrete moves: logistic or class-tree.
    #[arg(long, value_enum, default_value = "logistic")]
    pub learner: PolicyKind,
    /// Depth of class trees.
    #[arg(long, default_value_t = 6)]
    pub depth: usize,
    #[arg(long)]
    pub json: bool,
}

/// One iteration's success rate and mean cost ratio (learner over teacher).
type Point = Evaluation;

#[derive(Serialize)]
struct Curve {
    learning: &'static str,
    per_iteration: Vec<Point>,
}

#[derive(Serialize)]
struct GridnavReport {
    schema: &'static str,
    seeds: u64,
    labels_per_iteration: usize,
    learner: PolicyKind,
    curves: Vec<Curve>,
}

/// Episodes one after another on a map: a new random one starts when one ends.
struct Episodes<'a> {
    costs: &'a Grid<f32>,
    rng: ChaCha8Rng,
    current: GridNav<'a>,
    labels: usize,
}

impl<'a> Episodes<'a> {
    fn new(costs: &'a Grid<f32>, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let current = Self::fresh(costs, &mut rng);
        Episodes {
            costs,
            rng,
            current,
            labels: 0,
        }
    }

    fn fresh(costs: &'a Grid<f32>, rng: &mut ChaCha8Rng) -> GridNav<'a> {
        random_episode(costs, rng).expect("generated worlds have reachable pairs")
    }
}

impl Environment for Episodes<'_> {
    fn observe(&self) -> Vec<f64> {
        self.current.observe()
    }

    fn teacher(&self) -> f64 {
        Environment::teacher(&self.current)
    }

    fn execute(&mut self, action: f64, rng: &mut ChaCha8Rng) -> bool {
        self.labels += 1;
        let failed = self.current.execute(action, rng);
        if self.current.over() {
            self.current = Self::fresh(self.costs, &mut self.rng);
        }
        failed
    }
}

fn evaluate_policy(policy: &Policy, costs: &Grid<f32>, pairs: &[(Cell, Cell)]) -> Point {
    evaluate(costs, pairs, |x| {
        policy.act(x).round().clamp(0.0, 7.0) as usize
    })
}

pub fn run(args: GridnavBenchArgs) -> Result<()> {
    if args.iterations == 0 || args.seeds == 0 || args.labels == 0 || args.evaluation_pairs == 0 {
        return Err(Error::Usage(
            "bench gridnav needs --iterations, --labels, --seeds and --evaluation-pairs of at least 1"
                .into(),
        ));
    }
    if !args.learner.discrete() {
        return Err(Error::Usage(
            "gridnav's moves are classes: --learner logistic or class-tree".into(),
        ));
    }
    let learner = args.learner.learner(args.depth, 1e-4, MOVES.len());
    let mut curves = Vec::new();
    for (name, learning) in [
        ("behaviour-cloning", Learning::Supervised),
        ("dagger", Learning::Dagger(BetaSchedule::FirstRound)),
    ] {
        // Seeds run in parallel; their points are summed in seed order.
        let runs: Vec<Vec<Point>> = (1..=args.seeds)
            .into_par_iter()
            .map(|seed| -> Result<Vec<Point>> {
                let world = generate_world(&WorldConfig {
                    seed,
                    maps: 2,
                    width: 48,
                    height: 48,
                    demonstrations_per_map: 1,
                    ..WorldConfig::default()
                })
                .map_err(Error::Failed)?;
                let (train_map, eval_map) = (&world.truth[0], &world.truth[1]);
                let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xe7a1);
                let pairs: Vec<(Cell, Cell)> = (0..args.evaluation_pairs)
                    .map(|_| random_pair(eval_map, &mut rng))
                    .collect();
                let chain_seed = RefCell::new(seed * 1000);
                let mut points = Vec::new();
                learn(
                    learning,
                    &learner,
                    args.iterations,
                    seed,
                    |_| {
                        *chain_seed.borrow_mut() += 1;
                        Episodes::new(train_map, *chain_seed.borrow())
                    },
                    |env: &Episodes| env.labels >= args.labels,
                    |_, policy| points.push(evaluate_policy(policy, eval_map, &pairs)),
                );
                Ok(points)
            })
            .collect::<Result<_>>()?;
        let mut sums: Vec<(f64, f64, usize)> = vec![(0.0, 0.0, 0); args.iterations];
        for points in &runs {
            for (s, point) in sums.iter_mut().zip(points) {
                s.0 += point.success_rate;
                if point.cost_ratio.is_finite() {
                    s.1 += point.cost_ratio;
                    s.2 += 1;
                }
            }
        }
        curves.push(Curve {
            learning: name,
            per_iteration: sums
                .iter()
                .map(|&(success, ratio, n)| Point {
                    success_rate: success / args.seeds as f64,
                    cost_ratio: if n > 0 { ratio / n as f64 } else { f64::NAN },
                })
                .collect(),
        });
    }
    let report = GridnavReport {
        schema: "imitate.bench-gridnav/1",
        seeds: args.seeds,
        labels_per_iteration: args.labels,
        learner: args.learner,
        curves,
    };
    emit(&report, args.json, |r| {
        let mut text = format!(
            "gridnav: success rate and cost ratio on an unseen map ({} seeds, {} labels per iteration, {:?})\n\
             iteration  {}\n",
            r.seeds,
            r.labels_per_iteration,
            r.learner,
            r.curves
                .iter()
                .map(|c| format!("{:>28}", c.learning))
                .collect::<String>()
        );
        let n = r.curves[0].per_iteration.len();
        for i in 0..n {
            if i == 0 || (i + 1) % 5 == 0 || i + 1 == n {
                text += &format!("{:>9}  ", i + 1);
                for c in &r.curves {
                    let p = &c.per_iteration[i];
                    text += &format!("{:>17.0} % {:>8.3}", 100.0 * p.success_rate, p.cost_ratio);
                }
                text.push('\n');
            }
        }
        text.trim_end().to_string()
    });
    Ok(())
}
