//! What changed between two artifacts: their files; for costmaps, the log-cost per map
//! (mean and largest change, share of cells changed, rank correlation), the plans on a
//! reference set of start/goal pairs (changed or not, Hausdorff distance, cost ratio)
//! and the held-out metrics. Thresholds on the summary turn a diff into a CI check.

use std::collections::BTreeMap;

use rayon::prelude::*;
use serde::Serialize;

use super::costmap_artifact::CostmapArtifact;
use crate::artifact::Manifest;
use crate::grid::{Cell, Grid};
use crate::plan::{path_cost, shortest_path};

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct FileChanges {
    pub added: Vec<String>,
    pub removed: Vec<String>,
    pub changed: Vec<String>,
    pub unchanged: usize,
}

/// Files by path, compared by digest.
pub fn file_changes(old: &Manifest, new: &Manifest) -> FileChanges {
    let old_files: BTreeMap<&str, &str> = old
        .files
        .iter()
        .map(|f| (f.path.as_str(), f.digest.as_str()))
        .collect();
    let new_files: BTreeMap<&str, &str> = new
        .files
        .iter()
        .map(|f| (f.path.as_str(), f.digest.as_str()))
        .collect();
    let mut changes = FileChanges {
        added: Vec::new(),
        removed: Vec::new(),
        changed: Vec::new(),
        unchanged: 0,
    };
    for (path, digest) in &old_files {
        match new_files.get(path) {
            None => changes.removed.push(path.to_string()),
            Some(d) if d != digest => changes.changed.push(path.to_string()),
            Some(_) => changes.unchanged += 1,
        }
    }
    changes.added = new_files
        .keys()
        .filter(|p| !old_files.contains_key(*p))
        .map(|p| p.to_string())
        .collect();
    changes
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct MapDiff {
    pub map: String,
    pub cells: usize,
    pub mean_abs_log_cost: f64,
    pub max_abs_log_cost: f64,
    /// Share of cells whose log-cost changed by more than the tolerance.
    pub changed_share: f64,
    /// Spearman rank correlation of the two costmaps' cells.
    pub rank_correlation: f64,
}

fn log_costs(grid: &Grid<f32>) -> Vec<f64> {
    grid.data
        .iter()
        .map(|&c| f64::from(c.max(f32::MIN_POSITIVE)).ln())
        .collect()
}

/// Ranks from 1, ties sharing their mean rank.
fn ranks(values: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    let mut ranks = vec![0.0; values.len()];
    let mut i = 0;
    while i < order.len() {
        let mut j = i;
        while j + 1 < order.len() && values[order[j + 1]] == values[order[i]] {
            j += 1;
        }
        let mean = (i + j) as f64 / 2.0 + 1.0;
        for &k in &order[i..=j] {
            ranks[k] = mean;
        }
        i = j + 1;
    }
    ranks
}

fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut cov, mut va, mut vb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        cov += (x - ma) * (y - mb);
        va += (x - ma) * (x - ma);
        vb += (y - mb) * (y - mb);
    }
    if va == 0.0 || vb == 0.0 {
        // A constant costmap: perfectly correlated only with one constant too.
        return if va == vb { 1.0 } else { 0.0 };
    }
    cov / (va * vb).sqrt()
}

/// Compares two costmaps of the same raster.
pub fn map_diff(map: &str, old: &Grid<f32>, new: &Grid<f32>, tolerance: f64) -> MapDiff {
    let (a, b) = (log_costs(old), log_costs(new));
    let deltas: Vec<f64> = a
        .iter()
        .zip(&b)
        .map(|(x, y)| {
            let d = (y - x).abs();
            if d.is_finite() { d } else { 0.0 }
        })
        .collect();
    let cells = deltas.len();
    MapDiff {
        map: map.to_string(),
        cells,
        mean_abs_log_cost: deltas.iter().sum::<f64>() / cells.max(1) as f64,
        max_abs_log_cost: deltas.iter().fold(0.0, |m, d| m.max(*d)),
        changed_share: deltas.iter().filter(|d| **d > tolerance).count() as f64
            / cells.max(1) as f64,
        rank_correlation: pearson(&ranks(&a), &ranks(&b)),
    }
}

/// The distribution of the signed log-cost change (new − old) over the cells both
/// costmaps can cross: `bins` equal bins spanning ± the largest change, as (bin centre,
/// share of those cells).
pub fn change_histogram(old: &Grid<f32>, new: &Grid<f32>, bins: usize) -> Vec<(f64, f64)> {
    let changes: Vec<f64> = (log_costs(old).iter().zip(&log_costs(new)))
        .map(|(x, y)| y - x)
        .filter(|d| d.is_finite())
        .collect();
    let reach = changes.iter().fold(0.0f64, |m, d| m.max(d.abs())).max(1e-9);
    let width = 2.0 * reach / bins as f64;
    let mut counts = vec![0usize; bins];
    for d in &changes {
        counts[(((d + reach) / width) as usize).min(bins - 1)] += 1;
    }
    let total = changes.len().max(1) as f64;
    (counts.iter().enumerate())
        .map(|(i, &n)| (-reach + (i as f64 + 0.5) * width, n as f64 / total))
        .collect()
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct PathDiff {
    pub example: String,
    pub map: String,
    pub start: [u32; 2],
    pub goal: [u32; 2],
    pub changed: bool,
    /// Largest distance (cells) from a cell of either plan to the other plan.
    pub hausdorff_cells: f64,
    /// Cost of the new plan over the old plan's, both under the old costmap (≥ 1 up to
    /// ties: how much worse the new plan is in the old costmap's view).
    pub cost_ratio: f64,
}

fn hausdorff(a: &[Cell], b: &[Cell]) -> f64 {
    let one_way = |from: &[Cell], to: &[Cell]| {
        from.iter()
            .map(|c| to.iter().map(|d| c.distance_squared(*d)).min().unwrap_or(0))
            .max()
            .unwrap_or(0)
    };
    (one_way(a, b).max(one_way(b, a)) as f64).sqrt()
}

/// Plans every reference pair on both costmaps; pairs whose map either lacks, or with no
/// path on one of them, are left out.
pub fn path_diffs(
    pairs: &[(String, String, Cell, Cell)],
    old: &CostmapArtifact,
    new: &CostmapArtifact,
) -> Vec<PathDiff> {
    pairs
        .par_iter()
        .filter_map(|(example, map, start, goal)| {
            let (a, b) = (old.costmap(map)?, new.costmap(map)?);
            if a.geo != b.geo {
                return None;
            }
            let old_plan = shortest_path(a, *start, *goal)?.cells;
            let new_plan = shortest_path(b, *start, *goal)?.cells;
            let old_cost = path_cost(a, &old_plan).max(f64::MIN_POSITIVE);
            Some(PathDiff {
                example: example.clone(),
                map: map.clone(),
                start: [start.row, start.col],
                goal: [goal.row, goal.col],
                changed: old_plan != new_plan,
                hausdorff_cells: hausdorff(&old_plan, &new_plan),
                cost_ratio: path_cost(a, &new_plan) / old_cost,
            })
        })
        .collect()
}

/// The reference start/goal pairs: the old artifact's held-out examples (all its
/// examples when none is held out, the new artifact's when the old stores none).
pub fn reference_pairs(
    old: &CostmapArtifact,
    new: &CostmapArtifact,
) -> Vec<(String, String, Cell, Cell)> {
    let source = if old.paths.is_empty() { new } else { old };
    let held: Vec<String> = source.holdout_names();
    source
        .paths
        .iter()
        .filter(|p| held.is_empty() || held.contains(&p.episode))
        .filter_map(|p| {
            let (first, last) = (p.cells.first()?, p.cells.last()?);
            Some((p.episode.clone(), p.map.clone(), *first, *last))
        })
        .collect()
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct MetricDelta {
    pub metric: String,
    pub old: Option<f64>,
    pub new: Option<f64>,
    pub delta: Option<f64>,
}

const HOLDOUT_METRICS: [&str; 3] = [
    "within_radius",
    "mean_reference_cost_ratio",
    "max_reference_cost_ratio",
];

pub fn metric_deltas(old: &CostmapArtifact, new: &CostmapArtifact) -> Vec<MetricDelta> {
    HOLDOUT_METRICS
        .iter()
        .map(|name| {
            let (a, b) = (old.holdout_metric(name), new.holdout_metric(name));
            MetricDelta {
                metric: format!("holdout.{name}"),
                old: a,
                new: b,
                delta: a.zip(b).map(|(a, b)| b - a),
            }
        })
        .collect()
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct CostmapDiff {
    pub maps: Vec<MapDiff>,
    pub maps_added: Vec<String>,
    pub maps_removed: Vec<String>,
    /// Maps whose rasters differ (size, resolution or origin): not compared cell by cell.
    pub maps_regridded: Vec<String>,
    pub paths: Vec<PathDiff>,
    pub metrics: Vec<MetricDelta>,
}

pub fn costmap_diff(old: &CostmapArtifact, new: &CostmapArtifact, tolerance: f64) -> CostmapDiff {
    let mut diff = CostmapDiff {
        maps: Vec::new(),
        maps_added: Vec::new(),
        maps_removed: Vec::new(),
        maps_regridded: Vec::new(),
        paths: Vec::new(),
        metrics: metric_deltas(old, new),
    };
    for (name, a) in &old.costmaps {
        match new.costmap(name) {
            None => diff.maps_removed.push(name.clone()),
            Some(b) if b.geo != a.geo => diff.maps_regridded.push(name.clone()),
            Some(b) => diff.maps.push(map_diff(name, a, b, tolerance)),
        }
    }
    diff.maps_added = new
        .costmaps
        .iter()
        .filter(|(n, _)| old.costmap(n).is_none())
        .map(|(n, _)| n.clone())
        .collect();
    diff.paths = path_diffs(&reference_pairs(old, new), old, new);
    diff
}

/// The numbers thresholds can test, by name.
pub fn summary(files: &FileChanges, costmaps: Option<&CostmapDiff>) -> BTreeMap<String, f64> {
    let mut s = BTreeMap::new();
    s.insert(
        "files_changed".into(),
        (files.added.len() + files.removed.len() + files.changed.len()) as f64,
    );
    let Some(d) = costmaps else {
        return s;
    };
    let cells: usize = d.maps.iter().map(|m| m.cells).sum();
    let weighted = |f: fn(&MapDiff) -> f64| {
        d.maps.iter().map(|m| f(m) * m.cells as f64).sum::<f64>() / cells.max(1) as f64
    };
    s.insert(
        "max_abs_log_cost".into(),
        d.maps
            .iter()
            .map(|m| m.max_abs_log_cost)
            .fold(0.0, f64::max),
    );
    s.insert(
        "mean_abs_log_cost".into(),
        weighted(|m| m.mean_abs_log_cost),
    );
    s.insert("changed_cells_share".into(), weighted(|m| m.changed_share));
    s.insert(
        "min_rank_correlation".into(),
        d.maps
            .iter()
            .map(|m| m.rank_correlation)
            .fold(1.0, f64::min),
    );
    s.insert(
        "maps_changed".into(),
        (d.maps_added.len()
            + d.maps_removed.len()
            + d.maps_regridded.len()
            + d.maps.iter().filter(|m| m.max_abs_log_cost > 0.0).count()) as f64,
    );
    let changed = d.paths.iter().filter(|p| p.changed).count();
    s.insert("reference_paths".into(), d.paths.len() as f64);
    s.insert("changed_paths".into(), changed as f64);
    s.insert(
        "changed_paths_share".into(),
        changed as f64 / d.paths.len().max(1) as f64,
    );
    s.insert(
        "max_hausdorff_cells".into(),
        d.paths
            .iter()
            .map(|p| p.hausdorff_cells)
            .fold(0.0, f64::max),
    );
    s.insert(
        "max_path_cost_ratio".into(),
        d.paths.iter().map(|p| p.cost_ratio).fold(1.0, f64::max),
    );
    for m in &d.metrics {
        if let Some(delta) = m.delta {
            s.insert(format!("delta_{}", m.metric.replace('.', "_")), delta);
        }
    }
    s
}

/// A threshold such as `max_abs_log_cost > 0.1`.
#[derive(Debug, Clone, PartialEq)]
pub struct Threshold {
    pub name: String,
    pub op: String,
    pub value: f64,
}

impl std::str::FromStr for Threshold {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        for op in [">=", "<=", "==", "!=", ">", "<"] {
            if let Some((name, value)) = text.split_once(op) {
                let value = value
                    .trim()
                    .parse::<f64>()
                    .map_err(|_| format!("'{text}': '{}' is not a number", value.trim()))?;
                return Ok(Threshold {
                    name: name.trim().to_string(),
                    op: op.to_string(),
                    value,
                });
            }
        }
        Err(format!(
            "'{text}' is not NAME OP NUMBER (OP one of > >= < <= == !=)"
        ))
    }
}

impl Threshold {
    /// Whether the summary crosses this threshold; an error for an unknown name.
    pub fn crossed(&self, summary: &BTreeMap<String, f64>) -> Result<Option<String>, String> {
        let value = *summary.get(&self.name).ok_or_else(|| {
            format!(
                "--fail-if '{}': no such number (known: {})",
                self.name,
                summary.keys().cloned().collect::<Vec<_>>().join(", ")
            )
        })?;
        let hit = match self.op.as_str() {
            ">" => value > self.value,
            ">=" => value >= self.value,
            "<" => value < self.value,
            "<=" => value <= self.value,
            "==" => value == self.value,
            _ => value != self.value,
        };
        Ok(hit.then(|| format!("{} is {value} {} {}", self.name, self.op, self.value)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GeoRef;

    fn grid(values: Vec<f32>) -> Grid<f32> {
        let geo = GeoRef::square(3, 1, 1.0, [0.0, 0.0], "m");
        Grid::from_vec(geo, values)
    }

    #[test]
    fn the_change_histogram_counts_cells_by_signed_change() {
        let geo = GeoRef::unit(4, 1);
        let old = Grid::from_vec(geo.clone(), vec![1.0, 1.0, 1.0, 1.0]);
        let new = Grid::from_vec(geo, vec![1.0, 1.0, std::f32::consts::E, f32::INFINITY]);
        // Three cells both can cross: two unchanged, one up by 1 in log-cost.
        let bins = change_histogram(&old, &new, 4);
        assert_eq!(bins.len(), 4);
        assert!((bins[0].0 + 0.75).abs() < 1e-6 && (bins[3].0 - 0.75).abs() < 1e-6);
        let shares: Vec<f64> = bins.iter().map(|b| b.1).collect();
        assert_eq!(shares, [0.0, 0.0, 2.0 / 3.0, 1.0 / 3.0]);
    }

    #[test]
    fn map_diff_measures_change_and_rank_agreement() {
        let old = grid(vec![1.0, 2.0, 4.0]);
        let same = map_diff("m", &old, &old, 0.01);
        assert_eq!(
            (
                same.max_abs_log_cost,
                same.changed_share,
                same.rank_correlation
            ),
            (0.0, 0.0, 1.0)
        );
        // Doubling every cost keeps the ranks: correlation 1, every cell changed by ln 2.
        let doubled = map_diff("m", &old, &grid(vec![2.0, 4.0, 8.0]), 0.01);
        assert!((doubled.max_abs_log_cost - 2f64.ln()).abs() < 1e-6);
        assert_eq!(doubled.changed_share, 1.0);
        assert!((doubled.rank_correlation - 1.0).abs() < 1e-12);
        let reversed = map_diff("m", &old, &grid(vec![4.0, 2.0, 1.0]), 0.01);
        assert!((reversed.rank_correlation + 1.0).abs() < 1e-12);
    }

    #[test]
    fn ranks_share_ties() {
        assert_eq!(ranks(&[3.0, 1.0, 3.0, 2.0]), vec![3.5, 1.0, 3.5, 2.0]);
    }

    #[test]
    fn thresholds_parse_and_compare() {
        let t: Threshold = "max_abs_log_cost > 0.1".parse().unwrap();
        let mut s = BTreeMap::new();
        s.insert("max_abs_log_cost".to_string(), 0.5);
        assert!(t.crossed(&s).unwrap().is_some());
        let t: Threshold = "max_abs_log_cost<=0.4".parse().unwrap();
        assert!(t.crossed(&s).unwrap().is_none());
        let t: Threshold = "nope > 1".parse().unwrap();
        assert!(t.crossed(&s).unwrap_err().contains("max_abs_log_cost"));
        assert!("max_abs_log_cost ~ 1".parse::<Threshold>().is_err());
        assert!("x > y".parse::<Threshold>().is_err());
    }

    #[test]
    fn hausdorff_is_the_largest_gap_either_way() {
        let a = [Cell::new(0, 0), Cell::new(0, 1), Cell::new(0, 2)];
        let b = [Cell::new(0, 0), Cell::new(3, 1), Cell::new(0, 2)];
        assert_eq!(hausdorff(&a, &a), 0.0);
        assert!((hausdorff(&a, &b) - 3.0).abs() < 1e-12);
    }
}
