//! `imitate bench learch`: one LEARCH round on many large examples (by default 64
//! demonstrations on four 512×512 maps with 16 features), on 1 and on all threads, with the
//! share of the round spent planning.

use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::cli::emit;
use crate::error::{Error, Result};
use crate::features::{FeatureSpec, Op, compute};
use crate::grid::{FeatureStack, Grid, rasterize};
use crate::ioc::{Example, LearchConfig, WeakLearnerKind, train};
use crate::plan::{Moves, dijkstra};
use crate::sim::{WorldConfig, generate_world};

#[derive(Debug, clap::Args)]
pub struct LearchBenchArgs {
    #[arg(long, default_value_t = 512)]
    pub size: u32,
    /// Demonstrations in all (over four maps).
    #[arg(long, default_value_t = 64)]
    pub examples: usize,
    #[arg(long, value_enum, default_value = "ridge")]
    pub weak_learner: WeakLearnerKind,
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    #[arg(long)]
    pub json: bool,
}

/// 16 features: the 4 layers, blurs, slope, roughness, distances, and the bias.
fn spec() -> FeatureSpec {
    let op =
        |json: serde_json::Value| serde_json::from_value::<Op>(json).expect("a valid operator");
    use serde_json::json;
    FeatureSpec {
        layers: Some(
            ["elevation", "vegetation", "water", "road"]
                .map(String::from)
                .to_vec(),
        ),
        ops: vec![
            op(json!({"op": "blur", "layer": "elevation", "sigmas": [2, 8]})),
            op(json!({"op": "slope", "layer": "elevation"})),
            op(json!({"op": "roughness", "layer": "elevation", "windows": [7]})),
            op(json!({"op": "blur", "layer": "vegetation", "sigmas": [2, 8]})),
            op(json!({"op": "distance", "layer": "water", "above": 0.5})),
            op(json!({"op": "blur", "layer": "water", "sigmas": [4]})),
            op(json!({"op": "distance", "layer": "road", "class": 1})),
            op(json!({"op": "blur", "layer": "road", "sigmas": [4]})),
            op(json!({"op": "product", "a": "vegetation", "b": "elevation/slope_deg"})),
        ],
        bias: true,
        nodata_fill: 0.0,
        bank: None,
    }
}

#[derive(Serialize)]
struct Timing {
    threads: usize,
    round_seconds: f64,
    planning_seconds: f64,
    planning_share: f64,
}

#[derive(Serialize)]
struct LearchBenchReport {
    schema: &'static str,
    size: u32,
    maps: usize,
    examples: usize,
    features: usize,
    weak_learner: WeakLearnerKind,
    timings: Vec<Timing>,
    speed_up: f64,
}

pub fn run(args: LearchBenchArgs) -> Result<()> {
    if args.size < 32 || args.examples < 4 {
        return Err(Error::Usage(
            "bench learch needs --size >= 32 and --examples >= 4".into(),
        ));
    }
    let world = generate_world(&WorldConfig {
        maps: 4,
        width: args.size,
        height: args.size,
        demonstrations_per_map: args.examples.div_ceil(4),
        ..WorldConfig::default()
    })
    .map_err(Error::Failed)?;
    let stacks: Vec<FeatureStack> = world
        .maps
        .par_iter()
        .map(|m| compute(m, &spec()))
        .collect::<std::result::Result<_, _>>()
        .map_err(Error::Failed)?;
    let names: Vec<String> = world.maps.iter().map(|m| m.name.clone()).collect();
    let examples: Vec<Example> = world
        .demonstrations
        .iter()
        .take(args.examples)
        .map(|d| {
            let map = names
                .iter()
                .position(|n| *n == d.map)
                .expect("the world's own map");
            Example {
                id: d.episode.clone(),
                map,
                path: rasterize(&world.maps[map].geo, &d.xy()).expect("the world's own path"),
                waypoints: Vec::new(),
            }
        })
        .collect();
    // One model: what is timed is a round.
    let config = LearchConfig {
        rounds: 3,
        weak_learner: args.weak_learner,
        members: 1,
        ..LearchConfig::default()
    };
    let all_threads = rayon::current_num_threads();
    let mut timings = Vec::new();
    for threads in [1, all_threads] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| Error::Failed(e.to_string()))?;
        let (mut round, mut planning) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..args.repeat.max(1) {
            pool.install(|| -> Result<()> {
                // A round is the time between two rounds' ends: setup (feature scales,
                // per-example loss maps) happens once per training and is left out.
                let mut ends = Vec::new();
                train(
                    &stacks,
                    &names,
                    &examples,
                    &[],
                    &[],
                    None,
                    &config,
                    None,
                    |_| ends.push(Instant::now()),
                )
                .map_err(Error::Failed)?;
                for pair in ends.windows(2) {
                    round = round.min((pair[1] - pair[0]).as_secs_f64());
                }
                // The second round's planning alone: every example on the loss-augmented
                // costmap of the model after one round, with the planner LEARCH uses.
                let first = train(
                    &stacks,
                    &names,
                    &examples,
                    &[],
                    &[],
                    None,
                    &LearchConfig {
                        rounds: 1,
                        ..config.clone()
                    },
                    None,
                    |_| {},
                )
                .map_err(Error::Failed)?;
                let costmaps: Vec<Grid<f32>> =
                    stacks.par_iter().map(|s| first.model.costmap(s)).collect();
                let augmented: Vec<Grid<f32>> = examples
                    .par_iter()
                    .map(|ex| {
                        let mut costs = costmaps[ex.map].clone();
                        let on_path: std::collections::HashSet<_> = ex.path.iter().collect();
                        for i in 0..costs.data.len() {
                            if !on_path.contains(&costs.geo.cell_at(i)) {
                                costs.data[i] *= (1.0 - config.loss) as f32;
                            }
                        }
                        costs
                    })
                    .collect();
                let start = Instant::now();
                examples.par_iter().zip(&augmented).for_each(|(ex, costs)| {
                    let goal = *ex.path.last().expect("paths have cells");
                    let _ = dijkstra(costs, ex.path[0], goal, Moves::default());
                });
                planning = planning.min(start.elapsed().as_secs_f64());
                Ok(())
            })?;
        }
        timings.push(Timing {
            threads,
            round_seconds: round,
            planning_seconds: planning,
            planning_share: planning / round,
        });
        if all_threads == 1 {
            break;
        }
    }
    let speed_up = timings[0].round_seconds / timings.last().expect("one timing").round_seconds;
    let report = LearchBenchReport {
        schema: "imitate.bench.learch/1",
        size: args.size,
        maps: stacks.len(),
        examples: examples.len(),
        features: stacks[0].dim(),
        weak_learner: args.weak_learner,
        timings,
        speed_up,
    };
    emit(&report, args.json, |r| {
        let mut text = format!(
            "one LEARCH round ({:?}): {} examples on {} maps of {}x{} cells, {} features\n",
            r.weak_learner, r.examples, r.maps, r.size, r.size, r.features
        );
        for t in &r.timings {
            text += &format!(
                "{} thread(s): {:.3} s per round, planning {:.3} s ({:.0} %)\n",
                t.threads,
                t.round_seconds,
                t.planning_seconds,
                100.0 * t.planning_share
            );
        }
        text + &format!("speed-up: {:.2}x", r.speed_up)
    });
    Ok(())
}
