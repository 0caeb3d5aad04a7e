//! Built-in worlds with known answers, for tests, examples and benchmarks.

mod terrain;

pub use terrain::{SyntheticWorld, TrueCost, WorldConfig, generate_world};
