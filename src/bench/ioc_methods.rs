//! `imitate bench ioc-methods`: held-out path agreement of every grid IOC method
//! (LEARCH with ridge and with trees, MMP, MaxEnt) on two terrains, trained and measured
//! the same way, as one table:
//! - `quickstart`: the synthetic world of `testdata/world` (4 maps of 64², log-linear
//!   true cost), with the quickstart's features;
//! - `geotiff`: a real raster (by default `../shared/data/raster/rasterio_shade.tif`,
//!   a hillshade mask: shadow cells hold 0, the rest no data) as the layer `shade`, the
//!   share of shadow cells in blocks that make about `--cells` cells a side, with a
//!   teacher whose cost is not log-linear in the features: 1 + 7 · shade, plus 3 within
//!   3 cells of a mostly shaded cell (a margin the features only give as a distance).

use std::path::PathBuf;
use std::time::Instant;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::cli::emit;
use crate::error::{Error, Result};
use crate::features::{FeatureSpec, Op, compute};
use crate::grid::{Cell, FeatureStack, GeoRef, Grid, Layer, Map, rasterize};
use crate::io::geotiff::read_geotiff;
use crate::ioc::{
    Corridor, CorridorChoice, Example, GridMethod, LearchConfig, TrainedLearch, WeakLearnerKind,
    choose_corridor, default_rounds_and_step, hold_out_every, learch_evaluate, summarize, train,
};
use crate::plan::shortest_path;
use crate::sim::{WorldConfig, generate_world};

#[derive(Debug, clap::Args)]
pub struct IocMethodsArgs {
    /// The raster of the second terrain (its first band is the layer).
    #[arg(long, default_value = "../shared/data/raster/rasterio_shade.tif")]
    pub geotiff: PathBuf,
    /// Cells a side of the raster terrain after block averaging.
    #[arg(long, default_value_t = 96)]
    pub cells: u32,
    /// Teacher demonstrations on the raster terrain.
    #[arg(long, default_value_t = 40)]
    pub demonstrations: usize,
    /// Rounds of every method (default: each method's own, as `learch` runs it).
    #[arg(long)]
    pub rounds: Option<usize>,
    #[arg(long)]
    pub json: bool,
}

/// One terrain's maps, features, demonstrations split into training and held out, and
/// true costs.
pub(super) struct Terrain {
    pub name: String,
    pub names: Vec<String>,
    pub stacks: Vec<FeatureStack>,
    pub training: Vec<Example>,
    pub holdout: Vec<Example>,
    pub truth: Vec<Grid<f32>>,
}

#[derive(Serialize)]
pub(super) struct MethodResult {
    pub terrain: String,
    pub method: &'static str,
    pub held_out: usize,
    pub within_radius: f64,
    pub mean_cost_ratio: f64,
    pub max_cost_ratio: f64,
    /// Rounds run by each model (the most of its members').
    pub rounds: usize,
    /// Models trained and averaged (LEARCH's members).
    pub models: usize,
    pub seconds: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub training_within_radius: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub training_mean_cost_ratio: Option<f64>,
    /// `bench terrain --hidden-cost-off-by`: the hidden cost's perturbation these
    /// plans were made on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub off_by: Option<OffBy>,
    /// `--corridor auto`: the corridor the kept model was trained with, and why.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub corridor: Option<CorridorChoice>,
}

/// A perturbation of the hidden cost: every cell's cost times e^(ε g), g a Gaussian
/// field of unit spread correlated over a Gaussian of σ `cells`.
#[derive(Debug, Clone, Copy, Serialize)]
pub(super) struct OffBy {
    pub epsilon: f64,
    pub cells: f64,
}

#[derive(Serialize)]
struct IocMethodsReport {
    schema: &'static str,
    results: Vec<MethodResult>,
}

fn op(json: serde_json::Value) -> Op {
    serde_json::from_value(json).expect("a valid operator")
}

fn quickstart() -> Result<Terrain> {
    let world = generate_world(&WorldConfig::default()).map_err(Error::Failed)?;
    let spec = FeatureSpec {
        layers: Some(
            ["elevation", "vegetation", "water", "road"]
                .map(String::from)
                .to_vec(),
        ),
        ops: Vec::new(),
        bias: true,
        nodata_fill: 0.0,
        bank: None,
    };
    let stacks = world
        .maps
        .iter()
        .map(|m| compute(m, &spec))
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(Error::Failed)?;
    let names: Vec<String> = world.maps.iter().map(|m| m.name.clone()).collect();
    let examples = world
        .demonstrations
        .iter()
        .map(|d| {
            let map = names.iter().position(|n| *n == d.map).expect("its own map");
            Example {
                id: d.episode.clone(),
                map,
                path: rasterize(&world.maps[map].geo, &d.xy()).expect("its own path"),
                waypoints: Vec::new(),
            }
        })
        .collect();
    let (training, holdout) = hold_out_every(examples, 4);
    Ok(Terrain {
        name: "quickstart".into(),
        names,
        stacks,
        training,
        holdout,
        truth: world.truth,
    })
}

/// The share of data cells of the raster's first band per block, the blocks chosen so
/// that the longer side has about `cells` cells.
fn pooled_raster(args: &IocMethodsArgs) -> Result<Map> {
    let map = read_geotiff(&args.geotiff, "shade")?;
    let band = &map.layers[0].values;
    let (w, h) = (map.geo.width as usize, map.geo.height as usize);
    let factor = (w.max(h) as u32).div_ceil(args.cells.max(8)).max(1) as usize;
    let (pw, ph) = (w / factor, h / factor);
    let mut pooled = vec![0.0f32; pw * ph];
    for (i, value) in pooled.iter_mut().enumerate() {
        let (r, c) = (i / pw, i % pw);
        let mut with_data = 0usize;
        for rr in r * factor..(r + 1) * factor {
            for cc in c * factor..(c + 1) * factor {
                with_data += usize::from(band[rr * w + cc].is_finite());
            }
        }
        *value = with_data as f32 / (factor * factor) as f32;
    }
    let geo = GeoRef {
        width: pw as u32,
        height: ph as u32,
        resolution: map.geo.resolution * factor as f64,
        ..map.geo.clone()
    };
    Ok(Map {
        name: "shade".into(),
        geo,
        layers: vec![Layer::new("shade", pooled)],
    })
}

fn raster(args: &IocMethodsArgs) -> Result<Terrain> {
    let map = pooled_raster(args)?;
    let geo = map.geo.clone();
    let spec = FeatureSpec {
        layers: Some(vec!["shade".into()]),
        ops: vec![
            op(
                serde_json::json!({"op": "blur", "layer": "shade", "sigmas": [2.0 * geo.resolution]}),
            ),
            op(serde_json::json!({"op": "distance", "layer": "shade", "above": 0.5})),
        ],
        bias: true,
        nodata_fill: 0.0,
        bank: None,
    };
    let stack = compute(&map, &spec).map_err(Error::Failed)?;
    let shade = &map.layers[0].values;
    let distance = stack
        .planes()
        .nth(2)
        .expect("shade, its blur, its distance, bias");
    let margin = 3.0 * geo.resolution as f32;
    let truth = Grid::from_vec(
        geo.clone(),
        shade
            .iter()
            .zip(distance)
            .map(|(&s, &d)| 1.0 + 7.0 * s + if d < margin { 3.0 } else { 0.0 })
            .collect(),
    );
    let examples = teacher_paths(&truth, args.demonstrations, 7, "shade-demo")?;
    let (training, holdout) = hold_out_every(examples, 4);
    Ok(Terrain {
        name: "geotiff".into(),
        names: vec![map.name.clone()],
        stacks: vec![stack],
        training,
        holdout,
        truth: vec![truth],
    })
}

/// Optimal paths on `truth` between `count` seeded random pairs of cells at least half
/// the map apart (a pair without a path is drawn again), named `<prefix>-NNN`.
pub(super) fn teacher_paths(
    truth: &Grid<f32>,
    count: usize,
    seed: u64,
    prefix: &str,
) -> Result<Vec<Example>> {
    let geo = &truth.geo;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let min_separation = 0.5 * f64::from(geo.width.min(geo.height));
    let mut examples = Vec::new();
    let mut draws = 0;
    while examples.len() < count {
        draws += 1;
        if draws > 100 * count {
            return Err(Error::Failed(format!(
                "no {count} pairs of cells half the map apart with a teacher path \
                 (the map is {} × {} cells)",
                geo.width, geo.height
            )));
        }
        let mut random_cell = || {
            Cell::new(
                rng.random_range(0..geo.height),
                rng.random_range(0..geo.width),
            )
        };
        let (a, b) = (random_cell(), random_cell());
        if (a.distance_squared(b) as f64).sqrt() < min_separation {
            continue;
        }
        if let Some(route) = shortest_path(truth, a, b) {
            examples.push(Example {
                id: format!("{prefix}-{:03}", examples.len()),
                map: 0,
                path: route.cells,
                waypoints: Vec::new(),
            });
        }
    }
    Ok(examples)
}

/// One line per terrain and method, the terrain's column `terrain_width` wide.
pub(super) fn results_table(results: &[MethodResult], terrain_width: usize) -> String {
    let mut text = format!(
        "{:<terrain_width$} {:<16} held out  within  mean ratio  max ratio  rounds  seconds\n",
        "terrain", "method"
    );
    for m in results {
        let method = match m.off_by {
            Some(off) => format!("hidden e^±{}", off.epsilon),
            None => m.method.to_string(),
        };
        text += &format!(
            "{:<terrain_width$} {:<16} {:>8}  {:>6.3}  {:>10.3}  {:>9.3}  {:>6}  {:>7.1}\n",
            m.terrain,
            method,
            m.held_out,
            m.within_radius,
            m.mean_cost_ratio,
            m.max_cost_ratio,
            m.rounds,
            m.seconds
        );
    }
    text
}

/// The methods compared, with the settings each runs with: `learch`'s defaults, and
/// `rounds` for every method when given.
pub(super) fn methods(rounds: Option<usize>) -> Vec<(&'static str, LearchConfig)> {
    let with = |method: GridMethod, weak_learner: WeakLearnerKind| {
        let (default_rounds, step_size) = default_rounds_and_step(method, weak_learner);
        LearchConfig {
            method,
            weak_learner,
            rounds: rounds.unwrap_or(default_rounds),
            step_size,
            ..LearchConfig::default()
        }
    };
    vec![
        (
            "learch-ridge",
            with(GridMethod::Learch, WeakLearnerKind::Ridge),
        ),
        (
            "learch-tree",
            with(GridMethod::Learch, WeakLearnerKind::Tree),
        ),
        (
            "learch-alternate",
            with(GridMethod::Learch, WeakLearnerKind::Alternate),
        ),
        ("mmp", with(GridMethod::Mmp, WeakLearnerKind::Ridge)),
        ("maxent", with(GridMethod::Maxent, WeakLearnerKind::Tree)),
        (
            "maxent-linear",
            with(GridMethod::Maxent, WeakLearnerKind::Ridge),
        ),
    ]
}

/// Trains `method` on the terrain's training pairs with `config`, its corridor as
/// `corridor` asks, and scores the held-out plans under the hidden cost.
pub(super) fn measure(
    terrain: &Terrain,
    method: &'static str,
    config: &LearchConfig,
    corridor: Corridor,
) -> Result<MethodResult> {
    let started = Instant::now();
    let evaluate = |trained: &TrainedLearch, examples: &[Example]| {
        learch_evaluate(
            &trained.model,
            &terrain.stacks,
            &terrain.names,
            examples,
            Some(&terrain.truth),
        )
        .map_err(Error::Failed)
    };
    let ((trained, training), choice) = choose_corridor(
        corridor,
        config.method,
        |cells| {
            let config = LearchConfig {
                corridor: cells,
                ..config.clone()
            };
            let trained = train(
                &terrain.stacks,
                &terrain.names,
                &terrain.training,
                &[],
                &[],
                None,
                &config,
                None,
                |_| {},
            )
            .map_err(Error::Failed)?;
            let training = evaluate(&trained, &terrain.training)?;
            Ok::<_, Error>((trained, training))
        },
        |(_, training)| training,
    )?;
    let seconds = started.elapsed().as_secs_f64();
    let agreement = summarize(&evaluate(&trained, &terrain.holdout)?);
    let training = summarize(&training);
    Ok(MethodResult {
        training_within_radius: Some(training.within_radius),
        training_mean_cost_ratio: training.mean_reference_cost_ratio,
        terrain: terrain.name.clone(),
        method,
        held_out: agreement.examples,
        within_radius: agreement.within_radius,
        mean_cost_ratio: agreement.mean_reference_cost_ratio.unwrap_or(f64::NAN),
        max_cost_ratio: agreement.max_reference_cost_ratio.unwrap_or(f64::NAN),
        rounds: trained.members.iter().map(|m| m.rounds).max().unwrap_or(0),
        models: trained.members.len(),
        seconds,
        off_by: None,
        corridor: (corridor == Corridor::Auto).then_some(choice),
    })
}

pub fn run(args: IocMethodsArgs) -> Result<()> {
    if args.rounds == Some(0) || args.demonstrations < 4 {
        return Err(Error::Usage(
            "bench ioc-methods needs --rounds >= 1 and --demonstrations >= 4".into(),
        ));
    }
    let terrains = [quickstart()?, raster(&args)?];
    let mut results = Vec::new();
    for terrain in &terrains {
        for (method, config) in methods(args.rounds) {
            results.push(measure(terrain, method, &config, Corridor::Auto)?);
        }
    }
    let report = IocMethodsReport {
        schema: "imitate.bench-ioc-methods/2",
        results,
    };
    emit(&report, args.json, |r| {
        format!(
            "held-out agreement (within {} cells; cost ratio under the true cost)\n{}",
            crate::ioc::AGREEMENT_RADIUS,
            results_table(&r.results, 11)
        )
    });
    Ok(())
}
