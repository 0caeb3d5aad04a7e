//! Weak learners and regressors. In-memory only; they never touch files.

mod mlp;
mod ridge;
mod tree;

pub use mlp::{Dense, Mlp, MlpConfig};
pub use ridge::{Cholesky, RidgeAccumulator, solve_spd};
pub use tree::{Candidates, Node, RegressionTree, TreeConfig};
