//! `imitate` learns from robot demonstrations: costmaps for planners by inverse optimal
//! control (LEARCH, MMP, MaxEnt) and reactive policies by DAgger. See DESIGN.md in the
//! project's shared folder and README.md for the architecture.

pub mod artifact;
pub mod cli;
pub mod dagger;
pub mod error;
pub mod features;
pub mod grid;
pub mod io;
pub mod ioc;
pub mod learn;
pub mod pipeline;
pub mod plan;
pub mod report;
pub mod sim;
pub mod stage;

pub use error::{Error, Result};
