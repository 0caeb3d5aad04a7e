//! What changed between two artifacts of one kind: files, costmaps (log-cost per map,
//! plans on reference pairs, metrics), policies and DAgger datasets, with thresholds for
//! CI, rendered as text, JSON or markdown with pictures. `imitate diff` prints it; the
//! `diff` stage keeps it as an artifact.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::dagger::load_policy_artifact;
use crate::error::{Error, Result};
use crate::io::png::Rgb;
use crate::report::chart::{Chart, Legend, Series};
use crate::report::costmap_artifact::{CostmapArtifact, read_any_manifest};
use crate::report::dagger_diff::{
    DatasetDiff, PolicyDiff, dagger_summary, dataset_diff, is_track_policy, policy_diff,
};
use crate::report::diff::{
    CostmapDiff, FileChanges, Threshold, change_histogram, costmap_diff, file_changes, summary,
};
use crate::report::picture::{log_cost_range, paint_costs, paint_difference, side_by_side};

/// The comparison of two artifacts.
#[derive(Debug, Serialize)]
pub struct Comparison {
    pub schema: &'static str,
    pub old: String,
    pub new: String,
    pub kind: String,
    pub files: FileChanges,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub costmaps: Option<CostmapDiff>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub policies: Option<PolicyDiff>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub datasets: Option<DatasetDiff>,
    /// The numbers thresholds are checked against.
    pub summary: BTreeMap<String, f64>,
    /// The thresholds crossed, as sentences.
    pub failed: Vec<String>,
}

/// Compares the artifact folders `old_dir` and `new_dir` (of the same kind and schema
/// major version); cells whose log-cost moved more than `tolerance` count as changed.
pub fn compare(
    old_dir: &Path,
    new_dir: &Path,
    tolerance: f64,
    thresholds: &[Threshold],
) -> Result<Comparison> {
    let (old_manifest, new_manifest) = (read_any_manifest(old_dir)?, read_any_manifest(new_dir)?);
    if old_manifest.kind != new_manifest.kind {
        return Err(Error::Usage(format!(
            "cannot diff a '{}' artifact ({}) with a '{}' artifact ({})",
            old_manifest.kind,
            old_dir.display(),
            new_manifest.kind,
            new_dir.display()
        )));
    }
    let major = |v: &str| v.split('.').next().unwrap_or_default().to_string();
    if (&old_manifest.schema, major(&old_manifest.schema_version))
        != (&new_manifest.schema, major(&new_manifest.schema_version))
    {
        return Err(Error::Usage(format!(
            "incompatible schemas: {} {} and {} {}",
            old_manifest.schema,
            old_manifest.schema_version,
            new_manifest.schema,
            new_manifest.schema_version
        )));
    }
    let files = file_changes(&old_manifest, &new_manifest);
    let costmaps = if old_manifest.kind == "costmap" {
        let (old, new) = (
            CostmapArtifact::load(old_dir)?,
            CostmapArtifact::load(new_dir)?,
        );
        Some(costmap_diff(&old, &new, tolerance))
    } else {
        None
    };
    let policies =
        if old_manifest.kind == "policy" && is_track_policy(old_dir) && is_track_policy(new_dir) {
            Some(policy_diff(
                &load_policy_artifact(old_dir)?.0,
                &load_policy_artifact(new_dir)?.0,
                tolerance,
            ))
        } else {
            None
        };
    let datasets = if old_manifest.kind == "dagger-dataset" {
        Some(dataset_diff(old_dir, new_dir)?)
    } else {
        None
    };
    let mut numbers = summary(&files, costmaps.as_ref());
    dagger_summary(policies.as_ref(), datasets.as_ref(), &mut numbers);
    let mut failed = Vec::new();
    for threshold in thresholds {
        if let Some(reason) = threshold.crossed(&numbers).map_err(Error::Usage)? {
            failed.push(reason);
        }
    }
    Ok(Comparison {
        schema: "imitate.diff/1",
        old: old_dir.display().to_string(),
        new: new_dir.display().to_string(),
        kind: old_manifest.kind,
        files,
        costmaps,
        policies,
        datasets,
        summary: numbers,
        failed,
    })
}

/// The pictures of a costmap comparison, one per map: old, new, their difference and
/// the histogram of the change per cell side by side, named after the map.
pub fn pictures(old_dir: &Path, new_dir: &Path, diff: &CostmapDiff) -> Result<Vec<(String, Rgb)>> {
    let (old, new) = (
        CostmapArtifact::load(old_dir)?,
        CostmapArtifact::load(new_dir)?,
    );
    diff.maps
        .iter()
        .map(|m| {
            let missing = || Error::Failed(format!("map '{}' vanished while comparing", m.map));
            let a = old.costmap(&m.map).ok_or_else(missing)?;
            let b = new.costmap(&m.map).ok_or_else(missing)?;
            let scale = (256 / a.geo.width.max(a.geo.height)).clamp(1, 8);
            let range = log_cost_range(&[a, b]);
            let histogram = Chart {
                title: format!("Cost change per cell, {}", m.map),
                x_label: "log-cost change (new − old)".into(),
                y_label: "share of cells".into(),
                series: vec![Series {
                    name: "cells per bin".into(),
                    points: change_histogram(a, b, 41),
                    colour: [40, 80, 200],
                }],
                legend: Legend::UpperRight,
            }
            .draw(360, 256.max(a.geo.height * scale))
            .map_err(Error::Failed)?;
            let picture = side_by_side(
                &[
                    &paint_costs(a, range, scale),
                    &paint_costs(b, range, scale),
                    &paint_difference(a, b, None, scale),
                    &histogram,
                ],
                8,
            );
            Ok((m.map.clone(), picture))
        })
        .collect()
}

/// One line: whether every threshold passed, or which were crossed.
pub fn verdict(report: &Comparison) -> String {
    if report.failed.is_empty() {
        "thresholds: all passed".to_string()
    } else {
        format!("thresholds crossed: {}", report.failed.join("; "))
    }
}

/// For people on a terminal.
pub fn render_text(report: &Comparison) -> String {
    let mut t = String::new();
    let f = &report.files;
    let _ = writeln!(
        t,
        "{} artifact: {} -> {}\nfiles: {} changed, {} added, {} removed, {} unchanged",
        report.kind,
        report.old,
        report.new,
        f.changed.len(),
        f.added.len(),
        f.removed.len(),
        f.unchanged
    );
    if let Some(d) = &report.costmaps {
        for m in &d.maps {
            let _ = writeln!(
                t,
                "map {}: |Δ log-cost| mean {:.4} max {:.4}, {:.1}% of cells changed, rank correlation {:.4}",
                m.map,
                m.mean_abs_log_cost,
                m.max_abs_log_cost,
                100.0 * m.changed_share,
                m.rank_correlation
            );
        }
        for (what, maps) in [
            ("added", &d.maps_added),
            ("removed", &d.maps_removed),
            ("with another raster", &d.maps_regridded),
        ] {
            if !maps.is_empty() {
                let _ = writeln!(t, "maps {what}: {}", maps.join(", "));
            }
        }
        let changed: Vec<_> = d.paths.iter().filter(|p| p.changed).collect();
        let _ = writeln!(
            t,
            "plans on {} reference pairs: {} changed",
            d.paths.len(),
            changed.len()
        );
        for p in changed {
            let _ = writeln!(
                t,
                "  {} ({}): Hausdorff {:.1} cells, cost ratio {:.4}",
                p.example, p.map, p.hausdorff_cells, p.cost_ratio
            );
        }
        for m in &d.metrics {
            if let (Some(a), Some(b)) = (m.old, m.new) {
                let _ = writeln!(t, "{}: {a:.4} -> {b:.4} ({:+.4})", m.metric, b - a);
            }
        }
    }
    let _ = write!(t, "{}", dagger_lines(report, ""));
    let _ = writeln!(t, "{}", verdict(report));
    t
}

/// The policy and dataset comparisons, one line each, after `bullet`.
fn dagger_lines(report: &Comparison, bullet: &str) -> String {
    let mut t = String::new();
    if let Some(p) = &report.policies {
        let _ = writeln!(
            t,
            "{bullet}actions on {} states of a teacher's lap: |Δ| mean {:.4} max {:.4}, {:.1}% differ",
            p.states,
            p.mean_abs_action,
            p.max_abs_action,
            100.0 * p.disagreement_share
        );
        if let (Some(a), Some(b)) = (p.old_falls_per_lap, p.new_falls_per_lap) {
            let _ = writeln!(t, "{bullet}falls per lap: {a:.2} -> {b:.2}");
        }
    }
    if let Some(d) = &report.datasets {
        let _ = writeln!(
            t,
            "{bullet}rounds: {} -> {} ({} added, {} removed), steps: {} -> {}{}",
            d.old_rounds,
            d.new_rounds,
            d.rounds_added.len(),
            d.rounds_removed.len(),
            d.old_steps,
            d.new_steps,
            if d.schema_changed {
                ", observations changed"
            } else {
                ""
            }
        );
    }
    t
}

/// For a pull-request comment; pictures linked under `images`.
pub fn render_markdown(report: &Comparison, images: &Path) -> String {
    let mut t = String::new();
    let f = &report.files;
    let _ = writeln!(
        t,
        "### imitate diff: {} artifact\n\n`{}` → `{}`: {} files changed, {} added, {} removed.\n",
        report.kind,
        report.old,
        report.new,
        f.changed.len(),
        f.added.len(),
        f.removed.len()
    );
    if let Some(d) = &report.costmaps {
        let _ = writeln!(
            t,
            "| map | mean \\|Δ log-cost\\| | max \\|Δ log-cost\\| | cells changed | rank correlation |\n|---|---|---|---|---|"
        );
        for m in &d.maps {
            let _ = writeln!(
                t,
                "| {} | {:.4} | {:.4} | {:.1} % | {:.4} |",
                m.map,
                m.mean_abs_log_cost,
                m.max_abs_log_cost,
                100.0 * m.changed_share,
                m.rank_correlation
            );
        }
        let changed = d.paths.iter().filter(|p| p.changed).count();
        let _ = writeln!(
            t,
            "\n**Plans** on {} reference start/goal pairs: **{changed} changed**.\n",
            d.paths.len()
        );
        if changed > 0 {
            let _ = writeln!(
                t,
                "| example | map | Hausdorff (cells) | cost ratio |\n|---|---|---|---|"
            );
            for p in d.paths.iter().filter(|p| p.changed) {
                let _ = writeln!(
                    t,
                    "| {} | {} | {:.1} | {:.4} |",
                    p.example, p.map, p.hausdorff_cells, p.cost_ratio
                );
            }
            t.push('\n');
        }
        let deltas: Vec<_> = d.metrics.iter().filter(|m| m.delta.is_some()).collect();
        if !deltas.is_empty() {
            let _ = writeln!(t, "| metric | old | new | Δ |\n|---|---|---|---|");
            for m in deltas {
                let _ = writeln!(
                    t,
                    "| {} | {:.4} | {:.4} | {:+.4} |",
                    m.metric,
                    m.old.unwrap_or_default(),
                    m.new.unwrap_or_default(),
                    m.delta.unwrap_or_default()
                );
            }
            t.push('\n');
        }
        for m in &d.maps {
            let _ = writeln!(
                t,
                "**{}**: old, new, difference (red: costlier, blue: cheaper)\n\n![{}]({})\n",
                m.map,
                m.map,
                images.join(format!("{}.png", m.map)).display()
            );
        }
    }
    let lines = dagger_lines(report, "- ");
    if !lines.is_empty() {
        let _ = writeln!(t, "{lines}");
    }
    let _ = writeln!(t, "{}", verdict(report));
    t
}
