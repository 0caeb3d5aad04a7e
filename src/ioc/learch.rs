//! LEARCH (learning to search), as in the seed's listing: boosting in the space of
//! log-cost functions, with the planner in the loop.
//!
//! Each round t, for every example i: plan on the loss-augmented costmap
//! exp(s_t(F_i)) − l_i, compare the planned visitation μ* with the demonstration's μ,
//! and emit (f(s), sign(μ*−μ), |μ*−μ|) at the cells where they disagree. A ridge
//! regressor h_t fitted to all examples' points gives s_{t+1} = s_t + α_t h_t.
//!
//! Examples are planned in parallel; each returns its own sufficient statistics, and
//! they are merged in example order, so the result does not depend on the thread count.

use std::collections::BTreeMap;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::metrics::{Agreement, evaluate_example, summarize};
use super::model::{LogLinearCost, WeakLearner};
use crate::error::first_error_in_order;
use crate::grid::{CellPath, FeatureStack, Grid};
use crate::learn::RidgeAccumulator;
use crate::plan::{loss_augmented, path_cost, shortest_path};

/// Augmented costs never drop below this, so every cell stays passable.
const LOSS_FLOOR: f32 = 1e-6;

/// A demonstration on one of the maps.
#[derive(Debug, Clone)]
pub struct Example {
    pub id: String,
    /// Index into the maps / feature stacks the trainer is given.
    pub map: usize,
    pub path: CellPath,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum StepSchedule {
    /// α_t = step_size
    Constant,
    /// α_t = step_size / √(t + 1)
    InverseSqrt,
}

#[derive(Debug, Clone, PartialEq)]
pub struct LearchConfig {
    pub rounds: usize,
    pub step_size: f64,
    pub schedule: StepSchedule,
    /// Ridge penalty of the weak learner (on standardised features).
    pub ridge_lambda: f64,
    /// Hamming loss augmentation: while training, cells off the demonstration cost
    /// (1 − loss) times their learned cost, which asks the learned cost to prefer the
    /// demonstration by a margin. Relative to the cost so that it does not depend on
    /// the cost's overall scale; 0 turns augmentation off.
    pub loss: f64,
}

/// What one round did.
#[derive(Debug, Clone, Serialize)]
pub struct RoundMetrics {
    pub round: usize,
    pub step: f64,
    /// Mean over training examples of (C(demo) − C(plan)) / C(demo) on the
    /// loss-augmented costmap before the update: 0 when every demonstration is optimal.
    pub training_loss: f64,
    /// Cells where planned and demonstrated visitation differ, over all examples.
    pub disagreeing_cells: usize,
    /// Agreement of plans on the updated costmap with the held-out demonstrations.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub holdout: Option<Agreement>,
}

#[derive(Debug, Clone)]
pub struct TrainedLearch {
    pub model: LogLinearCost,
    pub rounds: Vec<RoundMetrics>,
}

/// Per-example contribution to a round.
struct ExampleGradient {
    data: RidgeAccumulator,
    loss: f64,
    disagreeing_cells: usize,
}

/// Runs LEARCH. `stacks[i]` are the features of map `i` (named `map_names[i]`); the
/// optional `references` are costmaps to score plans against (e.g. a synthetic world's
/// true costs). `on_round` sees each round's metrics as soon as they exist.
pub fn train(
    stacks: &[FeatureStack],
    map_names: &[String],
    training: &[Example],
    holdout: &[Example],
    references: Option<&[Grid<f32>]>,
    config: &LearchConfig,
    mut on_round: impl FnMut(&RoundMetrics),
) -> Result<TrainedLearch, String> {
    if training.is_empty() {
        return Err("no training examples".into());
    }
    let names = stacks[0].names.clone();
    if let Some(bad) = stacks.iter().find(|s| s.names != names) {
        return Err(format!(
            "feature stacks disagree: {:?} versus {:?}",
            names, bad.names
        ));
    }
    let mut model = LogLinearCost::zero(names, feature_scales(stacks));
    let mut rounds = Vec::with_capacity(config.rounds);
    for t in 0..config.rounds {
        let costmaps: Vec<Grid<f32>> = stacks.par_iter().map(|s| model.costmap(s)).collect();
        let gradients: Vec<Result<ExampleGradient, String>> = training
            .par_iter()
            .map(|ex| example_gradient(&model, &stacks[ex.map], &costmaps[ex.map], ex, config.loss))
            .collect::<Vec<_>>();
        let gradients = first_error_in_order(gradients)?;
        let mut data = RidgeAccumulator::new(model.feature_names.len());
        for g in &gradients {
            data.merge(&g.data);
        }
        let step = match config.schedule {
            StepSchedule::Constant => config.step_size,
            StepSchedule::InverseSqrt => config.step_size / ((t + 1) as f64).sqrt(),
        };
        model.push(WeakLearner {
            kind: "ridge".into(),
            step,
            weights: data.solve(config.ridge_lambda),
        });
        let holdout_agreement = (!holdout.is_empty())
            .then(|| evaluate(&model, stacks, map_names, holdout, references))
            .transpose()?
            .map(|evaluations| summarize(&evaluations));
        let metrics = RoundMetrics {
            round: t + 1,
            step,
            training_loss: gradients.iter().map(|g| g.loss).sum::<f64>() / gradients.len() as f64,
            disagreeing_cells: gradients.iter().map(|g| g.disagreeing_cells).sum(),
            holdout: holdout_agreement,
        };
        tracing::debug!(round = t + 1, weights = ?model.raw_weights, "learch model");
        on_round(&metrics);
        rounds.push(metrics);
    }
    Ok(TrainedLearch { model, rounds })
}

/// Plans every example on the model's costmap and compares with its demonstration.
pub fn evaluate(
    model: &LogLinearCost,
    stacks: &[FeatureStack],
    map_names: &[String],
    examples: &[Example],
    references: Option<&[Grid<f32>]>,
) -> Result<Vec<super::ExampleEvaluation>, String> {
    let costmaps: Vec<Grid<f32>> = stacks.par_iter().map(|s| model.costmap(s)).collect();
    let evaluations = examples
        .par_iter()
        .map(|ex| {
            evaluate_example(
                &ex.id,
                &map_names[ex.map],
                &costmaps[ex.map],
                &ex.path,
                references.map(|r| &r[ex.map]),
            )
            .ok_or_else(|| unreachable(ex))
        })
        .collect::<Vec<_>>();
    first_error_in_order(evaluations)
}

fn unreachable(ex: &Example) -> String {
    format!(
        "example '{}': no path from {} to {} on the learned costmap",
        ex.id,
        ex.path[0],
        ex.path[ex.path.len() - 1]
    )
}

fn example_gradient(
    model: &LogLinearCost,
    stack: &FeatureStack,
    costs: &Grid<f32>,
    ex: &Example,
    loss: f64,
) -> Result<ExampleGradient, String> {
    let geo = &stack.geo;
    // μ: how often the demonstration visits each cell.
    let mut visits: BTreeMap<usize, i64> = BTreeMap::new();
    for &cell in &ex.path {
        *visits.entry(geo.index(cell)).or_default() -= 1;
    }
    let augmented = if loss > 0.0 {
        // Hamming loss off the demonstration, as a share of each cell's cost.
        let per_cell: Vec<f32> = (0..costs.data.len())
            .map(|i| {
                if visits.contains_key(&i) {
                    0.0
                } else {
                    loss as f32 * costs.data[i]
                }
            })
            .collect();
        std::borrow::Cow::Owned(loss_augmented(costs, &per_cell, LOSS_FLOOR))
    } else {
        std::borrow::Cow::Borrowed(costs)
    };
    let start = ex.path[0];
    let goal = ex.path[ex.path.len() - 1];
    let route = shortest_path(&augmented, start, goal).ok_or_else(|| unreachable(ex))?;
    let demo_cost = path_cost(&augmented, &ex.path);
    // μ* − μ, with μ already subtracted above.
    for &cell in &route.cells {
        *visits.entry(geo.index(cell)).or_default() += 1;
    }
    let mut data = RidgeAccumulator::new(stack.dim());
    let mut raw = vec![0.0f32; stack.dim()];
    let mut x = vec![0.0; stack.dim()];
    let mut disagreeing_cells = 0;
    for (&i, &difference) in &visits {
        if difference == 0 {
            continue;
        }
        disagreeing_cells += 1;
        stack.cell_into(i, &mut raw);
        model.scaled(&raw, &mut x);
        data.add(
            &x,
            difference.signum() as f64,
            difference.unsigned_abs() as f64,
        );
    }
    Ok(ExampleGradient {
        data,
        loss: ((demo_cost - route.cost) / demo_cost.max(f64::MIN_POSITIVE)).max(0.0),
        disagreeing_cells,
    })
}

/// Per-feature standard deviation over all cells of all maps, so that the ridge
/// penalty treats features in metres and in [0, 1] alike; constant features (such as
/// the bias) keep scale 1.
fn feature_scales(stacks: &[FeatureStack]) -> Vec<f64> {
    let dim = stacks[0].dim();
    let mut sum = vec![0.0f64; dim];
    let mut sum_sq = vec![0.0f64; dim];
    let mut count = 0usize;
    for stack in stacks {
        for (j, plane) in stack.planes().enumerate() {
            for &v in plane {
                let v = f64::from(v);
                sum[j] += v;
                sum_sq[j] += v * v;
            }
        }
        count += stack.geo.cell_count();
    }
    let n = count.max(1) as f64;
    (0..dim)
        .map(|j| {
            let mean = sum[j] / n;
            let sd = (sum_sq[j] / n - mean * mean).max(0.0).sqrt();
            if sd > 1e-9 * mean.abs().max(1.0) {
                sd
            } else {
                1.0
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::{FeatureSpec, compute};
    use crate::grid::rasterize;
    use crate::sim::{WorldConfig, generate_world};

    /// A small synthetic world: (stacks, map names, examples, true costs).
    fn small_world() -> (Vec<FeatureStack>, Vec<String>, Vec<Example>, Vec<Grid<f32>>) {
        let config = WorldConfig {
            seed: 11,
            maps: 4,
            width: 48,
            height: 48,
            demonstrations_per_map: 12,
            ..WorldConfig::default()
        };
        let world = generate_world(&config).unwrap();
        let spec = FeatureSpec {
            layers: None,
            ops: Vec::new(),
            bias: true,
            nodata_fill: 0.0,
        };
        let stacks: Vec<FeatureStack> = world
            .maps
            .iter()
            .map(|m| compute(m, &spec).unwrap())
            .collect();
        let names: Vec<String> = world.maps.iter().map(|m| m.name.clone()).collect();
        let examples = world
            .demonstrations
            .iter()
            .map(|d| {
                let map = names.iter().position(|n| *n == d.map).unwrap();
                let path = rasterize(&world.maps[map].geo, &d.xy()).unwrap();
                Example {
                    id: d.episode.clone(),
                    map,
                    path,
                }
            })
            .collect();
        (stacks, names, examples, world.truth)
    }

    fn config() -> LearchConfig {
        LearchConfig {
            rounds: 40,
            step_size: 1.0,
            schedule: StepSchedule::InverseSqrt,
            ridge_lambda: 1e-3,
            loss: 0.3,
        }
    }

    #[test]
    fn learns_costs_whose_plans_match_held_out_demonstrations() {
        let (stacks, names, examples, truth) = small_world();
        // Every fourth demonstration is held out.
        let (mut training, mut holdout) = (Vec::new(), Vec::new());
        for (i, example) in examples.into_iter().enumerate() {
            if i % 4 == 0 {
                holdout.push(example)
            } else {
                training.push(example)
            }
        }
        let trained = train(
            &stacks,
            &names,
            &training,
            &holdout,
            Some(&truth),
            &config(),
            |_| {},
        )
        .unwrap();
        let first = trained.rounds.first().unwrap();
        let last = trained.rounds.last().unwrap();
        assert!(
            last.training_loss < first.training_loss,
            "{first:?} -> {last:?}"
        );
        let agreement = last.holdout.clone().unwrap();
        assert_eq!(agreement.examples, holdout.len());
        assert!(agreement.within_radius >= 0.9, "{agreement:?}");
        assert!(
            agreement.mean_reference_cost_ratio.unwrap() <= 1.05,
            "{agreement:?}"
        );
        // Water is costly and roads are cheap in the true cost; the learned one agrees.
        let weight = |name: &str| {
            let j = trained
                .model
                .feature_names
                .iter()
                .position(|n| n == name)
                .unwrap();
            trained.model.raw_weights[j]
        };
        assert!(weight("water") > 0.0 && weight("road") < 0.0 && weight("vegetation") > 0.0);
    }

    #[test]
    fn the_model_does_not_depend_on_the_thread_count() {
        let (stacks, names, examples, _) = small_world();
        let config = LearchConfig {
            rounds: 5,
            ..config()
        };
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                train(&stacks, &names, &examples, &[], None, &config, |_| {})
                    .unwrap()
                    .model
            })
        };
        assert_eq!(run(1), run(2));
        assert_eq!(run(2), run(3));
    }

    #[test]
    fn unreachable_goals_are_reported() {
        let (mut stacks, names, examples, _) = small_world();
        let example = examples[0].clone();
        // Wall off the goal: non-finite features make every neighbour's cost infinite.
        let goal = *example.path.last().unwrap();
        let geo = stacks[example.map].geo.clone();
        for i in 0..geo.cell_count() {
            let cell = geo.cell_at(i);
            if cell.chebyshev(goal) == 1 {
                let n = geo.cell_count();
                for j in 0..stacks[example.map].dim() {
                    stacks[example.map].data[j * n + i] = f32::INFINITY;
                }
            }
        }
        let err = train(&stacks, &names, &[example], &[], None, &config(), |_| {}).unwrap_err();
        assert!(err.contains("no path"), "{err}");
    }
}
