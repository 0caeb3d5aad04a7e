//! `evaluate` (and `imitate evaluate`): how a costmap does on a fixed evaluation set.
//! The set is a dataset artifact (what `ingest` makes of demonstrations: one cell path
//! per episode); for each path the planner goes from its first cell to its last on the
//! costmap, and the plan is scored against the path: the share of planned cells within
//! 2 cells of it and, with reference costmaps (the true or a trusted cost), the plan's
//! cost over the path's and over the cheapest path's under them. Start/goal pairs
//! without a route to compare with are paths of two cells: their `optimal_cost_ratio`
//! is what tells.
//!
//! The result is an artifact, so that CI keeps it and a pipeline reruns it only when
//! the costmap, the set or the references changed.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::{StageParams, StageReport, commit_artifact};
use crate::artifact::{ArtifactBuilder, References, read_manifest};
use crate::error::{Error, Result};
use crate::io::fs::{to_json_bytes, write_bytes_atomic};
use crate::io::tables::read_paths;
use crate::ioc::{ExampleEvaluation, evaluate_example, summarize};
use crate::plan::{path_cost, shortest_path};
use crate::report::costmap_artifact::CostmapArtifact;

pub const KIND: &str = "evaluate";
/// 2: step lengths per row in geographic frames.
const VERSION: u32 = 2;

/// Parameters of `imitate evaluate` and of `uses: evaluate`.
#[derive(Debug, Clone, clap::Args, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvaluateParams {
    /// The costmap artifact folder to evaluate.
    #[serde(rename = "artifact")]
    pub costmap: PathBuf,
    /// A dataset artifact (from `ingest`) whose paths are the evaluation set.
    #[arg(long, value_name = "DIR")]
    pub dataset: PathBuf,
    /// Reference costmaps (repeat): plans and paths are also costed under them.
    /// `costmap/1` tables or one-band GeoTIFFs of costs, each matched to the map of its
    /// name (a GeoTIFF's is its file's), else to the only map of its grid.
    #[arg(long = "reference", value_name = "FILE")]
    #[serde(default)]
    pub references: Vec<PathBuf>,
    /// The artifact folder to write evaluation.json into.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

impl StageParams for EvaluateParams {
    const KIND: &'static str = KIND;
    const VERSION: u32 = VERSION;

    fn deps(&self) -> Vec<PathBuf> {
        let mut deps = vec![self.costmap.clone(), self.dataset.clone()];
        deps.extend(self.references.iter().cloned());
        deps
    }

    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport> {
        let mut out = ArtifactBuilder::new(&self.out)?;
        let evaluation = evaluate(self)?;
        write_bytes_atomic(
            &out.file("evaluation.json", "evaluation")?,
            &to_json_bytes(&evaluation),
        )?;
        let s = &evaluation.summary;
        let mut summary = format!(
            "{} paths: {:.1}% of planned cells within 2 cells",
            s.examples,
            100.0 * s.within_radius
        );
        if let (Some(mean), Some(optimal)) =
            (s.mean_reference_cost_ratio, s.mean_optimal_cost_ratio)
        {
            summary += &format!(", cost ratio {mean:.3} to the paths, {optimal:.3} to the optimum");
        }
        let metrics = serde_json::to_value(&evaluation.summary).expect("summaries serialise");
        commit_artifact(self, extra_deps, out, "evaluation", metrics, summary)
    }
}

/// The figures over the whole set.
#[derive(Debug, Serialize)]
pub struct EvaluationSummary {
    pub examples: usize,
    /// Paths between whose ends the costmap gives no route (blocked or cut off).
    pub unreachable: usize,
    /// Pooled share of planned cells within 2 cells of their path.
    pub within_radius: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_reference_cost_ratio: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_reference_cost_ratio: Option<f64>,
    /// The plan's cost over the cheapest path's, both under the reference.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_optimal_cost_ratio: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_optimal_cost_ratio: Option<f64>,
}

/// One path of the set.
#[derive(Debug, Serialize)]
pub struct PathEvaluation {
    #[serde(flatten)]
    pub plan: ExampleEvaluation,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub optimal_cost_ratio: Option<f64>,
}

#[derive(Debug, Serialize)]
pub struct Evaluation {
    pub schema: &'static str,
    pub summary: EvaluationSummary,
    pub paths: Vec<PathEvaluation>,
    /// Episodes whose ends the costmap cannot connect.
    pub unreachable: Vec<String>,
}

fn evaluate(params: &EvaluateParams) -> Result<Evaluation> {
    let artifact = CostmapArtifact::load(&params.costmap)?;
    let dataset = read_manifest(&params.dataset, "dataset")?;
    let paths_file = dataset
        .files_with_role("paths")
        .next()
        .map(|f| params.dataset.join(&f.path))
        .ok_or_else(|| Error::input(&params.dataset, "dataset lists no 'paths' file"))?;
    let references = References::load(&params.references)?;
    let maps: Vec<&str> = artifact.costmaps.iter().map(|(n, _)| n.as_str()).collect();
    let mut paths = Vec::new();
    let mut unreachable = Vec::new();
    for p in read_paths(&paths_file)? {
        let costs = artifact.costmap(&p.map).ok_or_else(|| {
            Error::input(
                &params.costmap,
                format!(
                    "has no costmap for map '{}' of episode '{}'",
                    p.map, p.episode
                ),
            )
        })?;
        if let Some(cell) = p.cells.iter().find(|c| !costs.geo.contains(**c)) {
            return Err(Error::input(
                &paths_file,
                format!(
                    "episode '{}': cell {cell} is off map '{}'",
                    p.episode, p.map
                ),
            ));
        }
        let reference = match references.is_empty() {
            true => None,
            false => Some(references.for_map(&p.map, &costs.geo, &maps)?),
        };
        let Some(plan) = evaluate_example(&p.episode, &p.map, costs, &p.cells, reference) else {
            unreachable.push(p.episode);
            continue;
        };
        let optimal_cost_ratio = reference.and_then(|truth| {
            let best = shortest_path(truth, p.cells[0], *p.cells.last()?)?;
            Some(path_cost(truth, &plan.planned) / best.cost.max(f64::MIN_POSITIVE))
        });
        paths.push(PathEvaluation {
            plan,
            optimal_cost_ratio,
        });
    }
    let plans: Vec<ExampleEvaluation> = paths.iter().map(|p| p.plan.clone()).collect();
    let agreement = summarize(&plans);
    let optimal: Vec<f64> = paths.iter().filter_map(|p| p.optimal_cost_ratio).collect();
    let summary = EvaluationSummary {
        examples: agreement.examples,
        unreachable: unreachable.len(),
        within_radius: agreement.within_radius,
        mean_reference_cost_ratio: agreement.mean_reference_cost_ratio,
        max_reference_cost_ratio: agreement.max_reference_cost_ratio,
        mean_optimal_cost_ratio: (!optimal.is_empty())
            .then(|| optimal.iter().sum::<f64>() / optimal.len() as f64),
        max_optimal_cost_ratio: optimal.iter().copied().reduce(f64::max),
    };
    Ok(Evaluation {
        schema: "imitate.evaluation/1",
        summary,
        paths,
        unreachable,
    })
}
