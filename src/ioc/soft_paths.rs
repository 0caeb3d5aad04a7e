//! The maximum-entropy distribution over grid paths to a goal (Ziebart et al. 2008):
//! P(path) ∝ exp(−cost(path)) over the 8-connected paths (corner cutting allowed, edge
//! cost = step length × mean of the two cells' costs, as the planner) that reach the goal
//! within a horizon of T steps and end there.
//!
//! Why a horizon: over all paths the partition function diverges as soon as cells cost
//! less than about ln 8 per step, because loops then gain weight faster than they pay
//! for it; learned costs near 1 do. With at most T steps it is always finite, and T a
//! small multiple of a demonstration's length keeps the detours that matter.
//!
//! Backward: V_k(x), the soft cost-to-go from x with at most k steps left (V_0 = 0 at the
//! goal, ∞ elsewhere; V_k(goal) = 0 as paths end there), V_k(x) = softmin over moves of
//! edge + V_{k−1}(next). Forward: the start's unit mass follows the policy
//! π_k(a | x) = exp(V_k(x) − edge − V_{k−1}(next)) and is absorbed at the goal. Everything
//! is computed on a window of the map, which keeps each example's cost in proportion to
//! its neighbourhood rather than to the map.

use super::soft_math::{exp, move_probabilities_row, soft_min_row};
use crate::grid::{Cell, Grid};
use crate::plan::StepLengths;

/// Moves: (row, column) offset, orthogonal first; their lengths come from the map's
/// cells (`StepLengths`), as the planner's.
const MOVES: [(i32, i32); 8] = [
    (-1, 0),
    (0, -1),
    (0, 1),
    (1, 0),
    (-1, -1),
    (-1, 1),
    (1, -1),
    (1, 1),
];

/// A rectangle of a map's cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    pub row0: u32,
    pub col0: u32,
    pub rows: u32,
    pub cols: u32,
}

impl Window {
    /// The bounding box of `cells`, grown by `margin` cells and clipped to the map.
    pub fn around(cells: &[Cell], margin: u32, width: u32, height: u32) -> Self {
        let (mut r0, mut c0, mut r1, mut c1) = (u32::MAX, u32::MAX, 0, 0);
        for c in cells {
            r0 = r0.min(c.row);
            c0 = c0.min(c.col);
            r1 = r1.max(c.row);
            c1 = c1.max(c.col);
        }
        let (r0, c0) = (r0.saturating_sub(margin), c0.saturating_sub(margin));
        let r1 = (r1 + margin).min(height - 1);
        let c1 = (c1 + margin).min(width - 1);
        Window {
            row0: r0,
            col0: c0,
            rows: r1 - r0 + 1,
            cols: c1 - c0 + 1,
        }
    }

    pub fn len(&self) -> usize {
        self.rows as usize * self.cols as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn contains(&self, cell: Cell) -> bool {
        (self.row0..self.row0 + self.rows).contains(&cell.row)
            && (self.col0..self.col0 + self.cols).contains(&cell.col)
    }

    /// Index of a cell inside the window (row-major).
    pub fn index(&self, cell: Cell) -> usize {
        (cell.row - self.row0) as usize * self.cols as usize + (cell.col - self.col0) as usize
    }

    pub fn cell(&self, index: usize) -> Cell {
        let cols = self.cols as usize;
        Cell::new(
            self.row0 + (index / cols) as u32,
            self.col0 + (index % cols) as u32,
        )
    }

    /// The window's neighbour of `index` by move `m`, with the move's length.
    fn step(&self, index: usize, m: usize, lengths: &StepLengths) -> Option<(usize, f64)> {
        let (dr, dc) = MOVES[m];
        let cols = self.cols as i64;
        let (r, c) = (
            (index as i64) / cols + dr as i64,
            (index as i64) % cols + dc as i64,
        );
        (r >= 0 && c >= 0 && r < self.rows as i64 && c < cols).then(|| {
            let next = (r * cols + c) as usize;
            (next, lengths.between(self.cell(index), self.cell(next)))
        })
    }
}

/// Soft values towards one goal on one window.
pub struct SoftGoal {
    window: Window,
    /// For cell x and move m at m · cells + x (a row's cells side by side, for the
    /// vector passes): the step's cost (∞ where blocked or off the window) and its
    /// length, so that the passes are straight loops without tests.
    edge: Vec<f64>,
    length: Vec<f64>,
    goal: usize,
    goal_cell: Cell,
    /// The one start the passes are restricted to, if any (see `SoftGoal::between`).
    start: Option<Cell>,
    horizon: usize,
    /// V_k for k = 0..=settled, each on the cells the passes can read (∞ elsewhere).
    values: Vec<Layer>,
    /// The first k from which V_k no longer changes (to 1e-13): V_k = V_settled for
    /// every k above, so the backward pass stops there and the forward pass reuses one
    /// policy. Cheap paths (cells costing less than about ln 8 per step) never settle:
    /// their loops keep gaining weight, and the horizon is what bounds them.
    settled: usize,
}

/// Values on a rectangle of window cells.
struct Layer {
    rect: Rect,
    data: Vec<f64>,
}

/// Window rows r0..r1 and columns c0..c1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Rect {
    r0: u32,
    r1: u32,
    c0: u32,
    c1: u32,
}

impl Rect {
    const EMPTY: Rect = Rect {
        r0: 0,
        r1: 0,
        c0: 0,
        c1: 0,
    };

    /// The window cells within `k` moves (Chebyshev distance) of `center`: only they
    /// can hold finite values after k backward steps, or mass after k forward ones.
    fn ball(window: &Window, center: Cell, k: usize) -> Rect {
        let k = k.min(u32::MAX as usize / 2) as u32;
        let (r, c) = (center.row - window.row0, center.col - window.col0);
        Rect {
            r0: r.saturating_sub(k),
            r1: r.saturating_add(k).saturating_add(1).min(window.rows),
            c0: c.saturating_sub(k),
            c1: c.saturating_add(k).saturating_add(1).min(window.cols),
        }
    }

    fn intersect(self, other: Rect) -> Rect {
        Rect {
            r0: self.r0.max(other.r0),
            r1: self.r1.min(other.r1),
            c0: self.c0.max(other.c0),
            c1: self.c1.min(other.c1),
        }
    }

    fn is_empty(&self) -> bool {
        self.r0 >= self.r1 || self.c0 >= self.c1
    }

    fn len(&self) -> usize {
        if self.is_empty() {
            0
        } else {
            (self.r1 - self.r0) as usize * (self.c1 - self.c0) as usize
        }
    }

    fn covers(&self, other: Rect) -> bool {
        other.is_empty()
            || (self.r0 <= other.r0
                && other.r1 <= self.r1
                && self.c0 <= other.c0
                && other.c1 <= self.c1)
    }

    /// Window indices of the cells, row-major.
    fn indices(self, width: u32) -> impl Iterator<Item = usize> {
        self.rows(width).flatten()
    }

    /// Window indices of each row's cells: what the hot loops walk, two plain loops
    /// rather than one flattened iterator.
    fn rows(self, width: u32) -> impl Iterator<Item = std::ops::Range<usize>> {
        let (c0, c1) = if self.is_empty() {
            (0, 0)
        } else {
            (self.c0 as usize, self.c1 as usize)
        };
        (self.r0..self.r1).map(move |row| {
            let base = row as usize * width as usize;
            base + c0..base + c1
        })
    }

    /// Position of window index `x` in the rectangle's data, if inside.
    fn offset(&self, x: usize, width: u32) -> Option<usize> {
        let (row, col) = ((x / width as usize) as u32, (x % width as usize) as u32);
        ((self.r0..self.r1).contains(&row) && (self.c0..self.c1).contains(&col)).then(|| {
            (row - self.r0) as usize * (self.c1 - self.c0) as usize + (col - self.c0) as usize
        })
    }
}

/// A copy of one layer on the window with a border of one cell all round (∞ outside
/// the layer and on the border), so that the passes read a cell's eight neighbours at
/// fixed offsets, a row's cells side by side, without bounds tests.
struct Scratch {
    values: Vec<f64>,
    /// The window's columns.
    cols: usize,
    rect: Rect,
}

impl Scratch {
    fn new(window: &Window) -> Self {
        let (rows, cols) = (window.rows as usize, window.cols as usize);
        Scratch {
            values: vec![f64::INFINITY; (rows + 2) * (cols + 2)],
            cols,
            rect: Rect::EMPTY,
        }
    }

    /// Position of window index `x`.
    fn at(&self, x: usize) -> usize {
        (x / self.cols + 1) * (self.cols + 2) + x % self.cols + 1
    }

    /// Position of move m's neighbour relative to a cell's.
    fn offsets(&self) -> [isize; 8] {
        let row = self.cols as isize + 2;
        MOVES.map(|(dr, dc)| dr as isize * row + dc as isize)
    }

    /// The values of window indices `cells` (one row's), each moved by `offset`.
    fn row(&self, cells: &std::ops::Range<usize>, offset: isize) -> &[f64] {
        let first = self.at(cells.start).wrapping_add_signed(offset);
        &self.values[first..first + cells.len()]
    }

    /// Hold `layer` instead, touching only the two layers' cells.
    fn load(&mut self, layer: &Layer) {
        let width = self.cols as u32;
        for row in self.rect.rows(width) {
            let first = self.at(row.start);
            self.values[first..first + row.len()].fill(f64::INFINITY);
        }
        let mut data = layer.data.as_slice();
        for row in layer.rect.rows(width) {
            let (this, rest) = data.split_at(row.len());
            let first = self.at(row.start);
            self.values[first..first + row.len()].copy_from_slice(this);
            data = rest;
        }
        self.rect = layer.rect;
    }
}

/// What the forward pass found.
pub struct Visitation {
    /// Expected visits of each window cell (the start counts once).
    pub visits: Vec<f64>,
    /// Expected edge incidence: for every step a→b, half its length added to a and to
    /// b, so that Σ incidence(x) · cost(x) is the expected path cost.
    pub incidence: Vec<f64>,
}

/// Relative change below which a soft value counts as settled.
const SETTLED: f64 = 1e-13;

/// Mass (of the start's 1) below which a cell's share is dropped rather than moved on:
/// far from the likely routes most cells hold next to nothing, and moving it costs as
/// much as moving real mass. What is dropped, over every cell and step of a long path,
/// stays below 1e-9 of a visit.
const NEGLIGIBLE_MASS: f64 = 1e-18;

impl SoftGoal {
    /// The backward pass towards `goal` with at most `horizon` steps, for any start in
    /// the window; `goal` must lie in it.
    pub fn new(costs: &Grid<f32>, window: Window, goal: Cell, horizon: usize) -> Self {
        Self::build(costs, window, None, goal, horizon)
    }

    /// The backward pass for paths from `start` only: V_k is kept on the cells that
    /// `start` reaches within horizon − k steps, all that the forward pass from `start`
    /// reads (about half the work on a long path). Other starts read as unreachable.
    pub fn between(
        costs: &Grid<f32>,
        window: Window,
        start: Cell,
        goal: Cell,
        horizon: usize,
    ) -> Self {
        Self::build(costs, window, Some(start), goal, horizon)
    }

    fn build(
        costs: &Grid<f32>,
        window: Window,
        start: Option<Cell>,
        goal_cell: Cell,
        horizon: usize,
    ) -> Self {
        let n = window.len();
        let cell_costs: Vec<f64> = (0..n)
            .map(|i| {
                let c = costs.get(window.cell(i));
                if c.is_finite() && c > 0.0 {
                    f64::from(c)
                } else {
                    f64::INFINITY
                }
            })
            .collect();
        let lengths = StepLengths::of(&costs.geo);
        let (mut edge, mut length) = (vec![0.0; n * 8], vec![0.0; n * 8]);
        for x in 0..n {
            for m in 0..8 {
                let (y, l) = window.step(x, m, &lengths).unwrap_or((x, 0.0));
                length[m * n + x] = l;
                edge[m * n + x] = if l == 0.0 {
                    f64::INFINITY
                } else {
                    l * 0.5 * (cell_costs[x] + cell_costs[y])
                };
            }
        }
        let mut soft = SoftGoal {
            window,
            edge,
            length,
            goal: window.index(goal_cell),
            goal_cell,
            start,
            horizon,
            values: Vec::new(),
            settled: horizon,
        };
        soft.backward();
        soft
    }

    /// The cells whose V_k the passes read: within k moves of the goal and, for one
    /// start, within horizon − k moves of it.
    fn region(&self, k: usize) -> Rect {
        let near_goal = Rect::ball(&self.window, self.goal_cell, k);
        match self.start {
            Some(start) => near_goal.intersect(Rect::ball(&self.window, start, self.horizon - k)),
            None => near_goal,
        }
    }

    /// V_k(x) = softmin over moves of edge + V_{k−1}(next), up to the horizon or until
    /// the values settle.
    fn backward(&mut self) {
        let (width, n) = (self.window.cols, self.window.len());
        let mut previous = Scratch::new(&self.window);
        let offsets = previous.offsets();
        let first = Layer {
            rect: self.region(0),
            data: vec![0.0; self.region(0).len()],
        };
        previous.load(&first);
        self.values.push(first);
        for k in 1..=self.horizon {
            let rect = self.region(k);
            let mut changed = false;
            let mut data = vec![0.0; rect.len()];
            let mut rest = data.as_mut_slice();
            for row in rect.rows(width) {
                let (out, after) = rest.split_at_mut(row.len());
                rest = after;
                // The goal's value stays 0 (paths end there): the row either side of it.
                let goal = row.contains(&self.goal).then_some(self.goal);
                let (before, beyond) = match goal {
                    Some(g) => (row.start..g, g + 1..row.end),
                    None => (row.clone(), row.end..row.end),
                };
                let (left, right) = out.split_at_mut(before.len());
                let right = &mut right[usize::from(goal.is_some())..];
                for (cells, out) in [(before, left), (beyond, right)] {
                    if cells.is_empty() {
                        continue;
                    }
                    let edges = std::array::from_fn(|m| &self.edge[m * n..][cells.clone()]);
                    let ahead = offsets.map(|offset| previous.row(&cells, offset));
                    changed |= soft_min_row(edges, ahead, previous.row(&cells, 0), SETTLED, out);
                }
                if let Some(g) = goal {
                    changed |= previous.values[previous.at(g)] != 0.0;
                }
            }
            let layer = Layer { rect, data };
            previous.load(&layer);
            self.values.push(layer);
            // Settled: no value moved, and every cell a later layer could read was
            // already within reach of the goal, so later layers would repeat this one.
            let readable = match self.start {
                Some(start) => Rect::ball(&self.window, start, self.horizon - k + 1),
                None => Rect::ball(&self.window, self.goal_cell, usize::MAX),
            };
            if !changed && Rect::ball(&self.window, self.goal_cell, k - 1).covers(readable) {
                self.settled = k;
                break;
            }
        }
    }

    /// The layer that holds V_k.
    fn layer(&self, k: usize) -> &Layer {
        &self.values[k.min(self.settled)]
    }

    /// Soft cost-to-go from `cell` with the full horizon: −log of the summed
    /// exp(−cost) of the paths from it; ∞ when the goal is out of reach.
    pub fn value(&self, cell: Cell) -> f64 {
        self.value_within(cell, self.horizon)
    }

    /// Soft cost-to-go from `cell` with at most `steps` steps (capped at the horizon).
    pub fn value_within(&self, cell: Cell, steps: usize) -> f64 {
        if !self.window.contains(cell) || self.start.is_some_and(|s| s != cell) {
            return f64::INFINITY;
        }
        let layer = self.layer(steps.min(self.horizon));
        layer
            .rect
            .offset(self.window.index(cell), self.window.cols)
            .map_or(f64::INFINITY, |i| layer.data[i])
    }

    /// Expected visitation of paths from `start` under the distribution.
    pub fn visitation(&self, start: Cell) -> Visitation {
        self.visitation_within(start, self.horizon)
    }

    /// Expected visitation of the paths from `start` of at most `steps` steps (capped
    /// at the horizon).
    pub fn visitation_within(&self, start: Cell, steps: usize) -> Visitation {
        let steps = steps.min(self.horizon);
        let n = self.window.len();
        let width = self.window.cols;
        if self.value_within(start, steps) == f64::INFINITY {
            return Visitation {
                visits: vec![0.0; n],
                incidence: vec![0.0; n],
            };
        }
        // V_left and V_left−1, and which layers they hold: a step's ahead is the next
        // step's here.
        let (mut here, mut ahead) = (Scratch::new(&self.window), Scratch::new(&self.window));
        let offsets = here.offsets();
        // Mass, visits and incidence with the layers' border, so that a move's flow
        // out of a row's cells lands side by side (moves off the window carry none).
        let padded = here.values.len();
        let (mut mass, mut moved) = (vec![0.0; padded], vec![0.0; padded]);
        let (mut visits, mut incidence) = (vec![0.0; padded], vec![0.0; padded]);
        let (origin, goal) = (here.at(self.window.index(start)), here.at(self.goal));
        mass[origin] = 1.0;
        visits[origin] = 1.0;
        let mut outgoing = vec![0.0; width as usize];
        // Move m's probability at x: exp(V_left(x) − edge − V_left−1(next)).
        let policy_at = |here: &Scratch, ahead: &Scratch, x: usize, m: usize| {
            let at = here.at(x);
            let next = ahead.values[at.wrapping_add_signed(offsets[m])];
            exp(here.values[at] - self.edge[m * n + x] - next)
        };
        let (mut here_k, mut ahead_k) = (None, None);
        // While both layers are the settled one the policy does not depend on the
        // steps left: its move probabilities are computed once.
        let mut settled_policy: Option<(Rect, Vec<f64>)> = None;
        // A row's move probabilities, move by move.
        let mut probabilities = vec![0.0; 8 * width as usize];
        for (taken, left) in (1..=steps).rev().enumerate() {
            let stationary = left > self.settled;
            let (want_here, want_ahead) = (left.min(self.settled), (left - 1).min(self.settled));
            if here_k != Some(want_here) {
                if ahead_k == Some(want_here) {
                    std::mem::swap(&mut here, &mut ahead);
                    std::mem::swap(&mut here_k, &mut ahead_k);
                } else {
                    here.load(self.layer(want_here));
                    here_k = Some(want_here);
                }
            }
            if ahead_k != Some(want_ahead) {
                ahead.load(self.layer(want_ahead));
                ahead_k = Some(want_ahead);
            }
            if stationary && settled_policy.is_none() {
                let rect = self.layer(left).rect;
                let mut p = vec![0.0; rect.len() * 8];
                for (i, x) in rect.indices(width).enumerate() {
                    for m in 0..8 {
                        p[i * 8 + m] = policy_at(&here, &ahead, x, m);
                    }
                }
                settled_policy = Some((rect, p));
            }
            let policy = settled_policy.as_ref().filter(|_| stationary);
            // Mass after `taken` steps lies within `taken` moves of the start, and after
            // this step within one more: only there do `moved` and `visits` change.
            let reach = Rect::ball(&self.window, start, taken + 1);
            for row in reach.rows(width) {
                let first = here.at(row.start);
                moved[first..first + row.len()].fill(0.0);
            }
            let cells = Rect::ball(&self.window, start, taken).intersect(self.region(left));
            for row in cells.rows(width) {
                // The row's cells that hold mass to move, from the first to the last.
                let holds = |&x: &usize| {
                    let m = mass[here.at(x)];
                    m >= NEGLIGIBLE_MASS && x != self.goal
                };
                let Some(first) = row.clone().find(holds) else {
                    continue;
                };
                let span = first..row.clone().rfind(holds).map_or(first, |x| x + 1);
                let len = span.len();
                let probabilities = &mut probabilities[..8 * len];
                match policy {
                    Some((rect, settled)) => {
                        for (i, x) in span.clone().enumerate() {
                            let at = rect.offset(x, width);
                            for m in 0..8 {
                                probabilities[m * len + i] =
                                    at.map_or(0.0, |at| settled[at * 8 + m]);
                            }
                        }
                    }
                    None => {
                        let edges = std::array::from_fn(|m| &self.edge[m * n..][span.clone()]);
                        let neighbours = offsets.map(|offset| ahead.row(&span, offset));
                        move_probabilities_row(
                            here.row(&span, 0),
                            edges,
                            neighbours,
                            probabilities,
                        );
                    }
                }
                // Mass too small to move stays put (and the goal's rests there).
                let source = here.at(span.start);
                for (i, m) in mass[source..source + len].iter_mut().enumerate() {
                    if *m < NEGLIGIBLE_MASS || span.start + i == self.goal {
                        for p in probabilities[i..].iter_mut().step_by(len) {
                            *p = 0.0;
                        }
                    }
                }
                let outgoing = &mut outgoing[..len];
                outgoing.fill(0.0);
                // Move by move, every cell of the span at once: each cell's flow lands
                // on a different neighbour. Each step's half length goes to both ends.
                for (m, &offset) in offsets.iter().enumerate() {
                    let target = source.wrapping_add_signed(offset);
                    let flows = mass[source..source + len]
                        .iter()
                        .zip(&probabilities[m * len..(m + 1) * len])
                        .map(|(&mass, &p)| mass * p);
                    let ends = moved[target..target + len]
                        .iter_mut()
                        .zip(&mut incidence[target..target + len]);
                    for (((flow, &length), (arrived, shared)), out) in flows
                        .zip(&self.length[m * n..][span.clone()])
                        .zip(ends)
                        .zip(outgoing.iter_mut())
                    {
                        let half = flow * length * 0.5;
                        *arrived += flow;
                        *shared += half;
                        *out += half;
                    }
                }
                for (shared, &out) in incidence[source..source + len].iter_mut().zip(&*outgoing) {
                    *shared += out;
                }
            }
            // Arrivals are visits; mass already at the goal rests there uncounted.
            for row in reach.rows(width) {
                let first = here.at(row.start);
                let cells = first..first + row.len();
                for (v, &arrived) in visits[cells.clone()].iter_mut().zip(&moved[cells]) {
                    *v += arrived;
                }
            }
            moved[goal] += mass[goal];
            std::mem::swap(&mut mass, &mut moved);
        }
        // Without the border.
        let unpadded = |padded: Vec<f64>| -> Vec<f64> {
            (0..self.window.rows as usize)
                .flat_map(|row| {
                    let first = here.at(row * width as usize);
                    padded[first..first + width as usize].to_vec()
                })
                .collect()
        };
        Visitation {
            visits: unpadded(visits),
            incidence: unpadded(incidence),
        }
    }
}

/// Edge incidence of a path on a window (see `Visitation::incidence`), with the steps
/// of the map's cells.
pub fn path_incidence(window: &Window, path: &[Cell], lengths: &StepLengths) -> Vec<f64> {
    let mut incidence = vec![0.0; window.len()];
    for pair in path.windows(2) {
        let half = lengths.between(pair[0], pair[1]) * 0.5;
        incidence[window.index(pair[0])] += half;
        incidence[window.index(pair[1])] += half;
    }
    incidence
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GeoRef;
    use crate::plan::path_cost;

    fn grid(width: u32, height: u32, data: Vec<f32>) -> Grid<f32> {
        Grid::from_vec(GeoRef::unit(width, height), data)
    }

    /// Every path of at most `left` steps from `x` that ends at the goal (first arrival).
    fn enumerate(
        costs: &Grid<f32>,
        path: &mut Vec<Cell>,
        goal: Cell,
        left: usize,
        out: &mut Vec<Vec<Cell>>,
    ) {
        let here = *path.last().unwrap();
        if here == goal {
            out.push(path.clone());
            return;
        }
        if left == 0 {
            return;
        }
        for (dr, dc) in MOVES {
            let (r, c) = (here.row as i64 + dr as i64, here.col as i64 + dc as i64);
            let next = Cell::new(r as u32, c as u32);
            if r < 0 || c < 0 || !costs.geo.contains(next) || !costs.get(next).is_finite() {
                continue;
            }
            path.push(next);
            enumerate(costs, path, goal, left - 1, out);
            path.pop();
        }
    }

    #[test]
    fn matches_brute_force_enumeration_of_paths() {
        let costs = grid(
            3,
            3,
            vec![1.0, 2.0, 0.5, 1.5, f32::INFINITY, 1.0, 0.7, 1.2, 3.0],
        );
        let (start, goal, horizon) = (Cell::new(0, 0), Cell::new(2, 2), 5);
        let window = Window::around(&[start, goal], 0, 3, 3);
        let soft = SoftGoal::new(&costs, window, goal, horizon);
        let mut paths = Vec::new();
        enumerate(&costs, &mut vec![start], goal, horizon, &mut paths);
        let weights: Vec<f64> = paths
            .iter()
            .map(|p| (-path_cost(&costs, p)).exp())
            .collect();
        let z: f64 = weights.iter().sum();
        assert!((soft.value(start) + z.ln()).abs() < 1e-9);
        let visitation = soft.visitation(start);
        let mut visits = vec![0.0; window.len()];
        let mut incidence = vec![0.0; window.len()];
        for (p, w) in paths.iter().zip(&weights) {
            for &c in p {
                visits[window.index(c)] += w / z;
            }
            for (i, v) in path_incidence(&window, p, &StepLengths::SQUARE)
                .iter()
                .enumerate()
            {
                incidence[i] += v * w / z;
            }
        }
        for i in 0..window.len() {
            assert!((visitation.visits[i] - visits[i]).abs() < 1e-9, "{i}");
            assert!((visitation.incidence[i] - incidence[i]).abs() < 1e-9, "{i}");
        }
        // The expected cost is Σ incidence · cost.
        let expected: f64 = paths
            .iter()
            .zip(&weights)
            .map(|(p, w)| path_cost(&costs, p) * w / z)
            .sum();
        let by_incidence: f64 = (0..window.len())
            .filter(|&i| visitation.incidence[i] > 0.0)
            .map(|i| visitation.incidence[i] * f64::from(costs.get(window.cell(i))))
            .sum();
        assert!((expected - by_incidence).abs() < 1e-9);
    }

    /// The passes without restriction or settling: every layer on the whole window.
    fn naive(costs: &Grid<f32>, start: Cell, goal: Cell, horizon: usize) -> (f64, Vec<f64>) {
        let (w, h) = (costs.geo.width, costs.geo.height);
        let window = Window::around(&[Cell::new(0, 0), Cell::new(h - 1, w - 1)], 0, w, h);
        let lengths = StepLengths::of(&costs.geo);
        let n = window.len();
        let edge = |x: usize, m: usize| {
            window.step(x, m, &lengths).map(|(y, l)| {
                let (a, b) = (costs.get(window.cell(x)), costs.get(window.cell(y)));
                (y, l, l * 0.5 * (f64::from(a) + f64::from(b)))
            })
        };
        let g = window.index(goal);
        let mut values = vec![vec![f64::INFINITY; n]];
        values[0][g] = 0.0;
        for k in 1..=horizon {
            let layer: Vec<f64> = (0..n)
                .map(|x| {
                    if x == g {
                        return 0.0;
                    }
                    let z: f64 = (0..8)
                        .filter_map(|m| edge(x, m))
                        .map(|(y, _, e)| (-e - values[k - 1][y]).exp())
                        .sum();
                    -z.ln()
                })
                .collect();
            values.push(layer);
        }
        let mut mass = vec![0.0; n];
        let mut visits = vec![0.0; n];
        mass[window.index(start)] = 1.0;
        visits[window.index(start)] = 1.0;
        for left in (1..=horizon).rev() {
            let mut moved = vec![0.0; n];
            moved[g] = mass[g];
            for x in (0..n).filter(|&x| x != g && mass[x] > 0.0) {
                for (y, _, e) in (0..8).filter_map(|m| edge(x, m)) {
                    let p = (values[left][x] - e - values[left - 1][y]).exp();
                    moved[y] += mass[x] * p;
                    visits[y] += mass[x] * p;
                }
            }
            mass = moved;
        }
        (values[horizon][window.index(start)], visits)
    }

    proptest::proptest! {
        /// Restricting the passes to one start and stopping once the values settle
        /// change nothing: against the naive passes, on cheap maps (which never settle)
        /// and dear ones (which do).
        #[test]
        fn restricted_and_settled_passes_match_the_naive_ones(
            width in 2u32..9,
            height in 2u32..9,
            scale in proptest::prop_oneof![0.2f32..1.0, 3.0f32..8.0],
            seed in 0u64..1000,
            extra in 0usize..12,
        ) {
            let data: Vec<f32> = (0..width * height)
                .map(|i| {
                    let r = (u64::from(i) * 2654435761 + seed * 40503) % 1000;
                    scale * (0.5 + r as f32 / 1000.0)
                })
                .collect();
            let costs = grid(width, height, data);
            let start = Cell::new((seed % u64::from(height)) as u32, 0);
            let goal = Cell::new(height - 1, width - 1);
            let horizon = start.chebyshev(goal) as usize + extra;
            let window = Window::around(&[Cell::new(0, 0), goal], 0, width, height);
            let (value, visits) = naive(&costs, start, goal, horizon);
            for soft in [
                SoftGoal::new(&costs, window, goal, horizon),
                SoftGoal::between(&costs, window, start, goal, horizon),
            ] {
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(1.0);
                proptest::prop_assert!(close(soft.value(start), value), "{} against {value}", soft.value(start));
                let found = soft.visitation(start).visits;
                for (i, (&a, &b)) in found.iter().zip(&visits).enumerate() {
                    proptest::prop_assert!(close(a, b), "cell {i}: {a} against {b}");
                }
            }
        }
    }

    #[test]
    fn dear_maps_settle_before_the_horizon() {
        let costs = grid(6, 6, vec![4.0; 36]);
        let (start, goal) = (Cell::new(0, 0), Cell::new(5, 5));
        let window = Window::around(&[start, goal], 0, 6, 6);
        let soft = SoftGoal::between(&costs, window, start, goal, 200);
        assert!(soft.settled < 60, "settled at {}", soft.settled);
        let cheap = grid(6, 6, vec![0.5; 36]);
        assert_eq!(SoftGoal::new(&cheap, window, goal, 200).settled, 200);
    }

    #[test]
    fn an_unreachable_goal_has_infinite_value_and_no_visits() {
        let costs = grid(3, 1, vec![1.0, f32::INFINITY, 1.0]);
        let window = Window::around(&[Cell::new(0, 0), Cell::new(0, 2)], 1, 3, 1);
        let soft = SoftGoal::new(&costs, window, Cell::new(0, 2), 10);
        assert_eq!(soft.value(Cell::new(0, 0)), f64::INFINITY);
        assert!(
            soft.visitation(Cell::new(0, 0))
                .visits
                .iter()
                .all(|&v| v == 0.0)
        );
    }
}
