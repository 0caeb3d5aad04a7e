//! What people look at: preview pictures, diffs between artifacts, reports.

pub mod chart;
pub mod compare;
pub mod costmap_artifact;
pub mod dagger_diff;
pub mod diff;
pub mod export;
mod legend;
pub mod picture;
mod preview;

pub use legend::with_legend;
pub use picture::paint_heat;
pub use preview::{COLOUR_BOTH, COLOUR_DEMONSTRATION, COLOUR_PLAN, Preview, render_preview};
