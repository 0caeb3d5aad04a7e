//! `imitate plan`: the cheapest path between two points on a costmap, as JSON on
//! stdout and optionally as a PNG overlay.

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;

use crate::artifact::load_costs;
use crate::error::{Error, Result};
use crate::grid::PointReader;
use crate::io::geojson::{Line, write_lines};
use crate::io::png::write_png;
use crate::plan::{Connectivity, GridPlanner, Moves, SearchKind};
use crate::report::{Preview, render_preview};

#[derive(Debug, Args)]
pub struct PlanArgs {
    /// A costmap artifact folder (written by `learch`), a `costmap/1` Parquet file, a
    /// raster of costs (any raster `ingest` reads; nodata and zero cells blocked) or a
    /// MovingAI `.map` grid.
    pub costmap: PathBuf,
    /// Start as "x,y" in the map frame (metres, or a GeoTIFF's CRS units: degrees, feet), or "row,col" with --cells.
    #[arg(long, allow_hyphen_values = true)]
    pub start: String,
    /// Goal, as --start.
    #[arg(long, allow_hyphen_values = true)]
    pub goal: String,
    /// Read --start and --goal as "row,col" cells.
    #[arg(long, conflicts_with = "crs")]
    pub cells: bool,
    /// Read --start and --goal, and write the path's points, in this CRS (`EPSG:<code>`
    /// or a PROJ string; EPSG:4326 for GPS longitude and latitude) rather than the map's.
    #[arg(long, value_name = "CRS")]
    pub crs: Option<String>,
    /// Which map of an artifact, or band of a GeoTIFF (band1, ...); default: its only one.
    #[arg(long)]
    pub map: Option<String>,
    #[arg(long, value_enum, default_value_t = Connectivity::Eight)]
    pub connectivity: Connectivity,
    /// Forbid diagonal steps past blocked cells.
    #[arg(long)]
    pub no_corner_cutting: bool,
    #[arg(long, value_enum, default_value_t = SearchKind::Astar)]
    pub planner: SearchKind,
    /// Also draw the path over the costmap into this PNG.
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
    /// Also write the path as GeoJSON (a LineString in longitude and latitude, RFC 7946)
    /// into this file, for QGIS or a web map; the map must have a CRS.
    #[arg(long, value_name = "FILE")]
    pub geojson: Option<PathBuf>,
    /// Pixels per cell in the PNG.
    #[arg(long, default_value_t = 4)]
    pub scale: u32,
}

#[derive(Serialize)]
struct PlanOutput {
    schema: &'static str,
    map: String,
    cost: f64,
    cells: Vec<[u32; 2]>,
    /// The CRS of `world`: the map's frame, or the one `--crs` named.
    crs: String,
    world: Vec<[f64; 2]>,
}

pub fn run(args: PlanArgs) -> Result<()> {
    let (name, costs) = load_costs(&args.costmap, args.map.as_deref())?;
    let points = PointReader::new(
        &costs,
        &name,
        &args.costmap,
        args.cells,
        args.crs.as_deref(),
    )?;
    let (start, goal) = (
        points.locate(&args.start, "start")?,
        points.locate(&args.goal, "goal")?,
    );
    let moves = Moves {
        connectivity: args.connectivity,
        corner_cutting: !args.no_corner_cutting,
    };
    let mut planner = GridPlanner::new(&costs, moves);
    let route = match args.planner {
        SearchKind::Astar => planner.astar(start, goal),
        SearchKind::Dijkstra => planner.dijkstra(start, goal),
    }
    .ok_or_else(|| Error::Failed(format!("no path from {start} to {goal} on map '{name}'")))?;
    if let Some(png) = &args.png {
        if !(1..=64).contains(&args.scale) {
            return Err(Error::Usage("--scale must be in 1..=64".into()));
        }
        let picture = render_preview(
            &Preview {
                costs: &costs,
                demonstrations: vec![],
                plans: vec![&route.cells],
            },
            args.scale,
        )?;
        write_png(png, &picture)?;
    }
    let cost = route.cost * crate::plan::unit_step_metres(&costs.geo);
    if let Some(file) = &args.geojson {
        let line = Line {
            properties: serde_json::json!({"kind": "plan", "map": name, "cost": cost}),
            cells: &route.cells,
        };
        write_lines(file, &costs.geo, &[line], &args.costmap)?;
    }
    let output = PlanOutput {
        schema: "imitate.plan/1",
        cost,
        cells: route.cells.iter().map(|c| [c.row, c.col]).collect(),
        crs: points.crs().to_string(),
        world: route
            .cells
            .iter()
            .map(|&c| points.world(c))
            .collect::<Result<_>>()?,
        map: name.clone(),
    };
    outln!(
        "{}",
        serde_json::to_string(&output).expect("plans serialise")
    );
    Ok(())
}
