//! DAgger (Ross, Gordon & Bagnell 2011), the seed's first listing: run the current
//! policy, mixed per step with the teacher with probability β_i; record the teacher's
//! action in every visited state without executing it; aggregate; train on everything
//! so far. Behaviour cloning is the same loop with the teacher always driving.
//!
//! This module holds the loop over in-memory rounds: β schedules, rollouts that keep
//! both the executed and the teacher's action, and policies fitted from the aggregate's
//! sufficient statistics. The dataset on disk is `dataset`, the rounds from logs and
//! demonstrations `log_round` and `demo_round`, and the polars queries over them `query`.

pub mod dataset;
pub mod demo_round;
pub mod log_round;
pub mod onnx;
mod policy;
pub mod query;
pub mod train;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

pub use policy::{
    Aggregate, LinearPolicy, LogisticPolicy, MlpPolicy, Policy, PolicyData, PolicyKind,
    PolicyLearner, load_policy_artifact, policy_observation_names,
};

use rayon::prelude::*;

use crate::grid::Grid;
use crate::sim::gridnav::{GridNav, random_episode};
use crate::sim::{Track, TrackSim};

/// A system a policy drives and a teacher labels.
pub trait Environment {
    /// What the policy sees.
    fn observe(&self) -> Vec<f64>;
    /// The teacher's action in the current state.
    fn teacher(&self) -> f64;
    /// Executes an action; true when the step failed (a fall, a crash).
    fn execute(&mut self, action: f64, rng: &mut ChaCha8Rng) -> bool;
}

impl Environment for GridNav<'_> {
    fn observe(&self) -> Vec<f64> {
        self.observation()
    }

    /// The teacher's move, as a class index.
    fn teacher(&self) -> f64 {
        GridNav::teacher(self) as f64
    }

    fn execute(&mut self, action: f64, _rng: &mut ChaCha8Rng) -> bool {
        self.step(action.round().clamp(0.0, 7.0) as usize)
    }
}

impl Environment for TrackSim<'_> {
    fn observe(&self) -> Vec<f64> {
        self.observation().to_vec()
    }

    fn teacher(&self) -> f64 {
        TrackSim::teacher(self)
    }

    fn execute(&mut self, action: f64, rng: &mut ChaCha8Rng) -> bool {
        self.step(action, rng)
    }
}

/// β_i, the probability that the teacher acts at a step of round i (0-based).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
pub enum BetaSchedule {
    /// β_i = I(i = 0): the teacher drives the first round, the learner every later one.
    FirstRound,
    /// β_i = max(0, 1 − i / rounds).
    Linear { rounds: usize },
    /// β_i = p^i.
    Exponential { p: f64 },
}

impl BetaSchedule {
    pub fn beta(&self, round: usize) -> f64 {
        match *self {
            BetaSchedule::FirstRound => f64::from(u8::from(round == 0)),
            BetaSchedule::Linear { rounds } => (1.0 - round as f64 / rounds.max(1) as f64).max(0.0),
            BetaSchedule::Exponential { p } => p.powi(round as i32),
        }
    }
}

/// Who chose the executed action.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Actor {
    Teacher,
    Learner,
}

/// One control step of a rollout.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    pub observation: Vec<f64>,
    /// The teacher's action: the label (one number per output of the action).
    pub label: Vec<f64>,
    pub executed: Vec<f64>,
    pub actor: Actor,
    pub failed: bool,
}

/// Runs `policy` (the teacher where there is none yet) mixed with the teacher with
/// probability `beta` per step, until `done`; every step keeps the teacher's label.
pub fn rollout<E: Environment>(
    env: &mut E,
    policy: Option<&Policy>,
    beta: f64,
    rng: &mut ChaCha8Rng,
    mut done: impl FnMut(&E) -> bool,
) -> Vec<Step> {
    let mut steps = Vec::new();
    while !done(env) {
        let observation = env.observe();
        let label = env.teacher();
        let teacher_acts = policy.is_none() || rng.random::<f64>() < beta;
        let (actor, executed) = match policy {
            Some(p) if !teacher_acts => (Actor::Learner, p.act(&observation)),
            _ => (Actor::Teacher, label),
        };
        let failed = env.execute(executed, rng);
        steps.push(Step {
            observation,
            label: vec![label],
            executed: vec![executed],
            actor,
            failed,
        });
    }
    steps
}

/// Runs `episode` for episodes 0..`episodes` in parallel, in order of their index, each
/// with random stream (`round` << 32 | e) of `seed`: the same round at any thread count.
fn parallel_episodes<T: Send>(
    episodes: usize,
    seed: u64,
    round: usize,
    episode: impl Fn(&mut ChaCha8Rng) -> T + Sync,
) -> Vec<T> {
    (0..episodes)
        .into_par_iter()
        .map(|e| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(((round as u64) << 32) | e as u64);
            episode(&mut rng)
        })
        .collect()
}

/// One round on the track: `episodes` episodes of `laps` laps from random starts, driven
/// in parallel by `driver` (the teacher when `None`; a mixture draws its member per
/// episode) mixed with the teacher at `beta`.
pub fn track_round(
    track: &Track,
    driver: Option<&Policy>,
    beta: f64,
    laps: usize,
    episodes: usize,
    seed: u64,
    round: usize,
) -> Vec<Vec<Step>> {
    let cap = track.step_cap(laps as f64);
    parallel_episodes(episodes, seed, round, |rng| {
        let start = rng.random::<f64>() * track.length();
        let mut sim = TrackSim::new(track, start);
        let driver = driver.map(|p| p.for_episode(rng).clone());
        let mut count = 0;
        rollout(&mut sim, driver.as_ref(), beta, rng, |s| {
            count += 1;
            s.laps() >= laps as f64 || count > cap
        })
    })
}

/// One round of `gridnav` on `costs`: `episodes` walks between random reachable pairs,
/// in parallel as `track_round`. `None` when the map has no reachable pair.
pub fn gridnav_round(
    costs: &Grid<f32>,
    driver: Option<&Policy>,
    beta: f64,
    episodes: usize,
    seed: u64,
    round: usize,
) -> Option<Vec<Vec<Step>>> {
    parallel_episodes(episodes, seed, round, |rng| {
        let mut nav = random_episode(costs, rng)?;
        let driver = driver.map(|p| p.for_episode(rng).clone());
        Some(rollout(&mut nav, driver.as_ref(), beta, rng, GridNav::over))
    })
    .into_iter()
    .collect()
}

/// How the rounds gather their labels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Learning {
    /// Behaviour cloning: the teacher always drives.
    Supervised,
    /// DAgger with this β schedule.
    Dagger(BetaSchedule),
}

/// Rounds of imitation on an environment: each round makes a fresh environment with
/// `make_env(round)`, rolls out until `done`, aggregates the labels and refits. Calls
/// `after_round(round, &policy)` with each round's policy (to evaluate it) and returns
/// the last policy. Deterministic given `seed`.
#[allow(clippy::too_many_arguments)]
pub fn learn<E: Environment>(
    learning: Learning,
    learner: &PolicyLearner,
    rounds: usize,
    seed: u64,
    mut make_env: impl FnMut(usize) -> E,
    mut done: impl FnMut(&E) -> bool,
    mut after_round: impl FnMut(usize, &Policy),
) -> Option<Policy> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut data: Option<Aggregate> = None;
    let mut policy: Option<Policy> = None;
    for round in 0..rounds {
        let mut env = make_env(round);
        let (driver, beta) = match learning {
            Learning::Supervised => (None, 1.0),
            Learning::Dagger(schedule) => (policy.as_ref(), schedule.beta(round)),
        };
        let steps = rollout(&mut env, driver, beta, &mut rng, &mut done);
        let data = data.get_or_insert_with(|| {
            Aggregate::new(steps.first().map_or(0, |s| s.observation.len()), 1, learner)
        });
        for step in &steps {
            data.add(&step.observation, &step.label);
        }
        let fitted = data.fit(learner);
        after_round(round, &fitted);
        policy = Some(fitted);
    }
    policy
}

/// What forward training returns: the non-stationary policy and, per step t, the states
/// the episodes reached at t with the teacher's labels (what each step's policy was fitted
/// on).
pub struct ForwardTraining {
    pub policy: Policy,
    pub labels: Vec<Vec<Step>>,
}

/// Forward training (Ross & Bagnell 2010), the finite-horizon variant: for each step
/// t < `horizon`, `episodes` fresh episodes (from `make_env`, in parallel as
/// `track_round`) are driven by the policies already trained for steps 0..t, and the
/// teacher labels the state each reaches at step t; the policy for step t is fitted on
/// those labels alone. Episodes that fail on the way still give their state at step t.
pub fn forward_training<E: Environment>(
    learner: &PolicyLearner,
    horizon: usize,
    episodes: usize,
    seed: u64,
    make_env: impl Fn(&mut ChaCha8Rng) -> E + Sync,
) -> ForwardTraining {
    let mut steps: Vec<Policy> = Vec::with_capacity(horizon);
    let mut labels = Vec::with_capacity(horizon);
    for t in 0..horizon {
        let reached = parallel_episodes(episodes, seed, t, |rng| {
            let mut env = make_env(rng);
            for policy in &steps {
                let x = env.observe();
                env.execute(policy.act(&x), rng);
            }
            let observation = env.observe();
            let label = env.teacher();
            Step {
                observation,
                label: vec![label],
                executed: vec![label],
                actor: Actor::Teacher,
                failed: false,
            }
        });
        let fitted = match reached.first() {
            Some(first) => {
                let mut data = Aggregate::new(first.observation.len(), 1, learner);
                for step in &reached {
                    data.add(&step.observation, &step.label);
                }
                data.fit(learner)
            }
            None => Policy::Linear(PolicyData::new(0).fit(0.0)),
        };
        steps.push(fitted);
        labels.push(reached);
    }
    ForwardTraining {
        policy: Policy::Sequence { steps },
        labels,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::TreeConfig;
    use crate::sim::{Track, TrackConfig};

    /// Falls per lap of each round's policy, learning with a depth-3 tree.
    fn track_curve(learning: Learning, rounds: usize) -> Vec<f64> {
        let track = Track::new(TrackConfig::default());
        let learner = PolicyLearner::Tree(TreeConfig {
            max_depth: 3,
            ..TreeConfig::default()
        });
        let mut starts = ChaCha8Rng::seed_from_u64(5);
        let mut curve = Vec::new();
        learn(
            learning,
            &learner,
            rounds,
            5,
            |_| TrackSim::new(&track, starts.random::<f64>() * track.length()),
            |sim| sim.laps() >= 1.0,
            |_, policy| curve.push(track.falls_per_lap(3, 99, |s| policy.act(&s.observation()))),
        );
        curve
    }

    #[test]
    fn dagger_keeps_a_shallow_tree_on_the_track_where_cloning_does_not() {
        let cloning = track_curve(Learning::Supervised, 8);
        let dagger = track_curve(Learning::Dagger(BetaSchedule::FirstRound), 8);
        // The first round is the teacher's lap in both.
        assert_eq!(cloning[0], dagger[0]);
        // After the first rounds: cloning keeps falling, DAgger falls far less.
        let later = |c: &[f64]| c[3..].iter().sum::<f64>() / (c.len() - 3) as f64;
        assert!(later(&cloning) >= 0.5, "{cloning:?}");
        assert!(
            later(&dagger) < 0.5 * later(&cloning),
            "{dagger:?} vs {cloning:?}"
        );
    }

    #[test]
    fn forward_training_learns_one_policy_per_step_that_drives_a_lap() {
        let track = Track::new(TrackConfig::default());
        let learner = PolicyLearner::Tree(TreeConfig {
            max_depth: 3,
            ..TreeConfig::default()
        });
        let horizon = 140;
        let trained = forward_training(&learner, horizon, 5, 1, |_| TrackSim::new(&track, 0.0));
        let Policy::Sequence { steps } = &trained.policy else {
            panic!("forward training returns a sequence");
        };
        assert_eq!(steps.len(), horizon);
        assert_eq!(trained.labels.len(), horizon);
        assert!(trained.labels.iter().all(|at_t| at_t.len() == 5));
        let falls =
            track.lap_falls_per_lap(1, 9, |t, sim| trained.policy.act_at(t, &sim.observation()));
        assert!(falls <= 1.0, "{falls} falls");
    }

    #[test]
    fn rollouts_keep_the_teachers_label_and_who_acted() {
        let track = Track::new(TrackConfig::default());
        let mut sim = TrackSim::new(&track, 0.0);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let straight = Policy::Linear(LinearPolicy {
            mean: vec![0.0; 5],
            scale: vec![1.0; 5],
            weights: vec![0.0; 5],
            bias: 0.0,
            range: [-1.0, 1.0],
        });
        let mut count = 0;
        let steps = rollout(&mut sim, Some(&straight), 0.5, &mut rng, |_| {
            count += 1;
            count > 200
        });
        assert_eq!(steps.len(), 200);
        let by_learner = steps.iter().filter(|s| s.actor == Actor::Learner).count();
        assert!((60..140).contains(&by_learner), "{by_learner}");
        for s in &steps {
            match s.actor {
                Actor::Learner => assert_eq!(s.executed, [0.0]),
                Actor::Teacher => assert_eq!(s.executed, s.label),
            }
        }
    }

    #[test]
    fn beta_schedules() {
        assert_eq!(BetaSchedule::FirstRound.beta(0), 1.0);
        assert_eq!(BetaSchedule::FirstRound.beta(3), 0.0);
        assert_eq!(BetaSchedule::Linear { rounds: 4 }.beta(1), 0.75);
        assert_eq!(BetaSchedule::Linear { rounds: 4 }.beta(9), 0.0);
        assert!((BetaSchedule::Exponential { p: 0.5 }.beta(3) - 0.125).abs() < 1e-12);
    }
}
