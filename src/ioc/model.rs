//! The learned cost function: c(f) = exp(s(f)), s a sum of weighted linear weak learners.

use serde::{Deserialize, Serialize};

use crate::grid::{FeatureStack, Grid};

/// Log-costs are clamped to this range so that exp() stays a finite, positive f32.
const LOG_COST_LIMIT: f64 = 40.0;

/// One boosting round's regressor h_t on standardised features, and its step α_t.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WeakLearner {
    pub kind: String,
    pub step: f64,
    pub weights: Vec<f64>,
}

/// s(f) = Σ_t α_t h_t(f / scale), kept both as the list of learners (what LEARCH
/// produced) and collapsed into one function of the raw features (what is evaluated).
///
/// Features are scaled but not centred: a round whose data hold a feature at zero then
/// leaves that feature's weight alone, where centring would make it collinear with the
/// bias and let the ridge penalty move it at random.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogLinearCost {
    pub feature_names: Vec<String>,
    pub scale: Vec<f64>,
    pub learners: Vec<WeakLearner>,
    /// s(f) = Σ_j raw_weights[j] · f_j
    pub raw_weights: Vec<f64>,
}

impl LogLinearCost {
    /// The zero log-cost (cost 1 everywhere) over scaled features.
    pub fn zero(feature_names: Vec<String>, scale: Vec<f64>) -> Self {
        let dim = feature_names.len();
        LogLinearCost {
            feature_names,
            scale,
            learners: Vec::new(),
            raw_weights: vec![0.0; dim],
        }
    }

    /// Appends α h (h's weights on scaled features) and refolds the raw form.
    pub fn push(&mut self, learner: WeakLearner) {
        for j in 0..self.raw_weights.len() {
            self.raw_weights[j] += learner.step * learner.weights[j] / self.scale[j];
        }
        self.learners.push(learner);
    }

    /// Scales a raw feature vector the way the weak learners see it.
    pub fn scaled(&self, raw: &[f32], out: &mut [f64]) {
        for j in 0..raw.len() {
            out[j] = f64::from(raw[j]) / self.scale[j];
        }
    }

    pub fn log_cost(&self, raw: &[f32]) -> f64 {
        let s: f64 = raw
            .iter()
            .zip(&self.raw_weights)
            .map(|(&f, &w)| f64::from(f) * w)
            .sum::<f64>();
        s.clamp(-LOG_COST_LIMIT, LOG_COST_LIMIT)
    }

    /// Evaluates exp(s) on every cell of a feature stack, plane by plane (the same sum,
    /// in the same order, as `log_cost`).
    pub fn costmap(&self, stack: &FeatureStack) -> Grid<f32> {
        let mut log_cost = vec![0.0f64; stack.geo.cell_count()];
        for (&w, plane) in self.raw_weights.iter().zip(stack.planes()) {
            for (s, &f) in log_cost.iter_mut().zip(plane) {
                *s += f64::from(f) * w;
            }
        }
        let data = log_cost
            .iter()
            .map(|s| s.clamp(-LOG_COST_LIMIT, LOG_COST_LIMIT).exp() as f32)
            .collect();
        Grid::from_vec(stack.geo.clone(), data)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn collapsed_form_equals_sum_of_learners() {
        let mut model = LogLinearCost::zero(vec!["a".into(), "b".into()], vec![2.0, 0.5]);
        model.push(WeakLearner {
            kind: "ridge".into(),
            step: 0.5,
            weights: vec![1.0, -1.0],
        });
        model.push(WeakLearner {
            kind: "ridge".into(),
            step: 0.25,
            weights: vec![0.2, 3.0],
        });
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
