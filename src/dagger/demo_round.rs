//! Rounds from tables: expert demonstrations in Parquet files or LeRobot folders (v2
//! and v3), where every step's action is the expert's own, or rounds a policy drove
//! outside imitate, whose table holds the executed action beside the teacher's label. Observations come from one
//! or more columns and the action from one (a list column gives all its elements,
//! `name[i]` one element, a number column itself); rows of an episode are consecutive,
//! in time order. Frames that LeRobot's `<column>_is_pad` flags as padding are left out.

use std::path::{Path, PathBuf};

use super::dataset::{Dataset, NewRound};
use super::{Actor, Step};
use crate::error::{Error, Result};
use crate::io::demo_tables::{Column, labels, padding, row_vectors};
use crate::io::fs::file_digest;
use crate::io::tables::{Table, read_table};

/// Which columns hold what.
#[derive(Debug, Clone)]
pub struct DemoColumns {
    pub episode: Column,
    pub observations: Vec<Column>,
    /// The teacher's action: the label.
    pub action: Column,
    /// The executed action, when the learner drove; `None` for demonstrations.
    pub executed: Option<Column>,
}

impl DemoColumns {
    /// Columns named as on the command line: `name`, or `name[i]` for one element of
    /// a list column.
    pub fn parse(
        episode: &str,
        observations: &[String],
        action: &str,
        executed: Option<&str>,
    ) -> std::result::Result<Self, String> {
        let parse = |text: &str| {
            text.parse::<Column>()
                .map_err(|e| format!("column '{text}': {e}"))
        };
        Ok(DemoColumns {
            episode: parse(episode)?,
            observations: observations
                .iter()
                .map(|c| parse(c))
                .collect::<Result<_, _>>()?,
            action: parse(action)?,
            executed: executed.map(parse).transpose()?,
        })
    }
}

impl Default for DemoColumns {
    /// LeRobot's names.
    fn default() -> Self {
        DemoColumns {
            episode: Column::named("episode_index"),
            observations: vec![Column::named("observation.state")],
            action: Column::named("action"),
            executed: None,
        }
    }
}

/// What appending tables to a dataset did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Appended {
    /// A round holding the same files with the same columns was there already.
    Already { round: u32 },
    New {
        round: u32,
        steps: u64,
        episodes: u64,
    },
}

/// Appends one round to the dataset at `dataset`: the tables in `groups` (files whose
/// episode ids are shared: one table set, or one LeRobot folder), expert demonstrations
/// or, with `columns.executed`, a round the learner drove and the teacher labelled. The
/// same files with the same columns twice append nothing.
pub fn append_demonstrations(
    dataset: &Path,
    groups: &[Vec<PathBuf>],
    columns: &DemoColumns,
) -> Result<Appended> {
    let mut ds = Dataset::open(dataset)?;
    let mut digests = Vec::new();
    for file in groups.iter().flatten() {
        digests.push(file_digest(file)?.0);
    }
    let names = |columns: &[Column]| {
        (columns.iter())
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join(",")
    };
    let mut source = format!(
        "demonstrations {} observation={} action={}",
        digests.join(","),
        names(&columns.observations),
        columns.action
    );
    if let Some(executed) = &columns.executed {
        source.push_str(&format!(" executed={executed}"));
    }
    if let Some(existing) = ds.rounds.iter().find(|r| r.source == source) {
        return Ok(Appended::Already {
            round: existing.round,
        });
    }
    let mut episodes = Vec::new();
    for files in groups {
        episodes.extend(read_demo_round(files, columns, ds.info.action_dims())?);
    }
    // With executed actions the learner drove and the teacher only labelled.
    let beta = if columns.executed.is_some() { 0.0 } else { 1.0 };
    let number = ds.append(&NewRound {
        source,
        beta,
        policy: String::new(),
        teacher: "demonstrations".into(),
        period: 0.0,
        timestamps: None,
        episodes: &episodes,
    })?;
    let info = &ds.rounds[number as usize];
    Ok(Appended::New {
        round: number,
        steps: info.steps,
        episodes: info.episodes,
    })
}

/// The episodes of `files`, each a list of expert steps whose actions hold `actions`
/// numbers.
pub fn read_demo_round(
    files: &[PathBuf],
    columns: &DemoColumns,
    actions: usize,
) -> Result<Vec<Vec<Step>>> {
    let mut episodes: Vec<(String, Vec<Step>)> = Vec::new();
    for file in files {
        let batch = read_table(file, Table::DEMONSTRATIONS, true)?.batch;
        let ids = labels(file, &batch, &columns.episode)?;
        let parts: Vec<Vec<Vec<f64>>> = columns
            .observations
            .iter()
            .map(|c| row_vectors(file, &batch, c))
            .collect::<Result<_>>()?;
        let action_rows = row_vectors(file, &batch, &columns.action)?;
        let executed_rows = match &columns.executed {
            Some(column) => Some(row_vectors(file, &batch, column)?),
            None => None,
        };
        // LeRobot's `*_is_pad` flags: frames whose observation or action is padding
        // are left out.
        let mut padded = vec![false; ids.len()];
        for column in columns.observations.iter().chain([&columns.action]) {
            for (row, flag) in padding(file, &batch, column)?
                .into_iter()
                .flatten()
                .enumerate()
            {
                padded[row] |= flag;
            }
        }
        for (row, id) in ids.iter().enumerate() {
            if padded[row] {
                continue;
            }
            let action = &action_rows[row];
            if action.len() != actions {
                return Err(Error::input(
                    file,
                    format!(
                        "record {row}: the action '{}' holds {} numbers, the dataset's actions \
                         {actions}{}",
                        columns.action,
                        action.len(),
                        if actions == 1 && action.len() > 1 {
                            format!(
                                " (create the dataset with `dagger init --lerobot` or \
                                 `--actions`, or name one element, as '{}[0]')",
                                columns.action.name
                            )
                        } else if action.len() > actions && action.len() % actions == 0 {
                            format!(
                                ": an action chunk of {} vectors; choose what to learn: \
                                 its first vector ('{name}[0]') or the whole chunk (a \
                                 dataset made with --actions naming all {} numbers)",
                                action.len() / actions,
                                action.len(),
                                name = columns.action.name
                            )
                        } else {
                            String::new()
                        }
                    ),
                ));
            }
            let observation: Vec<f64> = parts.iter().flat_map(|p| p[row].clone()).collect();
            let executed = executed_rows.as_ref().map_or(action, |rows| &rows[row]);
            if executed.len() != action.len() {
                return Err(Error::input(
                    file,
                    format!(
                        "record {row}: the executed action holds {} numbers, the label {}",
                        executed.len(),
                        action.len()
                    ),
                ));
            }
            // Where the executed action is the teacher's own, the teacher acted.
            let actor = if executed == action {
                Actor::Teacher
            } else {
                Actor::Learner
            };
            let step = Step {
                observation,
                label: action.clone(),
                executed: executed.clone(),
                actor,
                failed: false,
            };
            match episodes.last_mut() {
                Some((last, steps)) if last == id => steps.push(step),
                _ => {
                    if episodes.iter().any(|(e, _)| e == id) {
                        return Err(Error::input(
                            file,
                            format!(
                                "record {row}: episode {id} resumes after another episode; rows of an episode must be consecutive"
                            ),
                        ));
                    }
                    episodes.push((id.clone(), vec![step]));
                }
            }
        }
    }
    Ok(episodes.into_iter().map(|(_, steps)| steps).collect())
}
