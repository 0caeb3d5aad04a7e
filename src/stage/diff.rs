//! `uses: diff`: the comparison of two artifacts kept as an artifact, so that a CI
//! pipeline stores what `imitate diff` would print: `diff.json` (every figure, the
//! thresholds crossed), `diff.md` (for a pull-request comment) and, for costmaps, one
//! picture per map (old, new, difference). Crossed thresholds are recorded, not fatal:
//! the stage's work is the comparison; `imitate diff --fail-if` gates a CI job.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::{StageParams, StageReport, commit_artifact};
use crate::artifact::ArtifactBuilder;
use crate::error::{Error, Result};
use crate::io::fs::{to_json_bytes, write_bytes_atomic};
use crate::io::png::write_png;
use crate::report::compare::{compare, pictures, render_markdown, verdict};
use crate::report::diff::Threshold;

pub const KIND: &str = "diff";
/// 2: the histogram of the change per cell beside each map's pictures.
const VERSION: u32 = 2;

fn default_tolerance() -> f64 {
    0.01
}

/// Parameters of `uses: diff`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiffParams {
    /// The old artifact folder.
    pub old: PathBuf,
    /// The new artifact folder, of the same kind.
    pub new: PathBuf,
    /// Thresholds to check, e.g. "max_abs_log_cost > 0.1" (see `imitate diff --fail-if`).
    #[serde(default)]
    pub fail_if: Vec<String>,
    /// Cells whose log-cost moved more than this count as changed.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// The artifact folder to write diff.json, diff.md and the pictures into.
    pub out: PathBuf,
}

impl StageParams for DiffParams {
    const KIND: &'static str = KIND;
    const VERSION: u32 = VERSION;

    fn deps(&self) -> Vec<PathBuf> {
        vec![self.old.clone(), self.new.clone()]
    }

    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport> {
        let thresholds = self
            .fail_if
            .iter()
            .map(|t| {
                t.parse::<Threshold>()
                    .map_err(|e| Error::Usage(format!("diff: fail_if '{t}': {e}")))
            })
            .collect::<Result<Vec<_>>>()?;
        let comparison = compare(&self.old, &self.new, self.tolerance, &thresholds)?;
        let mut out = ArtifactBuilder::new(&self.out)?;
        write_bytes_atomic(&out.file("diff.json", "diff")?, &to_json_bytes(&comparison))?;
        // Pictures sit beside diff.md, which links them by name.
        if let Some(diff) = &comparison.costmaps {
            for (map, picture) in pictures(&self.old, &self.new, diff)? {
                write_png(&out.file(&format!("{map}.png"), "picture")?, &picture)?;
            }
        }
        write_bytes_atomic(
            &out.file("diff.md", "report")?,
            render_markdown(&comparison, std::path::Path::new("")).as_bytes(),
        )?;
        let f = &comparison.files;
        let summary = format!(
            "{} artifact: {} files changed, {} added, {} removed; {}",
            comparison.kind,
            f.changed.len(),
            f.added.len(),
            f.removed.len(),
            verdict(&comparison)
        );
        let metrics = serde_json::json!({
            "summary": comparison.summary,
            "failed": comparison.failed,
        });
        commit_artifact(self, extra_deps, out, "diff", metrics, summary)
    }
}
