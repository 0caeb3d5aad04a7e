//! Weak learners and regressors. In-memory only; they never touch files.

mod ridge;

pub use ridge::{RidgeAccumulator, solve_spd};
