//! Weighted regression trees with histogram split finding: LEARCH's nonlinear weak
//! learner. Each feature's values are binned once (at most `bins` quantile edges, or
//! every edge for features split exactly, [`Candidates`]); a split is the bin edge
//! that most reduces the weighted squared error; ties go to the lower feature index
//! and the lower edge, so trees are deterministic.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TreeConfig {
    pub max_depth: usize,
    /// Smallest total weight a leaf may hold.
    pub min_leaf_weight: f64,
    pub bins: usize,
    /// L2 penalty on leaf values: a leaf predicts Σwy / (Σw + leaf_l2), so leaves
    /// holding little weight move the model little.
    #[serde(default)]
    pub leaf_l2: f64,
}

impl Default for TreeConfig {
    fn default() -> Self {
        TreeConfig {
            max_depth: 3,
            min_leaf_weight: 1.0,
            bins: 32,
            leaf_l2: 0.0,
        }
    }
}

/// The thresholds a tree may split one feature at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Candidates {
    /// None: the feature is never split on.
    Unused,
    /// At most `TreeConfig::bins − 1`: midpoints between quantiles of the feature's
    /// distinct values, enough to place a threshold on a continuous feature.
    Binned,
    /// Between every two consecutive distinct values (up to `u16::MAX` of them), for a
    /// feature whose every level may be where the cost changes: a distance in cells
    /// takes hundreds of values, and binned candidates skip most of the small ones.
    Exact,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "node", rename_all = "snake_case")]
pub enum Node {
    Leaf {
        value: f64,
    },
    /// Rows with `feature <= threshold` go left.
    Split {
        feature: usize,
        threshold: f64,
        left: Box<Node>,
        right: Box<Node>,
    },
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RegressionTree {
    pub root: Node,
}

impl RegressionTree {
    /// How many leaves the tree has.
    pub fn leaves(&self) -> usize {
        fn count(node: &Node) -> usize {
            match node {
                Node::Leaf { .. } => 1,
                Node::Split { left, right, .. } => count(left) + count(right),
            }
        }
        count(&self.root)
    }

    pub fn predict(&self, row: &[f64]) -> f64 {
        self.predict_by(|j| row[j])
    }

    /// [`RegressionTree::predict`] with feature `j`'s value `value(j)`, read only for
    /// the features the path through the tree tests.
    pub fn predict_by(&self, value: impl Fn(usize) -> f64) -> f64 {
        let mut node = &self.root;
        loop {
            match node {
                Node::Leaf { value } => return *value,
                Node::Split {
                    feature,
                    threshold,
                    left,
                    right,
                } => {
                    node = if value(*feature) <= *threshold {
                        left
                    } else {
                        right
                    }
                }
            }
        }
    }

    /// Fits `targets` with `weights` on the rows of `features` (row-major, `dims` wide).
    pub fn fit(
        features: &[f64],
        dims: usize,
        targets: &[f64],
        weights: &[f64],
        config: &TreeConfig,
    ) -> RegressionTree {
        let rows = targets.len();
        debug_assert_eq!(features.len(), rows * dims);
        let columns: Vec<f64> = (0..dims)
            .flat_map(|j| (0..rows).map(move |i| features[i * dims + j]))
            .collect();
        let candidates = vec![Candidates::Binned; dims];
        Self::fit_on(
            &columns,
            targets,
            weights,
            config,
            &candidates,
            &vec![1.0; dims],
        )
    }

    /// [`RegressionTree::fit`] on features stored column by column (`columns`: one
    /// feature's values of every row after another's, a feature for each of
    /// `candidates`), with each feature's split thresholds as `candidates` says and its
    /// splits' gains times its factor in `gain_factors` (1 for a feature split on
    /// freely).
    pub fn fit_on(
        columns: &[f64],
        targets: &[f64],
        weights: &[f64],
        config: &TreeConfig,
        candidates: &[Candidates],
        gain_factors: &[f64],
    ) -> RegressionTree {
        let rows = targets.len();
        debug_assert_eq!(columns.len(), rows * candidates.len());
        debug_assert_eq!(gain_factors.len(), candidates.len());
        let column = |j: usize| &columns[j * rows..(j + 1) * rows];
        // A feature with no split candidates is never split on. Columns are sorted and
        // binned in parallel: on the terrain learners they are most of a round's serial
        // work, between the examples' parallel passes.
        let edges: Vec<Vec<f64>> = (candidates.par_iter().enumerate())
            .map(|(j, candidates)| match candidates {
                Candidates::Unused => Vec::new(),
                Candidates::Binned => bin_edges(column(j), config.bins),
                Candidates::Exact => bin_edges(column(j), usize::from(u16::MAX)),
            })
            .collect();
        // Bin index of every value, column by column (none for a feature never split on).
        let binned: Vec<Vec<u16>> = (edges.par_iter().enumerate())
            .map(|(j, edges)| match edges.is_empty() {
                true => Vec::new(),
                false => (column(j).iter())
                    .map(|&v| edges.partition_point(|&e| e < v) as u16)
                    .collect(),
            })
            .collect();
        let all: Vec<usize> = (0..rows).filter(|&i| weights[i] > 0.0).collect();
        let fitter = Fitter {
            edges: &edges,
            binned: &binned,
            targets,
            weights,
            config,
            gain_factors,
        };
        RegressionTree {
            root: fitter.grow(&all, 0),
        }
    }
}

/// Up to `bins − 1` split candidates: midpoints between distinct quantiles.
fn bin_edges(values: &[f64], bins: usize) -> Vec<f64> {
    // Sorted as integers in f64's total order (equal keys are equal bits, so no order
    // of equals is lost), a third the time of comparing the floats.
    let mut keys: Vec<u64> = (values.iter())
        .filter(|v| v.is_finite())
        .map(|&v| total_order_key(v))
        .collect();
    keys.sort_unstable();
    let mut sorted: Vec<f64> = keys.into_iter().map(from_total_order_key).collect();
    sorted.dedup();
    if sorted.len() <= 1 {
        return Vec::new();
    }
    let candidates = (bins.max(2) - 1).min(sorted.len() - 1);
    let mut edges: Vec<f64> = (1..=candidates)
        .map(|k| {
            let i = k * (sorted.len() - 1) / (candidates + 1).max(1);
            let i = i.min(sorted.len() - 2);
            0.5 * (sorted[i] + sorted[i + 1])
        })
        .collect();
    edges.dedup();
    edges
}

/// An integer whose order is `f64::total_cmp`'s: negative values' bits flipped,
/// positive values' sign bit set.
fn total_order_key(v: f64) -> u64 {
    let bits = v.to_bits();
    match bits >> 63 {
        1 => !bits,
        _ => bits | 1 << 63,
    }
}

fn from_total_order_key(key: u64) -> f64 {
    f64::from_bits(match key >> 63 {
        1 => key & !(1 << 63),
        _ => !key,
    })
}

struct Fitter<'a> {
    edges: &'a [Vec<f64>],
    binned: &'a [Vec<u16>],
    targets: &'a [f64],
    weights: &'a [f64],
    config: &'a TreeConfig,
    gain_factors: &'a [f64],
}

impl Fitter<'_> {
    fn leaf(&self, rows: &[usize]) -> Node {
        let (sw, swy) = rows.iter().fold((0.0, 0.0), |(w, wy), &i| {
            (w + self.weights[i], wy + self.weights[i] * self.targets[i])
        });
        Node::Leaf {
            value: if sw > 0.0 {
                swy / (sw + self.config.leaf_l2)
            } else {
                0.0
            },
        }
    }

    fn grow(&self, rows: &[usize], depth: usize) -> Node {
        if depth >= self.config.max_depth || rows.len() < 2 {
            return self.leaf(rows);
        }
        let Some((feature, bin)) = self.best_split(rows) else {
            return self.leaf(rows);
        };
        let (left, right): (Vec<usize>, Vec<usize>) = rows
            .iter()
            .partition(|&&i| (self.binned[feature][i] as usize) <= bin);
        Node::Split {
            feature,
            threshold: self.edges[feature][bin],
            left: Box::new(self.grow(&left, depth + 1)),
            right: Box::new(self.grow(&right, depth + 1)),
        }
    }

    /// The (feature, edge index) with the largest weighted squared-error reduction.
    fn best_split(&self, rows: &[usize]) -> Option<(usize, usize)> {
        let (total_w, total_wy) = rows.iter().fold((0.0, 0.0), |(w, wy), &i| {
            (w + self.weights[i], wy + self.weights[i] * self.targets[i])
        });
        let l2 = self.config.leaf_l2;
        let parent = total_wy * total_wy / (total_w + l2).max(f64::MIN_POSITIVE);
        let mut best: Option<(f64, usize, usize)> = None;
        for (feature, edges) in self.edges.iter().enumerate() {
            if edges.is_empty() {
                continue;
            }
            let mut w = vec![0.0; edges.len() + 1];
            let mut wy = vec![0.0; edges.len() + 1];
            for &i in rows {
                let b = self.binned[feature][i] as usize;
                w[b] += self.weights[i];
                wy[b] += self.weights[i] * self.targets[i];
            }
            let (mut left_w, mut left_wy) = (0.0, 0.0);
            for bin in 0..edges.len() {
                left_w += w[bin];
                left_wy += wy[bin];
                let right_w = total_w - left_w;
                if left_w < self.config.min_leaf_weight || right_w < self.config.min_leaf_weight {
                    continue;
                }
                let right_wy = total_wy - left_wy;
                let gain = (left_wy * left_wy / (left_w + l2)
                    + right_wy * right_wy / (right_w + l2)
                    - parent)
                    * self.gain_factors[feature];
                if gain > 1e-12 && best.is_none_or(|(g, _, _)| gain > g + 1e-12) {
                    best = Some((gain, feature, bin));
                }
            }
        }
        best.map(|(_, feature, bin)| (feature, bin))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn learns_an_and_of_two_indicators() {
        // y = 5 where a and b, −10 where a and not b, 0 elsewhere: depth 2 is exact.
        let mut x = Vec::new();
        let mut y = Vec::new();
        for a in 0..2 {
            for b in 0..2 {
                for noise in 0..3 {
                    x.extend_from_slice(&[f64::from(a), f64::from(b), f64::from(noise)]);
                    y.push(match (a, b) {
                        (1, 1) => 5.0,
                        (1, 0) => -10.0,
                        _ => 0.0,
                    });
                }
            }
        }
        let w = vec![1.0; y.len()];
        let tree = RegressionTree::fit(
            &x,
            3,
            &y,
            &w,
            &TreeConfig {
                max_depth: 2,
                ..TreeConfig::default()
            },
        );
        for (row, target) in x.chunks(3).zip(&y) {
            assert!((tree.predict(row) - target).abs() < 1e-12, "{row:?}");
        }
        // The noise feature is never used.
        assert!(!uses(&tree.root, 2));
    }

    #[test]
    fn damped_gains_give_a_feature_only_the_splits_it_wins_by_far() {
        // y is 1 where feature 1 > 0.5; feature 0 agrees on all rows but the last.
        let (x, y): (Vec<f64>, Vec<f64>) = (0..20)
            .map(|i| {
                let f1 = f64::from(u8::from(i >= 10));
                let f0 = if i == 19 { 0.0 } else { f1 };
                ([f0, f1], f1)
            })
            .fold((Vec::new(), Vec::new()), |(mut x, mut y), (row, t)| {
                x.extend_from_slice(&row);
                y.push(t);
                (x, y)
            });
        let w = vec![1.0; y.len()];
        let config = TreeConfig {
            max_depth: 1,
            ..TreeConfig::default()
        };
        let root_feature = |gains: [f64; 2]| {
            let columns = by_column(&x, 2);
            let tree =
                RegressionTree::fit_on(&columns, &y, &w, &config, &[Candidates::Binned; 2], &gains);
            match tree.root {
                Node::Split { feature, .. } => feature,
                Node::Leaf { .. } => panic!("no split"),
            }
        };
        assert_eq!(root_feature([1.0, 1.0]), 1);
        // Damped a little, the better feature still wins; damped much, it loses.
        assert_eq!(root_feature([1.0, 0.95]), 1);
        assert_eq!(root_feature([1.0, 0.3]), 0);
    }

    /// Row-major features, `dims` wide, column by column.
    fn by_column(rows: &[f64], dims: usize) -> Vec<f64> {
        (0..dims)
            .flat_map(|j| rows.iter().skip(j).step_by(dims).copied())
            .collect()
    }

    #[test]
    fn total_order_keys_sort_as_total_cmp_and_round_trip() {
        let mut values = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            5e-324,
            -5e-324,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.1,
            -2.5e10,
        ];
        for &v in &values {
            assert_eq!(
                from_total_order_key(total_order_key(v)).to_bits(),
                v.to_bits()
            );
        }
        let mut by_keys = values.clone();
        by_keys.sort_unstable_by_key(|&v| total_order_key(v));
        values.sort_by(f64::total_cmp);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&by_keys), bits(&values));
    }

    fn uses(node: &Node, feature: usize) -> bool {
        match node {
            Node::Leaf { .. } => false,
            Node::Split {
                feature: f,
                left,
                right,
                ..
            } => *f == feature || uses(left, feature) || uses(right, feature),
        }
    }

    #[test]
    fn features_not_usable_are_never_split_on() {
        // y follows feature 0 exactly and feature 1 roughly; without feature 0 the
        // tree falls back on feature 1.
        let x: Vec<f64> = (0..40)
            .flat_map(|i| [f64::from(i), f64::from(i / 4)])
            .collect();
        let y: Vec<f64> = (0..40).map(|i| if i < 18 { 0.0 } else { 1.0 }).collect();
        let w = vec![1.0; y.len()];
        let config = TreeConfig {
            max_depth: 1,
            ..TreeConfig::default()
        };
        let free = RegressionTree::fit(&x, 2, &y, &w, &config);
        assert!(uses(&free.root, 0));
        let held = RegressionTree::fit_on(
            &by_column(&x, 2),
            &y,
            &w,
            &config,
            &[Candidates::Unused, Candidates::Binned],
            &[1.0; 2],
        );
        assert!(!uses(&held.root, 0) && uses(&held.root, 1));
    }

    #[test]
    fn exact_candidates_find_a_step_between_values_that_bins_merge() {
        // y steps between x = 3 and x = 4 of 0..1000: 32 bins put no edge there.
        let x: Vec<f64> = (0..1000).map(f64::from).collect();
        let y: Vec<f64> = (0..1000).map(|i| f64::from(u8::from(i <= 3))).collect();
        let w = vec![1.0; y.len()];
        let config = TreeConfig {
            max_depth: 1,
            ..TreeConfig::default()
        };
        let threshold =
            |candidates| match RegressionTree::fit_on(&x, &y, &w, &config, &[candidates], &[1.0])
                .root
            {
                Node::Split { threshold, .. } => threshold,
                Node::Leaf { .. } => panic!("no split"),
            };
        assert_eq!(threshold(Candidates::Exact), 3.5);
        assert!(threshold(Candidates::Binned) > 4.0);
    }

    #[test]
    fn weights_decide_the_leaf_values_and_zero_weight_rows_are_ignored() {
        let x = [0.0, 1.0, 2.0];
        let y = [1.0, 3.0, 100.0];
        let w = [1.0, 3.0, 0.0];
        let tree = RegressionTree::fit(
            &x,
            1,
            &y,
            &w,
            &TreeConfig {
                max_depth: 0,
                ..TreeConfig::default()
            },
        );
        assert!((tree.predict(&[5.0]) - 2.5).abs() < 1e-12);
    }

    #[test]
    fn the_leaf_penalty_shrinks_light_leaves_towards_zero() {
        let x = [0.0, 1.0, 2.0, 3.0];
        let y = [1.0, 1.0, -1.0, -1.0];
        let heavy = [100.0, 100.0, 100.0, 100.0];
        let light = [1.0, 1.0, 1.0, 1.0];
        let config = TreeConfig {
            max_depth: 1,
            leaf_l2: 2.0,
            ..TreeConfig::default()
        };
        let heavy = RegressionTree::fit(&x, 1, &y, &heavy, &config);
        let light = RegressionTree::fit(&x, 1, &y, &light, &config);
        // Σwy / (Σw + λ): 200 / 202 with heavy leaves, 2 / 4 with light ones.
        assert!((heavy.predict(&[0.0]) - 200.0 / 202.0).abs() < 1e-12);
        assert!((light.predict(&[0.0]) - 0.5).abs() < 1e-12);
        assert!((light.predict(&[3.0]) + 0.5).abs() < 1e-12);
    }
}
