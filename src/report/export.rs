//! A costmap artifact into the tools people already use: a PNG with a colour bar, a
//! GeoTIFF keeping the georeference, and an MCAP log that opens in Foxglove (the costmap
//! as `nav_msgs/msg/OccupancyGrid` and `foxglove.Grid`, demonstrated and planned paths
//! as `nav_msgs/msg/Path`).

use std::path::Path;

use super::costmap_artifact::CostmapArtifact;
use super::legend::with_legend;
use super::picture::{log_cost_range, paint_costs};
use crate::error::{Error, Result};
use crate::grid::{Cell, Grid};
use crate::io::geojson::{Line, write_lines};
use crate::io::geotiff::write_geotiff;
use crate::io::mcap::{foxglove, ros2, writer::write_log};
use crate::io::png::write_png;
use crate::io::tables::EpisodePath;
use crate::plan::{Route, path_cost, shortest_path, unit_step_metres};
use serde_json::json;

/// The costmap in viridis (north up) with a colour bar labelled in cost on its right
/// (cheap at the bottom) and a scale bar in metres; colours span the 2nd to 98th
/// percentile of log-cost.
pub fn export_png(costs: &Grid<f32>, path: &Path) -> Result<()> {
    let scale = (512 / costs.geo.width.max(costs.geo.height)).clamp(1, 16);
    let range = log_cost_range(&[costs]);
    let picture = paint_costs(costs, range, scale);
    let figure = with_legend(&picture, &costs.geo, range, scale)
        .map_err(|e| Error::Failed(format!("{}: {e}", path.display())))?;
    write_png(path, &figure)
}

/// The costs as a float32 GeoTIFF; blocked (infinite) cells become nodata.
pub fn export_geotiff(costs: &Grid<f32>, path: &Path) -> Result<()> {
    let values: Vec<f32> = costs
        .data
        .iter()
        .map(|&c| if c.is_finite() { c } else { f32::NAN })
        .collect();
    write_geotiff(path, &costs.geo, &values)
}

/// The costs as a Nav2 `map_server` map: `<map>.yaml` and `<map>.pgm`, the occupancy
/// of [`occupancy`] read back by `map_server` in `scale` mode.
pub fn export_nav2(costs: &Grid<f32>, yaml_path: &Path) -> Result<()> {
    crate::io::nav2::write_nav2_map(yaml_path, &costs.geo, &occupancy(costs))
}

/// Occupancy 0–100 spanning the 2nd–98th percentile of log-cost; blocked cells 100.
fn occupancy(costs: &Grid<f32>) -> Vec<i8> {
    let (lo, hi) = log_cost_range(&[costs]);
    costs
        .data
        .iter()
        .map(|&c| {
            if !c.is_finite() {
                return 100;
            }
            let t = (c.max(f32::MIN_POSITIVE).ln() - lo) / (hi - lo);
            (100.0 * t.clamp(0.0, 1.0)).round() as i8
        })
        .collect()
}

fn centres(costs: &Grid<f32>, cells: &[Cell]) -> Vec<(f64, f64)> {
    cells.iter().map(|&c| costs.geo.center_of(c)).collect()
}

/// One map of the artifact as an MCAP log: `/map` (OccupancyGrid), `/costmap`
/// (foxglove.Grid with float32 `cost` and `log_cost`), `/demonstrations` and `/plans`
/// (one `nav_msgs/msg/Path` per example on this map, the plan from its start to its goal
/// on the costmap).
pub fn export_mcap(
    artifact: &CostmapArtifact,
    map: &str,
    costs: &Grid<f32>,
    path: &Path,
) -> Result<()> {
    let log_costs: Vec<f32> = costs
        .data
        .iter()
        .map(|c| c.max(f32::MIN_POSITIVE).ln())
        .collect();
    let examples = demonstrations_and_plans(artifact, map, costs);
    let frame = costs.geo.frame.as_str();
    write_log(path, |log| {
        let occupancy_channel = log.channel(
            "/map",
            "nav_msgs/msg/OccupancyGrid",
            &ros2::schemas::occupancy_grid(),
        )?;
        let grid_channel = log.raw_channel(
            "/costmap",
            "foxglove.Grid",
            "protobuf",
            &foxglove::file_descriptor_set(),
            "protobuf",
        )?;
        let grid_map_channel = log.channel(
            "/grid_map",
            "grid_map_msgs/msg/GridMap",
            &ros2::schemas::grid_map(),
        )?;
        let path_schema = ros2::schemas::path();
        let demo_channel = log.channel("/demonstrations", "nav_msgs/msg/Path", &path_schema)?;
        let plan_channel = log.channel("/plans", "nav_msgs/msg/Path", &path_schema)?;
        log.write(
            occupancy_channel,
            0,
            &ros2::occupancy_grid(0, &costs.geo, occupancy(costs)),
        )?;
        let grid = foxglove::grid_message(
            0,
            &costs.geo,
            &[("cost", &costs.data), ("log_cost", &log_costs)],
        );
        log.write_raw(grid_channel, 0, &grid)?;
        // grid_map marks cells without a value NaN: blocked cells are those.
        let valued = |values: &[f32]| -> Vec<f32> {
            (values.iter().zip(&costs.data))
                .map(|(&v, c)| if c.is_finite() { v } else { f32::NAN })
                .collect()
        };
        let layers = crate::grid::Map {
            name: map.to_string(),
            geo: costs.geo.clone(),
            layers: vec![
                crate::grid::Layer::new("cost", valued(&costs.data)),
                crate::grid::Layer::new("log_cost", valued(&log_costs)),
            ],
        };
        log.write(grid_map_channel, 0, &ros2::grid_map(0, &layers))?;
        for (k, (example, plan)) in examples.iter().enumerate() {
            let t = (k as u64 + 1) * 1_000_000_000;
            log.write(
                demo_channel,
                t,
                &ros2::path(t, frame, &centres(costs, &example.cells)),
            )?;
            if let Some(route) = plan {
                log.write(
                    plan_channel,
                    t,
                    &ros2::path(t, frame, &centres(costs, &route.cells)),
                )?;
            }
        }
        Ok(())
    })
}

/// Each demonstration on `map` beside the cheapest route between its ends on `costs`
/// (none where they are not joined).
fn demonstrations_and_plans<'a>(
    artifact: &'a CostmapArtifact,
    map: &str,
    costs: &Grid<f32>,
) -> Vec<(&'a EpisodePath, Option<Route>)> {
    artifact
        .paths
        .iter()
        .filter(|p| p.map == map)
        .map(|example| {
            let plan = match (example.cells.first(), example.cells.last()) {
                (Some(&start), Some(&goal)) => shortest_path(costs, start, goal),
                _ => None,
            };
            (example, plan)
        })
        .collect()
}

/// One map's demonstrations and the plans between their ends as GeoJSON (RFC 7946:
/// longitude and latitude), for QGIS or a web map beside the exported GeoTIFF: a
/// LineString per path, its properties `kind` (`demonstration` or `plan`), `episode` and
/// `cost` (on the learned costmap, cost × metres as `imitate plan` gives it).
pub fn export_geojson(
    artifact: &CostmapArtifact,
    map: &str,
    costs: &Grid<f32>,
    path: &Path,
) -> Result<()> {
    let examples = demonstrations_and_plans(artifact, map, costs);
    let metres = unit_step_metres(&costs.geo);
    let mut lines = Vec::new();
    for (example, plan) in &examples {
        let cost = path_cost(costs, &example.cells) * metres;
        lines.push(Line {
            properties: json!({"kind": "demonstration", "episode": example.episode, "cost": cost}),
            cells: &example.cells,
        });
        if let Some(route) = plan {
            lines.push(Line {
                properties: json!({"kind": "plan", "episode": example.episode, "cost": route.cost * metres}),
                cells: &route.cells,
            });
        }
    }
    write_lines(path, &costs.geo, &lines, &artifact.dir)
}
