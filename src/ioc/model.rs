//! The learned cost function: c(f) = link(s(f)), s a sum of weighted weak learners
//! (linear ridge regressors or regression trees) of the scaled features, and the link
//! exp (LEARCH, MaxEnt: costs stay positive whatever s is) or 1 + s floored at a small
//! positive cost (MMP's linear cost).

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::grid::{FeatureStack, Grid};
use crate::learn::RegressionTree;

/// Log-costs are clamped to this range so that exp() stays a finite, positive f32.
const LOG_COST_LIMIT: f64 = 40.0;

/// The least cost of a linear model, so that every cell stays passable.
pub const LINEAR_COST_FLOOR: f64 = 1e-3;

/// How the sum s of the learners becomes a cost. Either way the zero model costs 1
/// everywhere.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CostLink {
    /// c = exp(s)
    #[default]
    Exp,
    /// c = max(1 + s, LINEAR_COST_FLOOR)
    Linear,
}

impl CostLink {
    pub fn cost(self, s: f64) -> f64 {
        match self {
            CostLink::Exp => s.clamp(-LOG_COST_LIMIT, LOG_COST_LIMIT).exp(),
            CostLink::Linear => (1.0 + s).clamp(LINEAR_COST_FLOOR, f64::from(f32::MAX)),
        }
    }

    fn is_exp(&self) -> bool {
        *self == CostLink::Exp
    }
}

/// One boosting round's regressor h_t on scaled features, and its step α_t: `kind`
/// "ridge" with `weights`, or "tree" with `tree`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WeakLearner {
    pub kind: String,
    pub step: f64,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub weights: Vec<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tree: Option<RegressionTree>,
}

impl WeakLearner {
    pub fn ridge(step: f64, weights: Vec<f64>) -> Self {
        WeakLearner {
            kind: "ridge".into(),
            step,
            weights,
            tree: None,
        }
    }

    pub fn tree(step: f64, tree: RegressionTree) -> Self {
        WeakLearner {
            kind: "tree".into(),
            step,
            weights: Vec::new(),
            tree: Some(tree),
        }
    }
}

/// s(f) = Σ_t α_t h_t(f / scale), kept as the list of learners (what LEARCH produced),
/// with the linear ones also collapsed into weights on the raw features.
///
/// Features are scaled but not centred: a round whose data hold a feature at zero then
/// leaves that feature's weight alone, where centring would make it collinear with the
/// bias and let the ridge penalty move it at random.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogCostModel {
    pub feature_names: Vec<String>,
    pub scale: Vec<f64>,
    pub learners: Vec<WeakLearner>,
    /// The linear learners' part of s: Σ_j raw_weights[j] · f_j.
    pub raw_weights: Vec<f64>,
    /// Left out of the artifact when exp, so that earlier artifacts read the same.
    #[serde(default, skip_serializing_if = "CostLink::is_exp")]
    pub link: CostLink,
}

impl LogCostModel {
    /// The zero model (cost 1 everywhere) over scaled features, with the exp link.
    pub fn zero(feature_names: Vec<String>, scale: Vec<f64>) -> Self {
        Self::zero_with(feature_names, scale, CostLink::Exp)
    }

    pub fn zero_with(feature_names: Vec<String>, scale: Vec<f64>, link: CostLink) -> Self {
        let dim = feature_names.len();
        LogCostModel {
            feature_names,
            scale,
            learners: Vec::new(),
            raw_weights: vec![0.0; dim],
            link,
        }
    }

    /// The linear learners' weights on scaled features (what a gradient step on the
    /// scaled features moves).
    pub fn scaled_weights(&self) -> Vec<f64> {
        self.raw_weights
            .iter()
            .zip(&self.scale)
            .map(|(w, s)| w * s)
            .collect()
    }

    /// Appends α h; a linear h is folded into the raw weights.
    pub fn push(&mut self, learner: WeakLearner) {
        if learner.tree.is_none() {
            for j in 0..self.raw_weights.len() {
                self.raw_weights[j] += learner.step * learner.weights[j] / self.scale[j];
            }
        }
        self.learners.push(learner);
    }

    /// The model whose log-cost is `gamma` times this one's (the cost to the power
    /// `gamma`): every learner's step times `gamma`.
    pub fn with_contrast(&self, gamma: f64) -> Self {
        let mut model =
            LogCostModel::zero_with(self.feature_names.clone(), self.scale.clone(), self.link);
        for learner in &self.learners {
            model.push(WeakLearner {
                step: learner.step * gamma,
                ..learner.clone()
            });
        }
        model
    }

    /// The model whose cost is the geometric mean of the models' costs (their
    /// log-costs averaged): every learner of each, its step divided by their number.
    /// The models share their features, scales and link; one model comes back as it is.
    pub fn geometric_mean(models: &[LogCostModel]) -> Self {
        let first = &models[0];
        let mut mean =
            LogCostModel::zero_with(first.feature_names.clone(), first.scale.clone(), first.link);
        let share = models.len() as f64;
        for learner in models.iter().flat_map(|m| &m.learners) {
            mean.push(WeakLearner {
                step: learner.step / share,
                ..learner.clone()
            });
        }
        mean
    }

    /// The model of the first `rounds` learners (what early stopping keeps).
    pub fn truncated(&self, rounds: usize) -> Self {
        let mut model =
            LogCostModel::zero_with(self.feature_names.clone(), self.scale.clone(), self.link);
        for learner in self.learners.iter().take(rounds) {
            model.push(learner.clone());
        }
        model
    }

    fn trees(&self) -> impl Iterator<Item = (f64, &RegressionTree)> {
        self.learners
            .iter()
            .filter_map(|l| l.tree.as_ref().map(|t| (l.step, t)))
    }

    /// Scales a raw feature vector the way the weak learners see it.
    pub fn scaled(&self, raw: &[f32], out: &mut [f64]) {
        for j in 0..raw.len() {
            out[j] = f64::from(raw[j]) / self.scale[j];
        }
    }

    /// s(f), before the link (clamped for the exp link).
    pub fn log_cost(&self, raw: &[f32]) -> f64 {
        let mut s: f64 = raw
            .iter()
            .zip(&self.raw_weights)
            .map(|(&f, &w)| f64::from(f) * w)
            .sum::<f64>();
        if self.trees().next().is_some() {
            let mut x = vec![0.0; raw.len()];
            self.scaled(raw, &mut x);
            s += self
                .trees()
                .map(|(step, tree)| step * tree.predict(&x))
                .sum::<f64>();
        }
        s.clamp(-LOG_COST_LIMIT, LOG_COST_LIMIT)
    }

    /// Evaluates link(s) on every cell of a feature stack, plane by plane (the same
    /// sum, in the same order, as `log_cost`).
    pub fn costmap(&self, stack: &FeatureStack) -> Grid<f32> {
        self.costmap_growing(stack, &mut TreeSums::default())
    }

    /// [`LogCostModel::costmap`] with the trees' part of s kept in `sums` between calls
    /// on one stack: where this model's first trees are those `sums` holds (a boosting
    /// run's next round), only the others are evaluated and added; otherwise `sums`
    /// starts again from this model's trees.
    pub fn costmap_growing(&self, stack: &FeatureStack, sums: &mut TreeSums) -> Grid<f32> {
        let cells = stack.geo.cell_count();
        let trees: Vec<(f64, &RegressionTree)> = self.trees().collect();
        let extends = sums.values.len() == cells
            && sums.trees.len() <= trees.len()
            && (sums.trees.iter().zip(&trees))
                .all(|((a, ta), (b, tb))| a.to_bits() == b.to_bits() && ta == *tb);
        if !extends {
            *sums = TreeSums {
                trees: Vec::new(),
                values: vec![0.0; cells],
            };
        }
        let new_trees = &trees[sums.trees.len()..];
        let mut costs = vec![0.0f32; cells];
        // Blocks of cells in parallel: every cell's sum is added in the same order
        // whatever the threads.
        (costs.par_chunks_mut(COSTMAP_BLOCK))
            .zip(sums.values.par_chunks_mut(COSTMAP_BLOCK))
            .enumerate()
            .for_each(|(block, (costs, tree_sums))| {
                let first = block * COSTMAP_BLOCK;
                let mut log_cost = vec![0.0f64; costs.len()];
                for (&w, plane) in self.raw_weights.iter().zip(stack.planes()) {
                    for (s, &f) in log_cost.iter_mut().zip(&plane[first..]) {
                        *s += f64::from(f) * w;
                    }
                }
                for (k, tree_sum) in tree_sums.iter_mut().enumerate() {
                    let scaled = |j: usize| f64::from(stack.plane(j)[first + k]) / self.scale[j];
                    for (step, tree) in new_trees {
                        *tree_sum += step * tree.predict_by(scaled);
                    }
                }
                for ((cost, s), tree_sum) in costs.iter_mut().zip(&log_cost).zip(&*tree_sums) {
                    *cost = self.link.cost(s + tree_sum) as f32;
                }
            });
        // Recorded once their terms are in the sums.
        (sums.trees).extend(new_trees.iter().map(|&(step, tree)| (step, tree.clone())));
        Grid::from_vec(stack.geo.clone(), costs)
    }
}

/// Cells a task of [`LogCostModel::costmap`] evaluates.
const COSTMAP_BLOCK: usize = 4096;

/// The trees' part of a model's log-cost on every cell of one feature stack, summed
/// over `trees` (each with its step): what [`LogCostModel::costmap_growing`] keeps
/// between the rounds of a boosting run, which add one tree at a time.
#[derive(Debug, Clone, Default)]
pub struct TreeSums {
    trees: Vec<(f64, RegressionTree)>,
    values: Vec<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn collapsed_form_equals_sum_of_learners() {
        let mut model = LogCostModel::zero(vec!["a".into(), "b".into()], vec![2.0, 0.5]);
        model.push(WeakLearner::ridge(0.5, vec![1.0, -1.0]));
        model.push(WeakLearner::ridge(0.25, vec![0.2, 3.0]));
        let raw = [3.0f32, 1.0];
        let mut z = [0.0; 2];
        model.scaled(&raw, &mut z);
        let by_learners: f64 = model
            .learners
            .iter()
            .map(|l| l.step * (l.weights[0] * z[0] + l.weights[1] * z[1]))
            .sum();
        assert!((model.log_cost(&raw) - by_learners).abs() < 1e-12);
    }

    #[test]
    fn a_growing_costmap_is_the_costmap_to_the_bit() {
        use crate::grid::GeoRef;
        use crate::learn::TreeConfig;
        // 9000 cells: more than one block of cells.
        let geo = GeoRef::square(100, 90, 1.0, [0.0, 0.0], "m");
        let cells = geo.cell_count();
        let wave = |i: usize, k: f64| ((i as f64) * k).sin() as f32;
        let data = (0..cells)
            .map(|i| wave(i, 0.37))
            .chain((0..cells).map(|i| wave(i, 0.011)));
        let stack = FeatureStack {
            geo,
            names: vec!["a".into(), "b".into()],
            data: data.collect(),
        };
        let mut model = LogCostModel::zero(stack.names.clone(), vec![1.5, 0.5]);
        let mut sums = TreeSums::default();
        for round in 0..6 {
            // Trees and ridge steps in turn, each on another target.
            let learner = if round % 2 == 0 {
                let columns: Vec<f64> = (stack.data.iter().map(|&f| f64::from(f))).collect();
                let targets: Vec<f64> = (0..cells)
                    .map(|i| f64::from(wave(i, 0.05 * round as f64 + 0.1)))
                    .collect();
                let config = TreeConfig::default();
                let tree = RegressionTree::fit_on(
                    &columns,
                    &targets,
                    &vec![1.0; cells],
                    &config,
                    &[crate::learn::Candidates::Binned; 2],
                    &[1.0; 2],
                );
                WeakLearner::tree(0.3, tree)
            } else {
                WeakLearner::ridge(0.2, vec![0.4, -1.0 / round as f64])
            };
            model.push(learner);
            let bits = |g: &Grid<f32>| g.data.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
            let grown = model.costmap_growing(&stack, &mut sums);
            let fresh = model.costmap(&stack);
            assert_eq!(bits(&grown), bits(&fresh), "round {round}");
            // A model that does not extend the sums' (another member's, a contrast)
            // starts them again.
            let other = model.with_contrast(0.5);
            let mut reused = sums.clone();
            let other_grown = other.costmap_growing(&stack, &mut reused);
            assert_eq!(bits(&other_grown), bits(&other.costmap(&stack)));
            let cell = 4321;
            let mut raw = [0.0f32; 2];
            stack.cell_into(cell, &mut raw);
            let direct = model.link.cost(model.log_cost(&raw)) as f32;
            assert!((fresh.data[cell] - direct).abs() <= 1e-6 * direct);
        }
    }
}
