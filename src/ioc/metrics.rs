//! How well a learned costmap imitates: plans between a demonstration's ends compared
//! with the demonstration itself.

use serde::{Deserialize, Serialize};

use crate::grid::{Cell, Grid};
use crate::plan::{path_cost, shortest_path};

/// Planned cells count as agreeing when within this many cells (Euclidean) of the demonstration.
pub const AGREEMENT_RADIUS: u32 = 2;

/// The comparison of one plan with its demonstration.
#[derive(Debug, Clone, Serialize)]
pub struct ExampleEvaluation {
    pub example: String,
    pub map: String,
    pub planned_cells: usize,
    pub demonstrated_cells: usize,
    /// Share of planned cells within `AGREEMENT_RADIUS` cells of the demonstration.
    pub within_radius: f64,
    /// Planned path cost / demonstrated path cost, both under the reference costmap.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_cost_ratio: Option<f64>,
    #[serde(skip)]
    pub planned: Vec<Cell>,
}

/// Aggregate agreement over a set of examples.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Agreement {
    pub examples: usize,
    /// Pooled share of planned cells within `AGREEMENT_RADIUS` of their demonstration.
    pub within_radius: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_reference_cost_ratio: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_reference_cost_ratio: Option<f64>,
}

/// Plans from the demonstration's first to last cell on `costs` and compares.
/// `None` when the planner finds no path.
pub fn evaluate_example(
    example: &str,
    map: &str,
    costs: &Grid<f32>,
    demonstration: &[Cell],
    reference: Option<&Grid<f32>>,
) -> Option<ExampleEvaluation> {
    let (start, goal) = (demonstration[0], *demonstration.last()?);
    let route = shortest_path(costs, start, goal)?;
    let near = near_mask(costs.geo.width, costs.geo.height, demonstration);
    let width = costs.geo.width as usize;
    let within = route
        .cells
        .iter()
        .filter(|c| near[c.row as usize * width + c.col as usize])
        .count();
    let reference_cost_ratio = reference.map(|truth| {
        path_cost(truth, &route.cells) / path_cost(truth, demonstration).max(f64::MIN_POSITIVE)
    });
    Some(ExampleEvaluation {
        example: example.to_string(),
        map: map.to_string(),
        planned_cells: route.cells.len(),
        demonstrated_cells: demonstration.len(),
        within_radius: within as f64 / route.cells.len() as f64,
        reference_cost_ratio,
        planned: route.cells,
    })
}

/// Cells within `AGREEMENT_RADIUS` of any cell of `path`.
fn near_mask(width: u32, height: u32, path: &[Cell]) -> Vec<bool> {
    let r = AGREEMENT_RADIUS as i64;
    let mut mask = vec![false; width as usize * height as usize];
    for cell in path {
        for dr in -r..=r {
            for dc in -r..=r {
                if dr * dr + dc * dc > r * r {
                    continue;
                }
                let (row, col) = (i64::from(cell.row) + dr, i64::from(cell.col) + dc);
                if row >= 0 && col >= 0 && row < i64::from(height) && col < i64::from(width) {
                    mask[(row * i64::from(width) + col) as usize] = true;
                }
            }
        }
    }
    mask
}

pub fn summarize(evaluations: &[ExampleEvaluation]) -> Agreement {
    let planned: usize = evaluations.iter().map(|e| e.planned_cells).sum();
    let within: f64 = evaluations
        .iter()
        .map(|e| e.within_radius * e.planned_cells as f64)
        .sum();
    let ratios: Vec<f64> = evaluations
        .iter()
        .filter_map(|e| e.reference_cost_ratio)
        .collect();
    let has_ratios = !ratios.is_empty() && ratios.len() == evaluations.len();
    Agreement {
        examples: evaluations.len(),
        within_radius: if planned == 0 {
            0.0
        } else {
            within / planned as f64
        },
        mean_reference_cost_ratio: has_ratios
            .then(|| ratios.iter().sum::<f64>() / ratios.len() as f64),
        max_reference_cost_ratio: has_ratios.then(|| ratios.iter().copied().fold(0.0, f64::max)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GeoRef;

    #[test]
    fn a_plan_along_the_demonstration_agrees_fully() {
        let geo = GeoRef::square(8, 8, 1.0, [0.0, 0.0], "m");
        let costs = Grid::filled(geo, 1.0f32);
        let demo: Vec<Cell> = (0..8).map(|i| Cell::new(i, i)).collect();
        let e = evaluate_example("e", "m", &costs, &demo, Some(&costs)).unwrap();
        assert_eq!(e.within_radius, 1.0);
        assert!((e.reference_cost_ratio.unwrap() - 1.0).abs() < 1e-12);
        let detour: Vec<Cell> = (0..8)
            .map(|c| Cell::new(0, c))
            .chain((1..8).map(|r| Cell::new(r, 7)))
            .collect();
        let e = evaluate_example("e", "m", &costs, &detour, None).unwrap();
        // The diagonal plan strays from the L at (3, 3) and (4, 4), 3 cells from both legs.
        assert_eq!(e.within_radius, 6.0 / 8.0);
        let s = summarize(&[e]);
        assert_eq!(s.mean_reference_cost_ratio, None);
    }
}
