//! The DAgger dataset on disk: one row per control step, rounds as immutable partitions.
//!
//! ```text
//! DIR/meta/info.json                      observation names, the schema
//! DIR/meta/rounds.parquet                 dagger-rounds/1: one row per round
//! DIR/data/round=NNN/part-000.parquet     dagger-steps/1: the round's steps
//! DIR/manifest.json                       files, sizes and digests
//! ```
//!
//! Steps carry LeRobot's columns (`episode_index`, `frame_index`, `index`, `timestamp`,
//! `observation.state`, `action` — the teacher's label) plus `round`,
//! `action_executed`, `actor`, `beta`, `is_first`, `is_last`, `is_terminal`.
//!
//! Appending a round writes its partition into a hidden folder beside the others and
//! renames it into place, then replaces `rounds.parquet` and the manifest (each written
//! to a temporary file and renamed). `rounds.parquet` is what counts: a partition it does
//! not list (an append killed before the end) is ignored and removed by the next
//! append, so a killed append leaves the dataset as it was. The manifest keeps the
//! earlier rounds' digests, so an append reads nothing but its own round. A round from
//! a source already in the dataset is not added again.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow::array::{
    Array, ArrayRef, BooleanArray, FixedSizeListArray, Float32Array, Float64Array, Int64Array,
    RecordBatch, StringArray,
};
use arrow::datatypes::{DataType, Field, Schema};
use serde::{Deserialize, Serialize};

use super::query::{RoundStatistics, round_statistics};
use super::{Actor, Aggregate, PolicyLearner, Step};
use crate::artifact::{
    FileEntry, Lineage, MANIFEST, artifact_digest, verify_entries, verify_entry,
};
use crate::error::{Error, Result};
use crate::io::fs::{file_digest, to_json_bytes, write_bytes_atomic};
use crate::io::leftovers;
use crate::io::tables::{Table, read_table, write_table};

const INFO: &str = "meta/info.json";
const ROUNDS: &str = "meta/rounds.parquet";

/// What the dataset holds, fixed when it is created.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DatasetInfo {
    pub schema: String,
    pub observation_names: Vec<String>,
    /// The names of an action's numbers when it holds several (a robot's joints);
    /// empty for an action of one number.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub action_names: Vec<String>,
    /// What made the data ("track", "gridnav", "log", "demonstrations").
    pub environment: String,
    /// For `gridnav`: the costmap the episodes walk and the teacher plans on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub costs: Option<CostsSource>,
}

impl DatasetInfo {
    /// How many numbers an action holds.
    pub fn action_dims(&self) -> usize {
        self.action_names.len().max(1)
    }
}

/// Where a `gridnav` dataset's costmap comes from, and the digest of its costs, so that
/// later rounds are refused if it changed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CostsSource {
    /// A costmap as `imitate plan` takes it (artifact folder, table, GeoTIFF or `.map`).
    pub path: PathBuf,
    /// The map within an artifact folder holding several.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map: Option<String>,
    /// blake3 of the grid's size and costs.
    pub digest: String,
}

/// One row of `meta/rounds.parquet`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RoundInfo {
    pub round: u32,
    /// Identifies where the round came from; adding the same source again is a no-op.
    pub source: String,
    pub beta: f64,
    /// Digest of the policy that drove (empty when the teacher drove).
    pub policy: String,
    pub teacher: String,
    pub episodes: u64,
    pub steps: u64,
    pub learner_steps: u64,
    pub failures: u64,
}

/// A round to append: its episodes' steps and where they came from.
pub struct NewRound<'a> {
    pub source: String,
    pub beta: f64,
    pub policy: String,
    pub teacher: String,
    /// Seconds between control steps (for `timestamp`), unless `timestamps` are given.
    pub period: f64,
    /// Per step (all episodes in order): seconds since its episode's start.
    pub timestamps: Option<&'a [f64]>,
    pub episodes: &'a [Vec<Step>],
}

pub struct Dataset {
    dir: PathBuf,
    pub info: DatasetInfo,
    pub rounds: Vec<RoundInfo>,
    /// The manifest's files: every partition read is checked against its digest.
    files: Vec<FileEntry>,
}

/// Whether `dir` or a folder below it holds a file (it stops at the first).
fn holds_files(dir: &Path) -> bool {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return false;
    };
    entries.flatten().any(|entry| match entry.file_type() {
        Ok(t) if t.is_dir() => holds_files(&entry.path()),
        _ => true,
    })
}

fn partition(round: u32) -> String {
    format!("data/round={round:03}/part-000.parquet")
}

impl Dataset {
    /// Creates an empty dataset in `dir` (which must not hold one already).
    pub fn create(dir: &Path, info: DatasetInfo) -> Result<Dataset> {
        if dir.join(INFO).exists() {
            return Err(Error::input(dir, "already holds a DAgger dataset"));
        }
        // A dataset is made in a new or empty folder, never among a user's files.
        if holds_files(dir) {
            return Err(Error::Usage(format!(
                "{}: is a folder with files in it and no DAgger dataset; a new dataset \
                 goes in a new or empty folder",
                dir.display()
            )));
        }
        std::fs::create_dir_all(dir.join("meta"))
            .map_err(|e| Error::io(format!("creating {}", dir.display()), e))?;
        write_bytes_atomic(&dir.join(INFO), &to_json_bytes(&info))?;
        let mut dataset = Dataset {
            dir: dir.to_path_buf(),
            info,
            rounds: Vec::new(),
            files: Vec::new(),
        };
        dataset.write_rounds()?;
        dataset.write_manifest(&[])?;
        Ok(dataset)
    }

    /// Opens a dataset, checking its description and round list against the manifest.
    pub fn open(dir: &Path) -> Result<Dataset> {
        let info_path = dir.join(INFO);
        if !info_path.is_file() {
            return Err(Error::input(
                dir,
                "is not a DAgger dataset (no meta/info.json)",
            ));
        }
        // What killed appends left (each leftover is locked while its writer lives).
        leftovers::sweep(dir, &[leftovers::TEMPORARY]);
        leftovers::sweep(&dir.join("meta"), &[leftovers::TEMPORARY]);
        leftovers::sweep(&dir.join("data"), &[leftovers::ROUND]);
        let files = manifest_files(dir)?;
        verify_entry(dir, &files, INFO)?;
        let rounds_checked = verify_entry(dir, &files, ROUNDS);
        let bytes = std::fs::read(&info_path)
            .map_err(|_| Error::input(dir, "is not a DAgger dataset (no meta/info.json)"))?;
        let info: DatasetInfo = serde_json::from_slice(&bytes)
            .map_err(|e| Error::input(&info_path, format!("is not a dataset description: {e}")))?;
        let rounds = read_rounds(&dir.join(ROUNDS))?;
        let mut dataset = Dataset {
            dir: dir.to_path_buf(),
            info,
            rounds,
            files,
        };
        if let Err(damage) = rounds_checked
            && !dataset.finish_interrupted_append()?
        {
            return Err(damage);
        }
        Ok(dataset)
    }

    /// An append commits when the round list (`meta/rounds.parquet`) lands; the
    /// manifest follows. When a kill fell between the two, the list holds exactly one
    /// round more than the manifest, whose partition is in place: the manifest is
    /// brought up to date. Anything else is damage (returns false).
    fn finish_interrupted_append(&mut self) -> Result<bool> {
        let previous = self.files.clone();
        let listed: Vec<FileEntry> = (previous.iter())
            .filter(|f| f.path.starts_with("data/"))
            .cloned()
            .collect();
        let n = self.rounds.len();
        let interrupted = n == listed.len() + 1
            && (0..n - 1).all(|r| listed.iter().any(|f| f.path == partition(r as u32)))
            && self.dir.join(partition(n as u32 - 1)).is_file();
        if !interrupted {
            return Ok(false);
        }
        verify_entries(&self.dir, &listed)?;
        self.write_manifest(&previous)?;
        Ok(true)
    }

    /// Per-round statistics of the steps (a polars scan of the listed partitions).
    pub fn statistics(&self) -> Result<Vec<RoundStatistics>> {
        let listed: Vec<FileEntry> = (self.rounds.iter())
            .map(|r| self.entry(&partition(r.round)))
            .collect::<Result<_>>()?;
        verify_entries(&self.dir, &listed)?;
        let files: Vec<PathBuf> = (self.rounds.iter())
            .map(|r| self.dir.join(partition(r.round)))
            .collect();
        round_statistics(
            &self.dir,
            &files,
            self.info.observation_names.len(),
            self.info.action_dims(),
        )
    }

    pub fn steps(&self) -> u64 {
        self.rounds.iter().map(|r| r.steps).sum()
    }

    /// Appends a round; returns its number, or the existing round's when its source is
    /// already in the dataset. Refuses (and writes nothing) when an observation has
    /// another length than the dataset's or a label is not finite.
    pub fn append(&mut self, new: &NewRound<'_>) -> Result<u32> {
        let _lock = self.lock_for_append()?;
        if let Some(existing) = self.rounds.iter().find(|r| r.source == new.source) {
            return Ok(existing.round);
        }
        let dims = self.info.observation_names.len();
        for (e, episode) in new.episodes.iter().enumerate() {
            for (f, step) in episode.iter().enumerate() {
                let at = || format!("round source '{}', episode {e}, step {f}", new.source);
                if step.observation.len() != dims {
                    return Err(Error::input(
                        &self.dir,
                        format!(
                            "{}: the observation has {} values, the dataset's have {dims} ({})",
                            at(),
                            step.observation.len(),
                            self.info.observation_names.join(", ")
                        ),
                    ));
                }
                let actions = self.info.action_dims();
                if step.label.len() != actions || step.executed.len() != actions {
                    return Err(Error::input(
                        &self.dir,
                        format!(
                            "{}: the action has {} values, the dataset's have {actions}{}",
                            at(),
                            step.label.len(),
                            if self.info.action_names.is_empty() {
                                String::new()
                            } else {
                                format!(" ({})", self.info.action_names.join(", "))
                            }
                        ),
                    ));
                }
                // The first value that is not a number, named by its column and element.
                let not_finite = [
                    (
                        "observation.state",
                        &step.observation,
                        &self.info.observation_names,
                    ),
                    ("action", &step.label, &self.info.action_names),
                    ("action_executed", &step.executed, &self.info.action_names),
                ]
                .into_iter()
                .find_map(|(column, values, names)| {
                    let i = values.iter().position(|x| !x.is_finite())?;
                    let name = names.get(i).map_or(String::new(), |n| format!(", {n}"));
                    Some(format!("{column}[{i}]{name} is {}", values[i]))
                });
                if let Some(problem) = not_finite {
                    return Err(Error::input(&self.dir, format!("{}: {problem}", at())));
                }
            }
        }
        let total: usize = new.episodes.iter().map(Vec::len).sum();
        if new.timestamps.is_some_and(|t| t.len() != total) {
            return Err(Error::Failed(format!(
                "round source '{}': {} timestamps for {total} steps",
                new.source,
                new.timestamps.map_or(0, <[f64]>::len)
            )));
        }
        let round = self.rounds.len() as u32;
        let first_index = self.steps();
        let folder = self.dir.join(format!("data/round={round:03}"));
        // A partition no round lists is what a killed append left: not data.
        if folder.exists() {
            std::fs::remove_dir_all(&folder)
                .map_err(|e| Error::io(format!("removing {}", folder.display()), e))?;
        }
        let data = self.dir.join("data");
        std::fs::create_dir_all(&data)
            .map_err(|e| Error::io(format!("creating {}", data.display()), e))?;
        let (staging, _staging_held) = leftovers::claimed(|| {
            let staging = tempfile::Builder::new()
                .prefix(leftovers::ROUND)
                .tempdir_in(&data)?;
            let held = leftovers::hold(staging.path());
            Ok((staging, held))
        })
        .map_err(|e| Error::io(format!("creating a folder in {}", data.display()), e))?;
        let batch = steps_batch(round, first_index, new, dims, self.info.action_dims());
        write_table(
            &staging.path().join("part-000.parquet"),
            Table::DAGGER_STEPS,
            &batch,
            Vec::new(),
        )?;
        let staged = staging.keep();
        std::fs::rename(&staged, &folder)
            .map_err(|e| Error::io(format!("moving {} into place", folder.display()), e))?;
        let steps: Vec<&Step> = new.episodes.iter().flatten().collect();
        self.rounds.push(RoundInfo {
            round,
            source: new.source.clone(),
            beta: new.beta,
            policy: new.policy.clone(),
            teacher: new.teacher.clone(),
            episodes: new.episodes.len() as u64,
            steps: steps.len() as u64,
            learner_steps: steps.iter().filter(|s| s.actor == Actor::Learner).count() as u64,
            failures: steps.iter().filter(|s| s.failed).count() as u64,
        });
        let previous = manifest_files(&self.dir)?;
        self.write_rounds()?;
        self.write_manifest(&previous)?;
        Ok(round)
    }

    /// Reads each round's steps in order, for training in one pass over the rounds.
    pub fn for_each_round(
        &self,
        mut visit: impl FnMut(&RoundInfo, &RoundSteps) -> Result<()>,
    ) -> Result<()> {
        for info in &self.rounds {
            let steps = self.round_steps(info.round)?;
            visit(info, &steps)?;
        }
        Ok(())
    }

    /// One round's steps, read back after checking the partition's digest.
    pub fn round_steps(&self, round: u32) -> Result<RoundSteps> {
        let relative = partition(round);
        verify_entry(&self.dir, &self.files, &relative).map_err(|e| self.in_round(round, e))?;
        RoundSteps::read(
            &self.dir.join(relative),
            self.info.observation_names.len(),
            self.info.action_dims(),
        )
        .map_err(|e| self.in_round(round, e))
    }

    /// Holds the dataset for one append: no other process appends meanwhile (so what a
    /// killed append left can be swept), and a dataset changed since it was opened is
    /// refused rather than overwritten. The lock ends with the returned handle.
    fn lock_for_append(&self) -> Result<std::fs::File> {
        let folder = std::fs::File::open(&self.dir)
            .map_err(|e| Error::io(format!("opening {}", self.dir.display()), e))?;
        match folder.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                return Err(Error::Failed(format!(
                    "another imitate is adding a round to {}; wait for it to finish",
                    self.dir.display()
                )));
            }
            Err(std::fs::TryLockError::Error(e)) => {
                return Err(Error::io(format!("locking {}", self.dir.display()), e));
            }
        }
        let on_disk = read_rounds(&self.dir.join(ROUNDS))?;
        if on_disk.len() != self.rounds.len() {
            return Err(Error::Failed(format!(
                "{} gained rounds since it was opened (another process added them); run again",
                self.dir.display()
            )));
        }
        Ok(folder)
    }

    /// The manifest entry of `relative`, or an error saying the dataset is damaged.
    fn entry(&self, relative: &str) -> Result<FileEntry> {
        self.files
            .iter()
            .find(|e| e.path == relative)
            .cloned()
            .ok_or_else(|| {
                Error::input(
                    self.dir.join(relative),
                    "is not listed in the dataset's manifest: the dataset is damaged",
                )
            })
    }

    /// Names the round in an error about its partition.
    fn in_round(&self, round: u32, error: Error) -> Error {
        match error {
            Error::Input { path, message } => {
                Error::input(path, format!("round {round}: {message}"))
            }
            other => other,
        }
    }

    /// Every (observation, label) pair in the dataset, aggregated for `learner`.
    pub fn aggregate(&self, learner: &PolicyLearner) -> Result<Aggregate> {
        self.aggregate_episodes(learner, |_| true)
    }

    /// The pairs of the episodes `keep` accepts (by the episode's number across the
    /// dataset: round by round, in order), aggregated for `learner`.
    pub fn aggregate_episodes(
        &self,
        learner: &PolicyLearner,
        keep: impl Fn(u64) -> bool,
    ) -> Result<Aggregate> {
        let mut data = Aggregate::new(
            self.info.observation_names.len(),
            self.info.action_dims(),
            learner,
        );
        self.for_each_step(&keep, |observation, label| data.add(observation, label))?;
        Ok(data)
    }

    /// Visits the steps of the episodes `keep` accepts, by episode number across the
    /// dataset.
    fn for_each_step(
        &self,
        keep: &impl Fn(u64) -> bool,
        mut visit: impl FnMut(&[f64], &[f64]),
    ) -> Result<()> {
        let mut first_episode = 0u64;
        self.for_each_round(|info, steps| {
            for i in 0..steps.len() {
                if keep(first_episode + steps.episode(i)) {
                    visit(steps.observation(i), steps.label(i));
                }
            }
            first_episode += info.episodes;
            Ok(())
        })
    }

    /// Per number of the action: the root mean square of `policy`'s action minus the
    /// teacher's label over the steps of the episodes `keep` accepts.
    /// Root mean square error per action number of `predict` on the steps of the
    /// episodes `keep` takes.
    pub fn errors_per_action(
        &self,
        predict: impl Fn(&[f64]) -> Vec<f64>,
        keep: impl Fn(u64) -> bool,
    ) -> Result<Vec<f64>> {
        let mut squares = vec![0.0; self.info.action_dims()];
        let mut count = 0usize;
        self.for_each_step(&keep, |observation, label| {
            let action = predict(observation);
            for ((total, a), y) in squares.iter_mut().zip(action).zip(label) {
                *total += (a - y) * (a - y);
            }
            count += 1;
        })?;
        Ok(squares
            .into_iter()
            .map(|total| (total / count.max(1) as f64).sqrt())
            .collect())
    }

    /// The mean label per action number over the episodes `keep` takes: the baseline a
    /// learned policy has to beat.
    pub fn mean_action(&self, keep: impl Fn(u64) -> bool) -> Result<Vec<f64>> {
        let mut sums = vec![0.0; self.info.action_dims()];
        let mut count = 0usize;
        self.for_each_step(&keep, |_, label| {
            for (total, y) in sums.iter_mut().zip(label) {
                *total += y;
            }
            count += 1;
        })?;
        Ok(sums.into_iter().map(|s| s / count.max(1) as f64).collect())
    }

    fn write_rounds(&self) -> Result<()> {
        let r = &self.rounds;
        let int = |f: fn(&RoundInfo) -> u64| -> ArrayRef {
            Arc::new(Int64Array::from_iter_values(r.iter().map(|x| f(x) as i64)))
        };
        let text = |f: fn(&RoundInfo) -> &str| -> ArrayRef {
            Arc::new(StringArray::from_iter_values(r.iter().map(f)))
        };
        let columns: Vec<(&str, ArrayRef)> = vec![
            ("round", int(|x| u64::from(x.round))),
            ("source", text(|x| &x.source)),
            (
                "beta",
                Arc::new(Float64Array::from_iter_values(r.iter().map(|x| x.beta))),
            ),
            ("policy", text(|x| &x.policy)),
            ("teacher", text(|x| &x.teacher)),
            ("episodes", int(|x| x.episodes)),
            ("steps", int(|x| x.steps)),
            ("learner_steps", int(|x| x.learner_steps)),
            ("failures", int(|x| x.failures)),
        ];
        let batch = batch_of(columns);
        write_table(
            &self.dir.join(ROUNDS),
            Table::DAGGER_ROUNDS,
            &batch,
            Vec::new(),
        )
    }

    /// Writes the manifest, digesting only files `previous` does not already list.
    fn write_manifest(&mut self, previous: &[FileEntry]) -> Result<()> {
        let mut relative: Vec<(String, &str)> =
            vec![(INFO.to_string(), "info"), (ROUNDS.to_string(), "rounds")];
        relative.extend(self.rounds.iter().map(|r| (partition(r.round), "steps")));
        let mut files = Vec::new();
        for (path, role) in relative {
            let known = previous
                .iter()
                .find(|f| f.path == path && path.starts_with("data/"))
                .cloned();
            let entry = match known {
                Some(entry) => entry,
                None => {
                    let (digest, size) = file_digest(&self.dir.join(&path))?;
                    FileEntry {
                        path,
                        role: role.into(),
                        size,
                        digest,
                    }
                }
            };
            files.push(entry);
        }
        files.sort_by(|a, b| a.path.cmp(&b.path));
        let manifest = serde_json::json!({
            "kind": "dagger-dataset",
            "name": self.dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
            "schema": "imitate.dagger-dataset",
            "schema_version": "1.0.0",
            "digest": artifact_digest(&files),
            "files": files,
            "lineage": Lineage::new(
                "dagger-dataset",
                1,
                serde_json::json!({
                    "environment": self.info.environment,
                    "observation_names": self.info.observation_names,
                }),
                Vec::new(),
            ),
            "metrics": {"rounds": self.rounds.len(), "steps": self.steps()},
        });
        write_bytes_atomic(&self.dir.join(MANIFEST), &to_json_bytes(&manifest))?;
        self.files = files;
        Ok(())
    }
}

/// The file entries of the manifest in `dir`, if it has one.
fn manifest_files(dir: &Path) -> Result<Vec<FileEntry>> {
    #[derive(Deserialize)]
    struct Files {
        files: Vec<FileEntry>,
    }
    let path = dir.join(MANIFEST);
    match std::fs::read(&path) {
        Ok(bytes) => serde_json::from_slice::<Files>(&bytes)
            .map(|f| f.files)
            .map_err(|e| Error::input(&path, format!("is not a manifest: {e}"))),
        Err(_) => Ok(Vec::new()),
    }
}

fn batch_of(columns: Vec<(&str, ArrayRef)>) -> RecordBatch {
    let fields: Vec<Field> = columns
        .iter()
        .map(|(name, array)| Field::new(*name, array.data_type().clone(), false))
        .collect();
    RecordBatch::try_new(
        Arc::new(Schema::new(fields)),
        columns.into_iter().map(|(_, a)| a).collect(),
    )
    .expect("columns of one length")
}

/// A fixed-size list column of f32 vectors, `width` values per row.
fn vectors(values: Vec<f32>, width: usize) -> ArrayRef {
    let item = Arc::new(Field::new("item", DataType::Float32, false));
    Arc::new(FixedSizeListArray::new(
        item,
        width as i32,
        Arc::new(Float32Array::from(values)),
        None,
    ))
}

fn steps_batch(
    round: u32,
    first_index: u64,
    new: &NewRound<'_>,
    dims: usize,
    actions: usize,
) -> RecordBatch {
    let (mut episode, mut frame, mut index, mut time) = (vec![], vec![], vec![], vec![]);
    let (mut observation, mut action, mut executed, mut actor) = (vec![], vec![], vec![], vec![]);
    let (mut first, mut last, mut terminal) = (vec![], vec![], vec![]);
    let mut next = first_index as i64;
    for (e, steps) in new.episodes.iter().enumerate() {
        for (f, step) in steps.iter().enumerate() {
            episode.push(e as i64);
            frame.push(f as i64);
            index.push(next);
            next += 1;
            let at = index.len() - 1;
            time.push(new.timestamps.map_or(f as f64 * new.period, |t| t[at]));
            observation.extend(step.observation.iter().map(|&v| v as f32));
            action.extend(step.label.iter().map(|&v| v as f32));
            executed.extend(step.executed.iter().map(|&v| v as f32));
            actor.push(match step.actor {
                Actor::Teacher => "teacher",
                Actor::Learner => "learner",
            });
            first.push(f == 0);
            last.push(f + 1 == steps.len());
            terminal.push(step.failed);
        }
    }
    let rows = index.len();
    batch_of(vec![
        ("episode_index", Arc::new(Int64Array::from(episode))),
        ("frame_index", Arc::new(Int64Array::from(frame))),
        ("index", Arc::new(Int64Array::from(index))),
        ("timestamp", Arc::new(Float64Array::from(time))),
        ("observation.state", vectors(observation, dims)),
        ("action", vectors(action, actions)),
        ("action_executed", vectors(executed, actions)),
        ("actor", Arc::new(StringArray::from(actor))),
        (
            "round",
            Arc::new(Int64Array::from(vec![i64::from(round); rows])),
        ),
        ("beta", Arc::new(Float64Array::from(vec![new.beta; rows]))),
        ("is_first", Arc::new(BooleanArray::from(first))),
        ("is_last", Arc::new(BooleanArray::from(last))),
        ("is_terminal", Arc::new(BooleanArray::from(terminal))),
    ])
}

/// One round's observations and labels, read back.
pub struct RoundSteps {
    dims: usize,
    actions: usize,
    observations: Vec<f64>,
    /// `actions` numbers per step.
    labels: Vec<f64>,
    /// Per step, its episode within the round.
    episodes: Vec<i64>,
}

impl RoundSteps {
    fn read(path: &Path, dims: usize, actions: usize) -> Result<RoundSteps> {
        let batch = read_table(path, Table::DAGGER_STEPS, false)?.batch;
        let list = |name: &str| -> Result<Vec<f64>> {
            let column = batch
                .column_by_name(name)
                .ok_or_else(|| Error::input(path, format!("has no column '{name}'")))?;
            let list = column
                .as_any()
                .downcast_ref::<FixedSizeListArray>()
                .ok_or_else(|| Error::input(path, format!("column '{name}' is not a list")))?;
            let values = list
                .values()
                .as_any()
                .downcast_ref::<Float32Array>()
                .ok_or_else(|| Error::input(path, format!("column '{name}' is not float32")))?;
            Ok(values.values().iter().map(|&v| f64::from(v)).collect())
        };
        let observations = list("observation.state")?;
        let labels = list("action")?;
        let episodes = batch
            .column_by_name("episode_index")
            .and_then(|c| c.as_any().downcast_ref::<Int64Array>())
            .ok_or_else(|| Error::input(path, "has no int64 column 'episode_index'"))?
            .values()
            .to_vec();
        let steps = labels.len() / actions;
        if labels.len() != steps * actions
            || observations.len() != steps * dims
            || episodes.len() != steps
        {
            return Err(Error::input(
                path,
                format!("steps are not {dims} observation values and {actions} action values each"),
            ));
        }
        Ok(RoundSteps {
            dims,
            actions,
            observations,
            labels,
            episodes,
        })
    }

    pub fn len(&self) -> usize {
        self.labels.len() / self.actions
    }

    pub fn is_empty(&self) -> bool {
        self.labels.is_empty()
    }

    pub fn observation(&self, i: usize) -> &[f64] {
        &self.observations[i * self.dims..(i + 1) * self.dims]
    }

    /// The teacher's action at step `i`, one number per output.
    pub fn label(&self, i: usize) -> &[f64] {
        &self.labels[i * self.actions..(i + 1) * self.actions]
    }

    /// The episode of step `i` within its round.
    pub fn episode(&self, i: usize) -> u64 {
        self.episodes[i].max(0) as u64
    }
}

fn read_rounds(path: &Path) -> Result<Vec<RoundInfo>> {
    let batch = read_table(path, Table::DAGGER_ROUNDS, false)?.batch;
    let int = |name: &str| -> Result<Vec<u64>> {
        let a = batch
            .column_by_name(name)
            .and_then(|c| c.as_any().downcast_ref::<Int64Array>())
            .ok_or_else(|| Error::input(path, format!("has no int64 column '{name}'")))?;
        Ok(a.values().iter().map(|&v| v as u64).collect())
    };
    let text = |name: &str| -> Result<Vec<String>> {
        let a = batch
            .column_by_name(name)
            .and_then(|c| c.as_any().downcast_ref::<StringArray>())
            .ok_or_else(|| Error::input(path, format!("has no string column '{name}'")))?;
        Ok((0..a.len()).map(|i| a.value(i).to_string()).collect())
    };
    let beta = batch
        .column_by_name("beta")
        .and_then(|c| c.as_any().downcast_ref::<Float64Array>())
        .ok_or_else(|| Error::input(path, "has no float64 column 'beta'"))?
        .values()
        .to_vec();
    let (round, source, policy, teacher) = (
        int("round")?,
        text("source")?,
        text("policy")?,
        text("teacher")?,
    );
    let (episodes, steps, learner, failures) = (
        int("episodes")?,
        int("steps")?,
        int("learner_steps")?,
        int("failures")?,
    );
    Ok((0..round.len())
        .map(|i| RoundInfo {
            round: round[i] as u32,
            source: source[i].clone(),
            beta: beta[i],
            policy: policy[i].clone(),
            teacher: teacher[i].clone(),
            episodes: episodes[i],
            steps: steps[i],
            learner_steps: learner[i],
            failures: failures[i],
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info() -> DatasetInfo {
        DatasetInfo {
            schema: "imitate.dagger-dataset/1".into(),
            observation_names: vec!["a".into(), "b".into()],
            action_names: Vec::new(),
            environment: "test".into(),
            costs: None,
        }
    }

    fn step(a: f64, label: f64, actor: Actor) -> Step {
        Step {
            observation: vec![a, 2.0 * a],
            label: vec![label],
            executed: vec![label],
            actor,
            failed: false,
        }
    }

    fn steps_in(ds: &Dataset) -> usize {
        ds.aggregate(&PolicyLearner::Ridge { lambda: 1e-3 })
            .unwrap()
            .len()
    }

    fn round<'a>(source: &str, episodes: &'a [Vec<Step>]) -> NewRound<'a> {
        NewRound {
            source: source.into(),
            beta: 1.0,
            policy: String::new(),
            teacher: "test".into(),
            period: 0.2,
            timestamps: None,
            episodes,
        }
    }

    #[test]
    fn rounds_append_read_back_and_repeat_sources_are_no_ops() {
        let dir = tempfile::tempdir().unwrap();
        let mut ds = Dataset::create(dir.path(), info()).unwrap();
        let first = vec![vec![
            step(0.5, 0.1, Actor::Teacher),
            step(1.0, 0.2, Actor::Teacher),
        ]];
        let second = vec![
            vec![step(2.0, 0.4, Actor::Learner)],
            vec![step(3.0, 0.6, Actor::Learner)],
        ];
        assert_eq!(ds.append(&round("lap-1", &first)).unwrap(), 0);
        let manifest_after_one = std::fs::read(dir.path().join(MANIFEST)).unwrap();
        assert_eq!(ds.append(&round("lap-2", &second)).unwrap(), 1);
        // The same source again: nothing changes.
        let manifest = std::fs::read(dir.path().join(MANIFEST)).unwrap();
        assert_eq!(ds.append(&round("lap-1", &second)).unwrap(), 0);
        assert_eq!(std::fs::read(dir.path().join(MANIFEST)).unwrap(), manifest);
        assert_ne!(manifest, manifest_after_one);

        let reopened = Dataset::open(dir.path()).unwrap();
        assert_eq!(reopened.rounds, ds.rounds);
        assert_eq!(reopened.steps(), 4);
        assert_eq!(reopened.rounds[1].learner_steps, 2);
        assert_eq!(reopened.rounds[1].episodes, 2);
        let mut labels = Vec::new();
        reopened
            .for_each_round(|_, steps| {
                for i in 0..steps.len() {
                    labels.push((steps.observation(i).to_vec(), steps.label(i)[0]));
                }
                Ok(())
            })
            .unwrap();
        assert_eq!(labels[2], (vec![2.0, 4.0], 0.4f32 as f64));
        assert_eq!(steps_in(&reopened), 4);
    }

    #[test]
    fn statistics_describe_each_listed_round() {
        let dir = tempfile::tempdir().unwrap();
        let mut ds = Dataset::create(dir.path(), info()).unwrap();
        let teacher = vec![vec![
            step(1.0, 0.1, Actor::Teacher),
            step(3.0, 0.2, Actor::Teacher),
        ]];
        let mut learner = vec![vec![
            step(2.0, 0.5, Actor::Learner),
            step(2.0, 0.5, Actor::Learner),
            step(2.0, 0.5, Actor::Teacher),
        ]];
        // The learner was off by 0.3 and 0.4 where it drove (the teacher's step is not
        // counted): root mean square 0.354.
        learner[0][0].executed = vec![0.8];
        learner[0][1].executed = vec![0.1];
        ds.append(&round("teacher", &teacher)).unwrap();
        ds.append(&round("learner", &learner)).unwrap();
        // A partition no round lists (left by a killed append) is not scanned.
        let orphan = dir.path().join(partition(2));
        std::fs::create_dir_all(orphan.parent().unwrap()).unwrap();
        std::fs::copy(dir.path().join(partition(1)), &orphan).unwrap();

        let stats = ds.statistics().unwrap();
        assert_eq!(stats.len(), 2);
        assert_eq!(stats[0].learner_disagreement, None);
        assert_eq!(stats[0].observation_mean, [2.0, 4.0]);
        let sd = std::f64::consts::SQRT_2;
        assert!((stats[0].observation_std[0] - sd).abs() < 1e-12);
        let rms = stats[1].learner_disagreement.unwrap();
        assert!((rms - (0.125f64).sqrt()).abs() < 1e-6, "{rms}");
        assert_eq!(stats[1].observation_std, [0.0, 0.0]);
    }

    #[test]
    fn bad_rounds_are_refused_and_leave_the_dataset_as_it_was() {
        let dir = tempfile::tempdir().unwrap();
        let mut ds = Dataset::create(dir.path(), info()).unwrap();
        ds.append(&round("ok", &[vec![step(1.0, 0.1, Actor::Teacher)]]))
            .unwrap();
        let before = std::fs::read(dir.path().join(MANIFEST)).unwrap();
        let mut wide = step(1.0, 0.1, Actor::Teacher);
        wide.observation.push(3.0);
        let err = ds
            .append(&round("wide", &[vec![wide]]))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("3 values") && err.contains("episode 0, step 0"),
            "{err}"
        );
        let nan = step(1.0, f64::NAN, Actor::Teacher);
        let err = ds
            .append(&round("nan", &[vec![nan]]))
            .unwrap_err()
            .to_string();
        assert!(err.contains("step 0: action[0] is NaN"), "{err}");
        assert_eq!(std::fs::read(dir.path().join(MANIFEST)).unwrap(), before);
        assert_eq!(Dataset::open(dir.path()).unwrap().rounds.len(), 1);
        assert!(!dir.path().join("data/round=001").exists());
    }

    #[test]
    fn a_partition_left_by_a_killed_append_is_ignored_and_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let mut ds = Dataset::create(dir.path(), info()).unwrap();
        ds.append(&round("ok", &[vec![step(1.0, 0.1, Actor::Teacher)]]))
            .unwrap();
        // As if an append died after moving its partition, before listing it.
        let orphan = dir.path().join("data/round=001");
        std::fs::create_dir_all(&orphan).unwrap();
        std::fs::write(orphan.join("part-000.parquet"), b"half a file").unwrap();
        let reopened = Dataset::open(dir.path()).unwrap();
        assert_eq!(reopened.steps(), 1);
        assert_eq!(steps_in(&reopened), 1);
        let mut ds = reopened;
        ds.append(&round("next", &[vec![step(2.0, 0.2, Actor::Teacher)]]))
            .unwrap();
        assert_eq!(steps_in(&Dataset::open(dir.path()).unwrap()), 2);
    }

    #[test]
    fn actions_of_several_numbers_are_kept_checked_and_summarised_per_number() {
        let dir = tempfile::tempdir().unwrap();
        let info = DatasetInfo {
            action_names: vec!["shoulder".into(), "elbow".into()],
            ..info()
        };
        let mut ds = Dataset::create(dir.path(), info).unwrap();
        let two = |a: f64, executed: [f64; 2], actor| Step {
            observation: vec![a, 2.0 * a],
            label: vec![a, -a],
            executed: executed.to_vec(),
            actor,
            failed: false,
        };
        let steps = vec![vec![
            two(1.0, [1.0, -1.0], Actor::Teacher),
            two(2.0, [2.5, -2.0], Actor::Learner),
            two(3.0, [3.0, -4.0], Actor::Learner),
        ]];
        ds.append(&round("arm", &steps)).unwrap();
        let reopened = Dataset::open(dir.path()).unwrap();
        let read = reopened.round_steps(0).unwrap();
        assert_eq!(read.len(), 3);
        assert_eq!(read.label(2), [3.0, -3.0]);
        let stats = reopened.statistics().unwrap();
        // Learner errors: shoulder 0.5 and 0, elbow 0 and 1.
        let per = &stats[0].learner_disagreement_per_action;
        assert!((per[0].unwrap() - 0.125f64.sqrt()).abs() < 1e-6, "{per:?}");
        assert!((per[1].unwrap() - 0.5f64.sqrt()).abs() < 1e-6, "{per:?}");
        let all = stats[0].learner_disagreement.unwrap();
        assert!((all - (1.25f64 / 4.0).sqrt()).abs() < 1e-6, "{all}");
        // An action of one number is refused, naming the step and the action names.
        let err = ds
            .append(&round("one", &[vec![step(1.0, 0.5, Actor::Teacher)]]))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("the action has 1 values, the dataset's have 2 (shoulder, elbow)"),
            "{err}"
        );
    }
}
