//! `forecast` (and `imitate forecast`): where an agent that has walked part of a path will go next, under
//! the maximum-entropy model of a learned costmap (Ziebart et al. 2008, Kitani et al.
//! 2012): the posterior over candidate destinations and the expected visitation of the
//! rest of the path.
//!
//! For a partial path ξ from A to B and a destination g with soft cost-to-go V_g,
//! P(g | ξ) ∝ P(g) · exp(V_g(A) − C(ξ) − V_g(B)): how much of the probability of all
//! paths from A to g the paths through ξ hold. The visitation forecast is the mixture
//! over destinations of the expected visits of paths from B. Paths are limited to a
//! horizon (see `ioc::soft_paths`): from B, `horizon_factor` times the octile steps to
//! g; from A, that plus the steps already taken.
//!
//! The outputs are an artifact, so a pipeline reruns a forecast only when its costmap or
//! its parameters changed.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::{StageParams, StageReport, commit_artifact};
use crate::artifact::{ArtifactBuilder, load_costs};
use crate::error::{Error, Result};
use crate::grid::{Cell, Grid, PointReader};
use crate::io::fs::write_bytes_atomic;
use crate::io::png::write_png;
use crate::io::tables::{Table, write_numeric_table};
use crate::ioc::soft_paths::{SoftGoal, Window};
use crate::plan::path_cost;
use crate::report::{COLOUR_DEMONSTRATION, COLOUR_PLAN, paint_heat};

pub const KIND: &str = "forecast";
/// 2: MaxEnt's passes with their own exponential (the same bits on every machine).
/// 3: the forward pass drops negligible mass. 4: a start whose paths within the
/// horizon the layers cannot hold (a horizon that binds on a dear map) is answered in
/// the log domain rather than as unreachable. 5: forecast.json names the CRS of its
/// destinations' points (`--crs` reads and writes points in another CRS).
const VERSION: u32 = 5;

fn default_horizon_factor() -> f64 {
    1.5
}

fn default_window_margin() -> u32 {
    6
}

fn default_scale() -> u32 {
    4
}

/// Parameters of `imitate forecast` and of `uses: forecast`.
#[derive(Debug, Clone, clap::Args, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForecastParams {
    /// A costmap artifact folder (best one learned with `--method maxent`, whose costs
    /// are calibrated as log-probabilities) or a `costmap/1` Parquet file.
    #[serde(rename = "artifact")]
    pub costmap: PathBuf,
    /// The path walked so far: points "x,y" (metres, or "row,col" with --cells)
    /// separated by spaces or semicolons, consecutive cells neighbours.
    #[arg(long, allow_hyphen_values = true)]
    pub observed: String,
    /// A candidate destination, as a point (repeat for each).
    #[arg(long = "destination", allow_hyphen_values = true, required = true)]
    pub destinations: Vec<String>,
    /// Read points as "row,col" cells.
    #[arg(long, conflicts_with = "crs")]
    #[serde(default)]
    pub cells: bool,
    /// Read points, and write the destinations' in forecast.json, in this CRS
    /// (`EPSG:<code>` or a PROJ string; EPSG:4326 for GPS longitude and latitude).
    #[arg(long, value_name = "CRS")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crs: Option<String>,
    /// Which map of an artifact (default: its only one).
    #[arg(long)]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map: Option<String>,
    /// Paths may take up to this many times the octile steps to a destination.
    #[arg(long, default_value_t = 1.5)]
    #[serde(default = "default_horizon_factor")]
    pub horizon_factor: f64,
    /// Cells around the observed path and the destinations that paths may use.
    #[arg(long, default_value_t = 6)]
    #[serde(default = "default_window_margin")]
    pub window_margin: u32,
    /// Artifact folder for visitation.parquet, destinations.parquet, forecast.png and
    /// forecast.json.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Pixels per cell in the PNG.
    #[arg(long, default_value_t = 4)]
    #[serde(default = "default_scale")]
    pub scale: u32,
}

impl StageParams for ForecastParams {
    const KIND: &'static str = KIND;
    const VERSION: u32 = VERSION;

    fn deps(&self) -> Vec<PathBuf> {
        vec![self.costmap.clone()]
    }

    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport> {
        let mut out = ArtifactBuilder::new(&self.out)?;
        let output = forecast(self, &mut out)?;
        let summary = output
            .destinations
            .iter()
            .map(|d| format!("({}, {}) {:.3}", d.cell[0], d.cell[1], d.probability))
            .collect::<Vec<_>>()
            .join(", ");
        let metrics = serde_json::to_value(&output).expect("forecasts serialise");
        commit_artifact(self, extra_deps, out, "forecast", metrics, summary)
    }
}

#[derive(Serialize)]
struct Destination {
    cell: [u32; 2],
    world: [f64; 2],
    probability: f64,
}

#[derive(Serialize)]
struct ForecastOutput {
    schema: &'static str,
    map: String,
    observed_cells: usize,
    /// The CRS of the destinations' `world`: the map's frame, or the one `--crs` named.
    crs: String,
    destinations: Vec<Destination>,
}

/// Octile steps between two cells: the fewest 8-connected moves, diagonals as √2.
fn octile(a: Cell, b: Cell) -> f64 {
    let (dr, dc) = (
        f64::from(a.row.abs_diff(b.row)),
        f64::from(a.col.abs_diff(b.col)),
    );
    dr.max(dc) + (std::f64::consts::SQRT_2 - 1.0) * dr.min(dc)
}

/// The forecast of `args`, its files written into `out`.
fn forecast(args: &ForecastParams, out: &mut ArtifactBuilder) -> Result<ForecastOutput> {
    if !(args.horizon_factor.is_finite() && args.horizon_factor >= 1.0) {
        return Err(Error::Usage("--horizon-factor must be at least 1".into()));
    }
    if !(1..=64).contains(&args.scale) {
        return Err(Error::Usage("--scale must be in 1..=64".into()));
    }
    let (name, costs) = load_costs(&args.costmap, args.map.as_deref())?;
    let points = PointReader::new(
        &costs,
        &name,
        &args.costmap,
        args.cells,
        args.crs.as_deref(),
    )?;
    let at = |text: &str, what: &str| points.locate(text, what);
    let observed: Vec<Cell> = args
        .observed
        .split([' ', ';'])
        .filter(|p| !p.trim().is_empty())
        .map(|p| at(p, "observed"))
        .collect::<Result<_>>()?;
    if observed.is_empty() {
        return Err(Error::Usage("--observed holds no points".into()));
    }
    if let Some(pair) = observed.windows(2).find(|w| w[0].chebyshev(w[1]) != 1) {
        return Err(Error::Usage(format!(
            "--observed: {} and {} are not neighbouring cells (give every cell of the path)",
            pair[0], pair[1]
        )));
    }
    let destinations: Vec<Cell> = args
        .destinations
        .iter()
        .map(|d| at(d, "destination"))
        .collect::<Result<_>>()?;
    let (first, last) = (observed[0], observed[observed.len() - 1]);
    let taken = observed.len() - 1;
    let mut extent = observed.clone();
    extent.extend(&destinations);
    let geo = &costs.geo;
    let window = Window::around(&extent, args.window_margin, geo.width, geo.height);
    let walked = path_cost(&costs, &observed);

    // Per destination: the soft values, the log of its unnormalised posterior, and the
    // steps left from B.
    let models: Vec<(SoftGoal, f64, usize)> = destinations
        .iter()
        .map(|&goal| {
            let left = (args.horizon_factor * octile(last, goal).max(1.0)).ceil() as usize;
            let soft = SoftGoal::new(&costs, window, goal, left + taken);
            let log_weight =
                soft.value_within(first, left + taken) - walked - soft.value_within(last, left);
            (soft, log_weight, left)
        })
        .collect();
    let best = models
        .iter()
        .map(|m| m.1)
        .filter(|w| w.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);
    if best == f64::NEG_INFINITY {
        return Err(Error::input(
            &args.costmap,
            format!("no destination can be reached from {last} within the horizon on map '{name}'"),
        ));
    }
    let weights: Vec<f64> = models.iter().map(|m| (m.1 - best).exp()).collect();
    let total: f64 = weights.iter().sum();
    let posterior: Vec<f64> = weights.iter().map(|w| w / total).collect();

    let mut heat = Grid::from_vec(geo.clone(), vec![0.0f32; geo.cell_count()]);
    let mut visits = vec![0.0f64; window.len()];
    for ((soft, _, left), &p) in models.iter().zip(&posterior) {
        if p > 0.0 {
            let forecast = soft.visitation_within(last, *left);
            for (v, f) in visits.iter_mut().zip(&forecast.visits) {
                *v += p * f;
            }
        }
    }
    for (i, &v) in visits.iter().enumerate() {
        heat.data[geo.index(window.cell(i))] = v as f32;
    }

    let (rows, cols): (Vec<f64>, Vec<f64>) = (0..geo.cell_count())
        .map(|i| {
            let c = geo.cell_at(i);
            (f64::from(c.row), f64::from(c.col))
        })
        .unzip();
    let heat_values: Vec<f64> = heat.data.iter().map(|&v| f64::from(v)).collect();
    write_numeric_table(
        &out.file("visitation.parquet", "visitation")?,
        Table::FORECAST_VISITATION,
        &[("row", &rows), ("col", &cols), ("visits", &heat_values)],
    )?;
    let (d_rows, d_cols): (Vec<f64>, Vec<f64>) = destinations
        .iter()
        .map(|c| (f64::from(c.row), f64::from(c.col)))
        .unzip();
    write_numeric_table(
        &out.file("destinations.parquet", "destinations")?,
        Table::FORECAST_DESTINATIONS,
        &[
            ("row", &d_rows),
            ("col", &d_cols),
            ("probability", &posterior),
        ],
    )?;
    let mut marks: Vec<(Cell, [u8; 3])> = observed
        .iter()
        .map(|&c| (c, COLOUR_DEMONSTRATION))
        .collect();
    marks.extend(destinations.iter().map(|&c| (c, COLOUR_PLAN)));
    write_png(
        &out.file("forecast.png", "picture")?,
        &paint_heat(&heat, &marks, args.scale),
    )?;
    let output = ForecastOutput {
        schema: "imitate.forecast/1",
        map: name.clone(),
        observed_cells: observed.len(),
        crs: points.crs().to_string(),
        destinations: destinations
            .iter()
            .zip(&posterior)
            .map(|(&c, &probability)| {
                Ok(Destination {
                    cell: [c.row, c.col],
                    world: points.world(c)?,
                    probability,
                })
            })
            .collect::<Result<_>>()?,
    };
    let json = serde_json::to_string_pretty(&output).expect("forecasts serialise");
    write_bytes_atomic(&out.file("forecast.json", "forecast")?, json.as_bytes())?;
    Ok(output)
}
