//! What people look at: preview pictures and summaries.

mod preview;

pub use preview::{COLOUR_BOTH, COLOUR_DEMONSTRATION, COLOUR_PLAN, Preview, render_preview};
