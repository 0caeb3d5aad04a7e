//! `imitate bench objectworld`: the GPIRL objectworld protocol (Levine, Popović & Koltun
//! 2011): expected value difference of each IOC method for N demonstrations, over seeds.

use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::cli::emit;
use crate::error::{Error, Result};
use crate::io::tables::{Table, write_numeric_table};
use crate::ioc::objectworld::{
    ACTIONS, DISCOUNT, FeatureKind, ObjectWorld, expected_value_difference, optimal_policy,
    policy_values,
};
use crate::ioc::tabular::{Method, TabularConfig, TabularProblem, learn};

#[derive(Debug, clap::Args)]
pub struct ObjectworldArgs {
    /// Numbers of demonstrations (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "4,8,16,32,64,128")]
    pub demonstrations: Vec<usize>,
    /// Worlds per N (seeds 1, 2, ...).
    #[arg(long, default_value_t = 5)]
    pub seeds: u64,
    #[arg(long, value_enum, default_value = "discrete")]
    pub features: FeatureKind,
    /// Methods (repeat; default: all).
    #[arg(long = "method", value_enum)]
    pub methods: Vec<Method>,
    /// Grid side.
    #[arg(long, default_value_t = 32)]
    pub size: usize,
    /// Rounds of every learner; default per method.
    #[arg(long)]
    pub rounds: Option<usize>,
    /// Step size (LEARCH: c of c/√t; MMP, MaxEnt: learning rate); default per method.
    #[arg(long)]
    pub step_size: Option<f64>,
    /// L2 regularisation; default per method.
    #[arg(long)]
    pub lambda: Option<f64>,
    /// Depth of LEARCH's regression trees; default 2.
    #[arg(long)]
    pub depth: Option<usize>,
    /// LEARCH plans with the optimal policy of the loss-augmented reward instead of the
    /// soft-optimal policy.
    #[arg(long)]
    pub hard_planning: bool,
    /// Write each world, its true reward and every learned reward and policy as Parquet.
    #[arg(long, value_name = "DIR")]
    pub export: Option<PathBuf>,
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Run {
    method: &'static str,
    demonstrations: usize,
    seed: u64,
    evd: f64,
    seconds: f64,
}

#[derive(Serialize)]
struct Cell {
    method: &'static str,
    demonstrations: usize,
    mean_evd: f64,
    std_evd: f64,
    mean_seconds: f64,
}

#[derive(Serialize)]
struct Report {
    schema: &'static str,
    size: usize,
    features: FeatureKind,
    seeds: u64,
    /// EVD of the uniformly random policy, averaged over the worlds: for scale.
    random_policy_evd: f64,
    table: Vec<Cell>,
    runs: Vec<Run>,
}

fn random_policy_evd(world: &ObjectWorld) -> f64 {
    let truth = &world.true_reward;
    let best = policy_values(&world.mdp, truth, &optimal_policy(&world.mdp, truth));
    let uniform = vec![1.0 / ACTIONS as f64; world.states() * ACTIONS];
    let random = policy_values(&world.mdp, truth, &uniform);
    let n = world.states() as f64;
    best.iter().sum::<f64>() / n - random.iter().sum::<f64>() / n
}

pub fn run(args: ObjectworldArgs) -> Result<()> {
    if args.size < 4 || args.seeds == 0 || args.demonstrations.contains(&0) {
        return Err(Error::Usage(
            "objectworld needs --size >= 4, --seeds >= 1 and N >= 1 demonstrations".into(),
        ));
    }
    let methods = if args.methods.is_empty() {
        Method::ALL.to_vec()
    } else {
        args.methods.clone()
    };
    let config = |method: Method| {
        let defaults = TabularConfig::default_for(method);
        TabularConfig {
            rounds: args.rounds.unwrap_or(defaults.rounds),
            step_size: args.step_size.unwrap_or(defaults.step_size),
            lambda: args.lambda.unwrap_or(defaults.lambda),
            soft_planning: defaults.soft_planning && !args.hard_planning,
            tree: crate::learn::TreeConfig {
                max_depth: args.depth.unwrap_or(defaults.tree.max_depth),
                ..defaults.tree
            },
            ..defaults
        }
    };
    let worlds: Vec<ObjectWorld> = (1..=args.seeds)
        .into_par_iter()
        .map(|seed| ObjectWorld::generate(args.size, args.features, seed))
        .collect();
    let random = worlds.iter().map(random_policy_evd).sum::<f64>() / worlds.len() as f64;
    let jobs: Vec<(u64, usize, Method)> = (1..=args.seeds)
        .flat_map(|seed| {
            let methods = methods.clone();
            args.demonstrations
                .iter()
                .flat_map(move |&n| methods.clone().into_iter().map(move |m| (seed, n, m)))
        })
        .collect();
    let results: Vec<(Run, Vec<f64>)> = jobs
        .par_iter()
        .map(|&(seed, n, method)| {
            let world = &worlds[(seed - 1) as usize];
            let demos = world.demonstrations(n, seed * 1_000_003 + n as u64);
            let problem = TabularProblem {
                mdp: &world.mdp,
                discount: DISCOUNT,
                features: &world.features,
                dims: world.dims,
                demonstrations: &demos,
            };
            let start = Instant::now();
            let reward = learn(&problem, method, &config(method));
            let seconds = start.elapsed().as_secs_f64();
            let run = Run {
                method: method.name(),
                demonstrations: n,
                seed,
                evd: expected_value_difference(world, &reward),
                seconds,
            };
            (run, reward)
        })
        .collect();
    if let Some(dir) = &args.export {
        export(dir, &worlds, &results)?;
    }
    let mut table = Vec::new();
    for &method in &methods {
        for &n in &args.demonstrations {
            let runs: Vec<&Run> = results
                .iter()
                .map(|(r, _)| r)
                .filter(|r| r.method == method.name() && r.demonstrations == n)
                .collect();
            let count = runs.len() as f64;
            let mean = runs.iter().map(|r| r.evd).sum::<f64>() / count;
            let var = runs.iter().map(|r| (r.evd - mean).powi(2)).sum::<f64>() / count;
            table.push(Cell {
                method: method.name(),
                demonstrations: n,
                mean_evd: mean,
                std_evd: var.sqrt(),
                mean_seconds: runs.iter().map(|r| r.seconds).sum::<f64>() / count,
            });
        }
    }
    let report = Report {
        schema: "imitate.bench.objectworld/1",
        size: args.size,
        features: args.features,
        seeds: args.seeds,
        random_policy_evd: random,
        table,
        runs: results.into_iter().map(|(r, _)| r).collect(),
    };
    emit(&report, args.json, |r| {
        let mut text = format!(
            "objectworld {0}x{0}, {1:?} features, {2} seeds; random policy EVD {3:.2}\n\
             method          N    mean EVD   std    seconds/run\n",
            r.size, r.features, r.seeds, r.random_policy_evd
        );
        for c in &r.table {
            text += &format!(
                "{:<14} {:>4}  {:>8.2}  {:>6.2}  {:>8.3}\n",
                c.method, c.demonstrations, c.mean_evd, c.std_evd, c.mean_seconds
            );
        }
        text
    });
    Ok(())
}

/// `world-<seed>.parquet`: per state x, y, features, true reward; and
/// `learned-<seed>-<N>-<method>.parquet`: per state the learned reward and the action of
/// the policy optimal for it.
fn export(dir: &Path, worlds: &[ObjectWorld], results: &[(Run, Vec<f64>)]) -> Result<()> {
    for (i, world) in worlds.iter().enumerate() {
        let states = world.states();
        let x: Vec<f64> = (0..states).map(|s| (s % world.size) as f64).collect();
        let y: Vec<f64> = (0..states).map(|s| (s / world.size) as f64).collect();
        let columns: Vec<Vec<f64>> = (0..world.dims)
            .map(|j| {
                (0..states)
                    .map(|s| world.features[s * world.dims + j])
                    .collect()
            })
            .collect();
        let mut table: Vec<(&str, &[f64])> = vec![("x", &x), ("y", &y)];
        for (name, column) in world.feature_names.iter().zip(&columns) {
            table.push((name, column));
        }
        table.push(("true_reward", &world.true_reward));
        write_numeric_table(
            &dir.join(format!("world-{}.parquet", i + 1)),
            Table::OBJECTWORLD,
            &table,
        )?;
    }
    for (run, reward) in results {
        let world = &worlds[(run.seed - 1) as usize];
        let policy = optimal_policy(&world.mdp, reward);
        let action: Vec<f64> = policy
            .chunks(ACTIONS)
            .map(|row| row.iter().position(|p| *p > 0.0).unwrap_or(0) as f64)
            .collect();
        write_numeric_table(
            &dir.join(format!(
                "learned-{}-{}-{}.parquet",
                run.seed, run.demonstrations, run.method
            )),
            Table::LEARNED_REWARD,
            &[("reward", reward), ("action", &action)],
        )?;
    }
    Ok(())
}
