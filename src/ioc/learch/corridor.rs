//! Demonstrations as their demonstrators meant them: a recorded track wanders around
//! the route the robot was driven along (GNSS and odometry noise, a driver's
//! weaving), and LEARCH, asked to make every wobble optimal, learns the dear ground it
//! brushes as cheap. Each round instead takes the cheapest path under the current cost
//! through a corridor of cells around the track (Silver, Bagnell and Stentz, "Learning
//! from demonstration for autonomous navigation in complex unstructured terrain",
//! IJRR 2010: the example replaced by the best path within a corridor around it).

use crate::grid::{Cell, CellPath, GeoRef, Grid};
use crate::plan::{Moves, dijkstra};

/// The cheapest path under `costs` between the ends of `track` through the cells
/// within `radius` cells of one of its cells (round on the grid: a cell whose offset
/// (dr, dc) from a track cell has dr² + dc² ≤ (radius + ½)²). `None` when `radius` is
/// 0 or no such path exists (the track crosses blocked cells only).
pub(super) fn corridor_path(costs: &Grid<f32>, track: &[Cell], radius: u32) -> Option<CellPath> {
    let (first, last) = (track.first()?, track.last()?);
    if radius == 0 {
        return None;
    }
    let geo = &costs.geo;
    let r = radius as i64;
    let (mut r0, mut r1, mut c0, mut c1) = (i64::MAX, i64::MIN, i64::MAX, i64::MIN);
    for cell in track {
        let (row, col) = (i64::from(cell.row), i64::from(cell.col));
        (r0, r1, c0, c1) = (r0.min(row), r1.max(row), c0.min(col), c1.max(col));
    }
    let (r0, c0) = ((r0 - r).max(0), (c0 - r).max(0));
    let r1 = (r1 + r).min(i64::from(geo.height) - 1);
    let c1 = (c1 + r).min(i64::from(geo.width) - 1);
    let (w, h) = ((c1 - c0 + 1) as usize, (r1 - r0 + 1) as usize);
    let mut values = vec![f32::INFINITY; w * h];
    let reach = (radius as f64 + 0.5).powi(2);
    for cell in track {
        let (row, col) = (i64::from(cell.row), i64::from(cell.col));
        for dr in -r..=r {
            for dc in -r..=r {
                let (rr, cc) = (row + dr, col + dc);
                if ((dr * dr + dc * dc) as f64) > reach || rr < r0 || rr > r1 || cc < c0 || cc > c1
                {
                    continue;
                }
                let local = (rr - r0) as usize * w + (cc - c0) as usize;
                values[local] = costs.get(Cell::new(rr as u32, cc as u32));
            }
        }
    }
    let [sx, sy] = geo.cell_size();
    let window = GeoRef {
        width: w as u32,
        height: h as u32,
        origin: [
            geo.origin[0] + c0 as f64 * sx,
            geo.origin[1] + r0 as f64 * sy,
        ],
        ..geo.clone()
    };
    let local = |cell: &Cell| Cell::new(cell.row - r0 as u32, cell.col - c0 as u32);
    let route = dijkstra(
        &Grid::from_vec(window, values),
        local(first),
        local(last),
        Moves::default(),
    )?;
    Some(
        route
            .cells
            .into_iter()
            .map(|cell| Cell::new(cell.row + r0 as u32, cell.col + c0 as u32))
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::path_cost;

    fn costs(width: u32, height: u32, cost: impl Fn(u32, u32) -> f32) -> Grid<f32> {
        let geo = GeoRef::square(width, height, 1.0, [0.0, 0.0], "map");
        let values = (0..height)
            .flat_map(|r| (0..width).map(move |c| (r, c)))
            .map(|(r, c)| cost(r, c))
            .collect();
        Grid::from_vec(geo, values)
    }

    #[test]
    fn a_wobbling_track_becomes_the_cheap_road_it_wobbles_around() {
        // A cheap road along row 5 of dear ground; the track weaves a cell to either
        // side of it every few columns.
        let grid = costs(41, 11, |r, _| if r == 5 { 1.0 } else { 5.0 });
        let track: Vec<Cell> = (0..41)
            .map(|c| Cell::new([5, 6, 5, 4][c as usize % 4], c))
            .collect();
        let road = corridor_path(&grid, &track, 1).unwrap();
        assert!(road.iter().all(|cell| cell.row == 5), "{road:?}");
        assert_eq!((road[0], road[road.len() - 1]), (track[0], track[40]));
        assert!(path_cost(&grid, &road) < path_cost(&grid, &track));
    }

    #[test]
    fn the_path_keeps_to_the_corridor() {
        // The road lies 3 rows off the track: a corridor of 1 cell cannot reach it, one
        // of 3 can.
        let grid = costs(30, 12, |r, _| if r == 8 { 1.0 } else { 5.0 });
        let track: Vec<Cell> = (0..30).map(|c| Cell::new(5, c)).collect();
        let near = corridor_path(&grid, &track, 1).unwrap();
        assert!(
            near.iter().all(|cell| (4..=6).contains(&cell.row)),
            "{near:?}"
        );
        let wide = corridor_path(&grid, &track, 3).unwrap();
        assert!(
            wide.iter().filter(|cell| cell.row == 8).count() >= 24,
            "{wide:?}"
        );
        assert!(wide.iter().all(|cell| (2..=8).contains(&cell.row)));
        assert_eq!(corridor_path(&grid, &track, 0), None);
    }

    #[test]
    fn a_corridor_at_the_map_edge_is_clipped() {
        let grid = costs(10, 3, |_, _| 1.0);
        let track: Vec<Cell> = (0..10).map(|c| Cell::new(0, c)).collect();
        let path = corridor_path(&grid, &track, 2).unwrap();
        assert_eq!(path.len(), 10);
        assert!(path.iter().all(|cell| cell.row < 3));
    }
}
