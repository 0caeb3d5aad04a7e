//! The map step of a LEARCH round: every training example planned under the current
//! model (loss-augmented, or MaxEnt's soft paths) and compared with its
//! demonstration, giving the statistics the reduce step merges.

use std::collections::BTreeMap;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::*;
use crate::error::first_error_in_order;
use crate::features::distance_transform;
use crate::grid::{Cell, GeoRef};
use crate::ioc::soft_paths::{SoftGoal, Window, path_incidence};
use crate::learn::RidgeAccumulator;
use crate::plan::{Moves, StepLengths, augmented_cost, dijkstra, path_cost, shortest_path};

/// What one example contributes to a round (the map step, `PreparedExamples::plan`):
/// the ridge statistics or the points for a tree (LEARCH), or the direction of a linear
/// step on the scaled weights (MMP, MaxEnt). Merged in example order by `fit_round`.
/// Serialisable, to travel from workers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExampleStatistics {
    pub(super) data: RidgeAccumulator,
    pub(super) points: TreePoints,
    pub(super) direction: Vec<f64>,
    /// The demonstration's steps, which MMP and MaxEnt divide their steps by.
    pub(super) steps: usize,
    pub(super) loss: f64,
    pub(super) disagreeing_cells: usize,
}

/// One example's points for a round's regression tree: its cells' scaled features,
/// stored column by column as the tree bins them, and each cell's target and weight.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(super) struct TreePoints {
    /// The index of the map the points lie on (`Example::map`).
    map: usize,
    /// Each point's cell, a row-major index into its map.
    cells: Vec<usize>,
    rows: TreeRows,
}

/// Rows for a regression tree: features stored column by column as the tree bins them,
/// and each row's target and weight.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(super) struct TreeRows {
    /// Feature `j` of row `i` at `j * targets.len() + i`.
    pub(super) columns: Vec<f64>,
    pub(super) targets: Vec<f64>,
    pub(super) weights: Vec<f64>,
}

impl TreePoints {
    /// The points at `cells` (row-major indices into `stack`'s map), features scaled
    /// as `model` scales them.
    pub(super) fn of(
        model: &LogCostModel,
        stack: &FeatureStack,
        ex: &Example,
        cells: Vec<usize>,
        targets: Vec<f64>,
        weights: Vec<f64>,
    ) -> Self {
        let mut columns = Vec::with_capacity(stack.dim() * cells.len());
        for (plane, scale) in stack.planes().zip(&model.scale) {
            columns.extend(cells.iter().map(|&i| f64::from(plane[i]) / scale));
        }
        TreePoints {
            map: ex.map,
            cells,
            rows: TreeRows {
                columns,
                targets,
                weights,
            },
        }
    }

    pub(super) fn len(&self) -> usize {
        self.cells.len()
    }

    /// Every example's points together, column by column, in example order.
    pub(super) fn concatenated(all: &[&TreePoints], dims: usize) -> TreeRows {
        let rows: usize = all.iter().map(|p| p.len()).sum();
        let mut columns = vec![0.0; dims * rows];
        (columns.par_chunks_mut(rows.max(1)).enumerate()).for_each(|(j, column)| {
            let mut at = 0;
            for points in all {
                let n = points.len();
                column[at..at + n].copy_from_slice(&points.rows.columns[j * n..(j + 1) * n]);
                at += n;
            }
        });
        TreeRows {
            columns,
            targets: all.iter().flat_map(|p| &p.rows.targets).copied().collect(),
            weights: all.iter().flat_map(|p| &p.rows.weights).copied().collect(),
        }
    }

    /// Every example's points together, those at one cell of one map merged into one
    /// point in the order they first appear: its weight the sum of theirs, its target
    /// their weighted mean. The tree's sums over a leaf, and so its splits and values,
    /// are the same up to their rounding, on as many rows as there are cells: MaxEnt's
    /// examples each give a point at every cell their soft paths reach, most of them
    /// shared with the other examples'. `cell_counts`: the cells of each map.
    pub(super) fn merged_by_cell(
        all: &[&TreePoints],
        dims: usize,
        cell_counts: &[usize],
    ) -> TreeRows {
        let mut row_of_cell: Vec<Vec<u32>> = vec![Vec::new(); cell_counts.len()];
        // Each merged point's first (example, point), its summed weight and weight × target.
        let mut first = Vec::new();
        let (mut weights, mut weighted_targets) = (Vec::new(), Vec::new());
        for (e, points) in all.iter().enumerate() {
            let rows = &mut row_of_cell[points.map];
            if rows.is_empty() {
                *rows = vec![u32::MAX; cell_counts[points.map]];
            }
            for (k, &cell) in points.cells.iter().enumerate() {
                if rows[cell] == u32::MAX {
                    rows[cell] = first.len() as u32;
                    first.push((e, k));
                    weights.push(0.0);
                    weighted_targets.push(0.0);
                }
                let row = rows[cell] as usize;
                weights[row] += points.rows.weights[k];
                weighted_targets[row] += points.rows.weights[k] * points.rows.targets[k];
            }
        }
        let rows = first.len();
        let mut columns = vec![0.0; dims * rows];
        (columns.par_chunks_mut(rows.max(1)).enumerate()).for_each(|(j, column)| {
            for (value, &(e, k)) in column.iter_mut().zip(&first) {
                *value = all[e].rows.columns[j * all[e].len() + k];
            }
        });
        let targets = (weighted_targets.iter().zip(&weights))
            .map(|(&wy, &w): (&f64, &f64)| if w > 0.0 { wy / w } else { 0.0 })
            .collect();
        TreeRows {
            columns,
            targets,
            weights,
        }
    }
}

/// Per cell of the example's map, the share of the learned cost its loss takes off:
/// 0 on the demonstration, up to 1 away from it.
pub(super) fn loss_shares(stack: &FeatureStack, ex: &Example, config: &LearchConfig) -> Vec<f32> {
    let geo = &stack.geo;
    let mut on_path = vec![false; geo.cell_count()];
    for &cell in &ex.path {
        on_path[geo.index(cell)] = true;
    }
    match config.loss_kind {
        LossKind::Hamming => on_path
            .iter()
            .map(|&on| if on { 0.0 } else { 1.0 })
            .collect(),
        LossKind::Dilated => {
            let mut distance = vec![0.0f32; geo.cell_count()];
            let (w, h) = (geo.width as usize, geo.height as usize);
            distance_transform(
                &on_path,
                w,
                h,
                &[[1.0; 2]],
                f64::from(geo.width + geo.height),
                &mut distance,
            );
            let sigma2 = config.loss_sigma.max(1e-6).powi(2);
            distance
                .iter()
                .map(|&d| (1.0 - (-f64::from(d).powi(2) / sigma2).exp()) as f32)
                .collect()
        }
    }
}

/// An example's loss shares (`loss_shares`), kept row by row only where they are below
/// 1 (near the demonstration): an example then holds memory in proportion to its
/// path, not to its map (750 examples on 1000² maps held 3 GB as dense vectors).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct CompactShares {
    width: usize,
    /// Per row: the first column of its stored span and the span's range in `values`.
    rows: Vec<(usize, std::ops::Range<usize>)>,
    pub(super) values: Vec<f32>,
}

impl CompactShares {
    pub(super) fn new(dense: &[f32], width: usize) -> Self {
        let mut rows = Vec::with_capacity(dense.len() / width.max(1));
        let mut values = Vec::new();
        for row in dense.chunks(width.max(1)) {
            let first = row.iter().position(|&s| s != 1.0);
            let span = match first {
                Some(first) => {
                    let last = row.iter().rposition(|&s| s != 1.0).unwrap_or(first);
                    first..last + 1
                }
                None => 0..0,
            };
            let at = values.len();
            values.extend_from_slice(&row[span.clone()]);
            rows.push((span.start, at..values.len()));
        }
        CompactShares {
            width,
            rows,
            values,
        }
    }

    /// The loss-augmented costmap: each cell's cost less `loss` times its share of
    /// it, floored at `LOSS_FLOOR` (row by row: the stored spans, and the full share
    /// of 1 on either side, in loops that vectorise).
    pub(super) fn augmented(&self, costs: &Grid<f32>, loss: f32) -> Grid<f32> {
        let mut data = Vec::with_capacity(costs.data.len());
        // A share of 1: loss · 1 · c is loss · c to the bit.
        let full = |c: f32| augmented_cost(c, loss * c, LOSS_FLOOR);
        for (row, (first, stored)) in costs.data.chunks(self.width.max(1)).zip(&self.rows) {
            let shares = &self.values[stored.clone()];
            let first = if shares.is_empty() { row.len() } else { *first };
            let (before, rest) = row.split_at(first);
            let (span, after) = rest.split_at(shares.len());
            data.extend(before.iter().map(|&c| full(c)));
            data.extend(
                (span.iter().zip(shares))
                    .map(|(&c, &share)| augmented_cost(c, loss * share * c, LOSS_FLOOR)),
            );
            data.extend(after.iter().map(|&c| full(c)));
        }
        Grid::from_vec(costs.geo.clone(), data)
    }

    /// Every cell's share, in cell order: the dense vector this was made from.
    #[cfg(test)]
    pub(super) fn iter(&self) -> impl Iterator<Item = f32> + '_ {
        self.rows.iter().flat_map(move |(first, stored)| {
            let (before, after) = if stored.is_empty() {
                (self.width, 0)
            } else {
                (*first, self.width - first - stored.len())
            };
            std::iter::repeat_n(1.0, before)
                .chain(self.values[stored.clone()].iter().copied())
                .chain(std::iter::repeat_n(1.0, after))
        })
    }
}

/// Training examples ready for rounds: each with its loss over its map, computed once.
/// A worker holding a share of the examples keeps one of these for every round.
pub struct PreparedExamples {
    examples: Vec<Example>,
    shares: Vec<CompactShares>,
    /// The examples' indices, longest path first: the order a round's threads take
    /// them in, so that the last ones left are short and the threads finish together.
    longest_first: Vec<usize>,
}

impl PreparedExamples {
    pub fn new(stacks: &[FeatureStack], examples: Vec<Example>, config: &LearchConfig) -> Self {
        let shares = examples
            .par_iter()
            .map(|ex| {
                let stack = &stacks[ex.map];
                CompactShares::new(&loss_shares(stack, ex, config), stack.geo.width as usize)
            })
            .collect();
        let mut longest_first: Vec<usize> = (0..examples.len()).collect();
        longest_first.sort_by_key(|&i| std::cmp::Reverse(steps(&examples[i].path)));
        PreparedExamples {
            examples,
            shares,
            longest_first,
        }
    }

    pub fn len(&self) -> usize {
        self.examples.len()
    }

    pub fn is_empty(&self) -> bool {
        self.examples.is_empty()
    }

    /// The map step of a round: plans every example under `model` (on the
    /// loss-augmented costmap, or MaxEnt's soft paths) and returns their statistics in
    /// example order. `stacks` are every map's features, indexed by `Example::map`.
    pub fn plan(
        &self,
        model: &LogCostModel,
        stacks: &[FeatureStack],
        config: &LearchConfig,
    ) -> Result<Vec<ExampleStatistics>, String> {
        let mut sums = vec![TreeSums::default(); stacks.len()];
        self.plan_growing(model, stacks, config, &mut sums)
    }

    /// [`PreparedExamples::plan`] with each map's trees' sums kept in `sums` (one per
    /// stack) from the rounds before, for a model that grows round by round.
    pub fn plan_growing(
        &self,
        model: &LogCostModel,
        stacks: &[FeatureStack],
        config: &LearchConfig,
        sums: &mut [TreeSums],
    ) -> Result<Vec<ExampleStatistics>, String> {
        // Each map's costmap once, for the maps these examples use.
        let mut used = vec![false; stacks.len()];
        for ex in &self.examples {
            used[ex.map] = true;
        }
        let costmaps: Vec<Option<Grid<f32>>> = (stacks.iter().zip(&used).zip(sums))
            .map(|((s, &used), sums)| used.then(|| model.costmap_growing(s, sums)))
            .collect();
        // Taken longest first, one example a task; returned in example order.
        let mut statistics: Vec<(usize, Result<ExampleStatistics, String>)> = self
            .longest_first
            .par_iter()
            .with_max_len(1)
            .map(|&i| {
                let ex = &self.examples[i];
                let costs = costmaps[ex.map].as_ref().expect("costmaps of used maps");
                let statistics =
                    example_statistics(model, &stacks[ex.map], costs, ex, &self.shares[i], config);
                (i, statistics)
            })
            .collect();
        statistics.sort_by_key(|&(i, _)| i);
        first_error_in_order(statistics.into_iter().map(|(_, s)| s).collect())
    }
}

fn example_statistics(
    model: &LogCostModel,
    stack: &FeatureStack,
    costs: &Grid<f32>,
    ex: &Example,
    shares: &CompactShares,
    config: &LearchConfig,
) -> Result<ExampleStatistics, String> {
    match config.method {
        GridMethod::Learch | GridMethod::Mmp => {
            planned_gradient(model, stack, costs, ex, shares, config)
        }
        GridMethod::Maxent => maxent_gradient(model, stack, costs, ex, config),
    }
}

/// Steps a path takes (cells − 1).
fn steps(path: &[Cell]) -> usize {
    path.len().saturating_sub(1)
}

/// Σ_cells weight(cell) · scaled features(cell), over (map index, weight) pairs.
fn weighted_features(
    model: &LogCostModel,
    stack: &FeatureStack,
    weights: impl Iterator<Item = (usize, f64)>,
) -> Vec<f64> {
    let mut total = vec![0.0; stack.dim()];
    let mut raw = vec![0.0f32; stack.dim()];
    let mut x = vec![0.0; stack.dim()];
    for (i, weight) in weights {
        if weight == 0.0 {
            continue;
        }
        stack.cell_into(i, &mut raw);
        model.scaled(&raw, &mut x);
        for (t, v) in total.iter_mut().zip(&x) {
            *t += weight * v;
        }
    }
    total
}

/// LEARCH and MMP: plan on the loss-augmented costmap and compare with the
/// demonstration: the steps' lengths through each cell for LEARCH's weak learner,
/// feature counts weighted by them for MMP's subgradient.
fn planned_gradient(
    model: &LogCostModel,
    stack: &FeatureStack,
    costs: &Grid<f32>,
    ex: &Example,
    shares: &CompactShares,
    config: &LearchConfig,
) -> Result<ExampleStatistics, String> {
    let loss = config.loss;
    let geo = &stack.geo;
    let corridor = if ex.waypoints.is_empty() {
        corridor::corridor_path(costs, &ex.path, config.corridor)
    } else {
        corridor::waypoint_path(costs, &ex.path, &ex.waypoints, config.corridor)
    };
    let demonstration: &[Cell] = corridor.as_deref().unwrap_or(&ex.path);
    // μ: how often the demonstration visits each cell.
    let mut visits: BTreeMap<usize, i64> = BTreeMap::new();
    for &cell in demonstration {
        *visits.entry(geo.index(cell)).or_default() -= 1;
    }
    let augmented = if loss > 0.0 {
        std::borrow::Cow::Owned(shares.augmented(costs, loss as f32))
    } else {
        std::borrow::Cow::Borrowed(costs)
    };
    let start = ex.path[0];
    let goal = ex.path[ex.path.len() - 1];
    // LEARCH plans with the bucket-queue Dijkstra that stops at the goal (twice A*'s
    // speed on learned costmaps, whose cheapest cell makes A*'s heuristic weak); among
    // equally cheap paths it returns the first one its queue completes, a fixed order
    // (the same plans at any thread count). MMP keeps A*, whose goal-directed tie-break
    // suits its floored costs' many ties.
    let route = match config.method {
        GridMethod::Learch => dijkstra(&augmented, start, goal, Moves::default()),
        _ => shortest_path(&augmented, start, goal),
    }
    .ok_or_else(|| unreachable(ex))?;
    let demo_cost = path_cost(&augmented, demonstration);
    // μ* − μ, with μ already subtracted above.
    for &cell in &route.cells {
        *visits.entry(geo.index(cell)).or_default() += 1;
    }
    let mut data = RidgeAccumulator::new(stack.dim());
    let (mut point_cells, mut targets, mut weights) = (Vec::new(), Vec::new(), Vec::new());
    let mut direction = Vec::new();
    let mut raw = vec![0.0f32; stack.dim()];
    let mut x = vec![0.0; stack.dim()];
    let disagreeing_cells = visits.values().filter(|&&d| d != 0).count();
    let lengths = StepLengths::of(geo);
    if config.method == GridMethod::Mmp {
        // Φ(plan) − Φ(demo).
        let incidence = length_difference(geo, &lengths, &route.cells, demonstration, 1.0);
        direction = weighted_features(model, stack, incidence.into_iter());
    } else {
        // A path's cost changes with a cell's log-cost by the cost times the length of
        // the path's steps through the cell: the targets are the difference's sign, its
        // size the weight (in straight steps, so that square cells weigh a visit as
        // before; diagonals √2, and a geographic raster's narrow rows near the poles
        // little).
        let unit = straight_step(geo, &lengths);
        for (i, difference) in length_difference(geo, &lengths, &route.cells, demonstration, unit) {
            if difference.abs() < SHARED_STEPS {
                continue;
            }
            let (target, weight) = (difference.signum(), difference.abs());
            if config.weak_learner != WeakLearnerKind::Tree {
                stack.cell_into(i, &mut raw);
                model.scaled(&raw, &mut x);
                data.add(&x, target, weight);
            }
            if config.weak_learner != WeakLearnerKind::Ridge {
                point_cells.push(i);
                targets.push(target);
                weights.push(weight);
            }
        }
    }
    Ok(ExampleStatistics {
        data,
        points: TreePoints::of(model, stack, ex, point_cells, targets, weights),
        direction,
        steps: steps(&ex.path),
        loss: ((demo_cost - route.cost) / demo_cost.max(f64::MIN_POSITIVE)).max(0.0),
        disagreeing_cells,
    })
}

/// Per cell, the length of the plan's steps through it minus the demonstration's (each
/// step's length split between its two cells), in units of `unit`.
pub(super) fn length_difference(
    geo: &GeoRef,
    lengths: &StepLengths,
    plan: &[Cell],
    demonstration: &[Cell],
    unit: f64,
) -> BTreeMap<usize, f64> {
    let mut incidence: BTreeMap<usize, f64> = BTreeMap::new();
    for (path, sign) in [(plan, 1.0), (demonstration, -1.0)] {
        for pair in path.windows(2) {
            let half = 0.5 * lengths.between(pair[0], pair[1]) / unit;
            for cell in pair {
                *incidence.entry(geo.index(*cell)).or_default() += sign * half;
            }
        }
    }
    incidence
}

/// Length differences below this (in straight steps) are the rounding of steps that
/// plan and demonstration share.
const SHARED_STEPS: f64 = 1e-9;

/// The length of a straight step north from the middle row (east on a one-row grid):
/// the unit of LEARCH's visitation weights.
pub(super) fn straight_step(geo: &GeoRef, lengths: &StepLengths) -> f64 {
    let mid = geo.height / 2;
    if mid == 0 {
        lengths.between(Cell::new(0, 0), Cell::new(0, 1))
    } else {
        lengths.between(Cell::new(mid - 1, 0), Cell::new(mid, 0))
    }
}

/// MaxEnt: per cell, expected minus demonstrated visits times the cost (the gradient
/// of the log-likelihood with respect to the log-cost), as points for a tree, and
/// summed into cost-weighted feature counts for the log-linear weights (∂c/∂w = c · f),
/// within a window around the demonstration and a horizon of `horizon_factor` times
/// its steps.
/// The loss reported is the negative log-likelihood per step.
fn maxent_gradient(
    model: &LogCostModel,
    stack: &FeatureStack,
    costs: &Grid<f32>,
    ex: &Example,
    config: &LearchConfig,
) -> Result<ExampleStatistics, String> {
    let geo = &stack.geo;
    let (start, goal) = (ex.path[0], ex.path[ex.path.len() - 1]);
    let window = Window::around(&ex.path, config.window_margin, geo.width, geo.height);
    let horizon = ((steps(&ex.path) as f64 * config.horizon_factor).ceil() as usize)
        .max(steps(&ex.path))
        .max(1);
    let soft = SoftGoal::between(costs, window, start, goal, horizon);
    let log_partition = -soft.value(start);
    if !log_partition.is_finite() {
        return Err(unreachable(ex));
    }
    let expected = soft.visitation(start);
    let demonstrated = path_incidence(&window, &ex.path, &StepLengths::of(geo));
    let cost_at = |i: usize| f64::from(costs.get(window.cell(i)));
    // ∂(−log-likelihood)/∂s per cell: (expected − demonstrated incidence) · cost.
    let gradient: Vec<(usize, f64)> = (0..window.len())
        .map(|i| {
            let difference = expected.incidence[i] - demonstrated[i];
            (geo.index(window.cell(i)), difference * cost_at(i))
        })
        .collect();
    let mut points = TreePoints::default();
    if config.weak_learner != WeakLearnerKind::Ridge {
        // The functional gradient, as LEARCH's points: its sign the target, its size
        // the weight (cells whose share is negligible left out).
        let kept = || (gradient.iter()).filter(|(_, g)| g.abs() >= MAXENT_TREE_MIN_WEIGHT);
        let cells: Vec<usize> = kept().map(|&(i, _)| i).collect();
        let targets = kept().map(|(_, g)| g.signum()).collect();
        let weights = kept().map(|(_, g)| g.abs()).collect();
        points = TreePoints::of(model, stack, ex, cells, targets, weights);
    }
    let direction = weighted_features(model, stack, gradient.into_iter());
    let demo_cost = path_cost(costs, &ex.path);
    let disagreeing_cells = (0..window.len())
        .filter(|&i| (expected.visits[i] > 0.5) != (demonstrated[i] > 0.0))
        .count();
    Ok(ExampleStatistics {
        data: RidgeAccumulator::new(stack.dim()),
        points,
        direction,
        steps: steps(&ex.path),
        loss: (demo_cost + log_partition) / steps(&ex.path).max(1) as f64,
        disagreeing_cells,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_at_one_cell_of_one_map_merge_into_one_row_and_the_same_tree() {
        // Two features: the cell's index and its square. Dyadic weights, so that the
        // merged sums are exact.
        let points = |map, cells: Vec<usize>, targets: Vec<f64>, weights: Vec<f64>| {
            let index = cells.iter().map(|&c| c as f64);
            let square = cells.iter().map(|&c| (c * c) as f64);
            TreePoints {
                map,
                rows: TreeRows {
                    columns: index.chain(square).collect(),
                    targets,
                    weights,
                },
                cells,
            }
        };
        let a = points(0, vec![3, 5, 7], vec![1.0, -1.0, 1.0], vec![0.5, 0.25, 2.0]);
        let b = points(0, vec![5, 9], vec![1.0, -1.0], vec![0.75, 1.0]);
        // Cell 5 of another map is another point.
        let c = points(1, vec![5], vec![-1.0], vec![0.5]);
        let all = [&a, &b, &c];
        let merged = TreePoints::merged_by_cell(&all, 2, &[10, 10]);
        assert_eq!(merged.weights, [0.5, 1.0, 2.0, 1.0, 0.5]);
        assert_eq!(merged.targets, [1.0, 0.5, 1.0, -1.0, -1.0]);
        let columns = [3.0, 5.0, 7.0, 9.0, 5.0, 9.0, 25.0, 49.0, 81.0, 25.0];
        assert_eq!(merged.columns, columns);
        let fit = |rows: &TreeRows| {
            let config = crate::learn::TreeConfig {
                min_leaf_weight: 0.1,
                ..Default::default()
            };
            let candidates = [crate::learn::Candidates::Exact; 2];
            let (columns, targets, weights) = (&rows.columns, &rows.targets, &rows.weights);
            crate::learn::RegressionTree::fit_on(
                columns,
                targets,
                weights,
                &config,
                &candidates,
                &[1.0; 2],
            )
        };
        let tree = fit(&merged);
        assert!(tree.leaves() > 1);
        assert_eq!(tree, fit(&TreePoints::concatenated(&all, 2)));
    }

    #[test]
    fn plans_and_demonstrations_differ_by_the_lengths_of_their_steps() {
        let geo = GeoRef::unit(4, 4);
        let lengths = StepLengths::of(&geo);
        let c = |row, col| Cell::new(row, col);
        // A diagonal plan against a demonstration around the corner: the shared ends
        // differ by half a diagonal less half a straight step, the corner by a whole
        // straight step, the plan's middle cell by a whole diagonal.
        let plan = [c(0, 0), c(1, 1), c(2, 2)];
        let demonstration = [c(0, 0), c(0, 1), c(0, 2), c(1, 2), c(2, 2)];
        let unit = straight_step(&geo, &lengths);
        assert_eq!(unit, 1.0);
        let difference = length_difference(&geo, &lengths, &plan, &demonstration, unit);
        let half = 0.5 * std::f64::consts::SQRT_2 - 0.5;
        for (cell, expected) in [
            (c(0, 0), half),
            (c(2, 2), half),
            (c(1, 1), std::f64::consts::SQRT_2),
            (c(0, 1), -1.0),
            (c(0, 2), -1.0),
            (c(1, 2), -1.0),
        ] {
            let got = difference[&geo.index(cell)];
            assert!((got - expected).abs() < 1e-12, "{cell:?}: {got}");
        }
        // The same path taken by both cancels everywhere.
        let same = length_difference(&geo, &lengths, &plan, &plan, unit);
        assert!(same.values().all(|d| d.abs() < SHARED_STEPS));
        // In degrees, a step east weighs the cosine of its row's latitude against a
        // straight step north at the middle row (here at the equator), within the
        // ellipsoid's 1–2 % between a degree east and a degree north.
        let globe = GeoRef {
            degrees: true,
            ..GeoRef::square(4, 160, 1.0, [0.0, -80.0], "EPSG:4326")
        };
        let lengths = StepLengths::of(&globe);
        let unit = straight_step(&globe, &lengths);
        let east_at = |row| {
            let path = [c(row, 0), c(row, 1)];
            -length_difference(&globe, &lengths, &[], &path, unit)[&globe.index(c(row, 0))]
        };
        assert!((2.0 * east_at(80) - 1.0).abs() < 0.02, "{}", east_at(80));
        let near_pole = 2.0 * east_at(0) / (79.5f64.to_radians().cos());
        assert!((near_pole - 1.0).abs() < 0.02, "{near_pole}");
    }

    #[test]
    fn compact_shares_read_back_any_pattern() {
        let width = 5;
        let dense: Vec<f32> = [
            [1.0, 1.0, 1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0, 1.0, 1.0],
            [1.0, 1.0, 1.0, 1.0, 0.5],
            [1.0, 0.2, 1.0, 0.3, 1.0],
            [0.1, 0.2, 0.3, 0.4, 0.5],
        ]
        .concat();
        let compact = CompactShares::new(&dense, width);
        assert_eq!(compact.values.len(), 1 + 1 + 3 + 5);
        assert_eq!(compact.iter().collect::<Vec<_>>(), dense);
        // Augmented row by row as the dense shares augment every cell, blocked and
        // free cells included.
        let geo = GeoRef::square(width as u32, 5, 1.0, [0.0, 0.0], "m");
        let data = (0..25)
            .map(|i| match i {
                7 => f32::INFINITY,
                13 => 0.0,
                _ => 0.37 * i as f32 + 0.01,
            })
            .collect();
        let costs = Grid::from_vec(geo, data);
        let loss = 0.3f32;
        let per_cell: Vec<f32> = (dense.iter().zip(&costs.data))
            .map(|(&share, &cost)| loss * share * cost)
            .collect();
        let dense_augmented = crate::plan::loss_augmented(&costs, &per_cell, LOSS_FLOOR);
        let bits = |g: &Grid<f32>| g.data.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&compact.augmented(&costs, loss)),
            bits(&dense_augmented)
        );
    }
}
