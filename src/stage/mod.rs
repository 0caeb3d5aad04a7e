//! Stages: pure functions from typed on-disk inputs and parameters to typed on-disk
//! outputs. Each is reachable as a CLI subcommand and as a `uses:` entry of a pipeline,
//! with the same parameter struct. The runner knows stages only through `Stage` and
//! `build`; stages never know the runner.

pub mod dagger;
pub mod diff;
pub mod evaluate;
pub mod export;
pub mod features;
pub mod forecast;
pub mod ingest;
pub mod ioc;
pub mod learch;
pub mod report;

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::artifact::{ArtifactBuilder, Lineage, digest_input, digest_input_with};
use crate::error::{Error, Result};

/// What a finished stage tells its caller.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StageReport {
    pub output: PathBuf,
    pub digest: String,
    /// One line for people: what was made.
    pub summary: String,
}

/// `Send + Sync` so that a pipeline can run independent stages on several threads.
pub trait Stage: Send + Sync {
    fn kind(&self) -> &'static str;
    /// The implementation's version: bumped when the same inputs would give other outputs.
    fn version(&self) -> u32;
    /// The resolved parameters (defaults filled in), as recorded in lineage.
    fn params(&self) -> serde_json::Value;
    /// Files and artifact folders the stage reads.
    fn deps(&self) -> Vec<PathBuf>;
    /// The artifact folder the stage writes.
    fn out(&self) -> PathBuf;
    /// Runs the stage. `extra_deps` are inputs the pipeline declares beyond those the
    /// parameters name; they join the lineage like the others.
    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport>;
}

/// What each stage's parameters define; `Stage` follows from it, with the resolved
/// parameters being the parameters themselves, serialised with their defaults.
pub trait StageParams: Serialize + Send + Sync {
    const KIND: &'static str;
    /// Bumped when the same inputs would give other outputs.
    const VERSION: u32;
    fn deps(&self) -> Vec<PathBuf>;
    fn out(&self) -> PathBuf;
    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport>;
}

impl<T: StageParams> Stage for T {
    fn kind(&self) -> &'static str {
        T::KIND
    }

    fn version(&self) -> u32 {
        T::VERSION
    }

    fn params(&self) -> serde_json::Value {
        resolved(self)
    }

    fn deps(&self) -> Vec<PathBuf> {
        StageParams::deps(self)
    }

    fn out(&self) -> PathBuf {
        StageParams::out(self)
    }

    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport> {
        StageParams::run(self, extra_deps)
    }
}

/// A progress bar for long work (rounds, maps, logs): drawn on stderr when it is a
/// terminal, hidden otherwise (indicatif's default), so logs and pipes stay clean.
pub(crate) fn progress_bar(
    len: usize,
    what: impl Into<std::borrow::Cow<'static, str>>,
) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len as u64).with_message(what);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{msg} {wide_bar} {pos}/{len} ({elapsed})")
    {
        bar.set_style(style);
    }
    bar
}

type Constructor = fn(serde_json::Value) -> Result<Box<dyn Stage>>;

/// Every stage kind a pipeline can `use`.
const REGISTRY: &[(&str, Constructor)] = &[
    (ingest::KIND, |p| {
        Ok(Box::new(parse::<ingest::IngestParams>(ingest::KIND, p)?))
    }),
    (features::KIND, |p| {
        Ok(Box::new(parse::<features::FeaturesParams>(
            features::KIND,
            p,
        )?))
    }),
    (ioc::KIND, |p| {
        Ok(Box::new(parse::<ioc::IocParams>(ioc::KIND, p)?))
    }),
    (learch::KIND, |p| {
        Ok(Box::new(parse::<learch::LearchParams>(learch::KIND, p)?))
    }),
    (dagger::KIND, |p| {
        Ok(Box::new(parse::<dagger::DaggerParams>(dagger::KIND, p)?))
    }),
    (export::KIND, |p| {
        Ok(Box::new(parse::<export::ExportParams>(export::KIND, p)?))
    }),
    (report::KIND, |p| {
        Ok(Box::new(parse::<report::ReportParams>(report::KIND, p)?))
    }),
    (diff::KIND, |p| {
        Ok(Box::new(parse::<diff::DiffParams>(diff::KIND, p)?))
    }),
    (evaluate::KIND, |p| {
        Ok(Box::new(parse::<evaluate::EvaluateParams>(
            evaluate::KIND,
            p,
        )?))
    }),
    (forecast::KIND, |p| {
        Ok(Box::new(parse::<forecast::ForecastParams>(
            forecast::KIND,
            p,
        )?))
    }),
];

pub fn kinds() -> impl Iterator<Item = &'static str> {
    REGISTRY.iter().map(|(kind, _)| *kind)
}

/// Makes a stage of `kind` from its `with:` parameters.
pub fn build(kind: &str, params: serde_json::Value) -> Result<Box<dyn Stage>> {
    let (_, constructor) = REGISTRY.iter().find(|(k, _)| *k == kind).ok_or_else(|| {
        Error::Usage(format!(
            "unknown stage kind '{kind}' (known: {})",
            kinds().collect::<Vec<_>>().join(", ")
        ))
    })?;
    constructor(params)
}

fn parse<T: DeserializeOwned>(kind: &str, params: serde_json::Value) -> Result<T> {
    serde_json::from_value(params).map_err(|e| Error::Usage(format!("'{kind}' parameters: {e}")))
}

/// Resolved parameters as recorded in lineage.
fn resolved<T: Serialize>(params: &T) -> serde_json::Value {
    serde_json::to_value(params).expect("parameters serialise")
}

/// The lineage a run of `stage` would have now: its version and parameters, the
/// digests of its inputs as they are, and the stage key made of them.
pub fn lineage(stage: &dyn Stage, extra_deps: &[PathBuf]) -> Result<Lineage> {
    lineage_with(stage, extra_deps, &mut |file| {
        digest_input(file).map(|input| input.digest)
    })
}

/// As `lineage`, with input files digested by `digest_file` (e.g. through a stat cache).
pub fn lineage_with(
    stage: &dyn Stage,
    extra_deps: &[PathBuf],
    digest_file: &mut dyn FnMut(&Path) -> Result<String>,
) -> Result<Lineage> {
    let inputs = stage
        .deps()
        .iter()
        .chain(extra_deps)
        .map(|p| digest_input_with(p, digest_file))
        .collect::<Result<Vec<_>>>()?;
    Ok(Lineage::new(
        stage.kind(),
        stage.version(),
        stage.params(),
        inputs,
    ))
}

/// Commits a stage's artifact with its lineage, and reports it.
fn commit_artifact(
    stage: &dyn Stage,
    extra_deps: &[PathBuf],
    out: ArtifactBuilder,
    kind: &str,
    metrics: serde_json::Value,
    summary: String,
) -> Result<StageReport> {
    let manifest = out.commit(kind, lineage(stage, extra_deps)?, metrics)?;
    Ok(StageReport {
        output: stage.out(),
        digest: manifest.digest,
        summary,
    })
}
