//! Policies: linear on standardised observations (fitted by ridge regression from
//! streaming sufficient statistics) or regression trees (fitted on the rows). An action
//! of several numbers (a robot's joints) is learned one output at a time, each output
//! by the same learner ([`Policy::Outputs`]); actions are clamped to the range their
//! labels span ([−1, 1] when they fit in it, the built-in simulators' range).
//!
//! The statistics are those of [1, x] (XᵀX holds the counts, sums and cross products),
//! so the standardisation (means and standard deviations over all the data) and the
//! fit on the standardised observations come from them exactly, however many rounds
//! were added: a dataset larger than memory trains in one pass per round.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::learn::{Cholesky, Mlp, MlpConfig, RegressionTree, TreeConfig};

/// The kinds of policy a user chooses between.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum PolicyKind {
    /// Linear in the standardised observations (ridge regression).
    Ridge,
    /// A regression tree.
    Tree,
    /// Multinomial logistic regression, for discrete actions (class indices 0, 1, ...).
    Logistic,
    /// Classification trees for discrete actions: one tree per class.
    ClassTree,
    /// A small neural network (ReLU layers), every action number at once.
    Mlp,
}

impl PolicyKind {
    /// The learner of this kind, with a tree's depth, or the penalty of ridge and
    /// logistic regression; `classes` is the number of discrete actions (logistic only).
    pub fn learner(self, depth: usize, lambda: f64, classes: usize) -> PolicyLearner {
        match self {
            PolicyKind::Ridge => PolicyLearner::Ridge { lambda },
            PolicyKind::Tree => PolicyLearner::Tree(TreeConfig {
                max_depth: depth,
                ..TreeConfig::default()
            }),
            PolicyKind::Logistic => PolicyLearner::Logistic { classes, lambda },
            PolicyKind::ClassTree => PolicyLearner::ClassTrees {
                classes,
                config: TreeConfig {
                    max_depth: depth,
                    ..TreeConfig::default()
                },
            },
            PolicyKind::Mlp => PolicyLearner::Mlp(MlpConfig {
                weight_decay: lambda,
                ..MlpConfig::default()
            }),
        }
    }

    /// Whether the kind predicts class indices (discrete actions) rather than numbers.
    pub fn discrete(self) -> bool {
        matches!(self, PolicyKind::Logistic | PolicyKind::ClassTree)
    }
}

/// The policy of a policy artifact folder (the file its manifest lists with role
/// `policy`) and the artifact's digest.
pub fn load_policy_artifact(dir: &std::path::Path) -> crate::error::Result<(Policy, String)> {
    use crate::error::Error;
    let manifest = crate::artifact::read_manifest(dir, "policy")?;
    let file = manifest
        .files_with_role("policy")
        .next()
        .ok_or_else(|| Error::input(dir, "lists no policy file"))?;
    let path = dir.join(&file.path);
    let bytes =
        std::fs::read(&path).map_err(|e| Error::io(format!("reading {}", path.display()), e))?;
    let policy: Policy = serde_json::from_slice(&bytes)
        .map_err(|e| Error::input(&path, format!("is not a policy: {e}")))?;
    Ok((policy, manifest.digest))
}

/// The observation names a policy artifact's metrics record (`observation_names`), in
/// the order the policy reads them; empty when it records none.
pub fn policy_observation_names(dir: &std::path::Path) -> Vec<String> {
    let metrics: serde_json::Value = std::fs::read(dir.join("metrics.json"))
        .ok()
        .and_then(|bytes| serde_json::from_slice(&bytes).ok())
        .unwrap_or_default();
    (metrics["observation_names"]
        .as_array()
        .into_iter()
        .flatten())
    .filter_map(|n| n.as_str().map(String::from))
    .collect()
}

/// How a policy is fitted to the aggregated labels.
#[derive(Debug, Clone, PartialEq)]
pub enum PolicyLearner {
    /// Ridge regression with this penalty on standardised observations.
    Ridge { lambda: f64 },
    /// A regression tree: piecewise constant, so it does not extrapolate beyond the
    /// states it was shown, which is where DAgger's aggregation matters most.
    Tree(TreeConfig),
    /// Multinomial logistic regression over `classes` discrete actions (labels are the
    /// class indices), with this L2 penalty on standardised observations.
    Logistic { classes: usize, lambda: f64 },
    /// One regression tree per class fitted to the class's indicator: squared error on
    /// a one-hot target is the Gini impurity, so each is a one-vs-rest CART.
    ClassTrees { classes: usize, config: TreeConfig },
    /// A multilayer perceptron on standardised observations and actions.
    Mlp(MlpConfig),
}

/// The range actions are clamped to unless the labels went beyond it.
const UNIT_RANGE: [f64; 2] = [-1.0, 1.0];

fn unit_range() -> [f64; 2] {
    UNIT_RANGE
}

fn is_unit_range(range: &[f64; 2]) -> bool {
    *range == UNIT_RANGE
}

/// [−1, 1], or the labels' own span when they leave it.
fn action_range(least: f64, largest: f64) -> [f64; 2] {
    if least >= UNIT_RANGE[0] && largest <= UNIT_RANGE[1] || least > largest {
        UNIT_RANGE
    } else {
        [least, largest]
    }
}

/// A fitted policy: the action for an observation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
pub enum Policy {
    Linear(LinearPolicy),
    Tree {
        tree: RegressionTree,
        /// What the tree's predictions are clamped to.
        #[serde(default = "unit_range", skip_serializing_if = "is_unit_range")]
        range: [f64; 2],
    },
    /// Discrete actions: the most probable class, as a number.
    Logistic(LogisticPolicy),
    /// Discrete actions: the class whose tree scores highest (the first on ties).
    ClassTrees {
        trees: Vec<RegressionTree>,
    },
    /// Forward training's non-stationary policy: the t-th member acts at step t (the
    /// last one after the horizon).
    Sequence {
        steps: Vec<Policy>,
    },
    /// The uniform mixture of several rounds' policies, as the seed returns it: each
    /// episode is driven by one member drawn uniformly (`for_episode`).
    Mixture {
        members: Vec<Policy>,
    },
    /// An action of several numbers: member j gives number j.
    Outputs {
        members: Vec<Policy>,
    },
    Mlp(MlpPolicy),
}

impl Policy {
    /// The action for `x` (the first number of a several-number action, see
    /// [`Policy::act_all`]); a mixture acts as its first member (use `for_episode` to
    /// draw the member an episode runs with).
    pub fn act(&self, x: &[f64]) -> f64 {
        match self {
            Policy::Linear(p) => p.act(x),
            Policy::Mlp(p) => p.act_all(x).first().copied().unwrap_or(0.0),
            Policy::Tree { tree, range } => tree.predict(x).clamp(range[0], range[1]),
            Policy::Logistic(p) => p.most_probable(x) as f64,
            Policy::ClassTrees { trees } => {
                let scores = trees.iter().map(|t| t.predict(x));
                first_largest(scores) as f64
            }
            Policy::Mixture { members } | Policy::Outputs { members } => {
                members.first().map_or(0.0, |m| m.act(x))
            }
            Policy::Sequence { steps } => steps.first().map_or(0.0, |m| m.act(x)),
        }
    }

    /// Every number of the action for `x`.
    pub fn act_all(&self, x: &[f64]) -> Vec<f64> {
        match self {
            Policy::Outputs { members } => members.iter().map(|m| m.act(x)).collect(),
            Policy::Mlp(p) => p.act_all(x),
            Policy::Mixture { members } => members.first().map_or(Vec::new(), |m| m.act_all(x)),
            other => vec![other.act(x)],
        }
    }

    /// How many numbers an action holds.
    pub fn outputs(&self) -> usize {
        match self {
            Policy::Outputs { members } => members.len(),
            Policy::Mlp(p) => p.ranges.len(),
            Policy::Mixture { members } => members.first().map_or(1, Policy::outputs),
            _ => 1,
        }
    }

    /// The action at step `t` of an episode: only a sequence depends on it.
    pub fn act_at(&self, t: usize, x: &[f64]) -> f64 {
        match self {
            Policy::Sequence { steps } if !steps.is_empty() => steps[t.min(steps.len() - 1)].act(x),
            other => other.act(x),
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

/// The index of the largest score, the first on ties.
fn first_largest(scores: impl Iterator<Item = f64>) -> usize {
    let mut best = (f64::NEG_INFINITY, 0);
    for (k, score) in scores.enumerate() {
        if score > best.0 {
            best = (score, k);
        }
    }
    best.1
}

/// Every label so far: the sufficient statistics (for every output of the action), each
/// output's label range, and the rows when the learner needs them.
#[derive(Debug, Clone, PartialEq)]
pub struct Aggregate {
    stats: PolicyData,
    rows: Vec<f64>,
    /// Per output, its labels (kept with the rows).
    labels: Vec<Vec<f64>>,
    /// Per output, the least and largest label.
    spans: Vec<[f64; 2]>,
    dims: usize,
    keep_rows: bool,
}

impl Aggregate {
    /// For observations of `dims` numbers and actions of `outputs` numbers.
    pub fn new(dims: usize, outputs: usize, learner: &PolicyLearner) -> Self {
        let outputs = outputs.max(1);
        Aggregate {
            stats: PolicyData::with_outputs(dims, outputs),
            rows: Vec::new(),
            labels: vec![Vec::new(); outputs],
            spans: vec![[f64::INFINITY, f64::NEG_INFINITY]; outputs],
            dims,
            keep_rows: !matches!(learner, PolicyLearner::Ridge { .. }),
        }
    }

    /// Adds one step; `label` holds one number per output.
    pub fn add(&mut self, observation: &[f64], label: &[f64]) {
        self.stats.add_all(observation, label);
        for (j, &y) in label.iter().enumerate() {
            let span = &mut self.spans[j];
            *span = [span[0].min(y), span[1].max(y)];
            if self.keep_rows {
                self.labels[j].push(y);
            }
        }
        if self.keep_rows {
            self.rows.extend_from_slice(observation);
        }
    }

    /// How many steps were added.
    pub fn len(&self) -> usize {
        self.stats.len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The policy `learner` fits: one policy, or one per output for an action of
    /// several numbers.
    pub fn fit(&self, learner: &PolicyLearner) -> Policy {
        let range = |j: usize| action_range(self.spans[j][0], self.spans[j][1]);
        if let PolicyLearner::Mlp(config) = learner {
            return Policy::Mlp(self.fit_mlp(config));
        }
        let mut members: Vec<Policy> = match learner {
            // One factorisation for every output.
            PolicyLearner::Ridge { lambda } => (self.stats.fit_all(*lambda).into_iter())
                .enumerate()
                .map(|(j, p)| {
                    Policy::Linear(LinearPolicy {
                        range: range(j),
                        ..p
                    })
                })
                .collect(),
            _ => (0..self.spans.len())
                .map(|j| self.fit_output(j, learner, range(j)))
                .collect(),
        };
        if members.len() == 1 {
            return members.swap_remove(0);
        }
        Policy::Outputs { members }
    }

    /// One network for every output, on standardised observations and labels.
    fn fit_mlp(&self, config: &MlpConfig) -> MlpPolicy {
        let n = self.len();
        let standardise = |values: &mut dyn Iterator<Item = f64>| -> (f64, f64) {
            let values: Vec<f64> = values.collect();
            let mean = values.iter().sum::<f64>() / n.max(1) as f64;
            let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n.max(1) as f64;
            let sd = variance.sqrt();
            (mean, if sd > 1e-12 { sd } else { 1.0 })
        };
        let (mean, scale): (Vec<f64>, Vec<f64>) = (0..self.dims)
            .map(|j| standardise(&mut self.rows.iter().skip(j).step_by(self.dims).copied()))
            .unzip();
        let (target_mean, target_scale): (Vec<f64>, Vec<f64>) = (self.labels.iter())
            .map(|labels| standardise(&mut labels.iter().copied()))
            .unzip();
        let outputs = self.labels.len();
        let rows: Vec<f64> = (self.rows.iter().enumerate())
            .map(|(i, v)| (v - mean[i % self.dims]) / scale[i % self.dims])
            .collect();
        let targets: Vec<f64> = (0..n * outputs)
            .map(|i| {
                let (row, j) = (i / outputs, i % outputs);
                (self.labels[j][row] - target_mean[j]) / target_scale[j]
            })
            .collect();
        MlpPolicy {
            network: Mlp::fit(&rows, self.dims, &targets, outputs, config),
            mean,
            scale,
            target_mean,
            target_scale,
            ranges: (0..outputs)
                .map(|j| action_range(self.spans[j][0], self.spans[j][1]))
                .collect(),
        }
    }

    /// Output `j` by a learner that needs the rows.
    fn fit_output(&self, j: usize, learner: &PolicyLearner, range: [f64; 2]) -> Policy {
        let labels = &self.labels[j];
        match learner {
            PolicyLearner::Ridge { lambda } => Policy::Linear(LinearPolicy {
                range,
                ..self.stats.fit_all(*lambda).swap_remove(j)
            }),
            PolicyLearner::Logistic { classes, lambda } => Policy::Logistic(LogisticPolicy::fit(
                &self.rows, self.dims, labels, *classes, *lambda,
            )),
            PolicyLearner::ClassTrees { classes, config } => {
                let weights = vec![1.0; labels.len()];
                let trees = (0..*classes)
                    .into_par_iter()
                    .map(|k| {
                        let indicator: Vec<f64> = (labels.iter())
                            .map(|&label| f64::from(u8::from(label == k as f64)))
                            .collect();
                        RegressionTree::fit(&self.rows, self.dims, &indicator, &weights, config)
                    })
                    .collect();
                Policy::ClassTrees { trees }
            }
            PolicyLearner::Tree(config) => {
                let weights = vec![1.0; labels.len()];
                Policy::Tree {
                    tree: RegressionTree::fit(&self.rows, self.dims, labels, &weights, config),
                    range,
                }
            }
            PolicyLearner::Mlp(config) => Policy::Mlp(self.fit_mlp(config)),
        }
    }
}

/// a(x) = clamp(target_mean + target_scale · net((x − mean) / scale), ranges), every
/// number of the action from one network.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MlpPolicy {
    pub mean: Vec<f64>,
    pub scale: Vec<f64>,
    pub target_mean: Vec<f64>,
    pub target_scale: Vec<f64>,
    pub network: Mlp,
    pub ranges: Vec<[f64; 2]>,
}

impl MlpPolicy {
    pub fn act_all(&self, x: &[f64]) -> Vec<f64> {
        let z: Vec<f64> = (x.iter().zip(&self.mean).zip(&self.scale))
            .map(|((v, m), s)| (v - m) / s)
            .collect();
        (self.network.forward(&z).into_iter().enumerate())
            .map(|(j, y)| {
                let r = self.ranges[j];
                (self.target_mean[j] + self.target_scale[j] * y).clamp(r[0], r[1])
            })
            .collect()
    }
}

/// a(x) = clamp(bias + Σ w_j (x_j − mean_j) / scale_j, range).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinearPolicy {
    pub mean: Vec<f64>,
    pub scale: Vec<f64>,
    pub weights: Vec<f64>,
    pub bias: f64,
    #[serde(default = "unit_range", skip_serializing_if = "is_unit_range")]
    pub range: [f64; 2],
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
        (self.bias + z).clamp(self.range[0], self.range[1])
    }
}

/// P(a | x) ∝ exp(b_a + w_a · (x − mean) / scale) over discrete actions a.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogisticPolicy {
    pub mean: Vec<f64>,
    pub scale: Vec<f64>,
    /// Per class: the intercept, then one weight per observation.
    pub weights: Vec<Vec<f64>>,
}

impl LogisticPolicy {
    fn scores(&self, x: &[f64]) -> Vec<f64> {
        self.weights
            .iter()
            .map(|w| {
                w[0] + x
                    .iter()
                    .zip(&self.mean)
                    .zip(&self.scale)
                    .zip(&w[1..])
                    .map(|(((v, m), s), wj)| wj * (v - m) / s)
                    .sum::<f64>()
            })
            .collect()
    }

    /// The class of highest probability (the lowest index on ties).
    pub fn most_probable(&self, x: &[f64]) -> usize {
        first_largest(self.scores(x).into_iter())
    }

    /// Fits by full-batch gradient descent on the mean cross-entropy plus λ‖w‖² (the
    /// intercepts unpenalised). Rows are `dims` wide; labels are class indices.
    pub fn fit(rows: &[f64], dims: usize, labels: &[f64], classes: usize, lambda: f64) -> Self {
        let n = labels.len().max(1);
        let column = |j: usize| rows.iter().skip(j).step_by(dims.max(1));
        let mean: Vec<f64> = (0..dims)
            .map(|j| column(j).sum::<f64>() / n as f64)
            .collect();
        let scale: Vec<f64> = (0..dims)
            .map(|j| {
                let v = column(j).map(|x| (x - mean[j]).powi(2)).sum::<f64>() / n as f64;
                if v > 1e-24 { v.sqrt() } else { 1.0 }
            })
            .collect();
        let z: Vec<f64> = rows
            .chunks(dims.max(1))
            .flat_map(|r| {
                (0..dims)
                    .map(|j| (r[j] - mean[j]) / scale[j])
                    .collect::<Vec<_>>()
            })
            .collect();
        let mut weights = vec![vec![0.0; dims + 1]; classes];
        // Standardised features keep the curvature near 1: a fixed step converges.
        let step = 0.5;
        for _ in 0..300 {
            let mut gradient = vec![vec![0.0; dims + 1]; classes];
            for (i, &label) in labels.iter().enumerate() {
                let x = &z[i * dims..(i + 1) * dims];
                let scores: Vec<f64> = weights
                    .iter()
                    .map(|w| w[0] + x.iter().zip(&w[1..]).map(|(a, b)| a * b).sum::<f64>())
                    .collect();
                let top = scores.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                let total: f64 = scores.iter().map(|s| (s - top).exp()).sum();
                for (k, g) in gradient.iter_mut().enumerate() {
                    let p = (scores[k] - top).exp() / total;
                    let error = p - f64::from(u8::from(label as usize == k));
                    g[0] += error;
                    for j in 0..dims {
                        g[j + 1] += error * x[j];
                    }
                }
            }
            for (w, g) in weights.iter_mut().zip(&gradient) {
                w[0] -= step * g[0] / n as f64;
                for j in 1..=dims {
                    w[j] -= step * (g[j] / n as f64 + 2.0 * lambda * w[j]);
                }
            }
        }
        LogisticPolicy {
            mean,
            scale,
            weights,
        }
    }
}

/// The statistics of (observation, label) pairs for `LinearPolicy::fit`: the moments of
/// [1, x] (XᵀX) and, per output of the action, Xᵀy. Every output shares XᵀX, and the fit
/// one factorisation of it.
#[derive(Debug, Clone, PartialEq)]
pub struct PolicyData {
    /// 1 + the observation's length.
    dim: usize,
    outputs: usize,
    xtx: Vec<f64>,
    /// Row-major, `outputs` per row of X.
    xty: Vec<f64>,
    count: usize,
}

impl PolicyData {
    pub fn new(observation_dim: usize) -> Self {
        Self::with_outputs(observation_dim, 1)
    }

    /// For actions of `outputs` numbers.
    pub fn with_outputs(observation_dim: usize, outputs: usize) -> Self {
        let dim = observation_dim + 1;
        PolicyData {
            dim,
            outputs,
            xtx: vec![0.0; dim * dim],
            xty: vec![0.0; dim * outputs],
            count: 0,
        }
    }

    pub fn add(&mut self, observation: &[f64], label: f64) {
        self.add_all(observation, &[label]);
    }

    /// Adds one step whose action holds one number per output.
    pub fn add_all(&mut self, observation: &[f64], labels: &[f64]) {
        debug_assert_eq!(observation.len() + 1, self.dim);
        debug_assert_eq!(labels.len(), self.outputs);
        let x = |i: usize| if i == 0 { 1.0 } else { observation[i - 1] };
        for i in 0..self.dim {
            let xi = x(i);
            for (cell, &y) in self.xty[i * self.outputs..(i + 1) * self.outputs]
                .iter_mut()
                .zip(labels)
            {
                *cell += xi * y;
            }
            let row = &mut self.xtx[i * self.dim..(i + 1) * self.dim];
            for (j, cell) in row.iter_mut().enumerate() {
                *cell += xi * x(j);
            }
        }
        self.count += 1;
    }

    pub fn merge(&mut self, other: &PolicyData) {
        debug_assert_eq!((other.dim, other.outputs), (self.dim, self.outputs));
        for (a, b) in self.xtx.iter_mut().zip(&other.xtx) {
            *a += b;
        }
        for (a, b) in self.xty.iter_mut().zip(&other.xty) {
            *a += b;
        }
        self.count += other.count;
    }

    pub fn len(&self) -> usize {
        self.count
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Ridge regression with penalty `lambda` on the standardised observations (the
    /// intercept unpenalised) of the first output: see [`PolicyData::fit_all`].
    pub fn fit(&self, lambda: f64) -> LinearPolicy {
        self.fit_all(lambda).swap_remove(0)
    }

    /// Per output, the ridge regression with penalty `lambda` on the standardised
    /// observations (the intercept unpenalised): minimises mean (y − b − w·z)² + λ‖w‖².
    pub fn fit_all(&self, lambda: f64) -> Vec<LinearPolicy> {
        let d = self.dim - 1;
        let n = (self.count as f64).max(f64::MIN_POSITIVE);
        let at = |i: usize, j: usize| self.xtx[i * self.dim + j] / n;
        let mean: Vec<f64> = (1..=d).map(|j| at(0, j)).collect();
        let scale: Vec<f64> = (1..=d)
            .map(|j| {
                let variance = (at(j, j) - mean[j - 1] * mean[j - 1]).max(0.0);
                let sd = variance.sqrt();
                if sd > 1e-12 { sd } else { 1.0 }
            })
            .collect();
        // Centred, scaled normal equations: Cov(z) w = Cov(z, y), one Cov(z) for all.
        let mut a = vec![0.0; d * d];
        for i in 0..d {
            for j in 0..d {
                let cov = at(i + 1, j + 1) - mean[i] * mean[j];
                a[i * d + j] = cov / (scale[i] * scale[j]);
            }
            a[i * d + i] += lambda;
        }
        let factor = Cholesky::factor(&a, d);
        (0..self.outputs)
            .map(|k| {
                let xty = |i: usize| self.xty[i * self.outputs + k] / n;
                let y_mean = xty(0);
                let b: Vec<f64> = (0..d)
                    .map(|i| (xty(i + 1) - mean[i] * y_mean) / scale[i])
                    .collect();
                let weights = factor
                    .as_ref()
                    .map_or_else(|| vec![0.0; d], |f| f.solve(&b));
                LinearPolicy {
                    mean: mean.clone(),
                    scale: scale.clone(),
                    weights,
                    bias: y_mean,
                    range: UNIT_RANGE,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Class = which of three regions x[0] falls in; x[1] is noise.
    fn three_regions() -> (Vec<f64>, Vec<f64>) {
        let (mut rows, mut labels) = (Vec::new(), Vec::new());
        for k in 0..300 {
            let x = (k as f64 / 300.0) * 6.0 - 3.0;
            rows.extend([x, (k as f64 * 0.7).sin()]);
            labels.push(if x < -1.0 {
                0.0
            } else if x < 1.0 {
                1.0
            } else {
                2.0
            });
        }
        (rows, labels)
    }

    #[test]
    fn logistic_regression_separates_classes() {
        let (rows, labels) = three_regions();
        let p = LogisticPolicy::fit(&rows, 2, &labels, 3, 1e-4);
        assert_eq!(p.most_probable(&[-2.5, 0.0]), 0);
        assert_eq!(p.most_probable(&[0.0, 0.0]), 1);
        assert_eq!(p.most_probable(&[2.5, 0.0]), 2);
    }

    #[test]
    fn class_trees_separate_classes_a_line_cannot() {
        // Classes 0 and 2 on the outside, 1 in the middle... and 0 again beyond 2.5:
        // no single linear score orders them, one tree per class does.
        let (rows, mut labels) = three_regions();
        for (k, label) in labels.iter_mut().enumerate() {
            if rows[2 * k] > 2.5 {
                *label = 0.0;
            }
        }
        let learner = PolicyKind::ClassTree.learner(3, 0.0, 3);
        let mut data = Aggregate::new(2, 1, &learner);
        for (row, &label) in rows.chunks(2).zip(&labels) {
            data.add(row, &[label]);
        }
        let policy = data.fit(&learner);
        for (x, class) in [(-2.5, 0.0), (0.0, 1.0), (2.0, 2.0), (2.9, 0.0)] {
            assert_eq!(policy.act(&[x, 0.0]), class, "at {x}");
        }
    }

    #[test]
    fn actions_of_several_numbers_are_learned_per_output_within_their_range() {
        // Joint targets in degrees: far outside [−1, 1], each its own linear rule.
        let rules = [
            |x: &[f64]| 40.0 + 10.0 * x[0],
            |x: &[f64]| -90.0 + 5.0 * x[1],
            |x: &[f64]| 0.5 * x[0] - 0.25 * x[1],
        ];
        for kind in [PolicyKind::Ridge, PolicyKind::Tree] {
            let learner = kind.learner(8, 1e-6, 0);
            let mut data = Aggregate::new(2, 3, &learner);
            for k in 0..400 {
                let x = [(k as f64 * 0.37).sin(), (k as f64 * 0.11).cos()];
                data.add(&x, &rules.map(|r| r(&x)));
            }
            let policy = data.fit(&learner);
            assert_eq!(policy.outputs(), 3);
            let x = [0.3, -0.6];
            let actions = policy.act_all(&x);
            let tolerance = if kind == PolicyKind::Ridge { 1e-3 } else { 1.0 };
            for (j, rule) in rules.iter().enumerate() {
                assert!(
                    (actions[j] - rule(&x)).abs() < tolerance,
                    "{kind:?} {j}: {actions:?}"
                );
            }
            // Far outside the data the action stays within the labels' span.
            let far = policy.act_all(&[50.0, 0.0]);
            assert!(far[0] <= 50.0 + 1e-9, "{far:?}");
            let Policy::Outputs { members } = &policy else {
                panic!("{policy:?}")
            };
            let json = serde_json::to_string(&members[2]).unwrap();
            assert!(!json.contains("range"), "[−1, 1] is left out: {json}");
        }
    }

    #[test]
    fn one_factorisation_for_every_output_fits_as_each_alone() {
        let (mut joint, mut alone) = (
            PolicyData::with_outputs(2, 2),
            [PolicyData::new(2), PolicyData::new(2)],
        );
        for k in 0..50 {
            let x = [(k as f64 * 0.3).sin(), (k as f64 * 0.7).cos()];
            let y = [x[0] - 2.0 * x[1], 5.0 + x[1]];
            joint.add_all(&x, &y);
            alone[0].add(&x, y[0]);
            alone[1].add(&x, y[1]);
        }
        let fits = joint.fit_all(1e-3);
        assert_eq!(fits[0], alone[0].fit(1e-3));
        assert_eq!(fits[1], alone[1].fit(1e-3));
    }

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
