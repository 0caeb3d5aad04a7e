//! `imitate` learns from robot demonstrations: costmaps for planners by inverse optimal
//! control (LEARCH, MMP, MaxEnt) and reactive policies by DAgger. See DESIGN.md in the
//! project's shared folder and README.md for the architecture.

// Defined before the modules so that every one of them can use them.
/// `print!` for command output: when the reader goes away (`imitate ... | head`), the
/// command ends quietly instead of panicking on the closed pipe.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli::write_stdout(format_args!($($arg)*))
    };
}

/// `println!` for command output, as `out!`.
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::cli::write_stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

pub mod artifact;
pub mod bench;
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
