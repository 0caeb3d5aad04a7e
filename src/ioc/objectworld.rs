//! The objectworld benchmark of Levine, Popović & Koltun (2011, GPIRL): an N×N grid, five
//! actions (stay, up, down, left, right; clamped at the borders) that succeed with
//! probability 0.7 and otherwise give one of the other four outcomes uniformly, discount
//! 0.9. Each cell holds an object with probability 0.05, with an outer and an inner colour
//! (of 2 each). Features: the distance to the nearest object of each outer and inner
//! colour (continuous), or indicators distance < d for d = 1..N−1 (discrete). True
//! reward: +5 within distance 3 of outer colour 1 and 2 of outer colour 2, −10 within 3 of
//! colour 1 only, 0 elsewhere. Demonstrations: 8 steps of the soft-optimal expert from
//! uniform random starts. Metric: expected value difference (EVD).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::plan::{Backup, TabularMdp, value_iteration};

pub const ACTIONS: usize = 5;
pub const DISCOUNT: f64 = 0.9;
pub const STEPS: usize = 8;
const SUCCESS: f64 = 0.7;
const OBJECT_PROBABILITY: f64 = 0.05;
const COLOURS: usize = 2;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum FeatureKind {
    Continuous,
    Discrete,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Object {
    pub x: usize,
    pub y: usize,
    pub outer: usize,
    pub inner: usize,
}

/// A generated world: its MDP, objects, features (row-major, `dims` per state) and true
/// reward per state.
pub struct ObjectWorld {
    pub size: usize,
    pub mdp: TabularMdp,
    pub objects: Vec<Object>,
    pub features: Vec<f64>,
    pub dims: usize,
    pub feature_names: Vec<String>,
    pub true_reward: Vec<f64>,
}

/// A demonstration: the states visited and the actions taken (one fewer).
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    pub states: Vec<usize>,
    pub actions: Vec<usize>,
}

/// Where action `a` leads from (x, y): 0 stay, 1 up, 2 down, 3 left, 4 right.
fn step(size: usize, x: usize, y: usize, a: usize) -> usize {
    let (nx, ny) = match a {
        1 => (x, (y + 1).min(size - 1)),
        2 => (x, y.saturating_sub(1)),
        3 => (x.saturating_sub(1), y),
        4 => ((x + 1).min(size - 1), y),
        _ => (x, y),
    };
    ny * size + nx
}

/// The transition table: intended outcome with 0.7, each other outcome with 0.075.
pub fn grid_mdp(size: usize) -> TabularMdp {
    let miss = (1.0 - SUCCESS) / (ACTIONS - 1) as f64;
    let mut rows = Vec::with_capacity(size * size * ACTIONS * ACTIONS);
    for y in 0..size {
        for x in 0..size {
            let s = y * size + x;
            for a in 0..ACTIONS {
                for outcome in 0..ACTIONS {
                    let p = if outcome == a { SUCCESS } else { miss };
                    rows.push((s, a, step(size, x, y, outcome), p));
                }
            }
        }
    }
    TabularMdp::new(size * size, ACTIONS, rows).expect("a well-formed grid MDP")
}

impl ObjectWorld {
    pub fn generate(size: usize, kind: FeatureKind, seed: u64) -> ObjectWorld {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut objects = Vec::new();
        for y in 0..size {
            for x in 0..size {
                if rng.random_bool(OBJECT_PROBABILITY) {
                    let outer = rng.random_range(0..COLOURS);
                    let inner = rng.random_range(0..COLOURS);
                    objects.push(Object { x, y, outer, inner });
                }
            }
        }
        let absent = (2.0 * (size * size) as f64).sqrt();
        // dist[s][k]: k = outer colour c at 2c, inner colour c at 2c + 1.
        let states = size * size;
        let mut distance = vec![absent; states * 2 * COLOURS];
        for y in 0..size {
            for x in 0..size {
                let s = y * size + x;
                for o in &objects {
                    let d =
                        ((x as f64 - o.x as f64).powi(2) + (y as f64 - o.y as f64).powi(2)).sqrt();
                    for k in [2 * o.outer, 2 * o.inner + 1] {
                        let slot = &mut distance[s * 2 * COLOURS + k];
                        *slot = slot.min(d);
                    }
                }
            }
        }
        let kinds: Vec<String> = (0..COLOURS)
            .flat_map(|c| [format!("outer{}", c + 1), format!("inner{}", c + 1)])
            .collect();
        let (features, feature_names, dims) = match kind {
            FeatureKind::Continuous => (
                distance.clone(),
                kinds.iter().map(|k| format!("distance_{k}")).collect(),
                2 * COLOURS,
            ),
            FeatureKind::Discrete => {
                let thresholds = size - 1;
                let dims = 2 * COLOURS * thresholds;
                let mut features = vec![0.0; states * dims];
                for s in 0..states {
                    for k in 0..2 * COLOURS {
                        for d in 1..size {
                            if distance[s * 2 * COLOURS + k] < d as f64 {
                                features[s * dims + k * thresholds + d - 1] = 1.0;
                            }
                        }
                    }
                }
                let names = kinds
                    .iter()
                    .flat_map(|k| (1..size).map(move |d| format!("{k}_within_{d}")))
                    .collect();
                (features, names, dims)
            }
        };
        let true_reward = (0..states)
            .map(|s| {
                let (near1, near2) = (
                    distance[s * 2 * COLOURS] < 3.0,
                    distance[s * 2 * COLOURS + 2] < 2.0,
                );
                match (near1, near2) {
                    (true, true) => 5.0,
                    (true, false) => -10.0,
                    _ => 0.0,
                }
            })
            .collect();
        ObjectWorld {
            size,
            mdp: grid_mdp(size),
            objects,
            features,
            dims,
            feature_names,
            true_reward,
        }
    }

    pub fn states(&self) -> usize {
        self.size * self.size
    }

    /// Samples `count` demonstrations of `STEPS` states from uniform random starts, with
    /// the soft-optimal policy of the true reward.
    pub fn demonstrations(&self, count: usize, seed: u64) -> Vec<Trajectory> {
        let policy = soft_policy(&self.mdp, &self.true_reward);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..count)
            .map(|_| {
                let mut s = rng.random_range(0..self.states());
                let mut trajectory = Trajectory {
                    states: vec![s],
                    actions: Vec::new(),
                };
                for _ in 1..STEPS {
                    let a = sample(&policy[s * ACTIONS..(s + 1) * ACTIONS], &mut rng);
                    let outcomes: Vec<(usize, f64)> = self.mdp.transitions(s, a).collect();
                    let weights: Vec<f64> = outcomes.iter().map(|o| o.1).collect();
                    s = outcomes[sample(&weights, &mut rng)].0;
                    trajectory.actions.push(a);
                    trajectory.states.push(s);
                }
                trajectory
            })
            .collect()
    }
}

fn sample(weights: &[f64], rng: &mut ChaCha8Rng) -> usize {
    let total: f64 = weights.iter().sum();
    let mut u = rng.random_range(0.0..total);
    for (i, w) in weights.iter().enumerate() {
        if u < *w {
            return i;
        }
        u -= w;
    }
    weights.len() - 1
}

/// Rewards per state spread over actions, as value iteration takes them.
pub fn state_action_reward(mdp: &TabularMdp, reward: &[f64]) -> Vec<f64> {
    reward
        .iter()
        .flat_map(|&r| std::iter::repeat_n(r, mdp.actions()))
        .collect()
}

pub fn soft_policy(mdp: &TabularMdp, reward: &[f64]) -> Vec<f64> {
    value_iteration(
        mdp,
        &state_action_reward(mdp, reward),
        DISCOUNT,
        Backup::Soft,
        1e-8,
        10_000,
    )
    .policy(Backup::Soft)
}

/// The greedy policy of the optimal values under `reward`.
pub fn optimal_policy(mdp: &TabularMdp, reward: &[f64]) -> Vec<f64> {
    value_iteration(
        mdp,
        &state_action_reward(mdp, reward),
        DISCOUNT,
        Backup::Hard,
        1e-8,
        10_000,
    )
    .policy(Backup::Hard)
}

/// V^π under `reward` (policy evaluation by iteration to 1e-10).
pub fn policy_values(mdp: &TabularMdp, reward: &[f64], policy: &[f64]) -> Vec<f64> {
    let a_count = mdp.actions();
    let mut v = vec![0.0; mdp.states()];
    for _ in 0..100_000 {
        let next: Vec<f64> = (0..mdp.states())
            .map(|s| {
                reward[s]
                    + DISCOUNT
                        * (0..a_count)
                            .filter(|&a| policy[s * a_count + a] > 0.0)
                            .map(|a| {
                                policy[s * a_count + a]
                                    * mdp.transitions(s, a).map(|(n, p)| p * v[n]).sum::<f64>()
                            })
                            .sum::<f64>()
            })
            .collect();
        let change = next
            .iter()
            .zip(&v)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        v = next;
        if change < 1e-10 {
            break;
        }
    }
    v
}

/// Expected value difference under the true reward, from a uniform start: the optimal
/// policy's value minus the value of the policy optimal for `learned`.
pub fn expected_value_difference(world: &ObjectWorld, learned: &[f64]) -> f64 {
    let truth = &world.true_reward;
    let best = policy_values(&world.mdp, truth, &optimal_policy(&world.mdp, truth));
    let ours = policy_values(&world.mdp, truth, &optimal_policy(&world.mdp, learned));
    let n = world.states() as f64;
    best.iter().sum::<f64>() / n - ours.iter().sum::<f64>() / n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_world_follows_the_protocol() {
        let world = ObjectWorld::generate(32, FeatureKind::Discrete, 1);
        assert_eq!(world.states(), 1024);
        assert_eq!(world.dims, 4 * 31);
        // About 5 % of cells hold an object.
        assert!(
            (20..90).contains(&world.objects.len()),
            "{}",
            world.objects.len()
        );
        assert!(
            world
                .true_reward
                .iter()
                .all(|r| [5.0, -10.0, 0.0].contains(r))
        );
        // Stay at a corner: 0.7 + the clamped moves that also stay.
        let stay: f64 = world
            .mdp
            .transitions(0, 0)
            .filter(|(n, _)| *n == 0)
            .map(|(_, p)| p)
            .sum();
        assert!((stay - (0.7 + 2.0 * 0.075)).abs() < 1e-12);
        let demos = world.demonstrations(4, 2);
        assert!(
            demos
                .iter()
                .all(|d| d.states.len() == STEPS && d.actions.len() == STEPS - 1)
        );
    }

    #[test]
    fn the_true_reward_has_no_value_difference_and_zero_reward_some() {
        let world = ObjectWorld::generate(16, FeatureKind::Continuous, 3);
        assert!(expected_value_difference(&world, &world.true_reward).abs() < 1e-9);
        let flat = vec![0.0; world.states()];
        assert!(expected_value_difference(&world, &flat) >= 0.0);
    }
}
