//! Inverse optimal control on tabular MDPs with per-state features, behind one interface:
//! LEARCH (exponentiated functional gradient on the cost, with a ridge-linear or a
//! regression-tree weak learner), MMP (linear reward, regularised subgradient) and
//! MaxEnt IOC (soft value iteration backward, expected visitation forward, gradient =
//! demonstrated minus expected feature counts). Each returns a reward per state.

use serde::{Deserialize, Serialize};

use super::objectworld::{Trajectory, state_action_reward};
use crate::learn::{RegressionTree, RidgeAccumulator, TreeConfig};
use crate::plan::{Backup, TabularMdp, value_iteration_from};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    LearchLinear,
    LearchTree,
    Mmp,
    Maxent,
}

impl Method {
    pub const ALL: [Method; 4] = [
        Method::LearchLinear,
        Method::LearchTree,
        Method::Mmp,
        Method::Maxent,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Method::LearchLinear => "learch-linear",
            Method::LearchTree => "learch-tree",
            Method::Mmp => "mmp",
            Method::Maxent => "maxent",
        }
    }
}

/// An IOC problem: the MDP and its discount, state features (row-major, `dims` wide),
/// demonstrations.
pub struct TabularProblem<'a> {
    pub mdp: &'a TabularMdp,
    pub discount: f64,
    pub features: &'a [f64],
    pub dims: usize,
    pub demonstrations: &'a [Trajectory],
}

impl TabularProblem<'_> {
    fn states(&self) -> usize {
        self.mdp.states()
    }

    fn row(&self, s: usize) -> &[f64] {
        &self.features[s * self.dims..(s + 1) * self.dims]
    }

    /// Visits per state over all demonstrations.
    fn demonstrated_visits(&self) -> Vec<f64> {
        let mut visits = vec![0.0; self.states()];
        for d in self.demonstrations {
            for &s in &d.states {
                visits[s] += 1.0;
            }
        }
        visits
    }

    /// Expected visits per state of `policy` over the demonstrations' horizon, from
    /// their start states.
    fn expected_visits(&self, policy: &[f64]) -> Vec<f64> {
        let horizon = self
            .demonstrations
            .iter()
            .map(|d| d.states.len())
            .max()
            .unwrap_or(0);
        let mut now = vec![0.0; self.states()];
        for d in self.demonstrations {
            now[d.states[0]] += 1.0;
        }
        let mut total = now.clone();
        for _ in 1..horizon {
            let mut next = vec![0.0; self.states()];
            for (s, &mass) in now.iter().enumerate() {
                if mass == 0.0 {
                    continue;
                }
                let actions = self.mdp.actions();
                for a in 0..actions {
                    let pa = policy[s * actions + a];
                    if pa == 0.0 {
                        continue;
                    }
                    for (n, p) in self.mdp.transitions(s, a) {
                        next[n] += mass * pa * p;
                    }
                }
            }
            for (total, v) in total.iter_mut().zip(&next) {
                *total += v;
            }
            now = next;
        }
        total
    }

    fn feature_counts(&self, visits: &[f64]) -> Vec<f64> {
        let mut counts = vec![0.0; self.dims];
        for (s, &v) in visits.iter().enumerate() {
            if v != 0.0 {
                for (c, x) in counts.iter_mut().zip(self.row(s)) {
                    *c += v * x;
                }
            }
        }
        counts
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TabularConfig {
    pub rounds: usize,
    /// LEARCH: c of the step c/√t; MMP: likewise for its subgradient; MaxEnt: Adam's
    /// learning rate.
    pub step_size: f64,
    /// L2 regularisation (ridge weak learner, MMP, MaxEnt).
    pub lambda: f64,
    /// Loss added to the reward of states no demonstration visits (MMP, and LEARCH with
    /// hard planning).
    pub loss: f64,
    /// LEARCH's planner: the soft-optimal policy's expected visits (right for stochastic
    /// demonstrators; no loss augmentation) or the optimal policy's (loss-augmented).
    pub soft_planning: bool,
    pub tree: TreeConfig,
}

impl TabularConfig {
    /// Settings measured to work on objectworld (BENCHMARKS.md) for each method.
    pub fn default_for(method: Method) -> Self {
        let base = TabularConfig {
            rounds: 100,
            step_size: 0.5,
            lambda: 0.01,
            loss: 1.0,
            soft_planning: true,
            tree: TreeConfig {
                max_depth: 2,
                min_leaf_weight: 0.5,
                bins: 32,
                leaf_l2: 0.0,
            },
        };
        match method {
            Method::LearchLinear | Method::LearchTree => base,
            Method::Mmp => TabularConfig {
                soft_planning: false,
                ..base
            },
            Method::Maxent => TabularConfig {
                rounds: 40,
                step_size: 0.05,
                ..base
            },
        }
    }
}

/// Value iteration stops when no value moves more than this: far below what changes a
/// policy at objectworld's reward scale, and half the sweeps of 1e-6.
const PLANNING_TOLERANCE: f64 = 1e-4;

/// Value iteration round after round, each starting from the last solution.
struct Planner<'a> {
    mdp: &'a TabularMdp,
    discount: f64,
    backup: Backup,
    values: Option<Vec<f64>>,
}

impl<'a> Planner<'a> {
    fn new(problem: &TabularProblem<'a>, soft: bool) -> Self {
        Planner {
            mdp: problem.mdp,
            discount: problem.discount,
            backup: if soft { Backup::Soft } else { Backup::Hard },
            values: None,
        }
    }

    /// The policy (soft-optimal or greedy) of a reward per state.
    fn policy(&mut self, reward: &[f64]) -> Vec<f64> {
        let values = value_iteration_from(
            self.mdp,
            &state_action_reward(self.mdp, reward),
            self.discount,
            self.backup,
            PLANNING_TOLERANCE,
            10_000,
            self.values.as_deref(),
        );
        let policy = values.policy(self.backup);
        self.values = Some(values.state);
        policy
    }
}

/// Learns a reward per state.
pub fn learn(problem: &TabularProblem<'_>, method: Method, config: &TabularConfig) -> Vec<f64> {
    match method {
        Method::LearchLinear | Method::LearchTree => learch(problem, method, config),
        Method::Mmp => mmp(problem, config),
        Method::Maxent => maxent(problem, config),
    }
}

/// Features with a constant column appended (ridge learners fit an intercept that way).
fn with_bias(problem: &TabularProblem<'_>, s: usize) -> Vec<f64> {
    let mut x = problem.row(s).to_vec();
    x.push(1.0);
    x
}

/// LEARCH: cost c(s) = exp(Σ η_t h_t(φ(s))), reward −c. Each round plans (expected
/// visits from the demonstrations' starts of the soft-optimal policy, or of the optimal
/// policy of the loss-augmented reward), and fits the weak learner to +1 where the plan
/// visits more than the demonstrations (raise the cost there) and −1 where less,
/// weighted by the difference.
fn learch(problem: &TabularProblem<'_>, method: Method, config: &TabularConfig) -> Vec<f64> {
    let states = problem.states();
    let demonstrated = problem.demonstrated_visits();
    let mut log_cost = vec![0.0f64; states];
    let rows: Vec<f64> = problem.features.to_vec();
    let mut planner = Planner::new(problem, config.soft_planning);
    for round in 1..=config.rounds {
        let augmented: Vec<f64> = (0..states)
            .map(|s| {
                let augment = !config.soft_planning && demonstrated[s] == 0.0;
                -log_cost[s].exp() + if augment { config.loss } else { 0.0 }
            })
            .collect();
        let planned = problem.expected_visits(&planner.policy(&augmented));
        let gradient: Vec<f64> = planned
            .iter()
            .zip(&demonstrated)
            .map(|(p, d)| p - d)
            .collect();
        let targets: Vec<f64> = gradient.iter().map(|g| g.signum()).collect();
        let weights: Vec<f64> = gradient.iter().map(|g| g.abs()).collect();
        if weights.iter().all(|w| *w < 1e-12) {
            break;
        }
        let step = config.step_size / (round as f64).sqrt();
        match method {
            Method::LearchTree => {
                let tree =
                    RegressionTree::fit(&rows, problem.dims, &targets, &weights, &config.tree);
                for (s, lc) in log_cost.iter_mut().enumerate() {
                    *lc += step * tree.predict(problem.row(s));
                }
            }
            _ => {
                let mut ridge = RidgeAccumulator::new(problem.dims + 1);
                for s in (0..states).filter(|&s| weights[s] > 0.0) {
                    ridge.add(&with_bias(problem, s), targets[s], weights[s]);
                }
                let beta = ridge.solve(config.lambda);
                for (s, lc) in log_cost.iter_mut().enumerate() {
                    let x = with_bias(problem, s);
                    *lc += step * x.iter().zip(&beta).map(|(a, b)| a * b).sum::<f64>();
                }
            }
        }
    }
    log_cost.iter().map(|lc| -lc.exp()).collect()
}

/// MMP: reward θ·φ; subgradient steps on λ/2‖θ‖² + the structured hinge loss
/// (loss-augmented optimum minus demonstrations, in feature counts per demonstration).
fn mmp(problem: &TabularProblem<'_>, config: &TabularConfig) -> Vec<f64> {
    let demonstrated = problem.demonstrated_visits();
    let demo_counts = problem.feature_counts(&demonstrated);
    let n = problem.demonstrations.len().max(1) as f64;
    let mut theta = vec![0.0; problem.dims];
    let mut planner = Planner::new(problem, false);
    for round in 1..=config.rounds {
        let augmented: Vec<f64> = linear_reward(problem, &theta)
            .iter()
            .zip(&demonstrated)
            .map(|(r, d)| r + if *d > 0.0 { 0.0 } else { config.loss })
            .collect();
        let planned = problem.expected_visits(&planner.policy(&augmented));
        let planned_counts = problem.feature_counts(&planned);
        let step = config.step_size / (round as f64).sqrt();
        for j in 0..problem.dims {
            let g = config.lambda * theta[j] + (planned_counts[j] - demo_counts[j]) / n;
            theta[j] -= step * g;
        }
    }
    linear_reward(problem, &theta)
}

fn linear_reward(problem: &TabularProblem<'_>, theta: &[f64]) -> Vec<f64> {
    (0..problem.states())
        .map(|s| problem.row(s).iter().zip(theta).map(|(x, t)| x * t).sum())
        .collect()
}

/// MaxEnt IOC with a linear reward θ·φ, by Adam ascent on the demonstrations' log
/// likelihood (minus λ/2‖θ‖²).
fn maxent(problem: &TabularProblem<'_>, config: &TabularConfig) -> Vec<f64> {
    let demo_counts = problem.feature_counts(&problem.demonstrated_visits());
    let n = problem.demonstrations.len().max(1) as f64;
    let mut theta = vec![0.0; problem.dims];
    let (mut m, mut v) = (vec![0.0; problem.dims], vec![0.0; problem.dims]);
    let (beta1, beta2) = (0.9f64, 0.999f64);
    let mut planner = Planner::new(problem, true);
    for round in 1..=config.rounds {
        let policy = planner.policy(&linear_reward(problem, &theta));
        let expected = problem.feature_counts(&problem.expected_visits(&policy));
        for j in 0..problem.dims {
            let g = (demo_counts[j] - expected[j]) / n - config.lambda * theta[j];
            m[j] = beta1 * m[j] + (1.0 - beta1) * g;
            v[j] = beta2 * v[j] + (1.0 - beta2) * g * g;
            let m_hat = m[j] / (1.0 - beta1.powi(round as i32));
            let v_hat = v[j] / (1.0 - beta2.powi(round as i32));
            theta[j] += config.step_size * m_hat / (v_hat.sqrt() + 1e-8);
        }
    }
    linear_reward(problem, &theta)
}

#[cfg(test)]
mod tests {
    use super::super::objectworld::{FeatureKind, ObjectWorld, expected_value_difference};
    use super::*;

    #[test]
    fn every_method_beats_a_flat_reward_on_a_small_world() {
        let world = ObjectWorld::generate(12, FeatureKind::Discrete, 5);
        let demos = world.demonstrations(32, 6);
        let problem = TabularProblem {
            mdp: &world.mdp,
            discount: super::super::objectworld::DISCOUNT,
            features: &world.features,
            dims: world.dims,
            demonstrations: &demos,
        };
        let flat = expected_value_difference(&world, &vec![0.0; world.states()]);
        for method in Method::ALL {
            let reward = learn(&problem, method, &TabularConfig::default_for(method));
            let evd = expected_value_difference(&world, &reward);
            assert!(evd < flat, "{}: EVD {evd} vs flat {flat}", method.name());
        }
    }

    #[test]
    fn every_method_recovers_a_reward_that_is_linear_in_the_features() {
        // Features that are the true reward's own indicators: every learner's model class
        // holds the truth, so each must find a policy as good as the expert's.
        let world = ObjectWorld::generate(32, FeatureKind::Discrete, 1);
        let demos = world.demonstrations(64, 7);
        let features: Vec<f64> = world
            .true_reward
            .iter()
            .flat_map(|&r| [f64::from(r == 5.0), f64::from(r == -10.0), 1.0])
            .collect();
        let problem = TabularProblem {
            mdp: &world.mdp,
            discount: super::super::objectworld::DISCOUNT,
            features: &features,
            dims: 3,
            demonstrations: &demos,
        };
        for method in Method::ALL {
            let reward = learn(&problem, method, &TabularConfig::default_for(method));
            let evd = expected_value_difference(&world, &reward);
            assert!(evd < 0.5, "{}: EVD {evd}", method.name());
        }
    }
}
