//! Tabular MDPs from Parquet, so the IOC learners run on problems that are not grids:
//! transitions (`state, action, next_state, prob`), per-state features (`state` and one
//! numeric column per feature) and demonstrations (`trajectory, t, state`). Tables written
//! by pandas or polars are read as they are.

use std::path::Path;

use arrow::array::{Array, AsArray, RecordBatch};
use arrow::datatypes::{DataType, Float64Type, Int64Type};

use super::tables::{Table, read_table};
use crate::error::{Error, Result};
use crate::ioc::objectworld::Trajectory;
use crate::plan::TabularMdp;

const TRANSITIONS: Table = Table {
    name: "mdp-transitions",
    major: 1,
};
const FEATURES: Table = Table {
    name: "state-features",
    major: 1,
};
const TRAJECTORIES: Table = Table {
    name: "trajectories",
    major: 1,
};

fn integers(path: &Path, batch: &RecordBatch, name: &str) -> Result<Vec<usize>> {
    let column = batch
        .column_by_name(name)
        .ok_or_else(|| Error::input(path, format!("has no column '{name}'")))?;
    if !column.data_type().is_integer() {
        return Err(Error::input(
            path,
            format!(
                "column '{name}' has type {}, expected integers",
                column.data_type()
            ),
        ));
    }
    let cast = arrow::compute::cast(column, &DataType::Int64)
        .map_err(|e| Error::input(path, format!("column '{name}': {e}")))?;
    cast.as_primitive::<Int64Type>()
        .iter()
        .enumerate()
        .map(|(i, v)| match v {
            Some(v) if v >= 0 => Ok(v as usize),
            Some(v) => Err(Error::input(
                path,
                format!("record {i}: '{name}' is {v}, expected >= 0"),
            )),
            None => Err(Error::input(path, format!("record {i}: '{name}' is null"))),
        })
        .collect()
}

fn numbers(path: &Path, column: &dyn Array, name: &str) -> Result<Vec<f64>> {
    if !column.data_type().is_numeric() {
        return Err(Error::input(
            path,
            format!(
                "column '{name}' has type {}, expected numbers",
                column.data_type()
            ),
        ));
    }
    let cast = arrow::compute::cast(column, &DataType::Float64)
        .map_err(|e| Error::input(path, format!("column '{name}': {e}")))?;
    cast.as_primitive::<Float64Type>()
        .iter()
        .enumerate()
        .map(|(i, v)| match v {
            Some(v) if v.is_finite() => Ok(v),
            Some(v) => Err(Error::input(
                path,
                format!("record {i}: '{name}' is {v}, expected a finite number"),
            )),
            None => Err(Error::input(path, format!("record {i}: '{name}' is null"))),
        })
        .collect()
}

/// The MDP of `states` states from a transitions table.
pub fn read_transitions(path: &Path, states: usize) -> Result<TabularMdp> {
    let batch = read_table(path, TRANSITIONS, true)?.batch;
    let (s, a, n) = (
        integers(path, &batch, "state")?,
        integers(path, &batch, "action")?,
        integers(path, &batch, "next_state")?,
    );
    let column = batch
        .column_by_name("prob")
        .ok_or_else(|| Error::input(path, "has no column 'prob'"))?;
    let p = numbers(path, column.as_ref(), "prob")?;
    let actions = a.iter().max().map_or(0, |m| m + 1);
    let rows = (0..s.len()).map(|i| (s[i], a[i], n[i], p[i]));
    TabularMdp::new(states, actions, rows).map_err(|e| Error::input(path, e))
}

/// Per-state features: (row-major values, names); every state 0..n exactly once.
pub fn read_state_features(path: &Path) -> Result<(Vec<f64>, Vec<String>, usize)> {
    let batch = read_table(path, FEATURES, true)?.batch;
    let states = integers(path, &batch, "state")?;
    let count = states.len();
    let mut order = vec![usize::MAX; count];
    for (row, &s) in states.iter().enumerate() {
        if s >= count || order[s] != usize::MAX {
            return Err(Error::input(
                path,
                format!(
                    "record {row}: state {s} is repeated or outside 0..{count}: each state needs one row"
                ),
            ));
        }
        order[s] = row;
    }
    let schema = batch.schema();
    let names: Vec<String> = schema
        .fields()
        .iter()
        .map(|f| f.name().clone())
        .filter(|n| n != "state")
        .collect();
    if names.is_empty() {
        return Err(Error::input(path, "has no feature columns besides 'state'"));
    }
    let columns = names
        .iter()
        .map(|n| numbers(path, batch.column_by_name(n).expect("listed").as_ref(), n))
        .collect::<Result<Vec<_>>>()?;
    let mut values = vec![0.0; count * names.len()];
    for (s, &row) in order.iter().enumerate() {
        for (j, column) in columns.iter().enumerate() {
            values[s * names.len() + j] = column[row];
        }
    }
    Ok((values, names, count))
}

/// Demonstrations: rows of a trajectory consecutive, in increasing `t`.
pub fn read_trajectories(path: &Path, states: usize) -> Result<Vec<Trajectory>> {
    let batch = read_table(path, TRAJECTORIES, true)?.batch;
    let ids = integers(path, &batch, "trajectory")?;
    let visited = integers(path, &batch, "state")?;
    let t = numbers(
        path,
        batch
            .column_by_name("t")
            .ok_or_else(|| Error::input(path, "has no column 't'"))?
            .as_ref(),
        "t",
    )?;
    let mut trajectories: Vec<(usize, f64, Trajectory)> = Vec::new();
    for i in 0..ids.len() {
        if visited[i] >= states {
            return Err(Error::input(
                path,
                format!(
                    "record {i}: state {} is outside the MDP's {states} states",
                    visited[i]
                ),
            ));
        }
        match trajectories.last_mut() {
            Some((id, last_t, trajectory)) if *id == ids[i] => {
                if t[i] <= *last_t {
                    return Err(Error::input(
                        path,
                        format!("record {i}: trajectory {} goes back in time", ids[i]),
                    ));
                }
                *last_t = t[i];
                trajectory.states.push(visited[i]);
            }
            _ => {
                if trajectories.iter().any(|(id, _, _)| *id == ids[i]) {
                    return Err(Error::input(
                        path,
                        format!(
                            "record {i}: rows of trajectory {} are not consecutive",
                            ids[i]
                        ),
                    ));
                }
                trajectories.push((
                    ids[i],
                    t[i],
                    Trajectory {
                        states: vec![visited[i]],
                        actions: Vec::new(),
                    },
                ));
            }
        }
    }
    if trajectories.is_empty() {
        return Err(Error::input(path, "holds no demonstrations"));
    }
    Ok(trajectories.into_iter().map(|(_, _, t)| t).collect())
}
