//! The reduce step of a LEARCH round: the examples' statistics merged in example
//! order and the next weak learner fitted (ridge, a regression tree over the features
//! open in the round's stage, or MMP's and MaxEnt's linear steps).

use super::map_step::TreePoints;
use super::*;
use crate::features::is_distance;
use crate::learn::{Candidates, RegressionTree, RidgeAccumulator};

/// What the reduce step of a round made: the next weak learner and the round's figures.
pub struct FittedRound {
    pub learner: WeakLearner,
    pub step: f64,
    /// MMP's step was projected back onto positive costs.
    pub projected_to_margin: bool,
    /// Mean training loss of the examples.
    pub training_loss: f64,
    pub disagreeing_cells: usize,
}

/// The reduce step of round `t` (from 0) of member `member` (`MEMBERS`): merges the
/// examples' statistics in the order given (example order, whatever machine planned
/// them, so that the result is the same everywhere) and fits the next weak learner of
/// `model`. `stacks` are read by
/// MMP's projection and MaxEnt's trust region only.
pub fn fit_round(
    model: &LogCostModel,
    stacks: &[FeatureStack],
    statistics: &[ExampleStatistics],
    config: &LearchConfig,
    t: usize,
    member: usize,
) -> Result<FittedRound, String> {
    let step = config.step(t);
    let mut projected_to_margin = false;
    let learner = match (config.method, config.weak_learner.in_round(t)) {
        (GridMethod::Mmp, _) | (GridMethod::Maxent, WeakLearnerKind::Ridge) => {
            // The mean over demonstrated steps, plus the ridge penalty's pull.
            let steps = statistics.iter().map(|g| g.steps).sum::<usize>().max(1) as f64;
            let weights = model.scaled_weights();
            let mut direction: Vec<f64> = (0..weights.len())
                .map(|j| {
                    statistics.iter().map(|g| g.direction[j]).sum::<f64>() / steps
                        - config.ridge_lambda * weights[j]
                })
                .collect();
            // At most a unit step in the scaled weights (MMP, MaxEnt): MaxEnt's gradient grows
            // with the cost it multiplies, and would otherwise overshoot into
            // ever larger costs.
            let norm = direction.iter().map(|d| d * d).sum::<f64>().sqrt();
            if !norm.is_finite() {
                return Err(format!(
                    "{} round {}: the gradient is not finite (costs overflowed); \
                     lower --step-size or scale the features",
                    config.method.name(),
                    t + 1
                ));
            }
            if norm > 1.0 {
                direction.iter_mut().for_each(|d| *d /= norm);
            }
            if config.method == GridMethod::Maxent {
                // A trust region in log-cost: no cell's cost changes by more than a
                // factor e^MAXENT_LOG_COST_STEP in one round. A unit step on the
                // scaled weights can still move the log-cost by hundreds on cells
                // where a heavy-tailed feature is far from its mean, and the soft
                // values then overflow.
                let largest = largest_change(stacks, &model.scale, step, &direction);
                if largest > MAXENT_LOG_COST_STEP {
                    let shrink = MAXENT_LOG_COST_STEP / largest;
                    direction.iter_mut().for_each(|d| *d *= shrink);
                }
            }
            if config.method == GridMethod::Mmp {
                let (projected, moved) =
                    project_onto_positive_costs(model, stacks, step, &direction);
                if moved {
                    direction = projected;
                    projected_to_margin = true;
                }
            }
            WeakLearner::ridge(step, direction)
        }
        (GridMethod::Learch, WeakLearnerKind::Ridge) => {
            let mut data = RidgeAccumulator::new(model.feature_names.len());
            for g in statistics {
                data.merge(&g.data);
            }
            WeakLearner::ridge(step, data.solve(config.ridge_lambda))
        }
        (GridMethod::Learch | GridMethod::Maxent, _) => {
            let dims = model.feature_names.len();
            let all: Vec<&TreePoints> = statistics.iter().map(|g| &g.points).collect();
            // MaxEnt's examples share most of their points' cells; LEARCH's plans and
            // demonstrations rarely meet, and their rows are kept as they come.
            let rows = match config.method {
                GridMethod::Maxent => {
                    let cell_counts: Vec<usize> =
                        stacks.iter().map(|s| s.geo.cell_count()).collect();
                    TreePoints::merged_by_cell(&all, dims, &cell_counts)
                }
                _ => TreePoints::concatenated(&all, dims),
            };
            let (candidates, gains) =
                split_candidates(&model.feature_names, stacks, config, t, member);
            let tree = RegressionTree::fit_on(
                &rows.columns,
                &rows.targets,
                &rows.weights,
                &config.tree,
                &candidates,
                &gains,
            );
            WeakLearner::tree(step, tree)
        }
    };
    Ok(FittedRound {
        learner,
        step,
        projected_to_margin,
        training_loss: statistics.iter().map(|g| g.loss).sum::<f64>()
            / statistics.len().max(1) as f64,
        disagreeing_cells: statistics.iter().map(|g| g.disagreeing_cells).sum(),
    })
}

/// Where round `t`'s tree may split each feature, and the factor on its splits' gains:
/// distances between any two of their values, the others at binned candidates
/// ([`Candidates`]); features of a stage of `SCALE_STAGES` not yet open by then with
/// their gains times the member's factor for it, and none where that is 0.
pub(super) fn split_candidates(
    names: &[String],
    stacks: &[FeatureStack],
    config: &LearchConfig,
    t: usize,
    member: usize,
) -> (Vec<Candidates>, Vec<f64>) {
    let gains = split_gains(names, stacks, config, t, member);
    let candidates = names
        .iter()
        .zip(&gains)
        .map(|(name, &gain)| match gain > 0.0 {
            false => Candidates::Unused,
            true if is_distance(name) => Candidates::Exact,
            true => Candidates::Binned,
        })
        .collect();
    (candidates, gains)
}

/// The factor on round `t`'s split gains of each feature: 1 for every feature, or, in
/// stages, 1 for those of the stages of `SCALE_STAGES` open by then (and at least the
/// finest scale there is) and the member's factors (`MEMBERS`) for the others.
fn split_gains(
    names: &[String],
    stacks: &[FeatureStack],
    config: &LearchConfig,
    t: usize,
    member: usize,
) -> Vec<f64> {
    if !(config.widen_in_stages && config.method == GridMethod::Learch) {
        return vec![1.0; names.len()];
    }
    let (scales, finest) = scales_in_cells(names, stacks);
    let factors = &MEMBERS[member.min(MEMBERS.len() - 1)];
    names
        .iter()
        .zip(&scales)
        .map(|(name, &scale)| {
            let k = SCALE_STAGES
                .iter()
                .position(|stage| scale <= stage.cells)
                .unwrap_or(SCALE_STAGES.len() - 1);
            if scale <= finest || t as f64 >= SCALE_STAGES[k].from_share * config.rounds as f64 {
                1.0
            } else if is_distance(name) {
                factors.distances_before
            } else {
                factors.gain_before[k]
            }
        })
        .collect()
}

/// Each feature's scale in cells ([`scale_in_cells`], at the maps' finest cells), and
/// the finest of them.
fn scales_in_cells(names: &[String], stacks: &[FeatureStack]) -> (Vec<f64>, f64) {
    let cell_metres = stacks
        .iter()
        .flat_map(|s| s.geo.cell_metres())
        .fold(f64::INFINITY, f64::min);
    let scales: Vec<f64> = names
        .iter()
        .map(|n| scale_in_cells(n, cell_metres))
        .collect();
    let finest = scales.iter().copied().fold(f64::INFINITY, f64::min);
    (scales, finest)
}

/// The members to train on these features: one where every feature is of the finest
/// scale, since no stage then holds any back and the members would be the same model.
pub(super) fn members_to_train(
    config: &LearchConfig,
    names: &[String],
    stacks: &[FeatureStack],
) -> usize {
    let (scales, finest) = scales_in_cells(names, stacks);
    if scales.iter().any(|&scale| scale > finest) {
        config.member_count()
    } else {
        1
    }
}

/// The largest |Δs| over every cell of every map of the linear step `step · direction`
/// on scaled features.
fn largest_change(stacks: &[FeatureStack], scale: &[f64], step: f64, direction: &[f64]) -> f64 {
    let change: Vec<f64> = direction
        .iter()
        .zip(scale)
        .map(|(d, s)| step * d / s)
        .collect();
    stacks
        .par_iter()
        .map(|stack| {
            let mut ds = vec![0.0f64; stack.geo.cell_count()];
            for (plane, &dw) in stack.planes().zip(&change) {
                if dw != 0.0 {
                    for (ds, &f) in ds.iter_mut().zip(plane) {
                        *ds += dw * f64::from(f);
                    }
                }
            }
            ds.iter().fold(0.0f64, |m, d| m.max(d.abs()))
        })
        .reduce(|| 0.0, f64::max)
}

/// Projects MMP's step onto the costs that stay positive: the new scaled weights u
/// (u·x = s on scaled features x) are moved, one violated cell at a time, onto the
/// half-space 1 + u·x ≥ `MMP_COST_MARGIN` of the cell whose cost is lowest (the
/// alternating projections of Kaczmarz), until no cell of any map is below the margin
/// or `MAX_PROJECTIONS` were made. Returns the projected direction (so that
/// `step · direction` is the projected step) and whether it moved.
fn project_onto_positive_costs(
    model: &LogCostModel,
    stacks: &[FeatureStack],
    step: f64,
    direction: &[f64],
) -> (Vec<f64>, bool) {
    const MAX_PROJECTIONS: usize = 64;
    let before = model.scaled_weights();
    let mut u: Vec<f64> = before
        .iter()
        .zip(direction)
        .map(|(w, d)| w + step * d)
        .collect();
    let mut moved = false;
    let mut x = vec![0.0f64; u.len()];
    let mut raw = vec![0.0f32; u.len()];
    for _ in 0..MAX_PROJECTIONS {
        // The cheapest cell over every map (first in map, then cell order on ties).
        let weights: Vec<f64> = u.iter().zip(&model.scale).map(|(u, s)| u / s).collect();
        let lowest = stacks
            .par_iter()
            .enumerate()
            .map(|(m, stack)| {
                let mut cost = vec![1.0f64; stack.geo.cell_count()];
                for (plane, &w) in stack.planes().zip(&weights) {
                    for (c, &f) in cost.iter_mut().zip(plane) {
                        *c += w * f64::from(f);
                    }
                }
                let (i, c) = cost
                    .iter()
                    .enumerate()
                    .fold(
                        (0, f64::INFINITY),
                        |best, (i, &c)| if c < best.1 { (i, c) } else { best },
                    );
                (c, m, i)
            })
            .reduce(
                || (f64::INFINITY, usize::MAX, 0),
                |a, b| {
                    if b.0 < a.0 || (b.0 == a.0 && b.1 < a.1) {
                        b
                    } else {
                        a
                    }
                },
            );
        let (cost, m, i) = lowest;
        if m == usize::MAX || cost >= MMP_COST_MARGIN * (1.0 - 1e-9) {
            break;
        }
        stacks[m].cell_into(i, &mut raw);
        model.scaled(&raw, &mut x);
        let norm2 = x.iter().map(|v| v * v).sum::<f64>();
        if norm2 == 0.0 {
            break;
        }
        let lift = (MMP_COST_MARGIN - cost) / norm2;
        u.iter_mut().zip(&x).for_each(|(u, x)| *u += lift * x);
        moved = true;
    }
    let projected = u.iter().zip(&before).map(|(u, w)| (u - w) / step).collect();
    (projected, moved)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trees_widen_the_features_they_split_on_in_stages() {
        let stacks = [FeatureStack {
            geo: crate::grid::GeoRef::square(4, 4, 10.0, [0.0, 0.0], "map"),
            names: Vec::new(),
            data: Vec::new(),
        }];
        let names: Vec<String> = [
            "band/robust",
            "band/blur_3c",
            "band/blur_80m",
            "band/distance_to_above_q90_m",
            "bias",
        ]
        .map(String::from)
        .to_vec();
        let config = LearchConfig {
            weak_learner: WeakLearnerKind::Tree,
            rounds: 80,
            ..LearchConfig::default()
        };
        let gains = |config: &LearchConfig, t| split_gains(&names, &stacks, config, t, 0);
        assert_eq!(gains(&config, 0), [1.0, 0.3, 0.1, 0.0, 1.0]);
        assert_eq!(gains(&config, 19), [1.0, 0.3, 0.1, 0.0, 1.0]);
        assert_eq!(gains(&config, 20), [1.0, 1.0, 0.1, 0.0, 1.0]);
        assert_eq!(gains(&config, 40), [1.0; 5]);
        // The second member lets wider features and distances compete earlier.
        let second = |t| split_gains(&names, &stacks, &config, t, 1);
        assert_eq!(second(0), [1.0, 0.6, 0.3, 0.3, 1.0]);
        assert_eq!(second(20), [1.0, 1.0, 0.3, 0.3, 1.0]);
        assert_eq!(second(40), [1.0; 5]);
        let at_once = LearchConfig {
            widen_in_stages: false,
            ..config.clone()
        };
        assert_eq!(gains(&at_once, 0), [1.0; 5]);
        // With only regional features the first rounds split the finest freely.
        let wide = ["band/blur_8c".to_string(), "band/blur_16c".to_string()];
        assert_eq!(split_gains(&wide, &stacks, &config, 0, 0), [1.0, 0.1]);
        // Distances wait for their stage, then are split between any two of their values.
        use Candidates::{Binned, Exact, Unused};
        let candidates = |t| split_candidates(&names, &stacks, &config, t, 0).0;
        assert_eq!(candidates(0), [Binned, Binned, Binned, Unused, Binned]);
        assert_eq!(candidates(40), [Binned, Binned, Binned, Exact, Binned]);
    }
}
