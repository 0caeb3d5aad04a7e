//! Value iteration, hard (max) and soft (log-sum-exp), on tabular stochastic MDPs with
//! sparse transition lists: the planner of inverse optimal control on problems that
//! are not grids (MaxEnt IOC uses the soft one).

use rayon::prelude::*;

/// A finite MDP: for each state and action, a list of (next state, probability).
/// A state-action pair with no transitions is not available in that state.
#[derive(Debug, Clone, PartialEq)]
pub struct TabularMdp {
    states: usize,
    actions: usize,
    /// Transitions of pair (s, a) are `next[offsets[k]..offsets[k + 1]]`, k = s·A + a.
    offsets: Vec<usize>,
    next: Vec<u32>,
    prob: Vec<f64>,
}

/// The result of value iteration.
#[derive(Debug, Clone, PartialEq)]
pub struct Values {
    /// V(s).
    pub state: Vec<f64>,
    /// Q(s, a), row-major by state; −∞ for unavailable actions.
    pub action: Vec<f64>,
    pub iterations: usize,
    /// Whether the last sweep changed no value by more than the tolerance.
    pub converged: bool,
}

impl TabularMdp {
    /// Builds an MDP from (state, action, next state, probability) rows. Each listed
    /// pair's probabilities must sum to 1 (within 1e-6); every state needs an action.
    pub fn new(
        states: usize,
        actions: usize,
        transitions: impl IntoIterator<Item = (usize, usize, usize, f64)>,
    ) -> Result<Self, String> {
        let mut rows: Vec<(usize, usize, usize, f64)> = transitions.into_iter().collect();
        for (i, &(s, a, n, p)) in rows.iter().enumerate() {
            if s >= states || n >= states || a >= actions {
                return Err(format!(
                    "transition {i}: ({s}, {a}) -> {n} is outside {states} states x {actions} actions"
                ));
            }
            if !(p.is_finite() && (0.0..=1.0).contains(&p)) {
                return Err(format!("transition {i}: probability {p} is not in [0, 1]"));
            }
        }
        // Stable by (state, action): the order within a pair stays as given.
        rows.sort_by_key(|&(s, a, _, _)| (s, a));
        let mut offsets = vec![0usize; states * actions + 1];
        for &(s, a, _, _) in &rows {
            offsets[s * actions + a + 1] += 1;
        }
        for k in 0..states * actions {
            offsets[k + 1] += offsets[k];
        }
        let next: Vec<u32> = rows.iter().map(|r| r.2 as u32).collect();
        let prob: Vec<f64> = rows.iter().map(|r| r.3).collect();
        let mdp = TabularMdp {
            states,
            actions,
            offsets,
            next,
            prob,
        };
        for s in 0..states {
            if (0..actions).all(|a| !mdp.available(s, a)) {
                return Err(format!("state {s} has no action"));
            }
            for a in (0..actions).filter(|&a| mdp.available(s, a)) {
                let total: f64 = mdp.transitions(s, a).map(|(_, p)| p).sum();
                if (total - 1.0).abs() > 1e-6 {
                    return Err(format!(
                        "action {a} in state {s}: probabilities sum to {total}, not 1"
                    ));
                }
            }
        }
        Ok(mdp)
    }

    pub fn states(&self) -> usize {
        self.states
    }

    pub fn actions(&self) -> usize {
        self.actions
    }

    pub fn available(&self, s: usize, a: usize) -> bool {
        let k = s * self.actions + a;
        self.offsets[k + 1] > self.offsets[k]
    }

    /// (next state, probability) of taking `a` in `s`.
    pub fn transitions(&self, s: usize, a: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let k = s * self.actions + a;
        let range = self.offsets[k]..self.offsets[k + 1];
        self.next[range.clone()]
            .iter()
            .map(|&n| n as usize)
            .zip(self.prob[range].iter().copied())
    }

    /// Q(s, a) from state values (the tests check sweeps against it).
    #[cfg(test)]
    fn q(&self, s: usize, a: usize, reward: f64, discount: f64, values: &[f64]) -> f64 {
        if !self.available(s, a) {
            return f64::NEG_INFINITY;
        }
        reward
            + discount
                * self
                    .transitions(s, a)
                    .map(|(n, p)| p * values[n])
                    .sum::<f64>()
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backup {
    /// V(s) = max_a Q(s, a): the optimal policy's values.
    Hard,
    /// V(s) = log Σ_a exp Q(s, a): the maximum-entropy (soft-optimal) values.
    Soft,
}

/// Value iteration with rewards R(s, a) (row-major by state) and discount in [0, 1),
/// until no value moves by more than `tolerance` or after `max_iterations` sweeps.
/// Each sweep updates all states from the previous sweep's values (in parallel), so
/// the result does not depend on the thread count.
pub fn value_iteration(
    mdp: &TabularMdp,
    reward: &[f64],
    discount: f64,
    backup: Backup,
    tolerance: f64,
    max_iterations: usize,
) -> Values {
    value_iteration_from(
        mdp,
        reward,
        discount,
        backup,
        tolerance,
        max_iterations,
        None,
    )
}

/// [`value_iteration`] starting from `initial` values (e.g. the last solution of a
/// slightly different reward, which learners solve round after round) instead of zeros.
pub fn value_iteration_from(
    mdp: &TabularMdp,
    reward: &[f64],
    discount: f64,
    backup: Backup,
    tolerance: f64,
    max_iterations: usize,
    initial: Option<&[f64]>,
) -> Values {
    assert_eq!(
        reward.len(),
        mdp.states * mdp.actions,
        "one reward per state and action"
    );
    assert!((0.0..1.0).contains(&discount), "discount must be in [0, 1)");
    let a_count = mdp.actions;
    let mut values = match initial {
        Some(v) if v.len() == mdp.states => v.to_vec(),
        _ => vec![0.0f64; mdp.states],
    };
    let mut q = vec![0.0f64; mdp.states * a_count];
    let mut next = vec![0.0f64; mdp.states];
    let mut iterations = 0;
    let mut converged = false;
    // Small MDPs sweep on one thread: splitting a sweep of a few thousand pairs costs
    // more than it saves, and callers (learners, benchmarks) parallelise above us.
    let parallel = mdp.states * a_count >= 1 << 16;
    while iterations < max_iterations {
        iterations += 1;
        let sweep = |(s, (row, out)): (usize, (&mut [f64], &mut f64))| {
            for (a, q_sa) in row.iter_mut().enumerate() {
                let k = s * a_count + a;
                let range = mdp.offsets[k]..mdp.offsets[k + 1];
                *q_sa = if range.is_empty() {
                    f64::NEG_INFINITY
                } else {
                    let expected: f64 = mdp.next[range.clone()]
                        .iter()
                        .zip(&mdp.prob[range])
                        .map(|(&n, &p)| p * values[n as usize])
                        .sum();
                    reward[k] + discount * expected
                };
            }
            *out = backup_value(row, backup);
        };
        if parallel {
            q.par_chunks_mut(a_count)
                .zip(next.par_iter_mut())
                .enumerate()
                .for_each(sweep);
        } else {
            q.chunks_mut(a_count)
                .zip(next.iter_mut())
                .enumerate()
                .for_each(sweep);
        }
        let change = next
            .iter()
            .zip(&values)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        std::mem::swap(&mut values, &mut next);
        if change <= tolerance {
            converged = true;
            break;
        }
    }
    Values {
        state: values,
        action: q,
        iterations,
        converged,
    }
}

fn backup_value(q: &[f64], backup: Backup) -> f64 {
    let best = q.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    match backup {
        Backup::Hard => best,
        Backup::Soft => best + q.iter().map(|v| (v - best).exp()).sum::<f64>().ln(),
    }
}

impl Values {
    /// The soft-optimal policy π(a | s) = exp(Q(s, a) − V(s)) (of soft values), or the
    /// greedy one (of hard values, lowest action index among ties), row-major by state.
    pub fn policy(&self, backup: Backup) -> Vec<f64> {
        let a_count = self.action.len() / self.state.len().max(1);
        let mut policy = vec![0.0; self.action.len()];
        for (s, (row, out)) in self
            .action
            .chunks(a_count)
            .zip(policy.chunks_mut(a_count))
            .enumerate()
        {
            match backup {
                Backup::Soft => {
                    for (p, q) in out.iter_mut().zip(row) {
                        *p = (q - self.state[s]).exp();
                    }
                    let total: f64 = out.iter().sum();
                    out.iter_mut().for_each(|p| *p /= total);
                }
                Backup::Hard => {
                    let best = (0..a_count).fold(0, |b, a| if row[a] > row[b] { a } else { b });
                    out[best] = 1.0;
                }
            }
        }
        policy
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_self_loop_is_a_geometric_series() {
        let mdp = TabularMdp::new(1, 1, [(0, 0, 0, 1.0)]).unwrap();
        let v = value_iteration(&mdp, &[1.0], 0.9, Backup::Hard, 1e-12, 10_000);
        assert!(v.converged);
        assert!((v.state[0] - 10.0).abs() < 1e-9);
    }

    #[test]
    fn invalid_tables_are_refused() {
        assert!(
            TabularMdp::new(2, 1, [(0, 0, 1, 0.5)])
                .unwrap_err()
                .contains("sum to 0.5")
        );
        assert!(
            TabularMdp::new(2, 1, [(0, 0, 1, 1.0)])
                .unwrap_err()
                .contains("state 1 has no action")
        );
        assert!(
            TabularMdp::new(2, 1, [(0, 0, 5, 1.0)])
                .unwrap_err()
                .contains("outside")
        );
    }

    /// V^π for a deterministic policy by solving (I − γP)V = R with Gauss-Seidel sweeps.
    fn evaluate(mdp: &TabularMdp, reward: &[f64], discount: f64, policy: &[usize]) -> Vec<f64> {
        let mut v = vec![0.0; mdp.states()];
        for _ in 0..5000 {
            for s in 0..mdp.states() {
                v[s] = mdp.q(
                    s,
                    policy[s],
                    reward[s * mdp.actions() + policy[s]],
                    discount,
                    &v,
                );
            }
        }
        v
    }

    fn small_mdp() -> impl Strategy<Value = (TabularMdp, Vec<f64>)> {
        (1usize..4, 1usize..3).prop_flat_map(|(states, actions)| {
            let pairs = states * actions;
            (
                prop::collection::vec((0..states, 0.1f64..1.0, 0..states), pairs),
                prop::collection::vec(-1.0f64..1.0, pairs),
            )
                .prop_map(move |(targets, reward)| {
                    // Each pair moves to one state with probability p, else to another.
                    let rows = targets.iter().enumerate().flat_map(|(k, &(n1, p, n2))| {
                        let (s, a) = (k / actions, k % actions);
                        [(s, a, n1, p), (s, a, n2, 1.0 - p)]
                    });
                    (TabularMdp::new(states, actions, rows).unwrap(), reward)
                })
        })
    }

    proptest! {
        #[test]
        fn hard_values_are_the_best_policy_values((mdp, reward) in small_mdp()) {
            let gamma = 0.8;
            let v = value_iteration(&mdp, &reward, gamma, Backup::Hard, 1e-12, 100_000);
            prop_assert!(v.converged);
            let (n, a) = (mdp.states(), mdp.actions());
            let mut best = vec![f64::NEG_INFINITY; n];
            for code in 0..a.pow(n as u32) {
                let policy: Vec<usize> = (0..n).map(|s| code / a.pow(s as u32) % a).collect();
                for (b, x) in best.iter_mut().zip(evaluate(&mdp, &reward, gamma, &policy)) {
                    *b = b.max(x);
                }
            }
            for (x, b) in v.state.iter().zip(&best) {
                prop_assert!((x - b).abs() < 1e-6, "{x} vs {b}");
            }
        }

        #[test]
        fn soft_values_bound_hard_ones((mdp, reward) in small_mdp()) {
            let gamma = 0.8;
            let hard = value_iteration(&mdp, &reward, gamma, Backup::Hard, 1e-12, 100_000);
            let soft = value_iteration(&mdp, &reward, gamma, Backup::Soft, 1e-12, 100_000);
            let slack = (mdp.actions() as f64).ln() / (1.0 - gamma);
            for (h, s) in hard.state.iter().zip(&soft.state) {
                prop_assert!(*s >= h - 1e-9 && *s <= h + slack + 1e-9);
            }
            let policy = soft.policy(Backup::Soft);
            for row in policy.chunks(mdp.actions()) {
                prop_assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-9);
            }
        }
    }
}
