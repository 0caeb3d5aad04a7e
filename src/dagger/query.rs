//! The query layer over DAgger data, in polars: the as-of join that aligns a log's topics
//! by time, and scans of a dataset's round partitions for per-round statistics.
//!
//! arrow-rs writes and reads the tables (`dataset.rs`); polars only queries them. They
//! meet at the Parquet files, so neither knows the other's types.

use std::path::{Path, PathBuf};

use polars::prelude::*;
use serde::Serialize;

use crate::error::{Error, Result};

/// For each of the sorted times `left`, the index into the sorted times `right` of the
/// nearest one at most `tolerance` away (a polars as-of join, strategy "nearest"), or
/// `None` where there is none.
pub fn nearest_within(left: &[u64], right: &[u64], tolerance: u64) -> Result<Vec<Option<usize>>> {
    let fail = |e: PolarsError| Error::Failed(format!("aligning topics by time: {e}"));
    // Nanosecond log times fit i64 until the year 2262.
    let times = |t: &[u64]| t.iter().map(|&t| t as i64).collect::<Vec<_>>();
    let left_frame = df!("t" => times(left)).map_err(fail)?;
    let right_frame = df!(
        "t" => times(right),
        "right" => (0..right.len() as u64).collect::<Vec<_>>(),
    )
    .map_err(fail)?;
    let options = AsOfOptions {
        strategy: AsofStrategy::Nearest,
        tolerance: Some(Scalar::from(tolerance.min(i64::MAX as u64) as i64)),
        allow_eq: true,
        check_sortedness: true,
        ..Default::default()
    };
    let joined = left_frame
        .lazy()
        .join_builder()
        .with(right_frame.lazy())
        .left_on([col("t")])
        .right_on([col("t")])
        .how(JoinType::AsOf(Box::new(options)))
        .finish()
        .collect()
        .map_err(fail)?;
    let matched = joined.column("right").map_err(fail)?.u64().map_err(fail)?;
    Ok(matched.iter().map(|i| i.map(|i| i as usize)).collect())
}

/// What one round's steps say, beyond the counts in `meta/rounds.parquet`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RoundStatistics {
    #[serde(skip)]
    pub round: u32,
    /// Root mean square of (executed − teacher) over the learner's steps (and over
    /// the action's numbers): how far the learner's own actions were from the teacher's,
    /// where it drove. `None` when the teacher drove every step.
    pub learner_disagreement: Option<f64>,
    /// For an action of several numbers: the same per number, in the dataset's order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub learner_disagreement_per_action: Vec<Option<f64>>,
    /// Per observation value: mean and standard deviation over the round's steps
    /// (the state distribution the round visited).
    pub observation_mean: Vec<f64>,
    pub observation_std: Vec<f64>,
}

/// Per-round statistics over the partitions `files` (one per round) of the dataset in
/// `dataset`, whose observations have `dims` values and actions `actions`: one lazy
/// scan, grouped by round, in round order.
pub fn round_statistics(
    dataset: &Path,
    files: &[PathBuf],
    dims: usize,
    actions: usize,
) -> Result<Vec<RoundStatistics>> {
    if files.is_empty() {
        return Ok(Vec::new());
    }
    let fail = |e: PolarsError| Error::input(dataset, format!("reading its rounds: {e}"));
    let paths = files
        .iter()
        .map(|p| utf8_path(p).map(PlRefPath::new))
        .collect::<Result<Vec<_>>>()?;
    let mut args = ScanArgsParquet::default();
    // Rounds are `round=NNN` folders, but the files hold their `round` column already.
    args.hive_options.enabled = Some(false);
    let steps = LazyFrame::scan_parquet_files(paths.into_iter().collect(), args).map_err(fail)?;
    let element = |column: &str, k: usize| {
        col(column)
            .arr()
            .get(lit(k as i64), false)
            .cast(DataType::Float64)
    };
    let learner = col("actor").eq(lit("learner"));
    let mut aggregates: Vec<Expr> = (0..actions)
        .map(|j| {
            let error = element("action_executed", j) - element("action", j);
            (error.clone() * error)
                .filter(learner.clone())
                .mean()
                .alias(format!("learner_mse_{j}"))
        })
        .collect();
    let observation = |k: usize| element("observation.state", k);
    for k in 0..dims {
        aggregates.push(observation(k).mean().alias(format!("mean_{k}")));
        aggregates.push(observation(k).std(1).alias(format!("std_{k}")));
    }
    // The streaming engine reads the partitions in batches: memory stays bounded by the
    // groups (one per round), not the dataset.
    let table = steps
        .group_by([col("round")])
        .agg(aggregates)
        .sort(["round"], SortMultipleOptions::default())
        .collect_with_engine(Engine::Streaming)
        .map_err(fail)?
        // One query, one table (several come only from multi-sink plans).
        .unwrap_single();
    let floats = |name: &str| -> Result<Vec<Option<f64>>> {
        let column = table
            .column(name)
            .and_then(|c| c.cast(&DataType::Float64))
            .map_err(fail)?;
        Ok(column.f64().map_err(fail)?.iter().collect())
    };
    let rounds = floats("round")?;
    let mse = (0..actions)
        .map(|j| floats(&format!("learner_mse_{j}")))
        .collect::<Result<Vec<_>>>()?;
    let means = (0..dims)
        .map(|k| floats(&format!("mean_{k}")))
        .collect::<Result<Vec<_>>>()?;
    let stds = (0..dims)
        .map(|k| floats(&format!("std_{k}")))
        .collect::<Result<Vec<_>>>()?;
    Ok((0..table.height())
        .map(|r| RoundStatistics {
            round: rounds[r].unwrap_or(0.0) as u32,
            learner_disagreement: mse
                .iter()
                .map(|m| m[r])
                .sum::<Option<f64>>()
                .map(|total| (total / actions as f64).sqrt()),
            learner_disagreement_per_action: if actions > 1 {
                mse.iter().map(|m| m[r].map(f64::sqrt)).collect()
            } else {
                Vec::new()
            },
            observation_mean: means.iter().map(|m| m[r].unwrap_or(f64::NAN)).collect(),
            observation_std: stds.iter().map(|s| s[r].unwrap_or(0.0)).collect(),
        })
        .collect())
}

fn utf8_path(path: &Path) -> Result<&str> {
    path.to_str()
        .ok_or_else(|| Error::input(path, "is not a UTF-8 path (polars scans need one)"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_within_tolerance_prefers_the_closer() {
        let times = [10, 20, 30];
        let found = nearest_within(&[0, 24, 26, 40], &times, 5).unwrap();
        assert_eq!(found, [None, Some(1), Some(2), None]);
        assert_eq!(
            nearest_within(&[0, 5], &times, 10).unwrap(),
            [Some(0), Some(0)]
        );
        assert_eq!(nearest_within(&[5], &[], 10).unwrap(), [None]);
        assert_eq!(nearest_within(&[], &times, 10).unwrap(), []);
    }

    #[test]
    fn an_exact_match_wins() {
        let found = nearest_within(&[20], &[10, 20, 21], 100).unwrap();
        assert_eq!(found, [Some(1)]);
    }
}
