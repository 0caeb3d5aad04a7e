//! Pipelines: a YAML file of named stages, run in the order written. This is the
//! minimal runner (every stage, every time); stage keys, caching and the DAG are their
//! own work.

mod spec;

pub use spec::{PipelineSpec, StageSpec};

use std::path::Path;

use crate::error::{Error, Result, read_input};
use crate::stage::{self, StageReport};

/// Parses a pipeline file; errors name the file, line and column.
pub fn load(path: &Path) -> Result<PipelineSpec> {
    let bytes = read_input(path)?;
    let text = String::from_utf8(bytes).map_err(|_| Error::input(path, "is not UTF-8 text"))?;
    let spec: PipelineSpec = serde_saphyr::from_str(&text)
        .map_err(|e| Error::input(path, e.to_string().trim_start_matches("error: ")))?;
    if spec.schema != 1 {
        return Err(Error::input(
            path,
            format!(
                "schema {} is not supported (this imitate reads schema 1)",
                spec.schema
            ),
        ));
    }
    if spec.stages.0.is_empty() {
        return Err(Error::input(path, "has no stages"));
    }
    Ok(spec)
}

/// Builds every stage (so a typo in the last stage fails before the first runs), then
/// runs them in order. `on_done` sees each stage's report as it finishes.
pub fn run(
    path: &Path,
    mut on_done: impl FnMut(&str, &StageReport),
) -> Result<Vec<(String, StageReport)>> {
    let spec = load(path)?;
    let stages = spec
        .stages
        .0
        .iter()
        .map(|(name, s)| {
            stage::build(&s.uses, s.with.clone())
                .map(|built| (name.clone(), built))
                .map_err(|e| Error::input(path, format!("stage '{name}': {e}")))
        })
        .collect::<Result<Vec<_>>>()?;
    let mut reports = Vec::with_capacity(stages.len());
    for (name, stage) in stages {
        tracing::info!(stage = %name, kind = stage.kind(), "running");
        let report = stage.run()?;
        on_done(&name, &report);
        reports.push((name, report));
    }
    Ok(reports)
}
