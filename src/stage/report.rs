//! `report` (and `imitate report COSTMAP --out DIR`): a report people read, as an
//! artifact: `report.md` (pictures as files beside it) and a self-contained
//! `report.html` (pictures inline), with the previews, learning curves and the metrics
//! table. In a pipeline it reruns only when its costmap changed.

use std::fmt::Write as _;
use std::path::PathBuf;

use base64::Engine;
use serde::{Deserialize, Serialize};

use super::{StageParams, StageReport, commit_artifact};
use crate::artifact::ArtifactBuilder;
use crate::error::{Error, Result, read_input};
use crate::io::fs::write_bytes_atomic;
use crate::io::png::write_png;
use crate::report::chart::{Chart, Legend, Series};
use crate::report::costmap_artifact::CostmapArtifact;
use crate::report::picture::side_by_side;

pub const KIND: &str = "report";
/// 3: previews with a colour bar and a scale bar. 4: the corridor `--corridor auto`
/// chose, and why. 5: and that it prices the cells off the track dearer.
const VERSION: u32 = 5;

/// Parameters of `imitate report` and of `uses: report`.
#[derive(Debug, Clone, clap::Args, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReportParams {
    /// A costmap artifact folder.
    #[serde(rename = "artifact")]
    pub costmap: PathBuf,
    /// The artifact folder to write report.md, report.html and the pictures into.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

impl StageParams for ReportParams {
    const KIND: &'static str = KIND;
    const VERSION: u32 = VERSION;

    fn deps(&self) -> Vec<PathBuf> {
        vec![self.costmap.clone()]
    }

    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport> {
        let mut out = ArtifactBuilder::new(&self.out)?;
        let pictures = write_report(&self.costmap, &mut out)?;
        let metrics = serde_json::json!({ "pictures": pictures });
        let summary = format!("report.md, report.html and {pictures} pictures");
        commit_artifact(self, extra_deps, out, "report", metrics, summary)
    }
}

const LOSS_COLOUR: [u8; 3] = [200, 40, 40];
const AGREEMENT_COLOUR: [u8; 3] = [40, 90, 200];

/// What a method's training loss measures, for the chart's axis.
fn loss_description(method: &str) -> &'static str {
    match method {
        "maxent" => "neg. log-likelihood per step",
        _ => "margin (share of demo cost)",
    }
}

/// One learning curve against the round, as a chart.
fn learning_chart(
    title: &str,
    y_label: &str,
    (name, colour): (&str, [u8; 3]),
    values: &[f64],
    legend: Legend,
) -> Result<crate::io::png::Rgb> {
    Chart {
        title: title.into(),
        x_label: "round".into(),
        y_label: y_label.into(),
        series: vec![Series {
            name: name.into(),
            points: values
                .iter()
                .enumerate()
                .map(|(i, &v)| ((i + 1) as f64, v))
                .collect(),
            colour,
        }],
        legend,
    }
    .draw(420, 280)
    .map_err(Error::Failed)
}

/// Per round: training loss and held-out agreement.
fn curves(artifact: &CostmapArtifact) -> (Vec<f64>, Vec<f64>) {
    let rounds = artifact
        .metrics
        .get("rounds")
        .and_then(|r| r.as_array())
        .cloned()
        .unwrap_or_default();
    let series = |pointer: &str| {
        rounds
            .iter()
            .map(|r| {
                r.pointer(pointer)
                    .and_then(|v| v.as_f64())
                    .unwrap_or(f64::NAN)
            })
            .collect::<Vec<_>>()
    };
    (series("/training_loss"), series("/holdout/within_radius"))
}

fn number(value: Option<&serde_json::Value>) -> String {
    match value {
        Some(serde_json::Value::Number(n)) => match n.as_f64() {
            Some(v) if v.fract() != 0.0 => format!("{v:.4}"),
            _ => n.to_string(),
        },
        Some(serde_json::Value::String(s)) => s.clone(),
        Some(other) => other.to_string(),
        None => "–".into(),
    }
}

/// Writes the report of the costmap artifact `costmap` into `out`; returns how many
/// pictures it holds.
fn write_report(costmap: &std::path::Path, out: &mut ArtifactBuilder) -> Result<usize> {
    let artifact = CostmapArtifact::load(costmap)?;
    let manifest = &artifact.manifest;
    let (loss, agreement) = curves(&artifact);
    let mut pictures: Vec<(String, PathBuf, String)> = Vec::new();
    if !loss.is_empty() {
        let method = manifest
            .lineage
            .params
            .get("method")
            .and_then(|m| m.as_str())
            .unwrap_or("learch");
        let loss_chart = learning_chart(
            "Training loss per round",
            loss_description(method),
            ("training examples", LOSS_COLOUR),
            &loss,
            Legend::UpperRight,
        )?;
        let loss_words = format!(
            "training loss ({:.4} → {:.4})",
            loss.first().copied().unwrap_or(f64::NAN),
            loss.last().copied().unwrap_or(f64::NAN),
        );
        // Without held-out demonstrations there is no agreement to draw.
        let (plot, caption) = if agreement.iter().all(|a| a.is_nan()) {
            (
                loss_chart,
                format!("per round: {loss_words}; no demonstrations were held out"),
            )
        } else {
            let agreement_chart = learning_chart(
                "Held-out agreement per round",
                "cells within 2 of the demo (share)",
                ("held-out examples", AGREEMENT_COLOUR),
                &agreement,
                Legend::LowerRight,
            )?;
            (
                side_by_side(&[&loss_chart, &agreement_chart], 12),
                format!(
                    "per round, left: {loss_words}; right: share of held-out planned cells \
                     within 2 cells of the demonstration ({:.3} → {:.3})",
                    agreement.first().copied().unwrap_or(f64::NAN),
                    agreement.last().copied().unwrap_or(f64::NAN)
                ),
            )
        };
        let path = out.file("learning-curves.png", "picture")?;
        write_png(&path, &plot)?;
        pictures.push(("Learning curves".into(), path, caption));
    }
    for file in manifest.files_with_role("preview") {
        let name = std::path::Path::new(&file.path)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let target = out.file(&format!("preview-{name}.png"), "picture")?;
        let bytes = read_input(&artifact.dir.join(&file.path))?;
        write_bytes_atomic(&target, &bytes)?;
        pictures.push((
            format!("Map {name}"),
            target,
            "learned costmap (dark: cheap, yellow: costly, in the colour bar's cost per \
             metre; north up; the scale bar in metres), demonstrations red, plans on the \
             learned costmap green, both white"
                .into(),
        ));
    }

    let mut rows = Vec::new();
    for (set, label) in [("training", "training"), ("holdout", "held out")] {
        let summary = artifact.metrics.pointer(&format!("/{set}/summary"));
        // A set with no examples has no figures (its summary's zeros measure nothing).
        let figures =
            summary.filter(|s| s.get("examples").and_then(|n| n.as_u64()).unwrap_or(0) > 0);
        rows.push([
            label.to_string(),
            number(summary.and_then(|s| s.get("examples"))),
            number(figures.and_then(|s| s.get("within_radius"))),
            number(figures.and_then(|s| s.get("mean_reference_cost_ratio"))),
            number(figures.and_then(|s| s.get("max_reference_cost_ratio"))),
        ]);
    }
    let header = [
        "examples",
        "examples",
        "planned cells within 2 cells",
        "mean reference cost ratio",
        "max reference cost ratio",
    ];
    let lineage = &manifest.lineage;
    let params = serde_json::to_string(&lineage.params).unwrap_or_default();
    let corridor = corridor_choice(&artifact.metrics);

    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Costmap report: {}\n\nArtifact `{}` ({}), made by `{}` v{} with imitate {}.\n\nParameters: `{params}`\n",
        costmap.display(),
        manifest.digest,
        manifest.kind,
        lineage.stage,
        lineage.stage_version,
        lineage.tool_version,
    );
    if let Some(corridor) = &corridor {
        let _ = writeln!(md, "{corridor}\n");
    }
    let _ = writeln!(
        md,
        "| set | {} | {} | {} | {} |",
        header[1], header[2], header[3], header[4]
    );
    let _ = writeln!(md, "|---|---|---|---|---|");
    for r in &rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} |",
            r[0], r[1], r[2], r[3], r[4]
        );
    }
    md.push('\n');
    let mut html = format!(
        "<!doctype html><meta charset=\"utf-8\"><title>Costmap report</title>\
         <style>body{{font-family:sans-serif;max-width:60em;margin:2em auto}}\
         table{{border-collapse:collapse}}td,th{{border:1px solid #bbb;padding:.3em .6em}}\
         img{{image-rendering:pixelated;max-width:100%}}code{{overflow-wrap:anywhere}}</style>\
         <h1>Costmap report: {}</h1><p>Artifact <code>{}</code> ({}), made by <code>{}</code> v{} \
         with imitate {}.</p><p>Parameters: <code>{}</code></p>{}<table><tr><th>set</th>",
        escape(&costmap.display().to_string()),
        manifest.digest,
        escape(&manifest.kind),
        escape(&lineage.stage),
        lineage.stage_version,
        escape(&lineage.tool_version),
        escape(&params),
        corridor.map_or(String::new(), |c| format!("<p>{}</p>", escape(&c))),
    );
    for h in &header[1..] {
        let _ = write!(html, "<th>{h}</th>");
    }
    html.push_str("</tr>");
    for r in &rows {
        html.push_str("<tr>");
        for cell in r {
            let _ = write!(html, "<td>{}</td>", escape(cell));
        }
        html.push_str("</tr>");
    }
    html.push_str("</table>");
    for (title, path, caption) in &pictures {
        let file = path
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let _ = writeln!(md, "## {title}\n\n![{title}]({file})\n\n{caption}\n");
        let png =
            std::fs::read(path).map_err(|e| Error::io(format!("reading {}", path.display()), e))?;
        let _ = write!(
            html,
            "<h2>{}</h2><img alt=\"{}\" src=\"data:image/png;base64,{}\"><p>{}</p>",
            escape(title),
            escape(title),
            base64::engine::general_purpose::STANDARD.encode(png),
            escape(caption)
        );
    }
    write_bytes_atomic(&out.file("report.md", "report")?, md.as_bytes())?;
    write_bytes_atomic(&out.file("report.html", "report")?, html.as_bytes())?;
    Ok(pictures.len())
}

/// What `--corridor auto` chose and why, from the costmap's metrics (`None` where the
/// corridor was given, or the artifact predates the choice).
fn corridor_choice(metrics: &serde_json::Value) -> Option<String> {
    let corridor = metrics.get("corridor")?;
    let share = corridor.get("plans_as_long")?.as_f64()?;
    let below = corridor.get("retrains_below")?.as_f64()?;
    let cells = corridor.get("cells")?.as_u64()?;
    let found = format!(
        "{:.0} % of the training plans on the cost learned without a corridor were as long \
         as their demonstrations",
        100.0 * share
    );
    Some(match cells {
        0 => format!(
            "Corridor: none (`auto`). {found}, {:.0} % or more: the demonstrations were \
             learned as they are.",
            100.0 * below
        ),
        _ => format!(
            "Corridor: {cells} cell(s) (`auto`). {found}, under {:.0} %: the tracks wander, \
             and the model was trained again taking each demonstration as the cheapest path \
             within {cells} cell(s) of it, its cells off the track priced {:.0} % dearer.",
            100.0 * below,
            100.0 * crate::ioc::OFF_TRACK_PREMIUM
        ),
    })
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_report_says_what_the_automatic_corridor_chose() {
        let metrics = |cells: u32, share: f64| {
            serde_json::json!({"corridor": {"requested": "auto", "cells": cells,
                "plans_as_long": share, "retrains_below": 0.35}})
        };
        let kept = corridor_choice(&metrics(0, 0.85)).unwrap();
        assert!(kept.starts_with("Corridor: none (`auto`). 85 %"), "{kept}");
        let retrained = corridor_choice(&metrics(1, 0.2)).unwrap();
        assert!(
            retrained.starts_with("Corridor: 1 cell(s) (`auto`). 20 %"),
            "{retrained}"
        );
        assert!(retrained.contains("under 35 %"), "{retrained}");
        assert!(retrained.ends_with("priced 5 % dearer."), "{retrained}");
        // A corridor given in cells, and artifacts from before the choice: nothing.
        let given = serde_json::json!({"corridor": {"requested": 1, "cells": 1}});
        assert_eq!(corridor_choice(&given), None);
        assert_eq!(corridor_choice(&serde_json::json!({"rounds": []})), None);
    }
}
