//! Policies: linear on standardised observations (fitted by ridge regression from
//! streaming sufficient statistics) or regression trees (fitted on the rows).
//!
//! The statistics are those of [1, x] (XᵀX holds the counts, sums and cross products),
//! so the standardisation (means and standard deviations over all the data) and the
//! fit on the standardised observations come from them exactly, however many rounds
//! were added: a dataset larger than memory trains in one pass per round.

use serde::{Deserialize, Serialize};

use crate::learn::{RegressionTree, RidgeAccumulator, TreeConfig};

/// The kinds of policy a user chooses between.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum PolicyKind {
    /// Linear in the standardised observations (ridge regression).
    Ridge,
    /// A regression tree.
    Tree,
}

impl PolicyKind {
    /// The learner of this kind, with a tree's depth or ridge's penalty.
    pub fn learner(self, depth: usize, lambda: f64) -> PolicyLearner {
        match self {
            PolicyKind::Ridge => PolicyLearner::Ridge { lambda },
            PolicyKind::Tree => PolicyLearner::Tree(TreeConfig {
                max_depth: depth,
                ..TreeConfig::default()
            }),
        }
    }
}

/// How a policy is fitted to the aggregated labels.
#[derive(Debug, Clone, PartialEq)]
pub enum PolicyLearner {
    /// Ridge regression with this penalty on standardised observations.
    Ridge { lambda: f64 },
    /// A regression tree: piecewise constant, so it does not extrapolate beyond the
    /// states it was shown, which is where DAgger's aggregation matters most.
    Tree(TreeConfig),
}

/// A fitted policy: the action (in [−1, 1]) for an observation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
pub enum Policy {
    Linear(LinearPolicy),
    Tree {
        tree: RegressionTree,
    },
    /// The uniform mixture of several rounds' policies, as the seed returns it: each
    /// episode is driven by one member drawn uniformly (`for_episode`).
    Mixture {
        members: Vec<Policy>,
    },
}

impl Policy {
    /// The action for `x`; a mixture acts as its first member (use `for_episode` to
    /// draw the member an episode runs with).
    pub fn act(&self, x: &[f64]) -> f64 {
        match self {
            Policy::Linear(p) => p.act(x),
            Policy::Tree { tree } => tree.predict(x).clamp(-1.0, 1.0),
            Policy::Mixture { members } => members.first().map_or(0.0, |m| m.act(x)),
        }
    }

    /// The policy one episode runs with: a member drawn uniformly for a mixture, else
    /// the policy itself.
    pub fn for_episode(&self, rng: &mut rand_chacha::ChaCha8Rng) -> &Policy {
        use rand::RngExt;
        match self {
            Policy::Mixture { members } if !members.is_empty() => {
                members[rng.random_range(0..members.len())].for_episode(rng)
            }
            _ => self,
        }
    }
}

/// Every label so far: the sufficient statistics, and the rows when the learner needs
/// them.
#[derive(Debug, Clone, PartialEq)]
pub struct Aggregate {
    pub stats: PolicyData,
    rows: Vec<f64>,
    labels: Vec<f64>,
    dims: usize,
    keep_rows: bool,
}

impl Aggregate {
    pub fn new(dims: usize, learner: &PolicyLearner) -> Self {
        Aggregate {
            stats: PolicyData::new(dims),
            rows: Vec::new(),
            labels: Vec::new(),
            dims,
            keep_rows: matches!(learner, PolicyLearner::Tree(_)),
        }
    }

    pub fn add(&mut self, observation: &[f64], label: f64) {
        self.stats.add(observation, label);
        if self.keep_rows {
            self.rows.extend_from_slice(observation);
            self.labels.push(label);
        }
    }

    pub fn fit(&self, learner: &PolicyLearner) -> Policy {
        match learner {
            PolicyLearner::Ridge { lambda } => Policy::Linear(self.stats.fit(*lambda)),
            PolicyLearner::Tree(config) => {
                let weights = vec![1.0; self.labels.len()];
                Policy::Tree {
                    tree: RegressionTree::fit(
                        &self.rows,
                        self.dims,
                        &self.labels,
                        &weights,
                        config,
                    ),
                }
            }
        }
    }
}

/// a(x) = clamp(bias + Σ w_j (x_j − mean_j) / scale_j, −1, 1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinearPolicy {
    pub mean: Vec<f64>,
    pub scale: Vec<f64>,
    pub weights: Vec<f64>,
    pub bias: f64,
}

impl LinearPolicy {
    pub fn act(&self, x: &[f64]) -> f64 {
        let z: f64 = x
            .iter()
            .zip(&self.mean)
            .zip(&self.scale)
            .zip(&self.weights)
            .map(|(((v, m), s), w)| w * (v - m) / s)
            .sum();
        (self.bias + z).clamp(-1.0, 1.0)
    }
}

/// The statistics of (observation, label) pairs for `LinearPolicy::fit`.
#[derive(Debug, Clone, PartialEq)]
pub struct PolicyData {
    stats: RidgeAccumulator,
}

impl PolicyData {
    pub fn new(observation_dim: usize) -> Self {
        PolicyData {
            stats: RidgeAccumulator::new(observation_dim + 1),
        }
    }

    pub fn add(&mut self, observation: &[f64], label: f64) {
        let mut row = Vec::with_capacity(observation.len() + 1);
        row.push(1.0);
        row.extend_from_slice(observation);
        self.stats.add(&row, label, 1.0);
    }

    pub fn merge(&mut self, other: &PolicyData) {
        self.stats.merge(&other.stats);
    }

    pub fn len(&self) -> usize {
        self.stats.total_weight() as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Ridge regression with penalty `lambda` on the standardised observations (the
    /// intercept unpenalised): minimises mean (y − b − w·z)² + λ‖w‖².
    pub fn fit(&self, lambda: f64) -> LinearPolicy {
        let d = self.stats.dim() - 1;
        let n = self.stats.total_weight().max(f64::MIN_POSITIVE);
        let (xtx, xty) = self.stats.moments();
        let at = |i: usize, j: usize| xtx[i * (d + 1) + j] / n;
        let mean: Vec<f64> = (1..=d).map(|j| at(0, j)).collect();
        let scale: Vec<f64> = (1..=d)
            .map(|j| {
                let variance = (at(j, j) - mean[j - 1] * mean[j - 1]).max(0.0);
                let sd = variance.sqrt();
                if sd > 1e-12 { sd } else { 1.0 }
            })
            .collect();
        let y_mean = xty[0] / n;
        // Centred, scaled normal equations: Cov(z) w = Cov(z, y).
        let mut a = vec![0.0; d * d];
        let mut b = vec![0.0; d];
        for i in 0..d {
            for j in 0..d {
                let cov = at(i + 1, j + 1) - mean[i] * mean[j];
                a[i * d + j] = cov / (scale[i] * scale[j]);
            }
            a[i * d + i] += lambda;
            b[i] = (xty[i + 1] / n - mean[i] * y_mean) / scale[i];
        }
        let weights = crate::learn::solve_spd(&a, &b, d).unwrap_or_else(|| vec![0.0; d]);
        LinearPolicy {
            mean,
            scale,
            weights,
            bias: y_mean,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_linear_rule_and_merging_equals_adding() {
        let rule = |x: &[f64]| 0.1 + 0.3 * x[0] - 0.05 * x[1];
        let (mut all, mut first, mut second) =
            (PolicyData::new(2), PolicyData::new(2), PolicyData::new(2));
        for k in 0..200 {
            let x = [
                (k as f64 * 0.37).sin() * 2.0,
                (k as f64 * 0.11).cos() * 5.0 + 3.0,
            ];
            all.add(&x, rule(&x));
            if k < 80 {
                first.add(&x, rule(&x))
            } else {
                second.add(&x, rule(&x))
            }
        }
        first.merge(&second);
        let (p, q) = (all.fit(0.0), first.fit(0.0));
        for x in [[0.5, 2.0], [-1.0, 6.0]] {
            assert!((p.act(&x) - rule(&x)).abs() < 1e-9);
            assert!((p.act(&x) - q.act(&x)).abs() < 1e-9);
        }
        assert_eq!(all.len(), 200);
    }
}
