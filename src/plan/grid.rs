//! Dijkstra and A* on 4- or 8-connected grids.
//!
//! Ties are broken by a fixed processing order, so plans are reproducible.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use serde::{Deserialize, Serialize};

use super::queue::{Buckets, Heap, MinQueue};
use super::relax::{self, CLOSED, NO_PARENT, Node, RowSteps};
use super::steps::StepLengths;
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

/// Cost of one step of `length` between neighbouring cells with costs `a` and `b`.
pub fn edge_cost(a: f32, b: f32, length: f64) -> f64 {
    length * 0.5 * (f64::from(a) + f64::from(b))
}

/// Cost of a connected path under `costs` (sum of its edge costs).
pub fn path_cost(costs: &Grid<f32>, path: &[Cell]) -> f64 {
    let lengths = StepLengths::of(&costs.geo);
    path.windows(2)
        .map(|w| {
            edge_cost(
                costs.get(w[0]),
                costs.get(w[1]),
                lengths.between(w[0], w[1]),
            )
        })
        .sum()
}

/// Loss-augmented costs for LEARCH-style training: cost minus a per-cell loss, floored
/// at `floor` (> 0) so that no passable cell becomes free or blocked. Blocked cells
/// stay blocked.
pub fn loss_augmented(costs: &Grid<f32>, loss: &[f32], floor: f32) -> Grid<f32> {
    assert_eq!(loss.len(), costs.data.len(), "one loss per cell");
    let data = costs
        .data
        .iter()
        .zip(loss)
        .map(|(&c, &l)| augmented_cost(c, l, floor))
        .collect();
    Grid::from_vec(costs.geo.clone(), data)
}

/// One cell of [`loss_augmented`]: `cost` less `loss`, floored at `floor` where passable.
#[inline]
pub fn augmented_cost(cost: f32, loss: f32, floor: f32) -> f32 {
    if passable(cost) {
        (cost - loss).max(floor)
    } else {
        cost
    }
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

/// A finite cost above zero. Tested on the bits in one comparison (a positive finite
/// f32's bits lie strictly between those of 0 and ∞; negatives and NaNs above ∞'s), so
/// that loops over whole costmaps stay free of branches.
fn passable(cost: f32) -> bool {
    cost.to_bits().wrapping_sub(1) < f32::INFINITY.to_bits() - 1
}

/// The smallest and largest passable cost (∞ and 0 when none is). Eight running minima
/// and maxima instead of one, so that the pass vectorises rather than waiting on one
/// chain of comparisons.
fn passable_cost_range(costs: &[f32]) -> (f64, f64) {
    const LANES: usize = 8;
    let (mut low, mut high) = ([f32::INFINITY; LANES], [0.0f32; LANES]);
    let mut take = |lane: usize, c: f32| {
        let open = passable(c);
        low[lane] = low[lane].min(if open { c } else { f32::INFINITY });
        high[lane] = high[lane].max(if open { c } else { 0.0 });
    };
    let (chunks, rest) = costs.as_chunks::<LANES>();
    for chunk in chunks {
        for (lane, &c) in chunk.iter().enumerate() {
            take(lane, c);
        }
    }
    for (lane, &c) in rest.iter().enumerate() {
        take(lane, c);
    }
    let low = low.into_iter().fold(f32::INFINITY, f32::min);
    let high = high.into_iter().fold(0.0, f32::max);
    (f64::from(low), f64::from(high))
}

/// A planner over one costmap. The costmap is copied once into a grid with a one-cell
/// blocked border, so the inner loop finds neighbours by adding fixed offsets without
/// bounds checks, and the planner's buffers are reused between queries: each query
/// resets just the cells it reached, so it costs time in proportion to what it explores.
pub struct GridPlanner {
    geo: GeoRef,
    width: usize,
    height: usize,
    nodes: Vec<Node>,
    moves: Moves,
    lengths: StepLengths,
    min_cost: f64,
    max_cost: f64,
    /// Cells reached by the current query, to reset before the next one.
    touched: Vec<u32>,
    /// Whether the planner answers more than one query, and so must track and reset
    /// what each one reached (one-shot planners skip that work).
    reused: bool,
}

/// Where a search puts the neighbours whose cost went down.
trait Frontier {
    /// `node`'s cost went down from `old` (∞ when first reached) to `cost`.
    fn reached(&mut self, node: usize, old: f64, cost: f64);
}

impl<Q: MinQueue> Frontier for Q {
    #[inline(always)]
    fn reached(&mut self, node: usize, old: f64, cost: f64) {
        self.decrease(node as u32, old, cost);
    }
}

/// A*'s open list: ordered by cost plus the octile (or Manhattan) distance to the goal
/// times the cheapest cell cost, then by larger cost (deeper first), then by index.
struct AstarOpen<const N: usize> {
    /// Keys packed into one integer for cheap comparisons: f's bits (non-negative f64s
    /// order like their bits), then the complement of g's f32 bits (deeper first, a
    /// tie-break only), then the node index.
    heap: BinaryHeap<Reverse<u128>>,
    row: u32,
    goal_row: u32,
    goal_col: u32,
    min_cost: f64,
    /// Lower bounds on each kind of step anywhere on the grid.
    shortest: RowSteps,
}

impl<const N: usize> AstarOpen<N> {
    #[inline(always)]
    fn heuristic(&self, node: usize) -> f64 {
        let node = node as u32;
        let dr = f64::from((node / self.row).abs_diff(self.goal_row));
        let dc = f64::from((node % self.row).abs_diff(self.goal_col));
        let steps = if self.shortest == RowSteps::SQUARE {
            if N == 8 {
                dr.max(dc) + (SQRT_2 - 1.0) * dr.min(dc)
            } else {
                dr + dc
            }
        } else {
            // As many diagonal steps as both offsets allow, then straight ones: a
            // diagonal is never longer than its two sides.
            let (x, y) = (self.shortest.x, self.shortest.y[0]);
            let diagonals = if N == 8 { dr.min(dc) } else { 0.0 };
            diagonals * self.shortest.diagonal[0] + (dr - diagonals) * y + (dc - diagonals) * x
        };
        steps * self.min_cost
    }
}

impl<const N: usize> Frontier for AstarOpen<N> {
    #[inline(always)]
    fn reached(&mut self, node: usize, _old: f64, cost: f64) {
        let f = cost + self.heuristic(node);
        let deeper_first = u128::from(!(cost as f32).to_bits());
        self.heap.push(Reverse(
            (u128::from(f.to_bits()) << 64) | (deeper_first << 32) | node as u128,
        ));
    }
}

/// Relaxes the edges out of `u`, handing each neighbour whose cost went down to the
/// frontier and recording first reaches in `touched` (when `TRACK`). Generic over the
/// neighbourhood (N = 4 or 8) and the corner rule, so that every combination compiles to
/// straight-line code: this is where Dijkstra and A* spend their time. All eight steps
/// are evaluated at once, without branches, into a bit mask (`relax::candidates`); only
/// the neighbours that improve (about 1 in 6 on random costs) are then visited, which
/// saves most of the mispredicted branches of relaxing one at a time.
#[inline(always)]
fn expand<const N: usize, const NO_CORNER_CUTTING: bool, const TRACK: bool>(
    nodes: &mut [Node],
    row: usize,
    u: usize,
    lengths: &StepLengths,
    frontier: &mut impl Frontier,
    touched: &mut Vec<u32>,
) {
    // Rows differ only in geographic frames: elsewhere no division.
    let steps = match lengths.uniform() {
        Some(steps) => steps,
        None => lengths.row(u / row - 1),
    };
    // SAFETY: `u` is an inner cell of the padded grid (only passable cells are ever
    // queued, and the border is blocked), so its neighbours lie within `nodes`.
    let relax::Candidates {
        costs,
        mut improved,
    } = unsafe { relax::candidates(nodes, row, u, steps) };
    let neighbours = relax::neighbours(u, row);
    if N == 4 {
        improved &= 0b1111;
    }
    if N == 8 && NO_CORNER_CUTTING {
        let [up, left, right, down, ..] = neighbours;
        let open = |i: usize| u32::from(nodes[i].half != f32::INFINITY);
        let (open_up, open_left) = (open(up), open(left));
        let (open_right, open_down) = (open(right), open(down));
        let corners_allowed = (open_up & open_left) << 4
            | (open_up & open_right) << 5
            | (open_down & open_left) << 6
            | (open_down & open_right) << 7;
        improved &= 0b1111 | corners_allowed;
    }
    while improved != 0 {
        let k = improved.trailing_zeros() as usize;
        improved &= improved - 1;
        let v = neighbours[k];
        let node = &mut nodes[v];
        let old = node.dist;
        if TRACK && old == f64::INFINITY {
            touched.push(v as u32);
        }
        node.dist = costs[k];
        node.link = u as u32;
        frontier.reached(v, old, costs[k]);
    }
}

/// How many pops ahead the search prefetches the rows it will read.
const PREFETCH_AHEAD: usize = 4;

/// Asks the cache for the three rows around node `i` (the node and its neighbours),
/// which the search will read after it has finished the current node.
#[inline(always)]
fn prefetch_rows(nodes: &[Node], i: usize, row: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // Three nodes of 16 bytes may straddle two cache lines: ask for both ends.
        for at in [
            i - row - 1,
            i - row + 1,
            i - 1,
            i + 1,
            i + row - 1,
            i + row + 1,
        ] {
            // SAFETY: prefetching has no effect on memory; the pointer is in bounds.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(nodes.as_ptr().add(at) as *const i8) };
        }
    }
}

/// Calls `$search::<N, NO_CORNER_CUTTING>` for the planner's moves.
macro_rules! dispatch {
    ($self:ident . $search:ident ( $($arg:expr),* )) => {
        match ($self.moves.connectivity, $self.moves.corner_cutting) {
            (Connectivity::Four, _) => $self.$search::<4, false>($($arg),*),
            (Connectivity::Eight, true) => $self.$search::<8, false>($($arg),*),
            (Connectivity::Eight, false) => $self.$search::<8, true>($($arg),*),
        }
    };
}

impl GridPlanner {
    pub fn new(costs: &Grid<f32>, moves: Moves) -> Self {
        let (w, h) = (costs.geo.width as usize, costs.geo.height as usize);
        let pw = w + 2;
        let n = pw * (h + 2);
        assert!(n < NO_PARENT as usize, "grids up to 2^31 cells");
        let blocked = Node::BLOCKED;
        // Written once, row by row with the border around (not filled and then
        // overwritten), branch-free: on large maps this pass is a fair share of a search.
        let mut nodes = Vec::with_capacity(n);
        nodes.resize(pw, blocked);
        for src in costs.data.chunks_exact(w.max(1)).take(h) {
            nodes.push(blocked);
            nodes.extend(src.iter().map(|&c| Node {
                half: if passable(c) { 0.5 * c } else { f32::INFINITY },
                ..blocked
            }));
            nodes.push(blocked);
        }
        nodes.resize(n, blocked);
        let (min_cost, max_cost) = passable_cost_range(&costs.data);
        GridPlanner {
            geo: costs.geo.clone(),
            width: w,
            height: h,
            nodes,
            moves,
            lengths: StepLengths::of(&costs.geo),
            min_cost,
            max_cost,
            touched: Vec::new(),
            reused: true,
        }
    }

    /// A planner for one query, which need not track what it reaches.
    fn single_query(costs: &Grid<f32>, moves: Moves) -> Self {
        GridPlanner {
            reused: false,
            ..GridPlanner::new(costs, moves)
        }
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
            && self.nodes[self.pad(cell)].half.is_finite()
    }

    fn longest_step(&self) -> f64 {
        let (straight, any) = self.lengths.longest();
        match self.moves.connectivity {
            Connectivity::Four => straight,
            Connectivity::Eight => any,
        }
    }

    fn parent(&self, i: usize) -> Option<usize> {
        let p = self.nodes[i].link & !CLOSED;
        (p != NO_PARENT).then_some(p as usize)
    }

    fn path(&self, goal: usize) -> CellPath {
        let mut cells = vec![self.unpad(goal)];
        let mut i = goal;
        while let Some(p) = self.parent(i) {
            i = p;
            cells.push(self.unpad(i));
        }
        cells.reverse();
        cells
    }

    /// Puts every cell the last query reached back to "unreached".
    fn reset(&mut self) {
        for &i in &self.touched {
            let node = &mut self.nodes[i as usize];
            node.dist = f64::INFINITY;
            node.link = NO_PARENT;
        }
        self.touched.clear();
    }

    fn start(&mut self, i: usize) {
        self.nodes[i].dist = 0.0;
        self.nodes[i].link = NO_PARENT;
        self.touched.push(i as u32);
    }

    /// Dijkstra from `sources` until `stop` is settled (or everything reachable is).
    /// Reached cells are tracked only when the planner answers further queries.
    fn run_dijkstra<const N: usize, const NO_CORNER_CUTTING: bool>(
        &mut self,
        sources: &[usize],
        stop: Option<usize>,
    ) {
        let buckets = Buckets::new(self.min_cost, self.longest_step() * self.max_cost);
        match (buckets, self.reused) {
            (Some(q), true) => self.search::<N, NO_CORNER_CUTTING, true>(q, sources, stop),
            (Some(q), false) => self.search::<N, NO_CORNER_CUTTING, false>(q, sources, stop),
            (None, true) => {
                self.search::<N, NO_CORNER_CUTTING, true>(Heap::default(), sources, stop)
            }
            (None, false) => {
                self.search::<N, NO_CORNER_CUTTING, false>(Heap::default(), sources, stop)
            }
        }
    }

    fn search<const N: usize, const NO_CORNER_CUTTING: bool, const TRACK: bool>(
        &mut self,
        mut queue: impl MinQueue,
        sources: &[usize],
        stop: Option<usize>,
    ) {
        for &i in sources {
            if self.nodes[i].dist != 0.0 {
                self.start(i);
                queue.push(0.0, i as u32);
            }
        }
        let row = self.width + 2;
        let GridPlanner {
            nodes,
            touched,
            lengths,
            ..
        } = self;
        while let Some(u) = queue.pop() {
            let u = u as usize;
            if nodes[u].link & CLOSED != 0 {
                continue;
            }
            nodes[u].link |= CLOSED;
            if Some(u) == stop {
                break;
            }
            if let Some(next) = queue.peek(PREFETCH_AHEAD) {
                prefetch_rows(nodes, next as usize, row);
            }
            expand::<N, NO_CORNER_CUTTING, TRACK>(nodes, row, u, lengths, &mut queue, touched);
        }
    }

    fn run_astar<const N: usize, const NO_CORNER_CUTTING: bool>(&mut self, s: usize, g: usize) {
        if self.reused {
            self.astar_search::<N, NO_CORNER_CUTTING, true>(s, g);
        } else {
            self.astar_search::<N, NO_CORNER_CUTTING, false>(s, g);
        }
    }

    fn astar_search<const N: usize, const NO_CORNER_CUTTING: bool, const TRACK: bool>(
        &mut self,
        s: usize,
        g: usize,
    ) {
        let row = self.width + 2;
        let mut open = AstarOpen::<N> {
            heap: BinaryHeap::new(),
            row: row as u32,
            goal_row: (g / row) as u32,
            goal_col: (g % row) as u32,
            min_cost: self.min_cost,
            shortest: self.lengths.shortest(),
        };
        self.start(s);
        open.reached(s, f64::INFINITY, 0.0);
        let GridPlanner {
            nodes,
            touched,
            lengths,
            ..
        } = self;
        while let Some(Reverse(key)) = open.heap.pop() {
            let u = key as u32 as usize;
            if nodes[u].link & CLOSED != 0 {
                continue;
            }
            nodes[u].link |= CLOSED;
            if u == g {
                break;
            }
            expand::<N, NO_CORNER_CUTTING, TRACK>(nodes, row, u, lengths, &mut open, touched);
        }
    }

    /// Full Dijkstra from one or more sources: the cost-to-go (cost-to-come) field and
    /// the tree of cheapest paths. Blocked or off-grid sources are ignored.
    pub fn into_cost_to_go(mut self, sources: &[Cell]) -> CostField {
        self.reused = false;
        let starts: Vec<usize> = sources
            .iter()
            .filter(|&&c| self.open(c))
            .map(|&c| self.pad(c))
            .collect();
        dispatch!(self.run_dijkstra(&starts, None));
        CostField { searched: self }
    }

    /// Dijkstra from `start`, stopping when `goal` is settled.
    pub fn dijkstra(&mut self, start: Cell, goal: Cell) -> Option<Route> {
        if !self.open(start) || !self.open(goal) {
            return None;
        }
        let (s, g) = (self.pad(start), self.pad(goal));
        dispatch!(self.run_dijkstra(&[s], Some(g)));
        self.finish(g)
    }

    /// A* with the octile (or Manhattan) distance times the cheapest cell cost, which
    /// never overestimates and is consistent, so the first time the goal is settled its
    /// cost is optimal. Among equal estimates, deeper nodes go first, then lower indices.
    pub fn astar(&mut self, start: Cell, goal: Cell) -> Option<Route> {
        if !self.open(start) || !self.open(goal) {
            return None;
        }
        let (s, g) = (self.pad(start), self.pad(goal));
        dispatch!(self.run_astar(s, g));
        self.finish(g)
    }

    /// The route to `g` if the search settled it; then resets for the next query.
    fn finish(&mut self, g: usize) -> Option<Route> {
        let route = (self.nodes[g].link & CLOSED != 0).then(|| Route {
            cells: self.path(g),
            cost: self.nodes[g].dist,
        });
        self.reset();
        route
    }
}

/// Full Dijkstra from one or more sources (see `GridPlanner::into_cost_to_go`).
pub fn cost_to_go(costs: &Grid<f32>, sources: &[Cell], moves: Moves) -> CostField {
    GridPlanner::new(costs, moves).into_cost_to_go(sources)
}

/// Dijkstra from `start`, stopping when `goal` is settled.
pub fn dijkstra(costs: &Grid<f32>, start: Cell, goal: Cell, moves: Moves) -> Option<Route> {
    GridPlanner::single_query(costs, moves).dijkstra(start, goal)
}

/// A* from `start` to `goal` (see `GridPlanner::astar`).
pub fn astar(costs: &Grid<f32>, start: Cell, goal: Cell, moves: Moves) -> Option<Route> {
    GridPlanner::single_query(costs, moves).astar(start, goal)
}

/// The cheapest 8-connected path (corner cutting allowed) from `start` to `goal`, or
/// `None` when the goal cannot be reached or either end is blocked or off the grid.
pub fn shortest_path(costs: &Grid<f32>, start: Cell, goal: Cell) -> Option<Route> {
    astar(costs, start, goal, Moves::default())
}

/// Result of a full Dijkstra: the cost of reaching every cell from the nearest source,
/// and the tree of cheapest paths. It keeps the searched grid as it is, so making it
/// copies nothing.
pub struct CostField {
    searched: GridPlanner,
}

impl CostField {
    pub fn geo(&self) -> &GeoRef {
        &self.searched.geo
    }

    /// ∞ where no source reaches.
    pub fn cost_at(&self, cell: Cell) -> f64 {
        self.searched.nodes[self.searched.pad(cell)].dist
    }

    /// Every cell's cost, row by row.
    pub fn costs(&self) -> impl Iterator<Item = f64> + '_ {
        let w = self.searched.width;
        (0..self.searched.height).flat_map(move |row| {
            let base = (row + 1) * (w + 2) + 1;
            self.searched.nodes[base..base + w].iter().map(|n| n.dist)
        })
    }

    /// The cheapest path from a source to `cell`, or `None` when unreached.
    pub fn path_to(&self, cell: Cell) -> Option<CellPath> {
        let reached = self.geo().contains(cell) && self.cost_at(cell).is_finite();
        reached.then(|| self.searched.path(self.searched.pad(cell)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::is_connected8;
    use crate::plan::unit_step_metres;
    use proptest::prelude::*;

    #[derive(Clone, Debug)]
    enum Frame {
        Square,
        Rectangles(f64),
        Degrees(f64),
        WebMercator(f64),
    }

    fn grid(width: u32, height: u32, data: Vec<f32>) -> Grid<f32> {
        Grid::from_vec(GeoRef::unit(width, height), data)
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
            return passable(costs.get(Cell::new(a.row, b.col)))
                && passable(costs.get(Cell::new(b.row, a.col)));
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
                        let length = StepLengths::of(&costs.geo).between(a, b);
                        let d = dist[i] + edge_cost(costs.data[i], costs.data[j], length);
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
        (
            prop_oneof![Just(Connectivity::Four), Just(Connectivity::Eight)],
            any::<bool>(),
        )
            .prop_map(|(connectivity, corner_cutting)| Moves {
                connectivity,
                corner_cutting,
            })
    }

    fn small_grid() -> impl Strategy<Value = (Grid<f32>, usize, usize)> {
        (1u32..7, 1u32..7).prop_flat_map(|(w, h)| {
            let n = (w * h) as usize;
            (
                prop::collection::vec(prop_oneof![4 => 0.1f32..10.0, 1 => Just(f32::INFINITY)], n),
                0..n,
                0..n,
                // Square cells, rectangles either way round, 10° cells in degrees
                // from a southern edge (narrower towards the pole, each row its own
                // lengths), or 1000 km Web Mercator cells from a southern northing
                // (−15 000 km is about 80° S).
                prop_oneof![
                    2 => Just(Frame::Square),
                    1 => (0.3f64..3.0).prop_map(Frame::Rectangles),
                    1 => (-80.0f64..10.0).prop_map(Frame::Degrees),
                    1 => (-15e6f64..1e6).prop_map(Frame::WebMercator),
                ],
            )
                .prop_map(move |(data, s, t, frame)| {
                    let mut g = grid(w, h, data);
                    match frame {
                        Frame::Square => {}
                        Frame::Rectangles(y) => g.geo.resolution_y = Some(y),
                        Frame::Degrees(south) => {
                            g.geo.degrees = true;
                            g.geo.resolution = 10.0;
                            g.geo.origin = [0.0, south];
                        }
                        Frame::WebMercator(south) => {
                            g.geo.web_mercator = true;
                            g.geo.resolution = 1e6;
                            g.geo.origin = [0.0, south];
                        }
                    }
                    (g, s, t)
                })
        })
    }

    fn assert_valid(costs: &Grid<f32>, route: &Route, start: Cell, goal: Cell, moves: Moves) {
        assert_eq!(route.cells[0], start);
        assert_eq!(*route.cells.last().unwrap(), goal);
        assert!(
            route
                .cells
                .windows(2)
                .all(|w| step_allowed(costs, w[0], w[1], moves))
        );
        assert!((path_cost(costs, &route.cells) - route.cost).abs() <= 1e-9 * route.cost.max(1.0));
    }

    #[test]
    fn passable_means_finite_and_positive() {
        let edge_cases = [
            0.0,
            -0.0,
            f32::from_bits(1),
            f32::MIN_POSITIVE,
            1.0,
            f32::MAX,
            f32::INFINITY,
            -1.0,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
        ];
        for c in edge_cases {
            assert_eq!(passable(c), c.is_finite() && c > 0.0, "{c:e}");
        }
    }

    #[test]
    fn uniform_grid_takes_the_diagonal() {
        let g = grid(5, 5, vec![1.0; 25]);
        let route = shortest_path(&g, Cell::new(0, 0), Cell::new(4, 4)).unwrap();
        assert_eq!(route.cells.len(), 5);
        assert!((route.cost - 4.0 * SQRT_2).abs() < 1e-12);
        let four = Moves {
            connectivity: Connectivity::Four,
            corner_cutting: false,
        };
        assert!(
            (dijkstra(&g, Cell::new(0, 0), Cell::new(4, 4), four)
                .unwrap()
                .cost
                - 8.0)
                .abs()
                < 1e-12
        );
    }

    #[test]
    fn a_degree_east_is_shorter_towards_the_pole() {
        // 1° cells from the equator to 60° north: crossing ten cells east costs about
        // cos(latitude) of what it costs on the equator, in the planner's units.
        let mut g = grid(11, 60, vec![1.0; 660]);
        g.geo.degrees = true;
        let cost = |row| {
            shortest_path(&g, Cell::new(row, 0), Cell::new(row, 10))
                .unwrap()
                .cost
        };
        let (equator, north) = (cost(0), cost(59));
        let expected = 59.5f64.to_radians().cos() / 0.5f64.to_radians().cos();
        assert!(
            (north / equator / expected - 1.0).abs() < 0.01,
            "{north} / {equator}"
        );
        // In metres: ten cells of 111.3 km on the equator.
        let metres = equator * unit_step_metres(&g.geo);
        assert!((metres - 1_113_195.0).abs() < 500.0, "{metres}");
    }

    #[test]
    fn corners_are_not_cut_when_forbidden() {
        // . #
        // . .   a diagonal from (0,0) to (1,1) passes the blocked (0,1)... (row 0 is the bottom)
        let g = grid(2, 2, vec![1.0, f32::INFINITY, 1.0, 1.0]);
        let (a, b) = (Cell::new(0, 0), Cell::new(1, 1));
        let cutting = astar(&g, a, b, Moves::default()).unwrap();
        assert_eq!(cutting.cells.len(), 2);
        let careful = astar(
            &g,
            a,
            b,
            Moves {
                corner_cutting: false,
                ..Moves::default()
            },
        )
        .unwrap();
        assert_eq!(careful.cells, [a, Cell::new(1, 0), b]);
    }

    #[test]
    fn loss_augmentation_lowers_costs_down_to_the_floor() {
        let g = grid(4, 1, vec![2.0, 2.0, f32::INFINITY, 1.0]);
        let augmented = loss_augmented(&g, &[0.5, 3.0, 1.0, 0.0], 0.01);
        assert_eq!(augmented.data, [1.5, 0.01, f32::INFINITY, 1.0]);
    }

    #[test]
    fn multiple_sources_and_visitation() {
        let g = grid(7, 1, vec![1.0; 7]);
        let field = cost_to_go(&g, &[Cell::new(0, 0), Cell::new(0, 6)], Moves::default());
        let costs: Vec<f64> = field.costs().collect();
        assert_eq!(costs, [0.0, 1.0, 2.0, 3.0, 2.0, 1.0, 0.0]);
        assert_eq!(
            field.path_to(Cell::new(0, 2)).unwrap(),
            [Cell::new(0, 0), Cell::new(0, 1), Cell::new(0, 2)]
        );
        let p = field.path_to(Cell::new(0, 5)).unwrap();
        let q = field.path_to(Cell::new(0, 4)).unwrap();
        assert_eq!(
            visitation(&g.geo, [p.as_slice(), q.as_slice()]),
            [0, 0, 0, 0, 1, 2, 2]
        );
    }

    #[test]
    fn wide_cost_ranges_use_the_heap_and_agree() {
        let data: Vec<f32> = (0..100)
            .map(|i| if i % 7 == 0 { 1e-6 } else { 1e6 })
            .collect();
        let g = grid(10, 10, data);
        let field = cost_to_go(&g, &[Cell::new(0, 0)], Moves::default());
        let brute = brute_force(&g, Cell::new(0, 0), Moves::default());
        for (a, b) in field.costs().zip(&brute) {
            assert!((a - b).abs() <= 1e-9 * b.max(1.0), "{a} vs {b}");
        }
    }

    proptest! {
        #[test]
        fn dijkstra_and_astar_match_brute_force((g, s, t) in small_grid(), moves in all_moves()) {
            let (start, goal) = (g.geo.cell_at(s), g.geo.cell_at(t));
            let brute = brute_force(&g, start, moves);
            let expected = brute[t];
            // One planner answers every query, as in a benchmark: generations must keep
            // the queries apart.
            let mut planner = GridPlanner::new(&g, moves);
            let by_astar = planner.astar(start, goal);
            let field = cost_to_go(&g, &[start], moves);
            for (a, b) in field.costs().zip(&brute) {
                prop_assert!((a - b).abs() <= 1e-9 * b.max(1.0) || (a.is_infinite() && b.is_infinite()));
            }
            let by_dijkstra = planner.dijkstra(start, goal);
            prop_assert_eq!(planner.astar(start, goal), by_astar.clone());
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
