//! Pipelines: a YAML file of named stages, run in dependency order, make-style: a
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
//! Stages are ordered by what they read (`graph.rs`) and independent ones can run at
//! once (`--jobs`).

mod cache;
mod graph;
mod lock;
mod spec;
mod statcache;

pub use cache::CachedOutput;
pub use lock::{LockFile, LockedStage, differences, lock_path};
pub use spec::{ExpandedStage, Foreach, PipelineSpec, StageSpec};

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde::Serialize;

use crate::artifact::{Lineage, MANIFEST, Manifest};
use crate::error::{Error, Result, read_input};
use crate::stage::{self, Stage, StageReport};

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
    /// Stages to run at once (independent ones only); 0 or 1 runs one at a time.
    pub jobs: usize,
    /// Decide and report, run nothing, write nothing.
    pub dry_run: bool,
    /// Let outputs resolve outside the workspace through symbolic links.
    pub allow_outside_workspace: bool,
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
    extra_deps: &[PathBuf],
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
        .chain(extra_deps)
        .filter(|d| pending.iter().any(|p| d.starts_with(p)))
        .map(|d| format!("input will be remade: {}", d.display()))
        .collect();
    if !waiting.is_empty() {
        return Ok((waiting, None));
    }
    let now = stage::lineage_with(stage, extra_deps, &mut |file| stats.digest(file)).map_err(
        |e| match e {
            Error::Input { path, message } => {
                Error::input(path, format!("{message} (an input of stage '{name}')"))
            }
            other => other,
        },
    )?;
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

/// `message` prefixed with its line and column and followed by the line itself, as
/// YAML parse errors are shown.
fn at_line(text: &str, at: Option<(u64, u64)>, message: String) -> String {
    let Some((line, column)) = at else {
        return message;
    };
    let source = text
        .lines()
        .nth(line.saturating_sub(1) as usize)
        .unwrap_or("");
    let caret = " ".repeat(column.saturating_sub(1) as usize);
    format!("line {line} column {column}: {message}\n {line:>4} | {source}\n      | {caret}^")
}

/// Refuses, before any stage runs, an output that would replace what imitate did not
/// write, or that resolves outside the workspace through a symbolic link (unless
/// allowed). The workspace is the folder the run works in.
fn check_output(out: &Path, allow_outside_workspace: bool) -> std::result::Result<(), String> {
    crate::artifact::check_replaceable(out).map_err(|e| format!("`out` {e}"))?;
    if allow_outside_workspace {
        return Ok(());
    }
    let workspace = std::fs::canonicalize(".")
        .map_err(|e| format!("cannot resolve the workspace folder: {e}"))?;
    // The deepest part of the output path that exists says where it really leads.
    let existing = out
        .ancestors()
        .find(|a| !a.as_os_str().is_empty() && a.exists());
    if let Some(existing) = existing {
        let resolved = std::fs::canonicalize(existing)
            .map_err(|e| format!("cannot resolve {}: {e}", existing.display()))?;
        if !resolved.starts_with(&workspace) {
            return Err(format!(
                "`out` {} leads to {}, outside the workspace {}, through a symbolic link; \
                 run with --allow-outside-workspace to write there",
                out.display(),
                resolved.display(),
                workspace.display()
            ));
        }
    }
    Ok(())
}

/// The outputs kept in the workspace's cache, most recently used first.
pub fn cache_outputs() -> Result<Vec<CachedOutput>> {
    cache::OutputCache::in_workspace().outputs()
}

/// Bounds the workspace's cache (see [`cache::OutputCache::collect_garbage`]), holding
/// the run lock so that no run uses the cache meanwhile.
pub fn cache_gc(keep_last: Option<usize>, max_bytes: Option<u64>) -> Result<Vec<CachedOutput>> {
    let _lock = RunLock::acquire()?;
    let cache = cache::OutputCache::in_workspace();
    for folder in cache.folders() {
        crate::io::leftovers::sweep(&folder, &crate::io::leftovers::BESIDE_OUTPUTS);
    }
    cache.collect_garbage(keep_last, max_bytes)
}

/// Removes what killed runs left beside every output, in the cache and beside the lock
/// file (staging folders, temporary files), whether or not any stage runs now.
fn sweep_leftovers(outs: &[PathBuf], lock_file: &Path) {
    use crate::io::leftovers::{BESIDE_OUTPUTS, sweep};
    let parent = |p: &Path| match p.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut folders: std::collections::BTreeSet<PathBuf> = outs.iter().map(|o| parent(o)).collect();
    folders.insert(parent(lock_file));
    folders.extend(cache::OutputCache::in_workspace().folders());
    folders.insert(PathBuf::from(".imitate"));
    folders.insert(PathBuf::from(".imitate/checkpoints"));
    let removed: usize = folders.iter().map(|f| sweep(f, &BESIDE_OUTPUTS)).sum();
    if removed > 0 {
        tracing::info!(removed, "swept the leftovers of killed runs");
    }
}

/// Runs one stage that must run, given its extra dependencies: here
/// (`Stage::run`), or elsewhere (e.g. a cluster task that builds the stage from its
/// kind and resolved parameters) on a filesystem this process sees, since the run
/// reads the stage's manifest from its output folder afterwards.
pub type StageExecutor<'a> = dyn Fn(&dyn Stage, &[PathBuf]) -> Result<StageReport> + Sync + 'a;

/// What every stage's processing shares.
struct Context<'a> {
    options: &'a RunOptions,
    executor: &'a StageExecutor<'a>,
    lock: Mutex<LockFile>,
    lock_file: PathBuf,
    cache: cache::OutputCache,
    stats: Mutex<statcache::StatCache>,
}

/// Decides whether `stage` must run, and runs it (or restores its output from the
/// cache) unless this is a dry run; records it in the lock file as soon as it is done.
fn process(
    ctx: &Context,
    name: &str,
    stage: &dyn Stage,
    extra_deps: &[PathBuf],
    pending: &[PathBuf],
) -> Result<StageOutcome> {
    let (reasons, now) = {
        let lock = ctx
            .lock
            .lock()
            .expect("no stage panics while holding the lock file");
        let mut stats = ctx
            .stats
            .lock()
            .expect("no stage panics while holding the stat cache");
        reasons_to_run(
            name,
            stage,
            extra_deps,
            &lock,
            pending,
            ctx.options.force,
            &mut stats,
        )?
    };
    let mut outcome = StageOutcome {
        name: name.to_string(),
        kind: stage.kind(),
        out: stage.out(),
        reasons,
        ran: false,
        digest: None,
        summary: None,
    };
    if outcome.reasons.is_empty() {
        let lock = ctx
            .lock
            .lock()
            .expect("no stage panics while holding the lock file");
        outcome.digest = lock.stages.get(name).map(|l| l.out_digest.clone());
        return Ok(outcome);
    }
    if ctx.options.dry_run {
        return Ok(outcome);
    }
    let out = stage.out();
    let cached = now.as_ref().and_then(|l| ctx.cache.lookup(&l.stage_key));
    let summary = match cached {
        Some((_, dir)) => {
            ctx.cache.restore(&dir, &out)?;
            "restored from the output cache".to_string()
        }
        None => {
            tracing::info!(stage = %name, kind = stage.kind(), reasons = ?outcome.reasons, "running");
            (ctx.executor)(stage, extra_deps)?.summary
        }
    };
    let bytes = read_input(&out.join(MANIFEST))?;
    let manifest: Manifest = serde_json::from_slice(&bytes)
        .map_err(|e| Error::Failed(format!("stage '{name}' left an unreadable manifest: {e}")))?;
    ctx.cache
        .store(&manifest.lineage.stage_key, &out, &manifest.digest)?;
    outcome.digest = Some(manifest.digest.clone());
    {
        let mut lock = ctx
            .lock
            .lock()
            .expect("no stage panics while holding the lock file");
        lock.stages.insert(
            name.to_string(),
            LockedStage {
                lineage: manifest.lineage,
                out: out.to_string_lossy().into_owned(),
                out_digest: manifest.digest,
            },
        );
        lock::write(&ctx.lock_file, &lock)?;
    }
    outcome.ran = true;
    outcome.summary = Some(summary);
    Ok(outcome)
}

/// Builds every stage (so a typo in the last stage fails before the first runs), orders
/// them by their dependencies, then runs the stale ones, up to `jobs` at a time, each
/// recorded in the lock file as it finishes. `on_event` sees each outcome as soon as
/// it is known; the returned outcomes are in the run order, whatever the timing.
pub fn run(
    path: &Path,
    options: &RunOptions,
    on_event: impl FnMut(&StageOutcome),
) -> Result<Vec<StageOutcome>> {
    run_with(path, options, &|stage, extra| stage.run(extra), on_event)
}

/// `run`, each stage that must run handed to `executor`: the same keys, lock file,
/// cache and order, whoever does the work.
pub fn run_with(
    path: &Path,
    options: &RunOptions,
    executor: &StageExecutor<'_>,
    mut on_event: impl FnMut(&StageOutcome),
) -> Result<Vec<StageOutcome>> {
    let spec = load(path)?;
    let expanded = spec.expand().map_err(|e| Error::input(path, e))?;
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let stages = expanded
        .iter()
        .map(|s| {
            stage::build(&s.uses, s.with.clone()).map_err(|e| {
                let message = format!("stage '{}': {e}", s.name);
                Error::input(path, at_line(&text, s.position_for(&message), message))
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let names: Vec<String> = expanded.iter().map(|s| s.name.clone()).collect();
    let deps: Vec<Vec<PathBuf>> = stages
        .iter()
        .zip(&expanded)
        .map(|(s, e)| s.deps().into_iter().chain(e.deps.iter().cloned()).collect())
        .collect();
    // Declared outputs must be the ones the parameters name.
    for (s, e) in stages.iter().zip(&expanded) {
        if let Some(outs) = e.outs.as_ref().filter(|outs| **outs != [s.out()]) {
            let listed: Vec<String> = outs.iter().map(|o| o.display().to_string()).collect();
            let message = format!(
                "stage '{}': outs lists {}, but its parameters write {}",
                e.name,
                listed.join(", "),
                s.out().display()
            );
            return Err(Error::input(path, at_line(&text, e.with_at, message)));
        }
    }
    let outs: Vec<PathBuf> = stages.iter().map(|s| s.out()).collect();
    let graph = graph::build(&names, &deps, &outs).map_err(|e| {
        let at = expanded[e.stage].position_for(&e.message);
        Error::input(path, at_line(&text, at, e.message))
    })?;
    // The stages to consider: all, or the chosen one and (with --downstream) all that
    // read from it, transitively.
    let mut chosen = vec![options.only.is_none(); names.len()];
    if let Some(only) = &options.only {
        let first = names.iter().position(|n| n == only).ok_or_else(|| {
            Error::Usage(format!(
                "{} has no stage '{only}' (it has: {})",
                path.display(),
                names.join(", ")
            ))
        })?;
        chosen[first] = true;
        for &i in &graph.order {
            if options.downstream && graph.upstream[i].iter().any(|&j| chosen[j]) {
                chosen[i] = true;
            }
        }
    }
    let order: Vec<usize> = graph.order.iter().copied().filter(|&i| chosen[i]).collect();
    for &i in &order {
        check_output(&outs[i], options.allow_outside_workspace).map_err(|message| {
            let message = format!("stage '{}': {message}", names[i]);
            let at = expanded[i].position_for(&message);
            Error::input(path, at_line(&text, at, message))
        })?;
    }
    let _run_lock = if options.dry_run {
        None
    } else {
        Some(RunLock::acquire()?)
    };
    if !options.dry_run {
        sweep_leftovers(&outs, &lock_path(path));
    }
    let ctx = Context {
        options,
        executor,
        lock_file: lock_path(path),
        lock: Mutex::new(lock::read(&lock_path(path))?),
        cache: cache::OutputCache::in_workspace(),
        stats: Mutex::new(statcache::StatCache::in_workspace()),
    };
    let outcomes = if options.dry_run || options.jobs <= 1 {
        let mut pending: Vec<PathBuf> = Vec::new();
        let mut outcomes = Vec::with_capacity(order.len());
        for &i in &order {
            let outcome = process(
                &ctx,
                &names[i],
                stages[i].as_ref(),
                &expanded[i].deps,
                &pending,
            )?;
            // In a dry run, what would be remade has no digest to compare yet.
            if options.dry_run && !outcome.reasons.is_empty() {
                pending.push(outcome.out.clone());
            }
            on_event(&outcome);
            outcomes.push(outcome);
        }
        outcomes
    } else {
        run_parallel(
            &ctx,
            &expanded,
            &stages,
            &graph,
            &order,
            &chosen,
            &mut on_event,
        )?
    };
    if !options.dry_run {
        ctx.stats
            .lock()
            .expect("no stage panics while holding the stat cache")
            .save()?;
    }
    Ok(outcomes)
}

/// Runs stages on up to `jobs` threads, each as soon as every chosen stage it reads
/// from is done. After a failure no new stage starts; the first failure in run order is
/// returned once the running ones finish.
fn run_parallel(
    ctx: &Context,
    expanded: &[ExpandedStage],
    stages: &[Box<dyn Stage>],
    graph: &graph::Graph,
    order: &[usize],
    chosen: &[bool],
    on_event: &mut impl FnMut(&StageOutcome),
) -> Result<Vec<StageOutcome>> {
    let n = expanded.len();
    let position: Vec<usize> = {
        let mut p = vec![usize::MAX; n];
        order.iter().enumerate().for_each(|(k, &i)| p[i] = k);
        p
    };
    let mut waiting: Vec<usize> = (0..n)
        .map(|i| graph.upstream[i].iter().filter(|&&j| chosen[j]).count())
        .collect();
    // Ready stages by their place in the run order.
    let mut ready: std::collections::BTreeSet<usize> = order
        .iter()
        .filter(|&&i| waiting[i] == 0)
        .map(|&i| position[i])
        .collect();
    let mut results: Vec<Option<StageOutcome>> = vec![None; order.len()];
    let mut failures: Vec<(usize, Error)> = Vec::new();
    std::thread::scope(|scope| {
        let (done, finished) = std::sync::mpsc::channel::<(usize, Result<StageOutcome>)>();
        let mut running = 0;
        loop {
            while running < ctx.options.jobs && failures.is_empty() {
                let Some(k) = ready.pop_first() else { break };
                let (i, done) = (order[k], done.clone());
                let (name, stage, extra) =
                    (&expanded[i].name, stages[i].as_ref(), &expanded[i].deps);
                scope.spawn(move || {
                    let _ = done.send((k, process(ctx, name, stage, extra, &[])));
                });
                running += 1;
            }
            if running == 0 {
                break;
            }
            let (k, result) = finished
                .recv()
                .expect("a stage thread reports before it ends");
            running -= 1;
            match result {
                Ok(outcome) => {
                    on_event(&outcome);
                    results[k] = Some(outcome);
                    for &d in &graph.downstream[order[k]] {
                        if chosen[d] {
                            waiting[d] -= 1;
                            if waiting[d] == 0 {
                                ready.insert(position[d]);
                            }
                        }
                    }
                }
                Err(e) => failures.push((k, e)),
            }
        }
    });
    if let Some((_, e)) = failures.into_iter().min_by_key(|(k, _)| *k) {
        return Err(e);
    }
    Ok(results.into_iter().flatten().collect())
}
