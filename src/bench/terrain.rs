//! `imitate bench terrain`: the hidden-teacher protocol on any raster. A teacher whose
//! cost the learner never sees, and which is not log-linear in the raster's bands
//! (thresholds, squares, ratios, margins around regions), draws optimal paths between
//! far-apart cells; each method learns from three quarters of them with the default
//! feature bank and plans the rest. Reported per raster, teacher and method: held-out
//! planned cells within 2 cells of the teacher's path, the true-cost ratio of plan to
//! teacher (the primary figure: near-equal routes may leave the teacher's cells at
//! almost no cost) and training time, beside a uniform-cost baseline.

use std::path::PathBuf;
use std::time::Instant;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::ioc_methods::{
    MethodResult, OffBy, Terrain, measure, methods, results_table, teacher_paths,
};
use crate::cli::emit;
use crate::error::{Error, Result};
use crate::features::{
    Bank, FeatureSpec, compute, gaussian_blur, gaussian_blur_by_row, gradient, ground_windows,
    local_std_by_row,
};
use crate::grid::rasterize;
use crate::grid::{Edges, GeoRef, Grid, Layer, Map, coarsened, factor_for_cells};
use crate::io::read_raster;
use crate::ioc::{Corridor, Example};
use crate::ioc::{evaluate_example, hold_out_every, summarize};

/// The hidden teachers: costs the features never state directly.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Teacher {
    /// Steps: dear above the 60th percentile of the bands' brightness, dearer below the
    /// 15th.
    Threshold,
    /// A bowl: the squared distance of the brightness from its median, in IQRs.
    Square,
    /// A ratio: the normalised difference of the last and first band (of the band
    /// and its neighbourhood mean for one band, a Gaussian of 3 cells on the ground),
    /// dear above its median.
    Ratio,
    /// A margin: dear above the 70th percentile and within 3 cells of the brightest
    /// decile (a distance, which per-cell features only approximate; on the ground, in
    /// the cells' mean side where they are not square).
    Margin,
    /// Obstacles: dear above the median brightness and 43 times the cheapest cost above
    /// the 90th percentile, as a planner's near-lethal cells are. A learner that flattens
    /// the contrast sends plans across them.
    Obstacle,
    /// Steepness, as a ground robot pays for it: the gradient magnitude of the
    /// brightness (of the elevation, on a DEM) per metre, free up to its median and
    /// rising as the square of its rank between median and 90th percentile to 9 times
    /// the cheapest. The bank holds slope for DEMs but no gradient of imagery.
    Slope,
    /// A shore: 7 times the cheapest within 3 cells of the darkest decile (water,
    /// shadow; the lowest ground on a DEM; on the ground, as `margin`), the mirror of
    /// `margin`, and cheap everywhere else.
    Shore,
    /// Land cover: every class its own cost between 1 and 9, in no order of the codes
    /// (a class layer's classes where every band is one, else the brightness's deciles
    /// as classes), as a planner's cost table per land-cover class is.
    Classes,
    /// Texture, as a ground robot pays for rough ground: the brightness's local
    /// standard deviation (an elevation's, on a DEM) over a window of 5 to 21 cells
    /// drawn from the seed (`5 + 2 (seed mod 9)`; square on the ground, as the bank's
    /// roughness windows, in the cells' mean side), free up to its median and rising
    /// linearly to 9 times the cheapest at its 90th percentile. The window is the
    /// teacher's, not the bank's: the bank's spreads are over fixed windows.
    Texture,
    /// One band alone (the middle one: bands ÷ 2, counting from 0): 6 times the
    /// cheapest above its 65th percentile, a level the bank marks on no layer.
    Band,
    /// Inflation, as a planner's costmap inflates its obstacles: 7 times the cheapest
    /// on the brightness's darkest fifth, falling off as e^(−d / 4 cells) with the
    /// ground distance d from it. Neither the quantile nor the fall-off is the bank's.
    Inflation,
    /// Bright and steep at once: the `slope` teacher's ramp of the brightness's
    /// gradient, times 8, only above its median brightness (a product of two causes).
    Interaction,
    /// A regional cost: the brightness blurred over 6 cells on the ground, free up to
    /// its median and rising linearly to 9 times the cheapest at its 90th percentile.
    Regional,
    /// A sum of two causes, as a costmap sums its layers: 3 above the 80th percentile
    /// of the brightness, plus 3 times the `slope` teacher's ramp of its gradient.
    Sum,
}

/// The texture teacher's window, in cells: odd, 5 to 21, drawn from the seed.
pub fn texture_window(seed: u64) -> usize {
    5 + 2 * (seed % 9) as usize
}

/// What the learners are given to learn from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Features {
    /// The feature bank (`--bank`): what a user who only names the layers gets.
    Bank,
    /// The raster's bands as they are, and a bias: what the bank adds, measured.
    Layers,
    /// The teacher's hidden cost as the only layer, and a bias: the learner's ceiling
    /// with perfect features, which tells a learner's shortfall from the features'.
    Oracle,
}

#[derive(Debug, clap::Args)]
pub struct TerrainArgs {
    /// Rasters (GeoTIFF, Esri ASCII grid, SRTM tile (.hgt, .hgt.zip), GDAL VRT, JPEG 2000, georeferenced PNG or JPEG, BIL/GridFloat, DTED, XYZ, ERDAS Imagine, ENVI, netCDF, Surfer, GeoPackage; every band a layer).
    #[arg(required = true, value_name = "RASTER")]
    pub rasters: Vec<PathBuf>,
    /// Teachers to run (repeat the flag); default: the first eight, `threshold` to
    /// `texture` (`classes`, `band`, `inflation`, `interaction`, `regional` and `sum`
    /// on request).
    #[arg(long = "teacher", value_enum)]
    pub teachers: Vec<Teacher>,
    /// Methods to run (repeat the flag): learch-ridge, learch-tree, learch-alternate,
    /// mmp, maxent (trees), maxent-linear; default: every one. The uniform-cost
    /// baseline always runs (`--method uniform`: it alone).
    #[arg(long = "method")]
    pub methods: Vec<String>,
    /// The feature bank.
    #[arg(long, value_enum, default_value = "auto")]
    pub bank: Bank,
    /// What the learners learn from: the bank, the bands alone, or the hidden cost.
    #[arg(long, value_enum, default_value = "bank")]
    pub features: Features,
    /// Cells along the raster's longer side after block averaging (0 keeps the raster).
    #[arg(long, default_value_t = 160)]
    pub cells: u32,
    /// Teacher paths per raster and teacher; a quarter is held out.
    #[arg(long, default_value_t = 60)]
    pub paths: usize,
    /// Rounds of every method (default: each method's own, as `learch` runs it).
    #[arg(long)]
    pub rounds: Option<usize>,
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Overrides of every method's settings, for tuning: step size, depth of the trees,
    /// loss augmentation.
    #[arg(long)]
    pub step_size: Option<f64>,
    #[arg(long)]
    pub depth: Option<usize>,
    #[arg(long)]
    pub loss: Option<f64>,
    #[arg(long)]
    pub bins: Option<usize>,
    #[arg(long)]
    pub min_leaf_weight: Option<f64>,
    #[arg(long)]
    pub leaf_l2: Option<f64>,
    #[arg(long, value_enum)]
    pub loss_kind: Option<crate::ioc::LossKind>,
    #[arg(long, value_enum)]
    pub schedule: Option<crate::ioc::StepSchedule>,
    /// MaxEnt's paths may take up to this many times each demonstration's steps.
    #[arg(long, value_parser = at_least_one)]
    pub horizon_factor: Option<f64>,
    /// LEARCH keeps the contrast its rounds left (no choice of the cost's exponent on
    /// the training paths).
    #[arg(long)]
    pub keep_contrast: bool,
    /// LEARCH's trees split on features of every scale from the first round.
    #[arg(long)]
    pub all_scales_at_once: bool,
    /// LEARCH with trees: models trained and averaged (1: the staged model alone).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=crate::ioc::MEMBERS.len() as u64))]
    pub members: Option<u64>,
    /// LEARCH and MMP take each demonstration as the cheapest path through the cells
    /// within this many cells of it, or choose (`auto`, the default) as `imitate learch
    /// --corridor` does.
    #[arg(long, value_name = "CELLS|auto", default_value_t = Corridor::Auto)]
    pub corridor: Corridor,
    /// Also plans the held-out pairs on the hidden cost itself, off by a smooth random
    /// factor e^(ε g) (repeat the flag for several ε; 0 is the hidden cost): g is a
    /// seeded Gaussian field of unit spread, correlated over `--off-by-cells`. How far
    /// from the teacher a cost that close to its own plans, which bounds the share
    /// within 2 cells a learner of that accuracy can reach.
    #[arg(long = "hidden-cost-off-by", value_name = "EPSILON")]
    pub off_by: Vec<f64>,
    /// σ of the Gaussian correlating `--hidden-cost-off-by`'s field, in cells (0: every
    /// cell on its own).
    #[arg(long, default_value_t = 4.0, value_name = "CELLS")]
    pub off_by_cells: f64,
    /// The training demonstrations as recorded tracks that wander around the teacher's
    /// paths: a pose at each cell's centre, moved by a drift of this many cells per axis
    /// (Gaussian, correlated over about five poses, seeded), read into cells as
    /// `imitate ingest` reads a track. The held-out pairs are scored against the
    /// teacher's own paths, as always.
    #[arg(long, default_value_t = 0.0, value_name = "CELLS")]
    pub wander: f64,
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct TerrainReport {
    schema: &'static str,
    features: Features,
    cells: u32,
    paths: usize,
    /// `--wander`: the training tracks' drift, in cells (absent for exact paths).
    #[serde(skip_serializing_if = "is_zero")]
    wander: f64,
    results: Vec<MethodResult>,
}

fn is_zero(value: &f64) -> bool {
    *value == 0.0
}

/// Value at share `q` of the finite values (sorted, index ⌊q(n − 1)⌋).
fn quantile(values: &[f32], q: f64) -> f32 {
    let mut finite: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return 0.0;
    }
    let k = (q * (finite.len() - 1) as f64) as usize;
    *finite.select_nth_unstable_by(k, f32::total_cmp).1
}

/// The mean of the bands per cell (NaN where any band has no data).
fn brightness(map: &Map) -> Vec<f32> {
    let n = map.geo.cell_count();
    (0..n)
        .map(|i| map.layers.iter().map(|l| l.values[i]).sum::<f32>() / map.layers.len() as f32)
        .collect()
}

/// A cell's sides (x, y) in units of the middle row's mean side √(dx·dy) on the
/// ground, row by row where they change with latitude (one pair elsewhere). The
/// teachers' neighbourhoods are round on the ground, as a real cost's are (a margin of
/// so many metres), not in the raster's rows and columns: on cells that are not square
/// (a geographic raster away from the equator: Rhine 0.66, Jacksboro 0.81) a radius
/// of 3 cells spans fewer of them along their longer side, and on a world image in
/// degrees more columns toward the poles.
fn cell_sides(geo: &GeoRef) -> Vec<[f64; 2]> {
    let [sx, sy] = geo.cell_metres();
    let mean = (sx * sy).sqrt();
    geo.cell_metres_by_row()
        .iter()
        .map(|[x, y]| [x / mean, y / mean])
        .collect()
}

/// A Gaussian's σ of `sides` mean sides on the ground, in cells per axis and row.
fn sigmas_on_the_ground(sides: &[[f64; 2]], mean_sides: f64) -> Vec<[f64; 2]> {
    sides
        .iter()
        .map(|side| side.map(|s| mean_sides / s))
        .collect()
}

/// Whether a distance in mean sides is within `cells` of them; half a percent more, so
/// that near-square cells (GDAL's 300.038 × 300.042 m) count the cells square ones do.
fn within(distance: f32, cells: f32) -> bool {
    distance <= cells * 1.005
}

/// Ground distance, in mean cell sides ([`cell_sides`]), to the nearest cell of `z`
/// where `target` holds.
fn cells_to(
    z: &[f32],
    target: impl Fn(f32) -> bool,
    w: usize,
    h: usize,
    sides: &[[f64; 2]],
) -> Vec<f32> {
    let mask: Vec<bool> = z.iter().map(|&v| target(v)).collect();
    let mut distance = vec![0.0f32; z.len()];
    crate::features::distance_transform(&mask, w, h, sides, 1e9, &mut distance);
    distance
}

/// The gradient magnitude of the brightness `z` per metre, as its rank between its
/// median (0) and 90th percentile (1), clamped to [0, 1].
fn steepness_ramp(map: &Map, z: &[f32]) -> Vec<f32> {
    let (w, h) = (map.geo.width as usize, map.geo.height as usize);
    let mut steepness = vec![0.0; z.len()];
    let spacing = map.geo.cell_metres_by_row();
    gradient(z, w, h, &spacing, false, &mut steepness);
    let (s50, s90) = (quantile(&steepness, 0.5), quantile(&steepness, 0.9));
    let span = (s90 - s50).max(f32::EPSILON);
    steepness
        .iter()
        .map(|&s| ((s - s50) / span).clamp(0.0, 1.0))
        .collect()
}

/// The teacher's cost per cell: ≥ 1 on data cells, 12 on cells without data.
fn teacher_cost(map: &Map, teacher: Teacher, seed: u64) -> Vec<f32> {
    let (w, h) = (map.geo.width as usize, map.geo.height as usize);
    let z = brightness(map);
    let sides = cell_sides(&map.geo);
    let (q15, q50, q60, q70, q75, q90) = (
        quantile(&z, 0.15),
        quantile(&z, 0.5),
        quantile(&z, 0.6),
        quantile(&z, 0.7),
        quantile(&z, 0.75),
        quantile(&z, 0.9),
    );
    let iqr = (q75 - quantile(&z, 0.25)).max(f32::EPSILON);
    let data = |v: f32, cost: f32| if v.is_nan() { 12.0 } else { cost };
    // Free up to the median of `x`, rising linearly to 9 at its 90th percentile.
    let ramp = |x: &[f32]| -> Vec<f32> {
        let (x50, x90) = (quantile(x, 0.5), quantile(x, 0.9));
        let span = (x90 - x50).max(f32::EPSILON);
        x.iter()
            .zip(&z)
            .map(|(&r, &v)| data(v, 1.0 + 8.0 * ((r - x50) / span).clamp(0.0, 1.0)))
            .collect()
    };
    match teacher {
        Teacher::Threshold => z
            .iter()
            .map(|&v| data(v, 1.0 + 6.0 * f32::from(v > q60) + 3.0 * f32::from(v < q15)))
            .collect(),
        Teacher::Square => z
            .iter()
            .map(|&v| data(v, 1.0 + (4.0 * ((v - q50) / iqr).powi(2)).min(15.0)))
            .collect(),
        Teacher::Ratio => {
            let ratio: Vec<f32> = if map.layers.len() > 1 {
                let (a, b) = (
                    &map.layers[map.layers.len() - 1].values,
                    &map.layers[0].values,
                );
                a.iter()
                    .zip(b)
                    .map(|(&a, &b)| if a + b == 0.0 { 0.0 } else { (a - b) / (a + b) })
                    .collect()
            } else {
                let filled: Vec<f32> = z
                    .iter()
                    .map(|&v| if v.is_nan() { q50 } else { v })
                    .collect();
                let mut mean = vec![0.0; filled.len()];
                let sigmas = sigmas_on_the_ground(&sides, 3.0);
                gaussian_blur_by_row(&filled, w, h, &sigmas, &mut mean);
                filled
                    .iter()
                    .zip(&mean)
                    .map(|(&v, &m)| if v + m == 0.0 { 0.0 } else { (v - m) / (v + m) })
                    .collect()
            };
            ramp(&ratio)
        }
        Teacher::Margin => {
            let distance = cells_to(&z, |v| v > q90, w, h, &sides);
            z.iter()
                .zip(&distance)
                .map(|(&v, &d)| {
                    data(
                        v,
                        1.0 + 3.0 * f32::from(v > q70) + 4.0 * f32::from(within(d, 3.0)),
                    )
                })
                .collect()
        }
        Teacher::Obstacle => z
            .iter()
            .map(|&v| {
                data(
                    v,
                    1.0 + 2.0 * f32::from(v > q50) + 40.0 * f32::from(v > q90),
                )
            })
            .collect(),
        Teacher::Slope => steepness_ramp(map, &z)
            .iter()
            .zip(&z)
            .map(|(&s, &v)| data(v, 1.0 + 8.0 * s.powi(2)))
            .collect(),
        Teacher::Shore => {
            let q10 = quantile(&z, 0.1);
            let distance = cells_to(&z, |v| v < q10, w, h, &sides);
            z.iter()
                .zip(&distance)
                .map(|(&v, &d)| data(v, 1.0 + 6.0 * f32::from(within(d, 3.0))))
                .collect()
        }
        Teacher::Texture => {
            let filled: Vec<f32> = z
                .iter()
                .map(|&v| if v.is_nan() { q50 } else { v })
                .collect();
            let mut spread = vec![0.0; z.len()];
            let windows = ground_windows(map, texture_window(seed));
            local_std_by_row(&filled, w, h, &windows, &mut spread);
            ramp(&spread)
        }
        Teacher::Band => {
            let band = &map.layers[map.layers.len() / 2].values;
            let q65 = quantile(band, 0.65);
            band.iter()
                .zip(&z)
                .map(|(&b, &v)| data(v, 1.0 + 5.0 * f32::from(b > q65)))
                .collect()
        }
        Teacher::Inflation => {
            let q20 = quantile(&z, 0.2);
            let distance = cells_to(&z, |v| v < q20, w, h, &sides);
            z.iter()
                .zip(&distance)
                .map(|(&v, &d)| data(v, 1.0 + 6.0 * (-d / 4.0).exp()))
                .collect()
        }
        Teacher::Interaction | Teacher::Sum => {
            let steep = steepness_ramp(map, &z);
            let q80 = quantile(&z, 0.8);
            steep
                .iter()
                .zip(&z)
                .map(|(&s, &v)| {
                    let cost = if teacher == Teacher::Interaction {
                        1.0 + 8.0 * s * f32::from(v > q50)
                    } else {
                        1.0 + 3.0 * f32::from(v > q80) + 3.0 * s
                    };
                    data(v, cost)
                })
                .collect()
        }
        Teacher::Regional => {
            let filled: Vec<f32> = z
                .iter()
                .map(|&v| if v.is_nan() { q50 } else { v })
                .collect();
            let mut mean = vec![0.0; filled.len()];
            let sigmas = sigmas_on_the_ground(&sides, 6.0);
            gaussian_blur_by_row(&filled, w, h, &sigmas, &mut mean);
            ramp(&mean)
        }
        Teacher::Classes => {
            let codes = class_codes(map, &z);
            codes
                .iter()
                .zip(&z)
                .map(|(&k, &v)| {
                    // The golden ratio's multiples mod 1 spread the classes' costs over
                    // [1, 9) in an order unrelated to the codes'.
                    let scrambled = ((k + 1) as f64 * 0.618_033_988_749_895).fract();
                    data(v, 1.0 + 8.0 * scrambled as f32)
                })
                .collect()
        }
    }
}

/// Each cell's class index: its rank among the classes of the first layer where every
/// layer holds classes ([`Layer::classes`]), else the decile of the
/// brightness `z` it falls in (0 where there is no data).
fn class_codes(map: &Map, z: &[f32]) -> Vec<usize> {
    let all_classes = map.layers.iter().all(|l| l.classes().is_some());
    if let (true, Some(first)) = (all_classes, map.layers.first())
        && let Some(classes) = first.classes()
    {
        return first
            .values
            .iter()
            .map(|&v| classes.iter().position(|&c| c == v).unwrap_or(0))
            .collect();
    }
    let edges: Vec<f32> = (1..10).map(|d| quantile(z, f64::from(d) / 10.0)).collect();
    z.iter()
        .map(|&v| edges.iter().filter(|&&e| v > e).count())
        .collect()
}

/// One raster and teacher: features as `--features` says, seeded teacher paths between
/// cells at least half the map apart, a quarter held out.
fn terrain(map: &Map, teacher: Teacher, args: &TerrainArgs) -> Result<Terrain> {
    let geo = map.geo.clone();
    let truth = Grid::from_vec(geo.clone(), teacher_cost(map, teacher, args.seed));
    let spec = FeatureSpec {
        layers: None,
        ops: Vec::new(),
        bias: true,
        nodata_fill: 0.0,
        bank: (args.features == Features::Bank).then_some(args.bank),
    };
    let stack = if args.features == Features::Oracle {
        let oracle = Map {
            name: map.name.clone(),
            geo: geo.clone(),
            layers: vec![Layer::new("teacher_cost", truth.data.clone())],
        };
        compute(&oracle, &spec)
    } else {
        compute(map, &spec)
    }
    .map_err(Error::Failed)?;
    let examples = teacher_paths(&truth, args.paths, args.seed, "teacher")?;
    let (training, holdout) = hold_out_every(examples, 4);
    let training = wandering(training, &geo, args.wander, args.seed)?;
    Ok(Terrain {
        name: format!("{}/{}", map.name, teacher_name(teacher)),
        names: vec![map.name.clone()],
        stacks: vec![stack],
        training,
        holdout,
        truth: vec![truth],
    })
}

fn teacher_name(teacher: Teacher) -> &'static str {
    match teacher {
        Teacher::Threshold => "threshold",
        Teacher::Square => "square",
        Teacher::Ratio => "ratio",
        Teacher::Margin => "margin",
        Teacher::Obstacle => "obstacle",
        Teacher::Slope => "slope",
        Teacher::Shore => "shore",
        Teacher::Classes => "classes",
        Teacher::Texture => "texture",
        Teacher::Band => "band",
        Teacher::Inflation => "inflation",
        Teacher::Interaction => "interaction",
        Teacher::Regional => "regional",
        Teacher::Sum => "sum",
    }
}

/// Plans on a uniform cost: what no learning gives.
fn uniform(terrain: &Terrain) -> MethodResult {
    let flat: Vec<Grid<f32>> = (terrain.stacks.iter())
        .map(|s| Grid::filled(s.geo.clone(), 1.0f32))
        .collect();
    planned_on(terrain, &flat, "uniform")
}

/// A Gaussian field over `geo`'s cells: seeded standard normal values blurred by a
/// Gaussian of σ `cells` (none at 0), brought back to zero mean and unit spread.
fn smooth_field(geo: &GeoRef, cells: f64, seed: u64) -> Vec<f32> {
    let (width, height) = (geo.width as usize, geo.height as usize);
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x9e37);
    smoothed_noise(&mut rng, width, height, [cells, cells])
}

/// Seeded Gaussian noise on a `width` × `height` grid, blurred by `sigma` cells per
/// axis (0: none) and scaled to zero mean and unit spread.
fn smoothed_noise(rng: &mut ChaCha8Rng, width: usize, height: usize, sigma: [f64; 2]) -> Vec<f32> {
    // Box–Muller: one standard normal value from each pair of uniform ones.
    let white: Vec<f32> = (0..width * height)
        .map(|_| {
            let (u1, u2): (f64, f64) = (rng.random::<f64>().max(1e-12), rng.random::<f64>());
            ((-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
        })
        .collect();
    let mut field = white.clone();
    if sigma.iter().all(|&s| s > 0.0) {
        gaussian_blur(&white, width, height, sigma, &mut field);
    }
    let n = field.len() as f64;
    let mean = field.iter().map(|&g| f64::from(g)).sum::<f64>() / n;
    let spread = (field
        .iter()
        .map(|&g| (f64::from(g) - mean).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    field
        .iter()
        .map(|&g| ((f64::from(g) - mean) / spread.max(f64::MIN_POSITIVE)) as f32)
        .collect()
}

/// Poses a drift correlates over (σ of the Gaussian along the track), as a GNSS or
/// odometry track wanders around where the robot went.
const WANDER_CORRELATION_POSES: f64 = 5.0;

/// `--wander`: each example as a track that wanders around its path by a drift of
/// `cells` per axis (a seeded Gaussian per example, correlated over
/// `WANDER_CORRELATION_POSES`), read back into cells with `grid::rasterize` as ingest
/// reads a track. The examples as they are when `cells` is 0.
fn wandering(examples: Vec<Example>, geo: &GeoRef, cells: f64, seed: u64) -> Result<Vec<Example>> {
    if cells == 0.0 {
        return Ok(examples);
    }
    let [sx, sy] = geo.cell_size();
    let (width, height) = (f64::from(geo.width), f64::from(geo.height));
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x3a1d);
    examples
        .into_iter()
        .map(|mut example| {
            let n = example.path.len();
            // Along the track (one row of n poses), each axis drifting on its own.
            let sigma = [WANDER_CORRELATION_POSES, WANDER_CORRELATION_POSES];
            let col_drift = smoothed_noise(&mut rng, n, 1, sigma);
            let row_drift = smoothed_noise(&mut rng, n, 1, sigma);
            let poses: Vec<(f64, f64)> = (example.path.iter().enumerate())
                .map(|(i, cell)| {
                    let col = f64::from(cell.col) + 0.5 + cells * f64::from(col_drift[i]);
                    let row = f64::from(cell.row) + 0.5 + cells * f64::from(row_drift[i]);
                    let (col, row) = (
                        col.clamp(0.01, width - 0.01),
                        row.clamp(0.01, height - 0.01),
                    );
                    (geo.origin[0] + col * sx, geo.origin[1] + row * sy)
                })
                .collect();
            example.path = rasterize(geo, &poses)
                .map_err(|e| Error::Failed(format!("{}: a wandering track: {e}", example.id)))?;
            Ok(example)
        })
        .collect()
}

/// Plans on the hidden cost times e^(ε g), g `field`: a cost off by about ε in log
/// everywhere, smoothly, as a learner's errors are.
fn hidden_cost_off_by(terrain: &Terrain, field: &[f32], off: OffBy) -> MethodResult {
    let costs: Vec<Grid<f32>> = (terrain.truth.iter())
        .map(|truth| {
            let data = (truth.data.iter().zip(field))
                .map(|(&c, &g)| (f64::from(c) * (off.epsilon * f64::from(g)).exp()) as f32)
                .collect();
            Grid::from_vec(truth.geo.clone(), data)
        })
        .collect();
    MethodResult {
        off_by: Some(off),
        corridor: None,
        ..planned_on(terrain, &costs, "hidden-cost-off-by")
    }
}

/// The held-out pairs planned on `costs` (one per map), measured against the hidden cost.
fn planned_on(terrain: &Terrain, costs: &[Grid<f32>], method: &'static str) -> MethodResult {
    let evaluations: Vec<_> = (terrain.holdout.iter())
        .filter_map(|ex| {
            let truth = Some(&terrain.truth[ex.map]);
            evaluate_example(&ex.id, "", &costs[ex.map], &ex.path, truth)
        })
        .collect();
    let agreement = summarize(&evaluations);
    MethodResult {
        terrain: terrain.name.clone(),
        method,
        held_out: agreement.examples,
        within_radius: agreement.within_radius,
        mean_cost_ratio: agreement.mean_reference_cost_ratio.unwrap_or(f64::NAN),
        max_cost_ratio: agreement.max_reference_cost_ratio.unwrap_or(f64::NAN),
        rounds: 0,
        models: 0,
        seconds: 0.0,
        training_within_radius: None,
        training_mean_cost_ratio: None,
        off_by: None,
        corridor: None,
    }
}

/// A `--horizon-factor`: finite and at least 1 (a path needs its demonstration's steps).
fn at_least_one(text: &str) -> std::result::Result<f64, String> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 1.0 => Ok(v),
        _ => Err(format!("'{text}' is not a number of at least 1")),
    }
}

pub fn run(args: TerrainArgs) -> Result<()> {
    if args.rounds == Some(0) || args.paths < 8 {
        return Err(Error::Usage(
            "bench terrain needs --rounds >= 1 and --paths >= 8".into(),
        ));
    }
    let mut all_methods = methods(args.rounds);
    for (_, config) in &mut all_methods {
        if let Some(step) = args.step_size {
            config.step_size = step;
        }
        if let Some(depth) = args.depth {
            config.tree.max_depth = depth;
        }
        if let Some(loss) = args.loss {
            config.loss = loss;
        }
        if let Some(bins) = args.bins {
            config.tree.bins = bins;
        }
        if let Some(v) = args.min_leaf_weight {
            config.tree.min_leaf_weight = v;
        }
        if let Some(v) = args.leaf_l2 {
            config.tree.leaf_l2 = v;
        }
        if let Some(v) = args.loss_kind {
            config.loss_kind = v;
        }
        if let Some(v) = args.schedule {
            config.schedule = v;
        }
        if let Some(v) = args.horizon_factor {
            config.horizon_factor = v;
        }
        config.calibrate_contrast &= !args.keep_contrast;
        config.widen_in_stages &= !args.all_scales_at_once;
        if let Some(members) = args.members {
            config.members = members as usize;
        }
    }
    for m in &args.methods {
        if m != "uniform" && !all_methods.iter().any(|(name, _)| name == m) {
            return Err(Error::Usage(format!(
                "--method {m}: not one of {}, uniform",
                all_methods
                    .iter()
                    .map(|(n, _)| *n)
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
    }
    let finite_and_positive = |v: f64| v.is_finite() && v >= 0.0;
    if !(args.off_by.iter().all(|&e| finite_and_positive(e))
        && finite_and_positive(args.off_by_cells))
    {
        return Err(Error::Usage(
            "--hidden-cost-off-by and --off-by-cells take finite values of 0 or more".into(),
        ));
    }
    if !finite_and_positive(args.wander) {
        return Err(Error::Usage(
            "--wander takes a finite number of cells of 0 or more".into(),
        ));
    }
    let teachers = if args.teachers.is_empty() {
        vec![
            Teacher::Threshold,
            Teacher::Square,
            Teacher::Ratio,
            Teacher::Margin,
            Teacher::Obstacle,
            Teacher::Slope,
            Teacher::Shore,
            Teacher::Texture,
        ]
    } else {
        args.teachers.clone()
    };
    let mut results = Vec::new();
    for path in &args.rasters {
        let name = crate::io::map_name(path);
        let raster = read_raster(path, &name)?;
        let factor = factor_for_cells(&raster.geo, args.cells);
        let map = coarsened(raster, factor, Edges::Whole);
        for &teacher in &teachers {
            // The raster is this command's only input: what its content makes fail
            // (features, teacher paths) is an input error naming it.
            let terrain = terrain(&map, teacher, &args).map_err(|e| match e {
                Error::Failed(message) => Error::input(path, message),
                other => other,
            })?;
            results.push(uniform(&terrain));
            if !args.off_by.is_empty() {
                let field = smooth_field(&terrain.truth[0].geo, args.off_by_cells, args.seed);
                for &epsilon in &args.off_by {
                    let off = OffBy {
                        epsilon,
                        cells: args.off_by_cells,
                    };
                    results.push(hidden_cost_off_by(&terrain, &field, off));
                }
            }
            for (method, config) in &all_methods {
                if args.methods.is_empty() || args.methods.iter().any(|m| m == method) {
                    let started = Instant::now();
                    let result = measure(&terrain, method, config, args.corridor)?;
                    tracing::info!(
                        "{} {method}: {:.3} within, ratio {:.3} ({:.1} s)",
                        terrain.name,
                        result.within_radius,
                        result.mean_cost_ratio,
                        started.elapsed().as_secs_f64()
                    );
                    results.push(result);
                }
            }
        }
    }
    let report = TerrainReport {
        schema: "imitate.bench-terrain/2",
        features: args.features,
        cells: args.cells,
        paths: args.paths,
        wander: args.wander,
        results,
    };
    emit(&report, args.json, |r| {
        format!(
            "held-out plans, {} teacher paths per terrain (within {} cells of the teacher; \
             cost ratio under the teacher's hidden cost)\n{}",
            r.paths,
            crate::ioc::AGREEMENT_RADIUS,
            results_table(&r.results, 40)
        )
    });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wandering_track_drifts_around_its_path_and_is_read_as_ingest_reads_it() {
        let geo = GeoRef::square(80, 60, 30.0, [500.0, 900.0], "map");
        let straight = |row: u32| Example {
            id: format!("row-{row}"),
            map: 0,
            path: (5..75)
                .map(|col| crate::grid::Cell::new(row, col))
                .collect(),
            waypoints: Vec::new(),
        };
        let paths = vec![straight(20), straight(40)];
        let same = wandering(paths.clone(), &geo, 0.0, 7).unwrap();
        assert_eq!(same[1].path, paths[1].path);
        let wander = wandering(paths.clone(), &geo, 1.0, 7).unwrap();
        assert_eq!(
            wander[0].path,
            wandering(paths.clone(), &geo, 1.0, 7).unwrap()[0].path
        );
        for (track, path) in wander.iter().zip(&paths) {
            assert!(crate::grid::is_connected8(&track.path), "{:?}", track.path);
            assert_ne!(track.path, path.path);
            let row = path.path[0].row as f64;
            let off: Vec<f64> = track.path.iter().map(|c| c.row as f64 - row).collect();
            let spread = (off.iter().map(|d| d * d).sum::<f64>() / off.len() as f64).sqrt();
            assert!((0.3..2.5).contains(&spread), "{spread} cells off, {off:?}");
        }
    }

    fn strip(width: u32, height: u32) -> Map {
        let geo = GeoRef::square(width, height, 30.0, [0.0, 0.0], "map");
        Map {
            name: "strip".into(),
            layers: vec![Layer::new(
                "band1",
                (0..geo.cell_count()).map(|i| i as f32).collect(),
            )],
            geo,
        }
    }

    #[test]
    fn the_slope_teacher_is_free_on_flat_ground_and_dearest_where_steepest() {
        // Flat for half the strip, then ever steeper: the flat half costs 1, the cost
        // rises along the ramp and tops out at 9 from its 90th percentile of steepness.
        let mut map = strip(100, 1);
        for (i, v) in map.layers[0].values.iter_mut().enumerate() {
            *v = (i.saturating_sub(50) as f32).powi(2);
        }
        map.layers[0].values[0] = f32::NAN;
        let cost = teacher_cost(&map, Teacher::Slope, 7);
        assert_eq!(cost[0], 12.0);
        assert!(cost[1..49].iter().all(|&c| c == 1.0), "{cost:?}");
        assert!(cost[50..99].windows(2).all(|w| w[0] <= w[1]), "{cost:?}");
        assert_eq!(cost[98], 9.0);
        assert!(cost[70] > 1.0 && cost[70] < 9.0, "{}", cost[70]);
    }

    #[test]
    fn the_obstacle_teacher_has_three_levels_and_its_obstacles_are_the_brightest_decile() {
        // Brightness 0..100: cells above the median cost 3, the top decile 43, and a cell
        // without data 12, as in every teacher.
        let mut map = strip(100, 1);
        map.layers[0].values[0] = f32::NAN;
        let cost = teacher_cost(&map, Teacher::Obstacle, 7);
        assert_eq!(cost[0], 12.0);
        assert_eq!(cost[10], 1.0);
        assert_eq!(cost[60], 3.0);
        assert_eq!(cost[99], 43.0);
        let obstacles = cost.iter().filter(|&&c| c == 43.0).count();
        assert!((9..=11).contains(&obstacles), "{obstacles} obstacle cells");
    }

    #[test]
    fn the_shore_teacher_is_dear_within_three_cells_of_the_darkest_decile() {
        // Brightness 0..100 along a strip: the darkest decile is its first ten cells,
        // so cells up to three beyond it cost 7 and the rest 1.
        let map = strip(100, 1);
        let cost = teacher_cost(&map, Teacher::Shore, 7);
        let dark = (0..100)
            .filter(|&i| map.layers[0].values[i] < quantile(&map.layers[0].values, 0.1))
            .count();
        assert!((9..=11).contains(&dark), "{dark} dark cells");
        assert!(cost[..dark + 3].iter().all(|&c| c == 7.0), "{cost:?}");
        assert!(cost[dark + 3..].iter().all(|&c| c == 1.0), "{cost:?}");
    }
    #[test]
    fn the_shore_teachers_margin_is_round_on_the_ground_where_cells_are_not() {
        // Cells of 20 × 45 m (a mean side of 30 m) around one dark cell: the shore is
        // the cells within 3 mean sides (90 m) of it on the ground, 4 columns but only
        // 2 rows, where cells counted in rows and columns would make it 3 of each.
        let (w, h) = (21usize, 15usize);
        let mut geo = GeoRef::square(w as u32, h as u32, 20.0, [0.0, 0.0], "map");
        geo.resolution_y = Some(45.0);
        let (cx, cy) = (10, 7);
        let mut values = vec![100.0f32; w * h];
        values[cy * w + cx] = 0.0;
        let map = Map {
            name: "rectangles".into(),
            layers: vec![Layer::new("band1", values)],
            geo,
        };
        let cost = teacher_cost(&map, Teacher::Shore, 7);
        for r in 0..h {
            for c in 0..w {
                let metres = (20.0 * c.abs_diff(cx) as f64).hypot(45.0 * r.abs_diff(cy) as f64);
                let expected = if metres <= 90.0 * 1.005 { 7.0 } else { 1.0 };
                assert_eq!(cost[r * w + c], expected, "row {r}, column {c}: {metres} m");
            }
        }
        assert_eq!(cost[cy * w + cx + 4], 7.0);
        assert_eq!(cost[(cy + 3) * w + cx], 1.0);
    }

    #[test]
    fn the_inflation_teacher_falls_off_from_the_darkest_fifth() {
        // Brightness 0..100 along a strip: the darkest fifth is its first 20 cells
        // (cost 7), and a cell k cells beyond it costs 1 + 6 e^(−k/4).
        let map = strip(100, 1);
        let cost = teacher_cost(&map, Teacher::Inflation, 7);
        let dark = (0..100)
            .filter(|&i| map.layers[0].values[i] < quantile(&map.layers[0].values, 0.2))
            .count();
        assert!((19..=21).contains(&dark), "{dark} dark cells");
        assert!(cost[..dark].iter().all(|&c| c == 7.0), "{cost:?}");
        for k in 1..20 {
            let expected = 1.0 + 6.0 * (-(k as f32) / 4.0).exp();
            assert!(
                (cost[dark - 1 + k] - expected).abs() < 1e-5,
                "{k}: {cost:?}"
            );
        }
    }

    #[test]
    fn the_band_teacher_reads_the_middle_band_alone() {
        // Three bands: the first and last rise along the strip, the middle one falls,
        // so the dear cells are the first 35, where the middle band is above its 65th
        // percentile.
        let mut map = strip(100, 1);
        let rising = map.layers[0].values.clone();
        let falling: Vec<f32> = rising.iter().map(|v| 99.0 - v).collect();
        map.layers = vec![
            Layer::new("band1", rising.clone()),
            Layer::new("band2", falling),
            Layer::new("band3", rising),
        ];
        let cost = teacher_cost(&map, Teacher::Band, 7);
        let dear = cost.iter().take_while(|&&c| c == 6.0).count();
        assert!((33..=36).contains(&dear), "{cost:?}");
        assert!(cost[dear..].iter().all(|&c| c == 1.0), "{cost:?}");
    }

    #[test]
    fn steep_and_bright_teachers_multiply_or_add_their_causes() {
        // A ramp whose slope doubles halfway: steep only on its bright half, so the
        // product is dear there alone; the sum also charges the brightest fifth.
        let mut map = strip(100, 1);
        for (i, v) in map.layers[0].values.iter_mut().enumerate() {
            *v = if i < 50 {
                i as f32
            } else {
                50.0 + 2.0 * (i - 50) as f32
            };
        }
        let product = teacher_cost(&map, Teacher::Interaction, 7);
        let sum = teacher_cost(&map, Teacher::Sum, 7);
        assert!(product[..49].iter().all(|&c| c == 1.0), "{product:?}");
        assert!(product[60..99].iter().all(|&c| c == 9.0), "{product:?}");
        assert!(sum[..49].iter().all(|&c| c == 1.0), "{sum:?}");
        assert!(sum[60..80].iter().all(|&c| c == 4.0), "{sum:?}");
        assert!(sum[81..99].iter().all(|&c| c == 7.0), "{sum:?}");
    }

    #[test]
    fn the_regional_teacher_follows_the_blurred_brightness() {
        // On a strip the blur keeps a ramp's order (but at its ends): free on the
        // dark half, dearest on the bright tenth, rising between.
        let map = strip(100, 1);
        let cost = teacher_cost(&map, Teacher::Regional, 7);
        assert!(cost[10..45].iter().all(|&c| c == 1.0), "{cost:?}");
        assert!(cost[92..].iter().all(|&c| c == 9.0), "{cost:?}");
        assert!(cost[55..88].windows(2).all(|p| p[0] < p[1]), "{cost:?}");
    }

    #[test]
    fn the_classes_teacher_gives_each_class_one_cost_in_no_order_of_the_codes() {
        // A class layer of codes 10, 20, 30, 40: each code one cost in [1, 9), the
        // costs not rising with the codes, and a cell without data 12.
        let mut map = strip(100, 1);
        for (i, v) in map.layers[0].values.iter_mut().enumerate() {
            *v = 10.0 * (1 + i / 25) as f32;
        }
        map.layers[0].values[0] = f32::NAN;
        let cost = teacher_cost(&map, Teacher::Classes, 7);
        assert_eq!(cost[0], 12.0);
        let per_class: Vec<f32> = (0..4).map(|k| cost[k * 25 + 1]).collect();
        for k in 0..4 {
            assert!(
                cost[k * 25 + 1..(k + 1) * 25]
                    .iter()
                    .all(|&c| c == per_class[k])
            );
            assert!((1.0..9.0).contains(&per_class[k]), "{per_class:?}");
        }
        assert!(!per_class.windows(2).all(|w| w[0] <= w[1]), "{per_class:?}");
        assert!(!per_class.windows(2).all(|w| w[0] >= w[1]), "{per_class:?}");
        // Brightness that is no class layer: its deciles are the classes.
        let continuous = strip(100, 1);
        let mut distinct = teacher_cost(&continuous, Teacher::Classes, 7);
        distinct.sort_by(f32::total_cmp);
        distinct.dedup();
        assert_eq!(distinct.len(), 10, "{distinct:?}");
    }

    #[test]
    fn the_texture_teacher_is_dear_where_the_ground_is_rough_over_its_window() {
        // 60 × 40 cells, smooth in the west half and a checkerboard in the east: the
        // spread over the seed's window is 0 where the window is all smooth (cost 1),
        // largest where it is all checkerboard (cost 9), and rises across the seam.
        let mut map = strip(60, 40);
        for (i, v) in map.layers[0].values.iter_mut().enumerate() {
            let (x, y) = (i % 60, i / 60);
            *v = if x < 30 {
                5.0
            } else {
                10.0 * ((x + y) % 2) as f32
            };
        }
        map.layers[0].values[0] = f32::NAN;
        for seed in [7, 11] {
            let window = texture_window(seed);
            assert!(window % 2 == 1 && (5..=21).contains(&window), "{window}");
            let cost = teacher_cost(&map, Teacher::Texture, seed);
            assert_eq!(cost[0], 12.0);
            let seam: Vec<f32> = (29 - window / 2..=30 + window / 2)
                .map(|x| cost[20 * 60 + x])
                .collect();
            assert_eq!(seam[0], 1.0, "seed {seed}: {seam:?}");
            assert_eq!(*seam.last().unwrap(), 9.0, "seed {seed}: {seam:?}");
            assert!(
                seam.windows(2).all(|w| w[0] <= w[1]),
                "seed {seed}: {seam:?}"
            );
        }
        assert_ne!(texture_window(7), texture_window(11));
    }

    /// `--hidden-cost-off-by`'s field has unit spread around zero, is the same for a
    /// seed, and is smooth over its σ: neighbours nearly equal at 4 cells, unrelated at 0.
    #[test]
    fn the_off_by_field_is_seeded_standard_and_smooth_over_its_cells() {
        let geo = GeoRef::square(120, 90, 30.0, [0.0, 0.0], "map");
        let neighbour_correlation = |g: &[f32]| {
            let pairs = (0..g.len()).filter(|i| (i + 1) % 120 != 0);
            let (n, sum) = pairs.fold((0.0, 0.0), |(n, s), i| {
                (n + 1.0, s + f64::from(g[i]) * f64::from(g[i + 1]))
            });
            sum / n
        };
        for cells in [0.0, 4.0] {
            let field = smooth_field(&geo, cells, 7);
            assert_eq!(field, smooth_field(&geo, cells, 7));
            assert_ne!(field, smooth_field(&geo, cells, 11));
            let n = field.len() as f64;
            let mean = field.iter().map(|&g| f64::from(g)).sum::<f64>() / n;
            let spread = field.iter().map(|&g| f64::from(g).powi(2)).sum::<f64>() / n;
            assert!(
                mean.abs() < 1e-6 && (spread - 1.0).abs() < 1e-4,
                "{mean} {spread}"
            );
            let r = neighbour_correlation(&field);
            if cells == 0.0 {
                assert!(r.abs() < 0.05, "white noise: {r}");
            } else {
                assert!(r > 0.9, "σ 4 cells: {r}");
            }
        }
    }
}
