//! Pipelines: a YAML file of named stages, run in the order written, make-style: a
//! stage reruns only when its lineage (stage version, tool version, resolved
//! parameters, input digests) differs from the one in the lock file, or its output is
//! missing or not the one it made. A stage whose inputs came out byte-identical is
//! skipped (early cutoff), because input digests are content digests.
//!
//! Outputs are kept in a content-addressed cache (`cache.rs`), so a stage whose stage
//! key was seen before gets its output back without running.
//!
//! Input files are hashed through a stat cache (`statcache.rs`), so a run in which
//! nothing changed reads metadata only.
//!
//! Still to come (their own issue): parallel stages, `vars`/`foreach`, a repository
//! lock between concurrent runs.

mod cache;
mod lock;
mod spec;
mod statcache;

pub use lock::{LockFile, LockedStage, differences, lock_path};
pub use spec::{ExpandedStage, Foreach, PipelineSpec, StageSpec};

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::artifact::{Lineage, MANIFEST, Manifest};
use crate::error::{Error, Result, read_input};
use crate::stage::{self, Stage};

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

#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Rerun every stage (or the one chosen) whatever the lock file says.
    pub force: bool,
    /// Only this stage; its inputs must exist.
    pub only: Option<String>,
    /// With `only`: also the later stages that read what it writes, transitively.
    pub downstream: bool,
    /// Decide and report, run nothing, write nothing.
    pub dry_run: bool,
}

/// Holds the workspace's run lock (`.imitate/run.lock`) while alive, so that two runs
/// never write the same outputs and lock file at once.
struct RunLock {
    _held: std::fs::File,
}

impl RunLock {
    fn acquire() -> Result<RunLock> {
        let path = Path::new(".imitate/run.lock");
        std::fs::create_dir_all(".imitate").map_err(|e| Error::io("creating .imitate", e))?;
        let file = std::fs::File::options()
            .create(true)
            .truncate(false)
            .write(true)
            .open(path)
            .map_err(|e| Error::io(format!("opening {}", path.display()), e))?;
        match file.try_lock() {
            Ok(()) => Ok(RunLock { _held: file }),
            Err(std::fs::TryLockError::WouldBlock) => Err(Error::Failed(format!(
                "another `imitate run` is working in this workspace (it holds {}); wait for it to finish",
                path.display()
            ))),
            Err(std::fs::TryLockError::Error(e)) => {
                Err(Error::io(format!("locking {}", path.display()), e))
            }
        }
    }
}

/// What happened to (or would happen to) one stage.
#[derive(Debug, Clone, Serialize)]
pub struct StageOutcome {
    pub name: String,
    pub kind: &'static str,
    pub out: PathBuf,
    /// Why it (would) run; empty when up to date.
    pub reasons: Vec<String>,
    pub ran: bool,
    /// The output's digest, when there is one.
    pub digest: Option<String>,
    /// What the stage made, when it ran.
    pub summary: Option<String>,
}

/// The manifest digest of an output folder, or `None` when there is no readable one.
fn output_digest(out: &Path) -> Option<String> {
    let bytes = std::fs::read(out.join(MANIFEST)).ok()?;
    serde_json::from_slice::<Manifest>(&bytes)
        .ok()
        .map(|m| m.digest)
}

/// Why `stage` must run, or nothing when it is up to date. `pending` holds the outputs
/// of earlier stages that will run but have not (in a dry run), whose digests are not
/// known yet.
fn reasons_to_run(
    name: &str,
    stage: &dyn Stage,
    lock: &LockFile,
    pending: &[PathBuf],
    force: bool,
    stats: &mut statcache::StatCache,
) -> Result<(Vec<String>, Option<Lineage>)> {
    if force {
        return Ok((vec!["forced".into()], None));
    }
    let waiting: Vec<String> = stage
        .deps()
        .iter()
        .filter(|d| pending.iter().any(|p| d.starts_with(p)))
        .map(|d| format!("input will be remade: {}", d.display()))
        .collect();
    if !waiting.is_empty() {
        return Ok((waiting, None));
    }
    let now = stage::lineage_with(stage, &mut |file| stats.digest(file)).map_err(|e| match e {
        Error::Input { path, message } => {
            Error::input(path, format!("{message} (an input of stage '{name}')"))
        }
        other => other,
    })?;
    let Some(locked) = lock.stages.get(name) else {
        return Ok((vec!["never run".into()], Some(now)));
    };
    let mut reasons = differences(name, &locked.lineage, &now);
    let out = stage.out();
    if locked.out != out.to_string_lossy() {
        reasons.push(format!("output moved: {} → {}", locked.out, out.display()));
    } else {
        match output_digest(&out) {
            None => reasons.push(format!("output missing: {}", out.display())),
            Some(d) if d != locked.out_digest => {
                reasons.push(format!("output changed: {}", out.display()))
            }
            Some(_) => {}
        }
    }
    Ok((reasons, Some(now)))
}

/// Refuses, before anything runs, what cannot work: outputs outside the workspace, two
/// stages writing one place, and a stage reading what the same or a later stage writes
/// (stages run in the order listed).
fn check_graph(path: &Path, stages: &[(String, Box<dyn Stage>)]) -> Result<()> {
    use std::path::Component;
    for (i, (name, stage)) in stages.iter().enumerate() {
        let out = stage.out();
        let escapes = out
            .components()
            .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir));
        if escapes || out.as_os_str().is_empty() {
            return Err(Error::input(
                path,
                format!(
                    "stage '{name}' writes {}, outside the workspace: outputs are relative paths without '..'",
                    out.display()
                ),
            ));
        }
        for (other, later) in &stages[i + 1..] {
            let theirs = later.out();
            if out.starts_with(&theirs) || theirs.starts_with(&out) {
                return Err(Error::input(
                    path,
                    format!(
                        "stages '{name}' and '{other}' both write {}",
                        out.min(theirs).display()
                    ),
                ));
            }
        }
        for (j, (other, writer)) in stages.iter().enumerate().skip(i) {
            if let Some(dep) = stage
                .deps()
                .into_iter()
                .find(|d| d.starts_with(writer.out()))
            {
                let when = if j == i {
                    "itself".to_string()
                } else {
                    format!("stage '{other}', listed after it,")
                };
                return Err(Error::input(
                    path,
                    format!(
                        "stage '{name}' reads {}, which {when} writes: a stage may read only what earlier stages write",
                        dep.display()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Builds every stage (so a typo in the last stage fails before the first runs), then
/// runs the stale ones in order, recording each in the lock file as it finishes.
/// `on_event` sees each outcome as soon as it is known.
pub fn run(
    path: &Path,
    options: &RunOptions,
    mut on_event: impl FnMut(&StageOutcome),
) -> Result<Vec<StageOutcome>> {
    let spec = load(path)?;
    let expanded = spec.expand().map_err(|e| Error::input(path, e))?;
    let stages = expanded
        .iter()
        .map(|s| {
            let name = &s.name;
            stage::build(&s.uses, s.with.clone())
                .map(|built| (name.clone(), built))
                .map_err(|e| Error::input(path, format!("stage '{name}': {e}")))
        })
        .collect::<Result<Vec<_>>>()?;
    if let Some(only) = options
        .only
        .as_ref()
        .filter(|only| !stages.iter().any(|(n, _)| n == *only))
    {
        let names: Vec<&str> = stages.iter().map(|(n, _)| n.as_str()).collect();
        return Err(Error::Usage(format!(
            "{} has no stage '{only}' (it has: {})",
            path.display(),
            names.join(", ")
        )));
    }
    check_graph(path, &stages)?;
    let _run_lock = if options.dry_run {
        None
    } else {
        Some(RunLock::acquire()?)
    };
    let lock_file = lock_path(path);
    let mut lock = lock::read(&lock_file)?;
    let mut pending: Vec<PathBuf> = Vec::new();
    let cache = cache::OutputCache::in_workspace();
    let mut stats = statcache::StatCache::in_workspace();
    let mut outcomes = Vec::with_capacity(stages.len());
    // With --stage (and --downstream): the outputs of the stages chosen so far.
    let mut chosen_outs: Vec<PathBuf> = Vec::new();
    for (name, stage) in &stages {
        if let Some(only) = &options.only {
            let downstream = options.downstream
                && stage
                    .deps()
                    .iter()
                    .any(|d| chosen_outs.iter().any(|o| d.starts_with(o)));
            if only != name && !downstream {
                continue;
            }
            chosen_outs.push(stage.out());
        }
        let (reasons, now) = reasons_to_run(
            name,
            stage.as_ref(),
            &lock,
            &pending,
            options.force,
            &mut stats,
        )?;
        let mut outcome = StageOutcome {
            name: name.clone(),
            kind: stage.kind(),
            out: stage.out(),
            reasons,
            ran: false,
            digest: None,
            summary: None,
        };
        if outcome.reasons.is_empty() {
            outcome.digest = lock.stages.get(name).map(|l| l.out_digest.clone());
        } else if options.dry_run {
            pending.push(stage.out());
        } else {
            let out = stage.out();
            let cached = now.as_ref().and_then(|l| cache.lookup(&l.stage_key));
            let summary = match cached {
                Some((_, dir)) => {
                    cache.restore(&dir, &out)?;
                    "restored from the output cache".to_string()
                }
                None => {
                    tracing::info!(stage = %name, kind = stage.kind(), reasons = ?outcome.reasons, "running");
                    stage.run()?.summary
                }
            };
            let bytes = read_input(&out.join(MANIFEST))?;
            let manifest: Manifest = serde_json::from_slice(&bytes).map_err(|e| {
                Error::Failed(format!("stage '{name}' left an unreadable manifest: {e}"))
            })?;
            cache.store(&manifest.lineage.stage_key, &out, &manifest.digest)?;
            outcome.digest = Some(manifest.digest.clone());
            lock.stages.insert(
                name.clone(),
                LockedStage {
                    lineage: manifest.lineage,
                    out: out.to_string_lossy().into_owned(),
                    out_digest: manifest.digest,
                },
            );
            lock::write(&lock_file, &lock)?;
            outcome.ran = true;
            outcome.summary = Some(summary);
        }
        on_event(&outcome);
        outcomes.push(outcome);
    }
    if !options.dry_run {
        stats.save()?;
    }
    Ok(outcomes)
}
