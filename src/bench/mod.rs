//! The measured runs behind BENCHMARKS.md (`imitate bench ...`; the commands are in
//! `cli::bench`): each harness times the library's own code on real or generated data,
//! often beside a peer, and reports text for people or `--json` (with a schema tag) for
//! scripts. This module holds the small harnesses and what they share.

pub mod dagger_scale;
pub mod gridnav;
pub mod ingest;
pub mod ioc_methods;
pub mod learch;
pub mod objectworld;
pub mod terrain;
pub mod track;
pub mod verify;

use std::path::PathBuf;
use std::time::Instant;

use serde::Serialize;

use crate::cli::emit;
use crate::error::{Error, Result, read_input};
use crate::features::{FeatureSpec, Op, compute};
use crate::grid::{Cell, GeoRef, Grid};
use crate::io::fs::{to_json_bytes, write_bytes_atomic};
use crate::io::movingai::{read_map, read_scenarios};
use crate::plan::{Connectivity, GridPlanner, Moves, SearchKind};
use crate::sim::{WorldConfig, generate_world};

const TOLERANCE: f64 = 1e-4;

#[derive(Serialize)]
struct MovingAiReport {
    schema: &'static str,
    map: String,
    planner: SearchKind,
    scenarios: usize,
    mismatches: usize,
    first_mismatches: Vec<Mismatch>,
    total_seconds: f64,
    microseconds_per_query: f64,
}

#[derive(Serialize)]
struct Mismatch {
    line: usize,
    start: Cell,
    goal: Cell,
    optimal: f64,
    found: Option<f64>,
}

pub fn movingai(
    map_path: PathBuf,
    scen_path: PathBuf,
    planner_kind: SearchKind,
    json: bool,
) -> Result<()> {
    let map = read_map(&map_path)?;
    let scenarios = read_scenarios(&scen_path, &map.geo)?;
    let moves = Moves {
        connectivity: Connectivity::Eight,
        corner_cutting: false,
    };
    let mut planner = GridPlanner::new(&map, moves);
    let started = Instant::now();
    let found: Vec<Option<f64>> = scenarios
        .iter()
        .map(|s| match planner_kind {
            SearchKind::Astar => planner.astar(s.start, s.goal),
            SearchKind::Dijkstra => planner.dijkstra(s.start, s.goal),
        })
        .map(|route| route.map(|r| r.cost))
        .collect();
    let elapsed = started.elapsed().as_secs_f64();
    let mismatched: Vec<Mismatch> = scenarios
        .iter()
        .zip(&found)
        .enumerate()
        .filter(|(_, (s, f))| !matches_scenario(s.optimal_length, s.start != s.goal, **f))
        .map(|(i, (s, &f))| Mismatch {
            line: i + 2,
            start: s.start,
            goal: s.goal,
            optimal: s.optimal_length,
            found: f,
        })
        .collect();
    let report = MovingAiReport {
        schema: "imitate.bench.movingai/1",
        map: map_path.display().to_string(),
        planner: planner_kind,
        scenarios: scenarios.len(),
        mismatches: mismatched.len(),
        first_mismatches: mismatched.into_iter().take(10).collect(),
        total_seconds: elapsed,
        microseconds_per_query: 1e6 * elapsed / scenarios.len().max(1) as f64,
    };
    emit(&report, json, |report| {
        let mut text = format!(
            "{}: {} scenarios, {} mismatches, {:.1} µs per query ({:.3} s in all)",
            report.map,
            report.scenarios,
            report.mismatches,
            report.microseconds_per_query,
            report.total_seconds
        );
        for m in &report.first_mismatches {
            text.push_str(&format!(
                "\n  line {}: {} -> {}: optimal {}, found {:?}",
                m.line, m.start, m.goal, m.optimal, m.found
            ));
        }
        text
    });
    if report.mismatches > 0 {
        return Err(Error::Failed(format!(
            "{} scenarios do not match their optimal length",
            report.mismatches
        )));
    }
    Ok(())
}

pub fn read_raw_costs(path: &std::path::Path, width: u32, height: u32) -> Result<Grid<f32>> {
    let bytes = read_input(path)?;
    let n = width as usize * height as usize;
    if n == 0 || bytes.len() != n * 4 {
        return Err(Error::input(
            path,
            format!(
                "holds {} bytes; a {width}x{height} grid of f32 needs {}",
                bytes.len(),
                n * 4
            ),
        ));
    }
    let data = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    Ok(Grid::from_vec(geo(width, height), data))
}

fn geo(width: u32, height: u32) -> GeoRef {
    GeoRef {
        width,
        height,
        resolution: 1.0,
        resolution_y: None,
        origin: [0.0, 0.0],
        frame: "bench".into(),
        degrees: false,
        web_mercator: false,
        ground_scale: None,
        tiff_crs: None,
    }
}

pub fn uniform_costs(size: u32, seed: u64) -> Grid<f32> {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let n = size as usize * size as usize;
    Grid::from_vec(
        geo(size, size),
        (0..n).map(|_| rng.random_range(1.0f32..10.0)).collect(),
    )
}

#[derive(Serialize)]
struct DijkstraReport {
    schema: &'static str,
    width: u32,
    height: u32,
    connectivity: Connectivity,
    repeat: usize,
    best_seconds: f64,
    median_seconds: f64,
    reached: usize,
    /// Sum of all finite costs-to-go, to compare with another implementation.
    cost_sum: f64,
    max_cost: f64,
}

pub fn dijkstra(
    grid: &Grid<f32>,
    repeat: usize,
    connectivity: Connectivity,
    json: bool,
) -> Result<()> {
    let moves = Moves {
        connectivity,
        corner_cutting: true,
    };
    let mut times = Vec::with_capacity(repeat);
    let mut field = None;
    for _ in 0..repeat {
        let started = Instant::now();
        // Building the planner (padding the costmap) is part of the measured work.
        let result = GridPlanner::new(grid, moves).into_cost_to_go(&[Cell::new(0, 0)]);
        times.push(started.elapsed().as_secs_f64());
        field = Some(result);
    }
    let field = field.expect("repeat >= 1");
    times.sort_by(f64::total_cmp);
    let finite: Vec<f64> = field.costs().filter(|c| c.is_finite()).collect();
    let report = DijkstraReport {
        schema: "imitate.bench.dijkstra/1",
        width: grid.geo.width,
        height: grid.geo.height,
        connectivity,
        repeat,
        best_seconds: times[0],
        median_seconds: times[times.len() / 2],
        reached: finite.len(),
        cost_sum: finite.iter().sum(),
        max_cost: finite.iter().copied().fold(0.0, f64::max),
    };
    emit(&report, json, |report| {
        format!(
            "dijkstra {}x{} ({:?}-connected): best {:.4} s, median {:.4} s over {} runs; {} cells reached",
            report.width,
            report.height,
            connectivity,
            report.best_seconds,
            report.median_seconds,
            repeat,
            report.reached
        )
    });
    Ok(())
}

/// The benchmark's feature spec: the operators of every kind over 4 layers.
fn bench_feature_spec() -> FeatureSpec {
    let op =
        |json: serde_json::Value| serde_json::from_value::<Op>(json).expect("a valid operator");
    use serde_json::json;
    FeatureSpec {
        layers: Some(
            ["elevation", "vegetation", "water", "road"]
                .map(String::from)
                .to_vec(),
        ),
        ops: vec![
            op(json!({"op": "blur", "layer": "elevation", "sigmas": [1, 2, 4, 8]})),
            op(json!({"op": "gradient", "layer": "elevation"})),
            op(json!({"op": "slope", "layer": "elevation"})),
            op(json!({"op": "roughness", "layer": "elevation", "windows": [3, 7, 15]})),
            op(json!({"op": "laplacian", "layer": "elevation"})),
            op(json!({"op": "normalize", "layer": "elevation"})),
            op(json!({"op": "threshold", "layer": "elevation", "above": [10, 20]})),
            op(json!({"op": "normalize", "layer": "vegetation"})),
            op(json!({"op": "blur", "layer": "vegetation", "sigmas": [2, 8]})),
            op(json!({"op": "roughness", "layer": "vegetation", "windows": [7]})),
            op(json!({"op": "threshold", "layer": "vegetation", "above": [0.3, 0.6]})),
            op(json!({"op": "one_hot", "layer": "water", "classes": [0, 1]})),
            op(json!({"op": "distance", "layer": "water", "above": 0.5})),
            op(json!({"op": "blur", "layer": "water", "sigmas": [4]})),
            op(json!({"op": "one_hot", "layer": "road", "classes": [1]})),
            op(json!({"op": "distance", "layer": "road", "class": 1})),
            op(json!({"op": "blur", "layer": "road", "sigmas": [4]})),
            op(json!({"op": "product", "a": "vegetation", "b": "elevation/slope_deg"})),
        ],
        bias: true,
        nodata_fill: 0.0,
        bank: None,
    }
}

/// Resident memory now and at its peak (bytes), from /proc/self/status.
pub fn memory() -> (u64, u64) {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let field = |key: &str| {
        status
            .lines()
            .find(|l| l.starts_with(key))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse::<u64>().ok())
            .unwrap_or(0)
            * 1024
    };
    (field("VmRSS:"), field("VmHWM:"))
}

/// Resets the peak-memory mark so that the next reading covers what follows.
pub fn reset_peak_memory() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

#[derive(Serialize)]
struct FeatureSummary {
    name: String,
    mean: f64,
}

#[derive(Serialize)]
struct FeaturesReport {
    schema: &'static str,
    size: u32,
    threads: usize,
    features: Vec<FeatureSummary>,
    best_seconds: f64,
    output_bytes: u64,
    peak_extra_bytes: u64,
    peak_over_output: f64,
}

pub fn features(
    size: u32,
    repeat: usize,
    dump: Option<PathBuf>,
    bank: Option<crate::features::Bank>,
    json: bool,
) -> Result<()> {
    let config = WorldConfig {
        maps: 1,
        width: size,
        height: size,
        demonstrations_per_map: 0,
        ..WorldConfig::default()
    };
    let map = generate_world(&config)
        .map_err(Error::Usage)?
        .maps
        .remove(0);
    let spec = match bank {
        Some(bank) => FeatureSpec {
            layers: None,
            ops: Vec::new(),
            bias: true,
            nodata_fill: 0.0,
            bank: Some(bank),
        },
        None => bench_feature_spec(),
    };
    if let Some(dir) = &dump {
        for layer in &map.layers {
            let bytes: Vec<u8> = layer.values.iter().flat_map(|v| v.to_le_bytes()).collect();
            write_bytes_atomic(&dir.join(format!("{}.f32", layer.name)), &bytes)?;
        }
        let meta = serde_json::json!({"width": size, "height": size, "resolution": map.geo.resolution, "spec": spec});
        write_bytes_atomic(&dir.join("spec.json"), &to_json_bytes(&meta))?;
    }
    let mut best = f64::INFINITY;
    let mut last = None;
    let mut peak_extra = 0;
    for _ in 0..repeat {
        drop(last.take());
        let (before, _) = memory();
        reset_peak_memory();
        let started = Instant::now();
        let stack = compute(&map, &spec).map_err(Error::Failed)?;
        best = best.min(started.elapsed().as_secs_f64());
        let (_, peak) = memory();
        peak_extra = peak.saturating_sub(before);
        last = Some(stack);
    }
    let stack = last.expect("repeat >= 1");
    let output_bytes = (stack.data.len() * 4) as u64;
    let report = FeaturesReport {
        schema: "imitate.bench.features/1",
        size,
        threads: rayon::current_num_threads(),
        features: stack
            .names
            .iter()
            .zip(stack.planes())
            .map(|(name, plane)| FeatureSummary {
                name: name.clone(),
                mean: plane.iter().map(|&v| f64::from(v)).sum::<f64>() / plane.len() as f64,
            })
            .collect(),
        best_seconds: best,
        output_bytes,
        peak_extra_bytes: peak_extra,
        peak_over_output: peak_extra as f64 / output_bytes as f64,
    };
    emit(&report, json, |report| {
        format!(
            "features {size}x{size}: {} features in {:.3} s (best of {repeat}, {} threads); output {:.0} MiB, peak extra memory {:.0} MiB ({:.2}x the output)",
            report.features.len(),
            best,
            report.threads,
            output_bytes as f64 / (1 << 20) as f64,
            peak_extra as f64 / (1 << 20) as f64,
            report.peak_over_output
        )
    });
    Ok(())
}

#[derive(Serialize)]
struct HashReport {
    schema: &'static str,
    bytes: u64,
    best_seconds: f64,
    gib_per_second: f64,
}

pub fn hash(file: Option<PathBuf>, size_mib: usize, repeat: usize, json: bool) -> Result<()> {
    let scratch =
        tempfile::NamedTempFile::new().map_err(|e| Error::io("creating a temporary file", e))?;
    let path = match file {
        Some(path) => path,
        None => {
            use rand::{RngExt, SeedableRng};
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
            let mut block = vec![0u8; 1 << 20];
            let mut out = std::io::BufWriter::new(scratch.as_file());
            for _ in 0..size_mib {
                rng.fill(&mut block[..]);
                std::io::Write::write_all(&mut out, &block)
                    .map_err(|e| Error::io("writing the file to hash", e))?;
            }
            std::io::Write::flush(&mut out)
                .map_err(|e| Error::io("writing the file to hash", e))?;
            scratch.path().to_path_buf()
        }
    };
    let mut best = f64::INFINITY;
    let mut bytes = 0;
    for _ in 0..repeat {
        let started = Instant::now();
        bytes = crate::io::fs::file_digest(&path)?.1;
        best = best.min(started.elapsed().as_secs_f64());
    }
    let report = HashReport {
        schema: "imitate.bench.hash/1",
        bytes,
        best_seconds: best,
        gib_per_second: bytes as f64 / best / f64::from(1u32 << 30),
    };
    emit(&report, json, |r| {
        format!(
            "hashed {} MiB in {:.3} s: {:.2} GiB/s (best of {repeat}, file in the page cache)",
            r.bytes >> 20,
            r.best_seconds,
            r.gib_per_second
        )
    });
    Ok(())
}

/// Whether a found cost answers a scenario. An optimal length of 0 between distinct
/// cells is the benchmark's way of saying there is no path (GPPC scenario files), and
/// then finding none is right.
fn matches_scenario(optimal: f64, distinct: bool, found: Option<f64>) -> bool {
    match found {
        None => distinct && optimal == 0.0,
        Some(cost) => (cost - optimal).abs() <= TOLERANCE * optimal.max(1.0),
    }
}

#[cfg(test)]
mod tests {
    use super::matches_scenario;

    #[test]
    fn zero_length_between_distinct_cells_means_no_path() {
        assert!(matches_scenario(0.0, true, None));
        assert!(!matches_scenario(0.0, true, Some(3.0)));
        assert!(!matches_scenario(5.0, true, None));
        assert!(matches_scenario(5.0, true, Some(5.0)));
        assert!(matches_scenario(0.0, false, Some(0.0)));
        assert!(!matches_scenario(0.0, false, None));
    }
}
