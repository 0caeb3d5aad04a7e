//! Built-in worlds with known answers, for tests, examples and benchmarks.

pub mod gridnav;
mod terrain;
pub mod track;

pub use terrain::{SyntheticWorld, TrueCost, WorldConfig, generate_world};
pub use track::{Track, TrackConfig, TrackSim};
