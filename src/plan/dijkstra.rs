//! 8-connected Dijkstra on a per-cell costmap.
//!
//! Edge cost = step length (1 or √2 cells) × mean of the two cells' costs, the usual
//! discretisation of a line integral of cost. Cells with a non-finite or non-positive
//! cost are blocked. Ties are broken by cell index so plans are reproducible.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use crate::grid::{Cell, CellPath, Grid};

/// A planned path and its cost.
#[derive(Debug, Clone, PartialEq)]
pub struct Route {
    pub cells: CellPath,
    pub cost: f64,
}

/// The 8 neighbour offsets (row, col) in a fixed order, with their step lengths.
const NEIGHBOURS: [(i32, i32, f64); 8] = [
    (-1, 0, 1.0),
    (0, -1, 1.0),
    (0, 1, 1.0),
    (1, 0, 1.0),
    (-1, -1, std::f64::consts::SQRT_2),
    (-1, 1, std::f64::consts::SQRT_2),
    (1, -1, std::f64::consts::SQRT_2),
    (1, 1, std::f64::consts::SQRT_2),
];

/// Cost of one step between neighbouring cells with costs `a` and `b`.
pub fn edge_cost(a: f32, b: f32, diagonal: bool) -> f64 {
    let length = if diagonal {
        std::f64::consts::SQRT_2
    } else {
        1.0
    };
    length * 0.5 * (f64::from(a) + f64::from(b))
}

/// Cost of a connected path under `costs` (sum of its edge costs).
pub fn path_cost(costs: &Grid<f32>, path: &[Cell]) -> f64 {
    path.windows(2)
        .map(|w| {
            let diagonal = w[0].row != w[1].row && w[0].col != w[1].col;
            edge_cost(costs.get(w[0]), costs.get(w[1]), diagonal)
        })
        .sum()
}

fn passable(cost: f32) -> bool {
    cost.is_finite() && cost > 0.0
}

#[derive(PartialEq)]
struct Entry {
    dist: f64,
    index: u32,
}

impl Eq for Entry {}

impl Ord for Entry {
    /// Reversed so that `BinaryHeap` pops the smallest distance, then the smallest index.
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .dist
            .total_cmp(&self.dist)
            .then_with(|| other.index.cmp(&self.index))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// The cheapest path from `start` to `goal`, or `None` when the goal cannot be reached
/// (or either end is blocked or off the grid).
pub fn shortest_path(costs: &Grid<f32>, start: Cell, goal: Cell) -> Option<Route> {
    let geo = &costs.geo;
    if !geo.contains(start) || !geo.contains(goal) {
        return None;
    }
    if !passable(costs.get(start)) || !passable(costs.get(goal)) {
        return None;
    }
    let (width, height) = (geo.width as i64, geo.height as i64);
    let n = geo.cell_count();
    let mut dist = vec![f64::INFINITY; n];
    let mut parent = vec![u32::MAX; n];
    let mut done = vec![false; n];
    let start_index = geo.index(start);
    let goal_index = geo.index(goal);
    dist[start_index] = 0.0;
    let mut heap = BinaryHeap::new();
    heap.push(Entry {
        dist: 0.0,
        index: start_index as u32,
    });
    while let Some(Entry { dist: d, index }) = heap.pop() {
        let i = index as usize;
        if done[i] {
            continue;
        }
        done[i] = true;
        if i == goal_index {
            break;
        }
        let (row, col) = ((i as i64) / width, (i as i64) % width);
        let cost_here = costs.data[i];
        for &(dr, dc, length) in &NEIGHBOURS {
            let (r, c) = (row + i64::from(dr), col + i64::from(dc));
            if r < 0 || c < 0 || r >= height || c >= width {
                continue;
            }
            let j = (r * width + c) as usize;
            let cost_there = costs.data[j];
            if done[j] || !passable(cost_there) {
                continue;
            }
            let candidate = d + length * 0.5 * (f64::from(cost_here) + f64::from(cost_there));
            if candidate < dist[j] {
                dist[j] = candidate;
                parent[j] = index;
                heap.push(Entry {
                    dist: candidate,
                    index: j as u32,
                });
            }
        }
    }
    if !done[goal_index] {
        return None;
    }
    let mut cells = vec![goal];
    let mut i = goal_index;
    while i != start_index {
        i = parent[i] as usize;
        cells.push(geo.cell_at(i));
    }
    cells.reverse();
    Some(Route {
        cells,
        cost: dist[goal_index],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{GeoRef, is_connected8};
    use proptest::prelude::*;

    fn grid(width: u32, height: u32, data: Vec<f32>) -> Grid<f32> {
        let geo = GeoRef {
            width,
            height,
            resolution: 1.0,
            origin: [0.0, 0.0],
            frame: "map".into(),
        };
        Grid::from_vec(geo, data)
    }

    /// Bellman–Ford over the same 8-connected graph: slow, obviously correct.
    fn brute_force(costs: &Grid<f32>, start: Cell, goal: Cell) -> Option<f64> {
        let n = costs.geo.cell_count();
        let mut dist = vec![f64::INFINITY; n];
        if !passable(costs.get(start)) || !passable(costs.get(goal)) {
            return None;
        }
        dist[costs.geo.index(start)] = 0.0;
        for _ in 0..n {
            for i in 0..n {
                let a = costs.geo.cell_at(i);
                if !passable(costs.data[i]) || !dist[i].is_finite() {
                    continue;
                }
                for j in 0..n {
                    let b = costs.geo.cell_at(j);
                    if a.chebyshev(b) != 1 || !passable(costs.data[j]) {
                        continue;
                    }
                    let diagonal = a.row != b.row && a.col != b.col;
                    let d = dist[i] + edge_cost(costs.data[i], costs.data[j], diagonal);
                    if d < dist[j] {
                        dist[j] = d;
                    }
                }
            }
        }
        let d = dist[costs.geo.index(goal)];
        d.is_finite().then_some(d)
    }

    #[test]
    fn uniform_grid_takes_the_diagonal() {
        let g = grid(5, 5, vec![1.0; 25]);
        let route = shortest_path(&g, Cell::new(0, 0), Cell::new(4, 4)).unwrap();
        assert_eq!(route.cells.len(), 5);
        assert!((route.cost - 4.0 * std::f64::consts::SQRT_2).abs() < 1e-12);
    }

    #[test]
    fn walls_are_avoided_and_enclosed_goals_unreachable() {
        let mut data = vec![1.0; 25];
        for row in 0..4 {
            data[row * 5 + 2] = f32::INFINITY;
        }
        let g = grid(5, 5, data.clone());
        let route = shortest_path(&g, Cell::new(0, 0), Cell::new(0, 4)).unwrap();
        assert!(
            route.cells.iter().any(|c| c.row == 4),
            "goes round the wall"
        );
        data[4 * 5 + 2] = 0.0;
        let g = grid(5, 5, data);
        assert_eq!(shortest_path(&g, Cell::new(0, 0), Cell::new(0, 4)), None);
    }

    proptest! {
        #[test]
        fn matches_brute_force_on_small_grids(
            (w, h, data, s, t) in (1u32..6, 1u32..6).prop_flat_map(|(w, h)| {
                let n = (w * h) as usize;
                (
                    Just(w),
                    Just(h),
                    prop::collection::vec(
                        prop_oneof![4 => 0.1f32..10.0, 1 => Just(f32::INFINITY)],
                        n,
                    ),
                    0..n,
                    0..n,
                )
            })
        ) {
            let g = grid(w, h, data);
            let (start, goal) = (g.geo.cell_at(s), g.geo.cell_at(t));
            let expected = brute_force(&g, start, goal);
            let route = shortest_path(&g, start, goal);
            prop_assert_eq!(route.is_some(), expected.is_some());
            if let (Some(route), Some(expected)) = (route, expected) {
                prop_assert!((route.cost - expected).abs() <= 1e-9 * expected.max(1.0));
                prop_assert!(is_connected8(&route.cells));
                prop_assert_eq!(route.cells[0], start);
                prop_assert_eq!(*route.cells.last().unwrap(), goal);
                prop_assert!((path_cost(&g, &route.cells) - route.cost).abs() <= 1e-9 * route.cost.max(1.0));
                prop_assert!(route.cells.iter().all(|&c| passable(g.get(c))));
            }
        }
    }
}
