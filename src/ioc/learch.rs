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
use crate::grid::{CellPath, FeatureStack, Grid};
use crate::learn::RidgeAccumulator;
use crate::plan::{path_cost, shortest_path};

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
    let (center, scale) = standardization(stacks);
    let mut model = LogLinearCost::zero(names, center, scale);
    let mut rounds = Vec::with_capacity(config.rounds);
    for t in 0..config.rounds {
        let costmaps: Vec<Grid<f32>> = stacks.par_iter().map(|s| model.costmap(s)).collect();
        let gradients: Vec<ExampleGradient> = training
            .par_iter()
            .map(|ex| example_gradient(&model, &stacks[ex.map], &costmaps[ex.map], ex, config.loss))
            .collect::<Result<_, _>>()?;
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
    examples
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
        .collect()
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
        let keep = (1.0 - loss).max(1e-6) as f32;
        let mut aug = costs.clone();
        for (i, c) in aug.data.iter_mut().enumerate() {
            if !visits.contains_key(&i) {
                *c *= keep;
            }
        }
        std::borrow::Cow::Owned(aug)
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
    let mut x = vec![0.0; stack.dim()];
    let mut disagreeing_cells = 0;
    for (&i, &difference) in &visits {
        if difference == 0 {
            continue;
        }
        disagreeing_cells += 1;
        model.standardize(stack.at(i), &mut x);
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

/// Per-feature mean and standard deviation over all cells of all maps; constant
/// features (such as the bias) are left as they are.
fn standardization(stacks: &[FeatureStack]) -> (Vec<f64>, Vec<f64>) {
    let dim = stacks[0].dim();
    let mut sum = vec![0.0f64; dim];
    let mut sum_sq = vec![0.0f64; dim];
    let mut count = 0usize;
    for stack in stacks {
        for cell in stack.data.chunks_exact(dim) {
            for j in 0..dim {
                let v = f64::from(cell[j]);
                sum[j] += v;
                sum_sq[j] += v * v;
            }
        }
        count += stack.geo.cell_count();
    }
    let n = count.max(1) as f64;
    let mut center = vec![0.0; dim];
    let mut scale = vec![1.0; dim];
    for j in 0..dim {
        let mean = sum[j] / n;
        let var = (sum_sq[j] / n - mean * mean).max(0.0);
        if var.sqrt() > 1e-9 * mean.abs().max(1.0) {
            center[j] = mean;
            scale[j] = var.sqrt();
        }
    }
    (center, scale)
}
