//! `imitate diff A B`: what changed between two artifacts, as text, JSON or markdown
//! (with pictures, ready for a pull-request comment); `--fail-if` thresholds set the
//! exit code for CI.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::io::png::write_png;
use crate::report::compare::{compare, pictures, render_markdown, render_text};
use crate::report::diff::Threshold;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    Text,
    Json,
    Markdown,
}

#[derive(Debug, clap::Args)]
pub struct DiffArgs {
    /// The old artifact: a folder, or a stored version's digest (prefix) in this
    /// workspace's output cache (`imitate log` lists them).
    pub old: String,
    /// The new artifact, the same way.
    pub new: String,
    #[arg(long, value_enum, default_value = "text")]
    pub format: Format,
    /// Fail (exit code 1) when the summary crosses this threshold, e.g.
    /// 'max_abs_log_cost > 0.1' or 'changed_paths > 0' (repeat for several).
    #[arg(long = "fail-if", value_name = "NAME OP NUMBER", value_parser = parse_threshold)]
    pub fail_if: Vec<Threshold>,
    /// Cells whose log-cost moved more than this count as changed.
    #[arg(long, default_value_t = 0.01)]
    pub tolerance: f64,
    /// With --format markdown: write the pictures (old, new, difference per map) here;
    /// the markdown links them by this path.
    #[arg(long, value_name = "DIR", default_value = "imitate-diff")]
    pub images: PathBuf,
}

fn parse_threshold(text: &str) -> std::result::Result<Threshold, String> {
    text.parse()
}

/// A folder, or the one stored version whose digest starts with `reference`.
fn resolve(reference: &str) -> Result<PathBuf> {
    let path = PathBuf::from(reference);
    if path.is_dir() {
        return Ok(path);
    }
    let prefix = reference.strip_prefix("blake3:").unwrap_or(reference);
    let outputs = Path::new(".imitate/cache/outputs");
    let hex = prefix.len() >= 4 && prefix.bytes().all(|b| b.is_ascii_hexdigit());
    if !hex {
        return Err(Error::input(&path, "no such artifact folder"));
    }
    let mut found: Vec<PathBuf> = std::fs::read_dir(outputs)
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with(prefix))
        .map(|e| e.path())
        .collect();
    found.sort();
    match found.len() {
        1 => Ok(found.remove(0)),
        0 => Err(Error::Usage(format!(
            "'{reference}' is neither a folder nor a stored version in {} (imitate log lists them)",
            outputs.display()
        ))),
        n => Err(Error::Usage(format!(
            "'{reference}' matches {n} stored versions; give more digits"
        ))),
    }
}

pub fn run(args: DiffArgs) -> Result<()> {
    let (old_dir, new_dir) = (resolve(&args.old)?, resolve(&args.new)?);
    let comparison = compare(&old_dir, &new_dir, args.tolerance, &args.fail_if)?;
    let text = match args.format {
        Format::Json => {
            serde_json::to_string_pretty(&comparison).expect("reports serialise") + "\n"
        }
        Format::Text => render_text(&comparison),
        Format::Markdown => {
            if let Some(diff) = &comparison.costmaps {
                for (map, picture) in pictures(&old_dir, &new_dir, diff)? {
                    write_png(&args.images.join(format!("{map}.png")), &picture)?;
                }
            }
            render_markdown(&comparison, &args.images)
        }
    };
    out!("{text}");
    if comparison.failed.is_empty() {
        Ok(())
    } else {
        Err(Error::Stale(format!(
            "diff threshold crossed: {}",
            comparison.failed.join("; ")
        )))
    }
}
