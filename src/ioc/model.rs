//! The learned cost function: c(f) = link(s(f)), s a sum of weighted weak learners
//! (linear ridge regressors or regression trees) of the scaled features, and the link
//! exp (LEARCH, MaxEnt: costs stay positive whatever s is) or 1 + s floored at a small
//! positive cost (MMP's linear cost).

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
        let mut log_cost = vec![0.0f64; stack.geo.cell_count()];
        for (&w, plane) in self.raw_weights.iter().zip(stack.planes()) {
            for (s, &f) in log_cost.iter_mut().zip(plane) {
                *s += f64::from(f) * w;
            }
        }
        if self.trees().next().is_some() {
            let (mut raw, mut x) = (vec![0.0f32; stack.dim()], vec![0.0; stack.dim()]);
            for (i, s) in log_cost.iter_mut().enumerate() {
                stack.cell_into(i, &mut raw);
                self.scaled(&raw, &mut x);
                *s += self
                    .trees()
                    .map(|(step, tree)| step * tree.predict(&x))
                    .sum::<f64>();
            }
        }
        let data = log_cost.iter().map(|&s| self.link.cost(s) as f32).collect();
        Grid::from_vec(stack.geo.clone(), data)
    }
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
}
