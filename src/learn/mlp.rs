//! A small multilayer perceptron for policies whose action is not linear in the
//! observation and too smooth for shallow trees: ReLU hidden layers, a linear output
//! layer of every action number at once, squared error, Adam on minibatches.
//!
//! Deterministic by construction: He-initialised weights and the minibatch order come
//! from one seeded ChaCha8 stream, and the arithmetic runs in one thread in a fixed
//! order, so the same rows, configuration and seed give the same network on any machine
//! with IEEE doubles and at any thread count.
//!
//! Inputs and targets are expected standardised (the policy keeps the statistics).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq)]
pub struct MlpConfig {
    /// Widths of the hidden layers.
    pub hidden: Vec<usize>,
    pub epochs: usize,
    pub batch: usize,
    pub learning_rate: f64,
    /// L2 penalty on the weights (not the biases), added to the gradient.
    pub weight_decay: f64,
    pub seed: u64,
}

impl Default for MlpConfig {
    fn default() -> Self {
        MlpConfig {
            hidden: vec![64, 64],
            epochs: 200,
            batch: 32,
            learning_rate: 1e-3,
            weight_decay: 1e-5,
            seed: 0,
        }
    }
}

/// A fully connected layer: `weights` row-major, one row of `inputs` per output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Dense {
    pub inputs: usize,
    pub outputs: usize,
    pub weights: Vec<f64>,
    pub bias: Vec<f64>,
}

impl Dense {
    fn apply(&self, x: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.extend(
            self.weights
                .chunks_exact(self.inputs)
                .zip(&self.bias)
                .map(|(row, b)| b + row.iter().zip(x).map(|(w, v)| w * v).sum::<f64>()),
        );
    }
}

/// ReLU after every layer but the last.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Mlp {
    pub layers: Vec<Dense>,
}

/// Adam's running moments for one parameter vector.
struct Moments {
    first: Vec<f64>,
    second: Vec<f64>,
}

impl Moments {
    fn new(n: usize) -> Self {
        Moments {
            first: vec![0.0; n],
            second: vec![0.0; n],
        }
    }

    /// One Adam step of `params` along `gradient` (step count `t` from 1).
    fn step(&mut self, params: &mut [f64], gradient: &[f64], rate: f64, t: i32) {
        const B1: f64 = 0.9;
        const B2: f64 = 0.999;
        const EPSILON: f64 = 1e-8;
        let (c1, c2) = (1.0 - B1.powi(t), 1.0 - B2.powi(t));
        for (((p, g), m), v) in params
            .iter_mut()
            .zip(gradient)
            .zip(&mut self.first)
            .zip(&mut self.second)
        {
            *m = B1 * *m + (1.0 - B1) * g;
            *v = B2 * *v + (1.0 - B2) * g * g;
            *p -= rate * (*m / c1) / ((*v / c2).sqrt() + EPSILON);
        }
    }
}

impl Mlp {
    /// The network's outputs for `x`.
    pub fn forward(&self, x: &[f64]) -> Vec<f64> {
        let mut current = x.to_vec();
        let mut next = Vec::new();
        for (k, layer) in self.layers.iter().enumerate() {
            layer.apply(&current, &mut next);
            if k + 1 < self.layers.len() {
                next.iter_mut().for_each(|v| *v = v.max(0.0));
            }
            std::mem::swap(&mut current, &mut next);
        }
        current
    }

    /// Fits rows (`dims` numbers each) to targets (`outputs` numbers each).
    pub fn fit(
        rows: &[f64],
        dims: usize,
        targets: &[f64],
        outputs: usize,
        config: &MlpConfig,
    ) -> Mlp {
        let n = targets.len() / outputs.max(1);
        let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
        let widths: Vec<usize> = std::iter::once(dims)
            .chain(config.hidden.iter().copied())
            .chain(std::iter::once(outputs))
            .collect();
        let mut net = Mlp {
            layers: widths
                .windows(2)
                .map(|w| {
                    // He initialisation: uniform with the variance 2 / inputs.
                    let bound = (6.0 / w[0].max(1) as f64).sqrt();
                    Dense {
                        inputs: w[0],
                        outputs: w[1],
                        weights: (0..w[0] * w[1])
                            .map(|_| (rng.random::<f64>() * 2.0 - 1.0) * bound)
                            .collect(),
                        bias: vec![0.0; w[1]],
                    }
                })
                .collect(),
        };
        if n == 0 {
            return net;
        }
        let mut moments: Vec<(Moments, Moments)> = (net.layers.iter())
            .map(|l| (Moments::new(l.weights.len()), Moments::new(l.bias.len())))
            .collect();
        let mut order: Vec<usize> = (0..n).collect();
        let batch = config.batch.max(1);
        let mut t = 0;
        // Per layer: its input activations and, backwards, the error at its output.
        let mut activations: Vec<Vec<f64>> = vec![Vec::new(); net.layers.len() + 1];
        let mut grad_w: Vec<Vec<f64>> = net
            .layers
            .iter()
            .map(|l| vec![0.0; l.weights.len()])
            .collect();
        let mut grad_b: Vec<Vec<f64>> =
            net.layers.iter().map(|l| vec![0.0; l.bias.len()]).collect();
        for _ in 0..config.epochs {
            // Fisher–Yates with the one stream: the order is part of the seed.
            for i in (1..n).rev() {
                order.swap(i, rng.random_range(0..=i));
            }
            for chunk in order.chunks(batch) {
                grad_w
                    .iter_mut()
                    .for_each(|g| g.iter_mut().for_each(|v| *v = 0.0));
                grad_b
                    .iter_mut()
                    .for_each(|g| g.iter_mut().for_each(|v| *v = 0.0));
                for &row in chunk {
                    activations[0].clear();
                    activations[0].extend_from_slice(&rows[row * dims..(row + 1) * dims]);
                    for (k, layer) in net.layers.iter().enumerate() {
                        let (done, rest) = activations.split_at_mut(k + 1);
                        layer.apply(&done[k], &mut rest[0]);
                        if k + 1 < net.layers.len() {
                            rest[0].iter_mut().for_each(|v| *v = v.max(0.0));
                        }
                    }
                    // d(½‖ŷ − y‖²)/dŷ, averaged over the batch.
                    let scale = 1.0 / chunk.len() as f64;
                    let mut error: Vec<f64> = (activations[net.layers.len()].iter())
                        .zip(&targets[row * outputs..(row + 1) * outputs])
                        .map(|(p, y)| (p - y) * scale)
                        .collect();
                    for k in (0..net.layers.len()).rev() {
                        let layer = &net.layers[k];
                        let input = &activations[k];
                        for (o, &e) in error.iter().enumerate() {
                            grad_b[k][o] += e;
                            let row = &mut grad_w[k][o * layer.inputs..(o + 1) * layer.inputs];
                            for (g, &x) in row.iter_mut().zip(input) {
                                *g += e * x;
                            }
                        }
                        if k > 0 {
                            // Back through the weights, then the ReLU of the layer below.
                            let mut below = vec![0.0; layer.inputs];
                            for (o, &e) in error.iter().enumerate() {
                                let weights =
                                    &layer.weights[o * layer.inputs..(o + 1) * layer.inputs];
                                for (b, w) in below.iter_mut().zip(weights) {
                                    *b += e * w;
                                }
                            }
                            for (b, &a) in below.iter_mut().zip(input) {
                                if a <= 0.0 {
                                    *b = 0.0;
                                }
                            }
                            error = below;
                        }
                    }
                }
                t += 1;
                for (k, layer) in net.layers.iter_mut().enumerate() {
                    for (g, w) in grad_w[k].iter_mut().zip(&layer.weights) {
                        *g += config.weight_decay * w;
                    }
                    let (mw, mb) = &mut moments[k];
                    mw.step(&mut layer.weights, &grad_w[k], config.learning_rate, t);
                    mb.step(&mut layer.bias, &grad_b[k], config.learning_rate, t);
                }
            }
        }
        net
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_what_a_line_cannot_and_the_same_seed_gives_the_same_network() {
        // y = (x0 x1, |x0|): neither output is linear in x.
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let n = 400;
        let rows: Vec<f64> = (0..2 * n)
            .map(|_| rng.random::<f64>() * 2.0 - 1.0)
            .collect();
        let targets: Vec<f64> = rows
            .chunks(2)
            .flat_map(|x| [x[0] * x[1] * 2.0, x[0].abs() * 2.0 - 1.0])
            .collect();
        let config = MlpConfig {
            hidden: vec![32, 32],
            epochs: 150,
            ..MlpConfig::default()
        };
        let net = Mlp::fit(&rows, 2, &targets, 2, &config);
        let rmse = |net: &Mlp| {
            let total: f64 = rows
                .chunks(2)
                .zip(targets.chunks(2))
                .map(|(x, y)| {
                    let p = net.forward(x);
                    (p[0] - y[0]).powi(2) + (p[1] - y[1]).powi(2)
                })
                .sum();
            (total / (2 * n) as f64).sqrt()
        };
        assert!(rmse(&net) < 0.1, "{}", rmse(&net));
        assert_eq!(Mlp::fit(&rows, 2, &targets, 2, &config), net);
        let other = Mlp::fit(&rows, 2, &targets, 2, &MlpConfig { seed: 1, ..config });
        assert_ne!(other, net);
    }
}
