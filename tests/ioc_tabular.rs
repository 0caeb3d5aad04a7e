//! `imitate ioc` on a tabular MDP given as Parquet tables, as a user runs it.

mod common;

use std::path::Path;
use std::sync::Arc;

use arrow::array::{ArrayRef, Float64Array, Int64Array, RecordBatch};
use arrow::datatypes::{Field, Schema};
use common::*;

fn write(path: &Path, columns: Vec<(&str, ArrayRef)>) {
    let schema = Schema::new(
        columns
            .iter()
            .map(|(n, a)| Field::new(*n, a.data_type().clone(), false))
            .collect::<Vec<_>>(),
    );
    let batch = RecordBatch::try_new(
        Arc::new(schema),
        columns.into_iter().map(|(_, a)| a).collect(),
    )
    .unwrap();
    let file = std::fs::File::create(path).unwrap();
    let mut writer = parquet::arrow::ArrowWriter::try_new(file, batch.schema(), None).unwrap();
    writer.write(&batch).unwrap();
    writer.close().unwrap();
}

fn ints(values: impl IntoIterator<Item = i64>) -> ArrayRef {
    Arc::new(Int64Array::from_iter_values(values))
}

fn floats(values: impl IntoIterator<Item = f64>) -> ArrayRef {
    Arc::new(Float64Array::from_iter_values(values))
}

const STATES: i64 = 7;

/// A chain: action 0 steps left, 1 steps right (clamped); one-hot features; the expert
/// walks right to the end and stays.
fn chain(dir: &Path, prob_right: f64) {
    let mut rows = Vec::new();
    for s in 0..STATES {
        rows.push((s, 0, (s - 1).max(0), 1.0));
        rows.push((s, 1, (s + 1).min(STATES - 1), prob_right));
        if prob_right < 1.0 {
            rows.push((s, 1, s, 1.0 - prob_right));
        }
    }
    write(
        &dir.join("transitions.parquet"),
        vec![
            ("state", ints(rows.iter().map(|r| r.0))),
            ("action", ints(rows.iter().map(|r| r.1))),
            ("next_state", ints(rows.iter().map(|r| r.2))),
            ("prob", floats(rows.iter().map(|r| r.3))),
        ],
    );
    let mut features: Vec<(String, ArrayRef)> = vec![("state".into(), ints(0..STATES))];
    for k in 0..STATES {
        features.push((
            format!("at_{k}"),
            floats((0..STATES).map(|s| f64::from(s == k))),
        ));
    }
    write(
        &dir.join("features.parquet"),
        features
            .iter()
            .map(|(n, a)| (n.as_str(), a.clone()))
            .collect(),
    );
    let mut demo = Vec::new();
    for (id, start) in [0, 2, 1, 4, 0, 3].into_iter().enumerate() {
        for t in 0..8 {
            demo.push((id as i64, t as f64, (start + t).min(STATES - 1)));
        }
    }
    write(
        &dir.join("demos.parquet"),
        vec![
            ("trajectory", ints(demo.iter().map(|r| r.0))),
            ("t", floats(demo.iter().map(|r| r.1))),
            ("state", ints(demo.iter().map(|r| r.2))),
        ],
    );
}

fn ioc(dir: &Path, method: &str, out: &str) -> std::process::Output {
    imitate(
        dir,
        &[
            "ioc",
            "--transitions",
            "transitions.parquet",
            "--features",
            "features.parquet",
            "--demonstrations",
            "demos.parquet",
            "--method",
            method,
            "--out",
            out,
        ],
    )
}

#[test]
fn every_method_learns_to_walk_the_chain_like_the_expert() {
    let dir = tempfile::tempdir().unwrap();
    chain(dir.path(), 1.0);
    for method in ["learch-linear", "learch-tree", "mmp", "maxent"] {
        let out = ioc(dir.path(), method, method);
        assert!(out.status.success(), "{method}: {}", stderr(&out));
        let table = imitate::io::tables::read_numeric_table(
            &dir.path().join(method).join("reward.parquet"),
            imitate::io::tables::Table::LEARNED_REWARD,
            &["state", "reward", "action"],
        )
        .unwrap();
        let (reward, action) = (&table[1], &table[2]);
        // The end of the chain is where the expert goes: its reward is the highest, and
        // the learned reward's optimal policy steps right from every other state.
        let best = reward.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(reward[STATES as usize - 1], best, "{method}: {reward:?}");
        for s in 0..STATES as usize - 1 {
            assert_eq!(action[s], 1.0, "{method}: state {s}: {action:?}");
        }
    }
}

#[test]
fn bad_tables_are_input_errors() {
    let dir = tempfile::tempdir().unwrap();
    chain(dir.path(), 0.8);
    // "step right" now sums to 0.8 + 0.2 = 1: fine. Break it.
    let out = ioc(dir.path(), "maxent", "ok");
    assert!(out.status.success(), "{}", stderr(&out));
    write(
        &dir.path().join("transitions.parquet"),
        vec![
            ("state", ints([0, 0])),
            ("action", ints([0, 0])),
            ("next_state", ints([1, 2])),
            ("prob", floats([0.5, 0.4])),
        ],
    );
    let out = ioc(dir.path(), "maxent", "bad");
    assert_input_error(&out, &["transitions.parquet", "sum to"]);
    chain(dir.path(), 1.0);
    write(
        &dir.path().join("demos.parquet"),
        vec![
            ("trajectory", ints([0, 0])),
            ("t", floats([0.0, 1.0])),
            ("state", ints([1, 99])),
        ],
    );
    let out = ioc(dir.path(), "maxent", "bad");
    assert_input_error(&out, &["demos.parquet", "record 1", "state 99"]);
    assert!(!dir.path().join("bad").exists());
}
