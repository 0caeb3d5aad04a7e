//! Dijkstra and A* on 4- or 8-connected grids.
//!
//! The costmap is copied once into a grid with a one-cell blocked border, so that the
//! inner loop finds neighbours by adding fixed index offsets, with no bounds checks.
//! Ties are broken by a fixed processing order, so plans are reproducible.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use serde::{Deserialize, Serialize};

use super::queue::MinQueue;
use crate::grid::{Cell, CellPath, GeoRef, Grid};

const SQRT_2: f64 = std::f64::consts::SQRT_2;

/// Which neighbours a step may go to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Connectivity {
    Four,
    Eight,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Moves {
    pub connectivity: Connectivity,
    /// Whether a diagonal step may pass a blocked orthogonal neighbour (MovingAI
    /// benchmarks forbid it).
    pub corner_cutting: bool,
}

impl Default for Moves {
    fn default() -> Self {
        Moves {
            connectivity: Connectivity::Eight,
            corner_cutting: true,
        }
    }
}

/// A planned path and its cost.
#[derive(Debug, Clone, PartialEq)]
pub struct Route {
    pub cells: CellPath,
    pub cost: f64,
}

/// Cost of one step between neighbouring cells with costs `a` and `b`.
pub fn edge_cost(a: f32, b: f32, diagonal: bool) -> f64 {
    let length = if diagonal { SQRT_2 } else { 1.0 };
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

/// How many times the paths visit each cell (row-major).
pub fn visitation<'a>(geo: &GeoRef, paths: impl IntoIterator<Item = &'a [Cell]>) -> Vec<u32> {
    let mut counts = vec![0u32; geo.cell_count()];
    for path in paths {
        for &cell in path {
            counts[geo.index(cell)] += 1;
        }
    }
    counts
}

fn passable(cost: f32) -> bool {
    cost.is_finite() && cost > 0.0
}

/// One neighbour step: index offset in the padded grid, length, and the two orthogonal
/// offsets a diagonal passes (equal to `offset` for orthogonal steps).
#[derive(Clone, Copy)]
struct Step {
    offset: isize,
    length: f64,
    side_a: isize,
    side_b: isize,
}

/// The costmap with a blocked border, and everything the search loops need.
struct Padded {
    width: usize,
    height: usize,
    /// Half of each cell's cost (edge cost = length × (half_u + half_v)); blocked = ∞.
    half: Vec<f64>,
    steps: Vec<Step>,
    check_corners: bool,
    min_cost: f64,
    max_cost: f64,
}

impl Padded {
    fn new(costs: &Grid<f32>, moves: Moves) -> Self {
        let (w, h) = (costs.geo.width as usize, costs.geo.height as usize);
        let pw = w + 2;
        let mut half = vec![f64::INFINITY; pw * (h + 2)];
        let (mut min_cost, mut max_cost) = (f64::INFINITY, 0.0f64);
        for row in 0..h {
            let src = &costs.data[row * w..(row + 1) * w];
            let dst = &mut half[(row + 1) * pw + 1..(row + 1) * pw + 1 + w];
            for (d, &c) in dst.iter_mut().zip(src) {
                if passable(c) {
                    let c = f64::from(c);
                    *d = 0.5 * c;
                    min_cost = min_cost.min(c);
                    max_cost = max_cost.max(c);
                }
            }
        }
        let p = pw as isize;
        let mut steps = vec![
            Step { offset: -p, length: 1.0, side_a: -p, side_b: -p },
            Step { offset: -1, length: 1.0, side_a: -1, side_b: -1 },
            Step { offset: 1, length: 1.0, side_a: 1, side_b: 1 },
            Step { offset: p, length: 1.0, side_a: p, side_b: p },
        ];
        if moves.connectivity == Connectivity::Eight {
            for (dr, dc) in [(-1, -1), (-1, 1), (1, -1), (1, 1)] {
                steps.push(Step { offset: dr * p + dc, length: SQRT_2, side_a: dr * p, side_b: dc });
            }
        }
        let check_corners = !moves.corner_cutting && moves.connectivity == Connectivity::Eight;
        Padded { width: w, height: h, half, steps, check_corners, min_cost, max_cost }
    }

    fn pad(&self, cell: Cell) -> usize {
        (cell.row as usize + 1) * (self.width + 2) + cell.col as usize + 1
    }

    fn unpad(&self, index: usize) -> Cell {
        let pw = self.width + 2;
        Cell::new((index / pw - 1) as u32, (index % pw - 1) as u32)
    }

    fn open(&self, cell: Cell) -> bool {
        (cell.row as usize) < self.height
            && (cell.col as usize) < self.width
            && self.half[self.pad(cell)].is_finite()
    }

    fn longest_step(&self) -> f64 {
        if self.steps.len() == 8 { SQRT_2 } else { 1.0 }
    }

    /// Calls `relax(neighbour, edge cost)` for every allowed step out of `u`.
    #[inline(always)]
    fn for_each_step(&self, u: usize, mut relax: impl FnMut(usize, f64)) {
        let hu = self.half[u];
        for step in &self.steps {
            let v = u.wrapping_add_signed(step.offset);
            let hv = self.half[v];
            if !hv.is_finite() {
                continue;
            }
            if self.check_corners
                && step.side_a != step.side_b
                && !(self.half[u.wrapping_add_signed(step.side_a)].is_finite()
                    && self.half[u.wrapping_add_signed(step.side_b)].is_finite())
            {
                continue;
            }
            relax(v, step.length * (hu + hv));
        }
    }

    fn path(&self, parent: &[u32], goal: usize) -> CellPath {
        let mut cells = vec![self.unpad(goal)];
        let mut i = goal;
        while parent[i] != u32::MAX {
            i = parent[i] as usize;
            cells.push(self.unpad(i));
        }
        cells.reverse();
        cells
    }
}

/// Result of a full Dijkstra: the cost of reaching every cell from the nearest source.
#[derive(Debug, Clone)]
pub struct CostField {
    pub geo: GeoRef,
    /// Row-major; ∞ where no source reaches.
    pub cost: Vec<f64>,
    /// Row-major index of each cell's predecessor; `u32::MAX` at sources and unreached cells.
    parent: Vec<u32>,
}

impl CostField {
    pub fn cost_at(&self, cell: Cell) -> f64 {
        self.cost[self.geo.index(cell)]
    }

    /// The cheapest path from a source to `cell`, or `None` when unreached.
    pub fn path_to(&self, cell: Cell) -> Option<CellPath> {
        if !self.geo.contains(cell) || !self.cost_at(cell).is_finite() {
            return None;
        }
        let mut cells = vec![cell];
        let mut i = self.geo.index(cell);
        while self.parent[i] != u32::MAX {
            i = self.parent[i] as usize;
            cells.push(self.geo.cell_at(i));
        }
        cells.reverse();
        Some(cells)
    }
}

/// The search state of one Dijkstra run on the padded grid.
struct Search {
    dist: Vec<f64>,
    parent: Vec<u32>,
    settled: Vec<bool>,
}

/// Dijkstra from `sources` until `stop` is settled (or everything reachable is).
fn run_dijkstra(grid: &Padded, sources: &[usize], stop: Option<usize>) -> Search {
    let n = grid.half.len();
    let mut s = Search { dist: vec![f64::INFINITY; n], parent: vec![u32::MAX; n], settled: vec![false; n] };
    let min_edge = grid.min_cost;
    let max_edge = grid.longest_step() * grid.max_cost;
    let mut queue = MinQueue::new(min_edge, max_edge);
    for &i in sources {
        if s.dist[i] != 0.0 {
            s.dist[i] = 0.0;
            queue.push(0.0, i as u32);
        }
    }
    while let Some(u) = queue.pop() {
        let u = u as usize;
        if s.settled[u] {
            continue;
        }
        s.settled[u] = true;
        if Some(u) == stop {
            break;
        }
        let du = s.dist[u];
        let (dist, parent) = (&mut s.dist, &mut s.parent);
        grid.for_each_step(u, |v, w| {
            let candidate = du + w;
            if candidate < dist[v] {
                dist[v] = candidate;
                parent[v] = u as u32;
                queue.push(candidate, v as u32);
            }
        });
    }
    s
}

/// Full Dijkstra from one or more sources: the cost-to-go (cost-to-come) field and
/// the tree of cheapest paths. Blocked or off-grid sources are ignored.
pub fn cost_to_go(costs: &Grid<f32>, sources: &[Cell], moves: Moves) -> CostField {
    let grid = Padded::new(costs, moves);
    let starts: Vec<usize> = sources.iter().filter(|&&c| grid.open(c)).map(|&c| grid.pad(c)).collect();
    let search = run_dijkstra(&grid, &starts, None);
    let geo = costs.geo.clone();
    let mut cost = Vec::with_capacity(geo.cell_count());
    let mut parent = Vec::with_capacity(geo.cell_count());
    let pw = grid.width + 2;
    for row in 0..grid.height {
        let base = (row + 1) * pw + 1;
        cost.extend_from_slice(&search.dist[base..base + grid.width]);
        parent.extend(search.parent[base..base + grid.width].iter().map(|&p| {
            if p == u32::MAX {
                p
            } else {
                let c = grid.unpad(p as usize);
                (c.row as usize * grid.width + c.col as usize) as u32
            }
        }));
    }
    CostField { geo, cost, parent }
}

/// Dijkstra from `start`, stopping when `goal` is settled.
pub fn dijkstra(costs: &Grid<f32>, start: Cell, goal: Cell, moves: Moves) -> Option<Route> {
    let grid = Padded::new(costs, moves);
    if !grid.open(start) || !grid.open(goal) {
        return None;
    }
    let (s, g) = (grid.pad(start), grid.pad(goal));
    let search = run_dijkstra(&grid, &[s], Some(g));
    search.settled[g].then(|| Route { cells: grid.path(&search.parent, g), cost: search.dist[g] })
}

/// A* with the octile (or Manhattan) distance times the cheapest cell cost, which never
/// overestimates and is consistent, so the first time the goal is reached is optimal.
/// Among equal estimates, deeper nodes go first, then lower indices.
pub fn astar(costs: &Grid<f32>, start: Cell, goal: Cell, moves: Moves) -> Option<Route> {
    let grid = Padded::new(costs, moves);
    if !grid.open(start) || !grid.open(goal) {
        return None;
    }
    let (s, g) = (grid.pad(start), grid.pad(goal));
    let pw = grid.width + 2;
    let (goal_row, goal_col) = (g / pw, g % pw);
    let eight = moves.connectivity == Connectivity::Eight;
    let min_cost = grid.min_cost;
    let heuristic = |i: usize| {
        let dr = (i / pw).abs_diff(goal_row) as f64;
        let dc = (i % pw).abs_diff(goal_col) as f64;
        let steps = if eight { dr.max(dc) + (SQRT_2 - 1.0) * dr.min(dc) } else { dr + dc };
        steps * min_cost
    };
    let n = grid.half.len();
    let mut dist = vec![f64::INFINITY; n];
    let mut parent = vec![u32::MAX; n];
    let mut closed = vec![false; n];
    let mut open = BinaryHeap::new();
    dist[s] = 0.0;
    open.push((Reverse(heuristic(s).to_bits()), 0u64, Reverse(s as u32)));
    while let Some((_, _, Reverse(u))) = open.pop() {
        let u = u as usize;
        if closed[u] {
            continue;
        }
        closed[u] = true;
        if u == g {
            return Some(Route { cells: grid.path(&parent, g), cost: dist[g] });
        }
        let du = dist[u];
        grid.for_each_step(u, |v, w| {
            let candidate = du + w;
            if candidate < dist[v] {
                dist[v] = candidate;
                parent[v] = u as u32;
                let f = candidate + heuristic(v);
                open.push((Reverse(f.to_bits()), candidate.to_bits(), Reverse(v as u32)));
            }
        });
    }
    None
}

/// The cheapest 8-connected path (corner cutting allowed) from `start` to `goal`, or
/// `None` when the goal cannot be reached or either end is blocked or off the grid.
pub fn shortest_path(costs: &Grid<f32>, start: Cell, goal: Cell) -> Option<Route> {
    astar(costs, start, goal, Moves::default())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::is_connected8;
    use proptest::prelude::*;

    fn grid(width: u32, height: u32, data: Vec<f32>) -> Grid<f32> {
        let geo = GeoRef { width, height, resolution: 1.0, origin: [0.0, 0.0], frame: "map".into() };
        Grid::from_vec(geo, data)
    }

    fn step_allowed(costs: &Grid<f32>, a: Cell, b: Cell, moves: Moves) -> bool {
        let diagonal = a.row != b.row && a.col != b.col;
        if a.chebyshev(b) != 1 || !passable(costs.get(b)) {
            return false;
        }
        if diagonal && moves.connectivity == Connectivity::Four {
            return false;
        }
        if diagonal && !moves.corner_cutting {
            return passable(costs.get(Cell::new(a.row, b.col))) && passable(costs.get(Cell::new(b.row, a.col)));
        }
        true
    }

    /// Bellman–Ford over the same graph: slow, obviously correct.
    fn brute_force(costs: &Grid<f32>, start: Cell, moves: Moves) -> Vec<f64> {
        let n = costs.geo.cell_count();
        let mut dist = vec![f64::INFINITY; n];
        if !passable(costs.get(start)) {
            return dist;
        }
        dist[costs.geo.index(start)] = 0.0;
        for _ in 0..n {
            for i in 0..n {
                let a = costs.geo.cell_at(i);
                if !dist[i].is_finite() || !passable(costs.data[i]) {
                    continue;
                }
                for j in 0..n {
                    let b = costs.geo.cell_at(j);
                    if step_allowed(costs, a, b, moves) {
                        let diagonal = a.row != b.row && a.col != b.col;
                        let d = dist[i] + edge_cost(costs.data[i], costs.data[j], diagonal);
                        if d < dist[j] {
                            dist[j] = d;
                        }
                    }
                }
            }
        }
        dist
    }

    fn all_moves() -> impl Strategy<Value = Moves> {
        (prop_oneof![Just(Connectivity::Four), Just(Connectivity::Eight)], any::<bool>())
            .prop_map(|(connectivity, corner_cutting)| Moves { connectivity, corner_cutting })
    }

    fn small_grid() -> impl Strategy<Value = (Grid<f32>, usize, usize)> {
        (1u32..7, 1u32..7).prop_flat_map(|(w, h)| {
            let n = (w * h) as usize;
            (
                prop::collection::vec(prop_oneof![4 => 0.1f32..10.0, 1 => Just(f32::INFINITY)], n),
                0..n,
                0..n,
            )
                .prop_map(move |(data, s, t)| (grid(w, h, data), s, t))
        })
    }

    fn assert_valid(costs: &Grid<f32>, route: &Route, start: Cell, goal: Cell, moves: Moves) {
        assert_eq!(route.cells[0], start);
        assert_eq!(*route.cells.last().unwrap(), goal);
        assert!(route.cells.windows(2).all(|w| step_allowed(costs, w[0], w[1], moves)));
        assert!((path_cost(costs, &route.cells) - route.cost).abs() <= 1e-9 * route.cost.max(1.0));
    }

    #[test]
    fn uniform_grid_takes_the_diagonal() {
        let g = grid(5, 5, vec![1.0; 25]);
        let route = shortest_path(&g, Cell::new(0, 0), Cell::new(4, 4)).unwrap();
        assert_eq!(route.cells.len(), 5);
        assert!((route.cost - 4.0 * SQRT_2).abs() < 1e-12);
        let four = Moves { connectivity: Connectivity::Four, corner_cutting: false };
        assert!((dijkstra(&g, Cell::new(0, 0), Cell::new(4, 4), four).unwrap().cost - 8.0).abs() < 1e-12);
    }

    #[test]
    fn corners_are_not_cut_when_forbidden() {
        // . #
        // . .   a diagonal from (0,0) to (1,1) passes the blocked (0,1)... (row 0 is the bottom)
        let g = grid(2, 2, vec![1.0, f32::INFINITY, 1.0, 1.0]);
        let (a, b) = (Cell::new(0, 0), Cell::new(1, 1));
        let cutting = astar(&g, a, b, Moves::default()).unwrap();
        assert_eq!(cutting.cells.len(), 2);
        let careful = astar(&g, a, b, Moves { corner_cutting: false, ..Moves::default() }).unwrap();
        assert_eq!(careful.cells, [a, Cell::new(1, 0), b]);
    }

    #[test]
    fn multiple_sources_and_visitation() {
        let g = grid(7, 1, vec![1.0; 7]);
        let field = cost_to_go(&g, &[Cell::new(0, 0), Cell::new(0, 6)], Moves::default());
        let costs: Vec<f64> = field.cost.clone();
        assert_eq!(costs, [0.0, 1.0, 2.0, 3.0, 2.0, 1.0, 0.0]);
        assert_eq!(field.path_to(Cell::new(0, 2)).unwrap(), [Cell::new(0, 0), Cell::new(0, 1), Cell::new(0, 2)]);
        let p = field.path_to(Cell::new(0, 5)).unwrap();
        let q = field.path_to(Cell::new(0, 4)).unwrap();
        assert_eq!(visitation(&g.geo, [p.as_slice(), q.as_slice()]), [0, 0, 0, 0, 1, 2, 2]);
    }

    #[test]
    fn wide_cost_ranges_use_the_heap_and_agree() {
        let data: Vec<f32> = (0..100).map(|i| if i % 7 == 0 { 1e-6 } else { 1e6 }).collect();
        let g = grid(10, 10, data);
        let field = cost_to_go(&g, &[Cell::new(0, 0)], Moves::default());
        let brute = brute_force(&g, Cell::new(0, 0), Moves::default());
        for (a, b) in field.cost.iter().zip(&brute) {
            assert!((a - b).abs() <= 1e-9 * b.max(1.0), "{a} vs {b}");
        }
    }

    proptest! {
        #[test]
        fn dijkstra_and_astar_match_brute_force((g, s, t) in small_grid(), moves in all_moves()) {
            let (start, goal) = (g.geo.cell_at(s), g.geo.cell_at(t));
            let brute = brute_force(&g, start, moves);
            let expected = brute[t];
            let field = cost_to_go(&g, &[start], moves);
            for (a, b) in field.cost.iter().zip(&brute) {
                prop_assert!((a - b).abs() <= 1e-9 * b.max(1.0) || (a.is_infinite() && b.is_infinite()));
            }
            let by_dijkstra = dijkstra(&g, start, goal, moves);
            let by_astar = astar(&g, start, goal, moves);
            prop_assert_eq!(by_astar.is_some(), expected.is_finite() && passable(g.get(goal)));
            prop_assert_eq!(by_dijkstra.is_some(), by_astar.is_some());
            if let (Some(d), Some(a)) = (by_dijkstra, by_astar) {
                prop_assert!((a.cost - expected).abs() <= 1e-9 * expected.max(1.0));
                prop_assert!((d.cost - expected).abs() <= 1e-9 * expected.max(1.0));
                assert_valid(&g, &a, start, goal, moves);
                assert_valid(&g, &d, start, goal, moves);
                if moves.connectivity == Connectivity::Eight {
                    prop_assert!(is_connected8(&a.cells));
                }
                let via_field = field.path_to(goal).unwrap();
                prop_assert!((path_cost(&g, &via_field) - expected).abs() <= 1e-9 * expected.max(1.0));
            }
        }
    }
}
