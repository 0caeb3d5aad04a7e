//! Weighted ridge regression through its normal equations.
//!
//! The accumulator holds the sufficient statistics XᵀWX and XᵀWy, so data can be added
//! example by example (in parallel) and merged in a fixed order: the fit then does not
//! depend on the thread count.

/// Sufficient statistics of a weighted least-squares problem in `dim` unknowns.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RidgeAccumulator {
    dim: usize,
    /// Upper triangle is enough, but the full matrix keeps merging and solving simple.
    xtwx: Vec<f64>,
    xtwy: Vec<f64>,
    total_weight: f64,
}

impl RidgeAccumulator {
    pub fn new(dim: usize) -> Self {
        RidgeAccumulator {
            dim,
            xtwx: vec![0.0; dim * dim],
            xtwy: vec![0.0; dim],
            total_weight: 0.0,
        }
    }

    pub fn dim(&self) -> usize {
        self.dim
    }

    pub fn total_weight(&self) -> f64 {
        self.total_weight
    }

    /// XᵀWX (row-major, `dim`²) and XᵀWy.
    pub fn moments(&self) -> (&[f64], &[f64]) {
        (&self.xtwx, &self.xtwy)
    }

    /// Adds the sample (x, y) with weight w.
    pub fn add(&mut self, x: &[f64], y: f64, w: f64) {
        debug_assert_eq!(x.len(), self.dim);
        for i in 0..self.dim {
            let wxi = w * x[i];
            self.xtwy[i] += wxi * y;
            let row = &mut self.xtwx[i * self.dim..(i + 1) * self.dim];
            for (cell, &xj) in row.iter_mut().zip(x) {
                *cell += wxi * xj;
            }
        }
        self.total_weight += w;
    }

    pub fn merge(&mut self, other: &RidgeAccumulator) {
        debug_assert_eq!(other.dim, self.dim);
        for (a, b) in self.xtwx.iter_mut().zip(&other.xtwx) {
            *a += b;
        }
        for (a, b) in self.xtwy.iter_mut().zip(&other.xtwy) {
            *a += b;
        }
        self.total_weight += other.total_weight;
    }

    /// Minimises Σ w (y − x·β)² / Σ w + λ‖β‖². Returns zeros when no data was added.
    pub fn solve(&self, lambda: f64) -> Vec<f64> {
        if self.total_weight <= 0.0 {
            return vec![0.0; self.dim];
        }
        let scale = 1.0 / self.total_weight;
        let mut a: Vec<f64> = self.xtwx.iter().map(|v| v * scale).collect();
        for i in 0..self.dim {
            a[i * self.dim + i] += lambda;
        }
        let b: Vec<f64> = self.xtwy.iter().map(|v| v * scale).collect();
        solve_spd(&a, &b, self.dim).unwrap_or_else(|| vec![0.0; self.dim])
    }
}

/// The Cholesky factor L (A = L Lᵀ) of a symmetric positive definite matrix, to solve
/// A x = b for as many right-hand sides as needed with one factorisation.
pub struct Cholesky {
    dim: usize,
    l: Vec<f64>,
}

impl Cholesky {
    /// Factors the `dim`×`dim` row-major `a`; `None` when it is not positive definite.
    pub fn factor(a: &[f64], dim: usize) -> Option<Self> {
        let mut l = vec![0.0; dim * dim];
        for i in 0..dim {
            for j in 0..=i {
                let mut sum = a[i * dim + j];
                for k in 0..j {
                    sum -= l[i * dim + k] * l[j * dim + k];
                }
                if i == j {
                    if sum.is_nan() || sum <= 0.0 {
                        return None;
                    }
                    l[i * dim + i] = sum.sqrt();
                } else {
                    l[i * dim + j] = sum / l[j * dim + j];
                }
            }
        }
        Some(Cholesky { dim, l })
    }

    /// x with A x = b: forward substitution L z = b, then back substitution Lᵀ x = z.
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        let (dim, l) = (self.dim, &self.l);
        let mut z = vec![0.0; dim];
        for i in 0..dim {
            let s: f64 = (0..i).map(|k| l[i * dim + k] * z[k]).sum();
            z[i] = (b[i] - s) / l[i * dim + i];
        }
        let mut x = vec![0.0; dim];
        for i in (0..dim).rev() {
            let s: f64 = (i + 1..dim).map(|k| l[k * dim + i] * x[k]).sum();
            x[i] = (z[i] - s) / l[i * dim + i];
        }
        x
    }
}

/// Solves A x = b for a symmetric positive definite `dim`×`dim` matrix A (row-major) by
/// Cholesky factorisation. `None` when A is not positive definite.
pub fn solve_spd(a: &[f64], b: &[f64], dim: usize) -> Option<Vec<f64>> {
    Cholesky::factor(a, dim).map(|c| c.solve(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_an_exact_linear_function() {
        let mut acc = RidgeAccumulator::new(3);
        for i in 0..50 {
            let x = [1.0, f64::from(i % 7), f64::from(i % 5) - 2.0];
            let y = 0.5 + 2.0 * x[1] - 3.0 * x[2];
            acc.add(&x, y, 1.0 + f64::from(i % 3));
        }
        let beta = acc.solve(0.0);
        for (got, want) in beta.iter().zip([0.5, 2.0, -3.0]) {
            assert!((got - want).abs() < 1e-9, "{beta:?}");
        }
    }

    #[test]
    fn ridge_shrinks_and_merging_equals_adding() {
        let samples: Vec<([f64; 2], f64, f64)> = (0..20)
            .map(|i| {
                (
                    [1.0, f64::from(i)],
                    f64::from(i) * 0.3 + 1.0,
                    1.0 + f64::from(i % 2),
                )
            })
            .collect();
        let mut all = RidgeAccumulator::new(2);
        let (mut left, mut right) = (RidgeAccumulator::new(2), RidgeAccumulator::new(2));
        for (k, (x, y, w)) in samples.iter().enumerate() {
            all.add(x, *y, *w);
            if k < 10 {
                left.add(x, *y, *w)
            } else {
                right.add(x, *y, *w)
            }
        }
        left.merge(&right);
        assert_eq!(left.solve(0.1), all.solve(0.1));
        let free = all.solve(0.0);
        let shrunk = all.solve(10.0);
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>();
        assert!(norm(&shrunk) < norm(&free));
    }

    #[test]
    fn empty_or_singular_problems_give_zeros() {
        assert_eq!(RidgeAccumulator::new(2).solve(1.0), vec![0.0, 0.0]);
        assert_eq!(solve_spd(&[0.0, 0.0, 0.0, 0.0], &[1.0, 1.0], 2), None);
    }
}
