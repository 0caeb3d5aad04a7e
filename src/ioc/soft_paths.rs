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
//! Backward: Z_k(x), the summed exp(−cost) of the paths from x with at most k steps left
//! (Z_0 = 1 at the goal, 0 elsewhere; Z_k(goal) = 1 as paths end there), Z_k(x) = Σ over
//! moves of exp(−edge) Z_{k−1}(next); the soft cost-to-go is V_k = −ln Z_k. Forward:
//! A_t(x), the summed exp(−cost) of the paths from the start that reach x in t steps
//! without having reached the goal (A_0 = 1 at the start, A_t(x) = Σ over moves into x
//! of A_{t−1}(prev) exp(−edge)); the paths at x after t of T steps are a share
//! A_t(x) Z_{T−t}(x) / Z_T(start) of them all, and those taking a step a → b one of
//! A_{t−1}(a) exp(−edge) Z_{T−t}(b) / Z_T(start): the visits and the edge incidence, with
//! no division per cell. Everything is computed on a window of the map, which keeps
//! each example's cost in proportion to its neighbourhood rather than to the map.
//!
//! Why partition functions rather than soft values: a backward step is then eight
//! products per cell, where a soft minimum takes eight exponentials and a logarithm
//! (MaxEnt trained 1.6–2 times slower so on 400² maps). What keeps them within a
//! float's range is a potential: each step is weighed by its cost less the drop in h,
//! the least cost to the goal (a Dijkstra pass), so every weight is at most 1 and
//! Z_k e^h is the summed exp(−excess cost) of the paths, near 1 on the likely routes
//! however long and dear they are; each layer is scaled by a power of two when its
//! largest value drifts far from 1. What falls below 2⁻¹⁰⁷⁴ of a layer's largest value
//! is dropped, as the forward pass drops negligible mass.

use super::soft_math::{
    add_products, arrive_row, binary_exponent, exp, flow_row, largest_of, ln_scaled,
    negated_exp_row, power_of_two, scaled_inverse,
};
use crate::grid::{Cell, Grid};
use crate::plan::StepLengths;
use crate::plan::queue::{Buckets, Heap, MinQueue};

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

    /// The window's neighbour of `index` by move `m`.
    #[cfg(test)]
    fn neighbour(&self, index: usize, m: usize) -> Option<usize> {
        let (dr, dc) = MOVES[m];
        let cols = self.cols as i64;
        let (r, c) = (
            (index as i64) / cols + dr as i64,
            (index as i64) % cols + dc as i64,
        );
        (r >= 0 && c >= 0 && r < self.rows as i64 && c < cols).then(|| (r * cols + c) as usize)
    }

    /// The window's neighbour of `index` by move `m`, with the move's length.
    #[cfg(test)]
    fn step(&self, index: usize, m: usize, lengths: &StepLengths) -> Option<(usize, f64)> {
        self.neighbour(index, m)
            .map(|next| (next, lengths.between(self.cell(index), self.cell(next))))
    }
}

/// Soft values towards one goal on one window.
pub struct SoftGoal {
    window: Window,
    /// For cell x and move m at m · cells + x (a row's cells side by side, for the
    /// row kernels): the step's weight exp(−(edge − h(x) + h(next))), its cost less the
    /// drop in the potential h (0 where blocked, off the window or out of the goal's
    /// reach), so that the passes are straight loops without tests.
    weight: Vec<f64>,
    /// Half the length of each move out of each window row's cells (the same along a
    /// row): what a step adds to the incidence of either end.
    half_lengths: Vec<[f64; 8]>,
    /// h(x): the least cost from x to the goal over the cells paths can use (∞ where
    /// there is none), the potential the weights are measured against.
    potential: Vec<f64>,
    /// Each window cell's price, ∞ where paths cannot enter: what the log-domain pass
    /// (`SoftGoal::exact`) prices steps with.
    priced: Vec<f64>,
    goal: usize,
    goal_cell: Cell,
    /// The one start the passes are restricted to, if any (see `SoftGoal::between`).
    start: Option<Cell>,
    horizon: usize,
    /// Z_k e^h for k = 0..=settled, each on the cells the passes can read (0 elsewhere).
    layers: Vec<Layer>,
    /// The layers' values, one after the other: one allocation rather than one a layer.
    memory: Vec<f64>,
    /// The first k from which Z_k no longer changes (to 1e-13): Z_k = Z_settled for
    /// every k above, so the backward pass stops there and the forward pass reuses one
    /// policy. Cheap paths (cells costing less than about ln 8 per step) never settle:
    /// their loops keep gaining weight, and the horizon is what bounds them.
    settled: usize,
}

/// Z_k e^h on a rectangle of window cells, over 2^exponent: the values at
/// `SoftGoal::memory[start..start + rect.len()]`.
struct Layer {
    rect: Rect,
    start: usize,
    exponent: i32,
}

/// A layer whose largest value leaves 2^±64 is scaled back to 1: far from the floats'
/// limits, and rarely (a step multiplies a layer's values by at most 8).
const DRIFT: i32 = 64;

/// The binary exponent of a start's scaled Z below which its fast answer is not
/// trusted. Every path within the step budget is then some 415 nats dearer than the
/// potential promised (a horizon that binds on a dear map), and the other cells of the
/// layers, scaled alike, may have lost to underflow what those paths carry; such a
/// start is answered in the log domain (`SoftGoal::exact`). Above it, whatever
/// underflowed weighs less than 2^−250 of the start's paths.
const TRUSTED_EXPONENT: i32 = -600;

/// How the passes answer for one start.
enum StartAnswer {
    /// From the layers: Z_steps(start) e^h(start) as a value and its layer's exponent.
    Layers(f64, i32),
    /// In the log domain: the layers' value is too small to trust.
    Exact,
    /// The goal cannot be reached from it within the steps (or it is not the start
    /// the passes are restricted to, or outside the window).
    Unreachable,
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
            (self.r1 - self.r0) as usize * self.cols()
        }
    }

    fn cols(&self) -> usize {
        if self.is_empty() {
            0
        } else {
            (self.c1 - self.c0) as usize
        }
    }

    fn covers(&self, other: Rect) -> bool {
        other.is_empty()
            || (self.r0 <= other.r0
                && other.r1 <= self.r1
                && self.c0 <= other.c0
                && other.c1 <= self.c1)
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

/// The window's cells laid out with a border of one cell all round, so that a cell's
/// eight neighbours lie at fixed offsets and a row's cells side by side, with no
/// bounds tests.
#[derive(Debug, Clone, Copy)]
struct Bordered {
    /// The window's columns.
    cols: usize,
    /// Positions in all, the border's included.
    len: usize,
}

impl Bordered {
    fn new(window: &Window) -> Self {
        let (rows, cols) = (window.rows as usize, window.cols as usize);
        Bordered {
            cols,
            len: (rows + 2) * (cols + 2),
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
}

/// One layer's values as the passes read them: row by row where the layer holds them
/// (0 elsewhere), with no bordered copy.
struct LayerRows<'a> {
    rect: Rect,
    data: &'a [f64],
}

impl<'a> LayerRows<'a> {
    fn of(layer: &Layer, data: &'a [f64]) -> Self {
        LayerRows {
            rect: layer.rect,
            data,
        }
    }

    /// For the cells of window row `row` at `columns`, each moved by (`dr`, `dc`):
    /// the columns whose moved cell lies in the layer, and the layer's values there
    /// (none where no such column is).
    fn moved(
        &self,
        row: usize,
        columns: &std::ops::Range<usize>,
        dr: i32,
        dc: i32,
    ) -> Option<(std::ops::Range<usize>, &'a [f64])> {
        let (r0, r1) = (self.rect.r0 as usize, self.rect.r1 as usize);
        let moved_row = row
            .checked_add_signed(dr as isize)
            .filter(|r| (r0..r1).contains(r))?;
        let (c0, c1) = (self.rect.c0 as isize, self.rect.c1 as isize);
        let first = (columns.start as isize).max(c0 - dc as isize);
        let last = (columns.end as isize).min(c1 - dc as isize);
        if first >= last {
            return None;
        }
        let cols = self.rect.cols();
        let at = (moved_row - r0) * cols + (first + dc as isize - c0) as usize;
        let kept = first as usize..last as usize;
        Some((kept.clone(), &self.data[at..at + kept.len()]))
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

/// Relative change below which a partition function counts as settled.
const SETTLED: f64 = 1e-13;

impl SoftGoal {
    /// The backward pass towards `goal` with at most `horizon` steps, for any start in
    /// the window; `goal` must lie in it.
    pub fn new(costs: &Grid<f32>, window: Window, goal: Cell, horizon: usize) -> Self {
        Self::build(costs, window, None, goal, horizon)
    }

    /// The backward pass for paths from `start` only: Z_k is kept on the cells that
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
        // Row by row: each cell's cost (∞ where it cannot be entered), and whether a
        // path of at most `horizon` steps from the start to the goal can use it (steps
        // between such cells are all the passes take).
        let cells = || {
            (window.row0..window.row0 + window.rows).flat_map(move |row| {
                (window.col0..window.col0 + window.cols).map(move |col| Cell::new(row, col))
            })
        };
        let usable = |cell: Cell| {
            start.is_none_or(|s| s.chebyshev(cell) + cell.chebyshev(goal_cell) <= horizon as u32)
        };
        let priced: Vec<f64> = cells()
            .map(|cell| match costs.get(cell) {
                c if c.is_finite() && c > 0.0 && usable(cell) => f64::from(c),
                _ => f64::INFINITY,
            })
            .collect();
        let lengths = StepLengths::of(&costs.geo);
        let (rows, cols) = (window.rows as usize, window.cols as usize);
        // Each window row's move lengths (0 off the window's rows): a step's length
        // depends on the rows it joins alone.
        let row_lengths: Vec<[f64; 8]> = (0..window.rows)
            .map(|r| {
                std::array::from_fn(|m| {
                    let (dr, dc) = MOVES[m];
                    let to = r as i64 + dr as i64;
                    if to < 0 || to >= window.rows as i64 {
                        return 0.0;
                    }
                    let row = |r: i64| window.row0 + r as u32;
                    lengths.between(
                        Cell::new(row(r as i64), 1),
                        Cell::new(row(to), (1 + dc) as u32),
                    )
                })
            })
            .collect();
        let steps = StepCosts {
            window: &window,
            priced: &priced,
            row_lengths: &row_lengths,
        };
        // Bounds on the steps' costs for the queue's buckets: the shortest move times
        // the cheapest cell, the longest times the dearest.
        let (mut cheapest, mut dearest) = (f64::INFINITY, 0.0f64);
        for &price in priced.iter().filter(|p| p.is_finite()) {
            cheapest = cheapest.min(price);
            dearest = dearest.max(price);
        }
        let (mut shortest, mut longest) = (f64::INFINITY, 0.0f64);
        for &length in row_lengths.iter().flatten().filter(|&&l| l > 0.0) {
            shortest = shortest.min(length);
            longest = longest.max(length);
        }
        let (least_edge, dearest_edge) = (shortest * cheapest, longest * dearest);
        let goal = window.index(goal_cell);
        let potential = match Buckets::new(least_edge, dearest_edge) {
            Some(buckets) => steps.cost_to_goal(goal, buckets),
            None => steps.cost_to_goal(goal, Heap::default()),
        };
        // Each step's excess over the potential's drop (at least 0, as h(x) is the least
        // of these sums; ∞ where the step is not taken), then its weight e^−excess, a
        // row of one move at a time.
        let mut weight = vec![f64::INFINITY; n * 8];
        for (m, &(dr, dc)) in MOVES.iter().enumerate() {
            for (r, lengths) in row_lengths.iter().enumerate() {
                let Some(to) = r.checked_add_signed(dr as isize).filter(|&to| to < rows) else {
                    continue;
                };
                // The row's cells whose move m stays in the window, and their neighbours.
                let (first, len) = ((dc < 0) as usize, cols - (dc != 0) as usize);
                let x = r * cols + first..r * cols + first + len;
                let y = (to * cols + first).wrapping_add_signed(dc as isize)..;
                let half_length = lengths[m] * 0.5;
                let out = &mut weight[m * n..][x.clone()];
                let ends = priced[x.clone()].iter().zip(&priced[y.clone()]);
                let drops = potential[x.clone()].iter().zip(&potential[y]);
                for (out, ((&px, &py), (&hx, &hy))) in out.iter_mut().zip(ends.zip(drops)) {
                    let excess = (step_cost(half_length, px, py) + hy) - hx;
                    *out = if hx.is_finite() && excess.is_finite() {
                        excess
                    } else {
                        f64::INFINITY
                    };
                }
            }
        }
        weights_from_excess(&mut weight);
        let mut soft = SoftGoal {
            window,
            weight,
            half_lengths: row_lengths.iter().map(|l| l.map(|l| l * 0.5)).collect(),
            potential,
            priced,
            goal,
            goal_cell,
            start,
            horizon,
            layers: Vec::new(),
            memory: Vec::new(),
            settled: horizon,
        };
        soft.backward();
        soft
    }

    /// The cells whose Z_k the passes read: within k moves of the goal and, for one
    /// start, within horizon − k moves of it.
    fn region(&self, k: usize) -> Rect {
        let near_goal = Rect::ball(&self.window, self.goal_cell, k);
        match self.start {
            Some(start) => near_goal.intersect(Rect::ball(&self.window, start, self.horizon - k)),
            None => near_goal,
        }
    }

    /// Z_k(x) = Σ over moves of the step's weight times Z_{k−1}(next), up to the horizon
    /// or until the values settle.
    /// Where the CPU has AVX2 the passes are compiled for it, the row kernels four
    /// cells at a time; without fused multiply-adds (which AVX2 does not bring) every
    /// cell's operations are the same, so the bits are too (a test holds them to it).
    fn backward(&mut self) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2.
            return unsafe { self.backward_avx2() };
        }
        self.backward_rows()
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn backward_avx2(&mut self) {
        self.backward_rows()
    }

    #[inline(always)]
    fn backward_rows(&mut self) {
        let (width, n) = (self.window.cols as usize, self.window.len());
        // Room for every layer up to the horizon, so that growing never copies them
        // (room a settled pass leaves unused is never touched).
        self.memory = Vec::with_capacity((0..=self.horizon).map(|k| self.region(k).len()).sum());
        let first = self.region(0);
        self.memory.resize(first.len(), 1.0);
        self.layers.push(Layer {
            rect: first,
            start: 0,
            exponent: 0,
        });
        let mut exponent = 0;
        for k in 1..=self.horizon {
            let rect = self.region(k);
            let mut changed = false;
            let start = self.memory.len();
            // The goal's Z stays 1 (paths end there), in the previous layer's scale.
            let at_goal = power_of_two(-exponent);
            // Each row summed move by move straight into the layers' memory, from the
            // layer before read where it holds values (elsewhere they are 0, and add
            // nothing): no copy of either layer.
            self.memory.resize(start + rect.len(), 0.0);
            let (before, data) = self.memory.split_at_mut(start);
            let layer = &self.layers[k - 1];
            let previous = LayerRows::of(layer, &before[layer.start..]);
            let row_cols = rect.cols();
            for (cells, out) in rect
                .rows(width as u32)
                .zip(data.chunks_exact_mut(row_cols.max(1)))
            {
                let (row, col) = (cells.start / width, cells.start % width);
                let columns = col..col + cells.len();
                for (m, &(dr, dc)) in MOVES.iter().enumerate() {
                    let Some((kept, ahead)) = previous.moved(row, &columns, dr, dc) else {
                        continue;
                    };
                    let at = kept.start - columns.start;
                    let weights = &self.weight[m * n + row * width..][kept.clone()];
                    add_products(weights, ahead, &mut out[at..at + kept.len()]);
                }
                if cells.contains(&self.goal) {
                    out[self.goal - cells.start] = at_goal;
                }
                if !changed {
                    changed = match previous.moved(row, &columns, 0, 0) {
                        // Outside the layer before, any value is a change from its 0.
                        None => out.iter().any(|&z| z != 0.0),
                        Some((kept, old)) => {
                            let at = kept.start - columns.start;
                            let moved = |(&z, &old): (&f64, &f64)| {
                                z != old && (z - old).abs() > SETTLED * z.max(old)
                            };
                            out[..at].iter().any(|&z| z != 0.0)
                                || out[at..at + kept.len()].iter().zip(old).any(moved)
                                || out[at + kept.len()..].iter().any(|&z| z != 0.0)
                        }
                    };
                }
            }
            let data = &mut self.memory[start..];
            let largest = largest_of(data);
            let drift = if largest > 0.0 {
                binary_exponent(largest)
            } else {
                0
            };
            if drift.abs() > DRIFT {
                // Two exact halves: 2^−drift alone may not be a float.
                let (half, rest) = (power_of_two(-drift / 2), power_of_two(-drift + drift / 2));
                data.iter_mut().for_each(|z| *z = *z * half * rest);
                exponent += drift;
                changed = true;
            }
            self.layers.push(Layer {
                rect,
                start,
                exponent,
            });
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

    /// The layer that holds Z_k.
    fn layer(&self, k: usize) -> &Layer {
        &self.layers[k.min(self.settled)]
    }

    /// A layer's values.
    fn data(&self, layer: &Layer) -> &[f64] {
        &self.memory[layer.start..layer.start + layer.rect.len()]
    }

    /// Soft cost-to-go from `cell` with the full horizon: −log of the summed
    /// exp(−cost) of the paths from it; ∞ when the goal is out of reach.
    pub fn value(&self, cell: Cell) -> f64 {
        self.value_within(cell, self.horizon)
    }

    /// Soft cost-to-go from `cell` with at most `steps` steps (capped at the horizon).
    pub fn value_within(&self, cell: Cell, steps: usize) -> f64 {
        match self.answer_at(cell, steps) {
            StartAnswer::Layers(z, exponent) => {
                self.potential[self.window.index(cell)] - ln_scaled(z, exponent)
            }
            StartAnswer::Exact => self.exact(cell, steps.min(self.horizon)).0,
            StartAnswer::Unreachable => f64::INFINITY,
        }
    }

    /// How the passes answer for paths from `cell` of at most `steps` steps.
    fn answer_at(&self, cell: Cell, steps: usize) -> StartAnswer {
        let steps = steps.min(self.horizon);
        if !self.window.contains(cell)
            || self.start.is_some_and(|s| s != cell)
            || cell.chebyshev(self.goal_cell) as usize > steps
            || !self.potential[self.window.index(cell)].is_finite()
        {
            return StartAnswer::Unreachable;
        }
        let layer = self.layer(steps);
        let z = layer
            .rect
            .offset(self.window.index(cell), self.window.cols)
            .map_or(0.0, |at| self.data(layer)[at]);
        if z > 0.0 && binary_exponent(z) >= TRUSTED_EXPONENT {
            StartAnswer::Layers(z, layer.exponent)
        } else {
            StartAnswer::Exact
        }
    }

    /// Expected visitation of paths from `start` under the distribution.
    pub fn visitation(&self, start: Cell) -> Visitation {
        self.visitation_within(start, self.horizon)
    }

    /// Expected visitation of the paths from `start` of at most `steps` steps (capped
    /// at the horizon).
    pub fn visitation_within(&self, start: Cell, steps: usize) -> Visitation {
        let steps = steps.min(self.horizon);
        let (z, exponent) = match self.answer_at(start, steps) {
            StartAnswer::Layers(z, exponent) => (z, exponent),
            StartAnswer::Exact => return self.exact(start, steps).1,
            StartAnswer::Unreachable => {
                return Visitation {
                    visits: vec![0.0; self.window.len()],
                    incidence: vec![0.0; self.window.len()],
                };
            }
        };
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2.
            return unsafe { self.visitation_avx2(start, steps, z, exponent) };
        }
        self.visitation_rows(start, steps, z, exponent)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn visitation_avx2(&self, start: Cell, steps: usize, z: f64, exponent: i32) -> Visitation {
        self.visitation_rows(start, steps, z, exponent)
    }

    /// The forward pass from `start`, whose Z_steps is `z_start` over 2^`z_exponent`.
    #[inline(always)]
    fn visitation_rows(
        &self,
        start: Cell,
        steps: usize,
        z_start: f64,
        z_exponent: i32,
    ) -> Visitation {
        let n = self.window.len();
        let width = self.window.cols;
        let layout = Bordered::new(&self.window);
        let offsets = layout.offsets();
        // The forward partition functions (the summed weight of the paths from the start
        // that reach a cell after `taken` steps without having reached the goal), over
        // 2^forward_exponent, [`Bordered`]: a move's arrivals from a row's cells land
        // side by side at a fixed offset.
        let padded = layout.len;
        let (mut forward, mut arrived) = (vec![0.0; padded], vec![0.0; padded]);
        let mut forward_exponent = 0;
        let (mut visits, mut incidence) = (vec![0.0; padded], vec![0.0; padded]);
        let (origin, goal) = (layout.at(self.window.index(start)), layout.at(self.goal));
        forward[origin] = 1.0;
        visits[origin] = 1.0;
        // Each window row's columns that paths reach (empty where none): the passes
        // read and write those alone, as far from the likely routes most cells hold
        // nothing.
        let rows = self.window.rows as usize;
        let mut spans = vec![0..0; rows];
        let (mut reached, mut next_spans) = (vec![0..0; rows], vec![0..0; rows]);
        let (start_row, start_col) = (
            (start.row - self.window.row0) as usize,
            (start.col - self.window.col0) as usize,
        );
        if origin != goal {
            spans[start_row] = start_col..start_col + 1;
        }
        let mut outgoing = vec![0.0; width as usize];
        for left in (1..=steps).rev() {
            // Z_left−1, the partition functions ahead of the step, read where the layer
            // holds them: elsewhere they are 0, and no path arrives.
            let layer = self.layer(left - 1);
            let ahead = LayerRows::of(layer, self.data(layer));
            // A path's share of them all: its weight times Z_left−1 where it arrives,
            // over Z_steps(start); with the scales, `forward` · Z_left−1 · `share`.
            let share = scaled_inverse(forward_exponent + layer.exponent - z_exponent, z_start);
            // Where the paths may arrive: the spans of the row and its two neighbours,
            // one column wider.
            for (r, reach) in reached.iter_mut().enumerate() {
                let around = &spans[r.saturating_sub(1)..(r + 2).min(rows)];
                let first = around
                    .iter()
                    .filter(|s| !s.is_empty())
                    .map(|s| s.start)
                    .min();
                let last = around.iter().map(|s| s.end).max().unwrap_or(0);
                *reach = match first {
                    Some(first) => first.saturating_sub(1)..(last + 1).min(width as usize),
                    None => 0..0,
                };
                let at = layout.at(r * width as usize);
                arrived[at + reach.start..at + reach.end].fill(0.0);
            }
            for (r, span) in spans.iter().enumerate().filter(|(_, s)| !s.is_empty()) {
                let source = layout.at(r * width as usize + span.start);
                let outgoing = &mut outgoing[..span.len()];
                outgoing.fill(0.0);
                // Move by move, every cell of the span at once: each cell's paths land on
                // a different neighbour.
                for (m, (&offset, &(dr, dc))) in offsets.iter().zip(&MOVES).enumerate() {
                    let Some((columns, z)) = ahead.moved(r, span, dr, dc) else {
                        continue;
                    };
                    let from = source + (columns.start - span.start);
                    let (target, len) = (from.wrapping_add_signed(offset), columns.len());
                    let cells =
                        r * width as usize + columns.start..r * width as usize + columns.end;
                    flow_row(
                        &forward[from..from + len],
                        &self.weight[m * n..][cells],
                        z,
                        self.half_lengths[r][m] * share,
                        &mut arrived[target..target + len],
                        &mut incidence[target..target + len],
                        &mut outgoing[columns.start - span.start..columns.end - span.start],
                    );
                }
                for (incidence, &out) in incidence[source..].iter_mut().zip(&*outgoing) {
                    *incidence += out;
                }
            }
            // Arrivals are visits; a negligible share is not moved on.
            let mut largest = [0.0f64; 4];
            for (r, (reach, span)) in reached.iter().zip(&mut next_spans).enumerate() {
                let at = layout.at(r * width as usize);
                let cells = at + reach.start..at + reach.end;
                if let Some((columns, z)) = ahead.moved(r, reach, 0, 0) {
                    let arrivals = at + columns.start..at + columns.end;
                    arrive_row(
                        &mut arrived[arrivals.clone()],
                        &mut visits[arrivals],
                        z,
                        share,
                        &mut largest,
                    );
                }
                if (at..at + width as usize).contains(&goal) {
                    arrived[goal] = 0.0;
                }
                let row = &arrived[cells];
                *span = match row.iter().position(|&a| a != 0.0) {
                    Some(first) => {
                        let last = row.iter().rposition(|&a| a != 0.0).unwrap_or(first);
                        reach.start + first..reach.start + last + 1
                    }
                    None => 0..0,
                };
            }
            std::mem::swap(&mut forward, &mut arrived);
            std::mem::swap(&mut spans, &mut next_spans);
            let largest = largest.into_iter().fold(0.0, f64::max);
            if largest == 0.0 {
                break;
            }
            let drift = binary_exponent(largest);
            if drift.abs() > DRIFT {
                // Two exact halves: 2^−drift alone may not be a float.
                let (half, rest) = (power_of_two(-drift / 2), power_of_two(-drift + drift / 2));
                for (r, span) in spans.iter().enumerate() {
                    let at = layout.at(r * width as usize);
                    forward[at + span.start..at + span.end]
                        .iter_mut()
                        .for_each(|a| *a = *a * half * rest);
                }
                forward_exponent += drift;
            }
        }
        // Without the border.
        let unpadded = |padded: Vec<f64>| -> Vec<f64> {
            (0..self.window.rows as usize)
                .flat_map(|row| {
                    let first = layout.at(row * width as usize);
                    padded[first..first + width as usize].to_vec()
                })
                .collect()
        };
        Visitation {
            visits: unpadded(visits),
            incidence: unpadded(incidence),
        }
    }

    /// Soft value and visitation of the paths from `start` of at most `steps` steps,
    /// in the log domain: soft values V_k = −ln Z_k layer by layer (each a log-sum-exp
    /// with its least term taken out), then the forward pass in step probabilities
    /// e^(V_k(x) − edge − V_k−1(y)) ≤ 1, so that nothing underflows however dear the
    /// paths the step budget leaves. Several times slower than the layers, and only
    /// asked where they cannot be trusted (`TRUSTED_EXPONENT`).
    fn exact(&self, start: Cell, steps: usize) -> (f64, Visitation) {
        let (n, width, rows) = (
            self.window.len(),
            self.window.cols as usize,
            self.window.rows as usize,
        );
        // Cells that can lie k steps from the goal on a path from the start.
        let rects: Vec<Rect> = (0..=steps)
            .map(|k| {
                Rect::ball(&self.window, self.goal_cell, k).intersect(Rect::ball(
                    &self.window,
                    start,
                    steps - k,
                ))
            })
            .collect();
        // The step from x by move m: where it lands and its cost, where it can be taken.
        let step = |x: usize, m: usize| -> Option<(usize, f64)> {
            let (dr, dc) = MOVES[m];
            let r = (x / width)
                .checked_add_signed(dr as isize)
                .filter(|&r| r < rows)?;
            let c = (x % width)
                .checked_add_signed(dc as isize)
                .filter(|&c| c < width)?;
            let y = r * width + c;
            let cost = step_cost(
                self.half_lengths[x / width][m],
                self.priced[x],
                self.priced[y],
            );
            cost.is_finite().then_some((y, cost))
        };
        let mut layers: Vec<Vec<f64>> = Vec::with_capacity(steps + 1);
        let value = |layers: &[Vec<f64>], k: usize, x: usize| {
            rects[k]
                .offset(x, self.window.cols)
                .map_or(f64::INFINITY, |at| layers[k][at])
        };
        for (k, rect) in rects.iter().enumerate() {
            let mut layer = Vec::with_capacity(rect.len());
            for x in rect.rows(self.window.cols).flatten() {
                layer.push(if x == self.goal {
                    0.0
                } else if k == 0 {
                    f64::INFINITY
                } else {
                    let ahead = || {
                        (0..8)
                            .filter_map(|m| step(x, m))
                            .map(|(y, cost)| cost + value(&layers, k - 1, y))
                    };
                    let least = ahead().fold(f64::INFINITY, f64::min);
                    if least.is_finite() {
                        let sum: f64 = ahead().map(|q| exp(least - q)).sum();
                        least - ln_scaled(sum, 0)
                    } else {
                        least
                    }
                });
            }
            layers.push(layer);
        }
        let origin = self.window.index(start);
        let (mut visits, mut incidence) = (vec![0.0; n], vec![0.0; n]);
        visits[origin] = 1.0;
        let mut mass = vec![0.0; n];
        if origin != self.goal {
            mass[origin] = 1.0;
        }
        let mut moved = vec![0.0; n];
        for left in (1..=steps).rev() {
            moved.fill(0.0);
            for x in rects[left].rows(self.window.cols).flatten() {
                if mass[x] == 0.0 {
                    continue;
                }
                let here = value(&layers, left, x);
                for m in 0..8 {
                    let Some((y, cost)) = step(x, m) else {
                        continue;
                    };
                    let flow = mass[x] * exp(here - cost - value(&layers, left - 1, y));
                    let half = self.half_lengths[x / width][m];
                    moved[y] += flow;
                    visits[y] += flow;
                    incidence[x] += half * flow;
                    incidence[y] += half * flow;
                }
            }
            moved[self.goal] = 0.0;
            std::mem::swap(&mut mass, &mut moved);
        }
        (
            value(&layers, steps, origin),
            Visitation { visits, incidence },
        )
    }
}

/// e^−x in place of each step's excess x (0 for ∞), compiled for AVX2 where the CPU
/// has it, four at a time (the same bits: see `SoftGoal::backward`).
fn weights_from_excess(excess: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        #[target_feature(enable = "avx2")]
        fn avx2(excess: &mut [f64]) {
            negated_exp_row(excess)
        }
        // SAFETY: the CPU has AVX2.
        return unsafe { avx2(excess) };
    }
    negated_exp_row(excess)
}

/// The cost of each step between window cells: its length times the mean of its two
/// cells' costs, ∞ where either cannot be entered or no path within the horizon uses it.
/// Worked out where needed rather than stored: eight steps a cell would be the largest
/// array the passes make, and a Dijkstra pass reading it would miss the cache at
/// every step.
struct StepCosts<'a> {
    window: &'a Window,
    /// Each cell's cost, ∞ where paths cannot use it.
    priced: &'a [f64],
    /// Each window row's move lengths.
    row_lengths: &'a [[f64; 8]],
}

impl StepCosts<'_> {
    /// h: the least cost from each window cell to `goal` (index), by Dijkstra backwards
    /// from the goal (∞ where there is no way). Each cell's h is the least of its steps'
    /// sums, whatever order the queue pops cells of equal keys.
    fn cost_to_goal(&self, goal: usize, mut open: impl MinQueue) -> Vec<f64> {
        let (rows, cols) = (self.window.rows as usize, self.window.cols as usize);
        // The prices with a border of ∞ round the window, so that a cell's eight
        // neighbours lie at fixed offsets without bounds tests (steps onto the border
        // cost ∞ and are never taken).
        let stride = cols + 2;
        let mut priced = vec![f64::INFINITY; (rows + 2) * stride];
        for (r, row) in self.priced.chunks_exact(cols).enumerate() {
            priced[(r + 1) * stride + 1..][..cols].copy_from_slice(row);
        }
        let at = |x: usize| (x / cols + 1) * stride + x % cols + 1;
        let offsets = MOVES.map(|(dr, dc)| dr as isize * stride as isize + dc as isize);
        // For a cell of window row r, half the length of the step into it from its
        // neighbour by move `back` (0 from off the window's rows), as `cost` has it.
        let halves: Vec<[f64; 8]> = (0..rows)
            .map(|r| {
                std::array::from_fn(|back| {
                    let from = r.checked_add_signed(MOVES[back].0 as isize);
                    match from.filter(|&from| from < rows) {
                        Some(from) => self.row_lengths[from][OPPOSITE[back]] * 0.5,
                        None => 0.0,
                    }
                })
            })
            .collect();
        let mut least = vec![f64::INFINITY; priced.len()];
        let mut done = vec![false; priced.len()];
        least[at(goal)] = 0.0;
        open.push(0.0, at(goal) as u32);
        while let Some(y) = open.pop() {
            let y = y as usize;
            if std::mem::replace(&mut done[y], true) {
                continue;
            }
            let (to_goal, price) = (least[y], priced[y]);
            let halves = &halves[y / stride - 1];
            for (&offset, &half) in offsets.iter().zip(halves) {
                // x reaches y by the move opposite to this one.
                let x = y.wrapping_add_signed(offset);
                let through = step_cost(half, priced[x], price) + to_goal;
                if !done[x] && through < least[x] {
                    open.decrease(x as u32, least[x], through);
                    least[x] = through;
                }
            }
        }
        // Without the border.
        (0..rows)
            .flat_map(|r| least[(r + 1) * stride + 1..][..cols].iter().copied())
            .collect()
    }
}

/// A step's cost: half its length times the sum of its two cells' prices.
#[inline(always)]
fn step_cost(half_length: f64, from: f64, to: f64) -> f64 {
    half_length * (from + to)
}

/// The move back of each of `MOVES`.
const OPPOSITE: [usize; 8] = [3, 2, 1, 0, 7, 6, 5, 4];

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
                    // −ln Σ exp(−q), q's least taken out so that dear maps do not underflow.
                    let q: Vec<f64> = (0..8)
                        .filter_map(|m| edge(x, m))
                        .map(|(y, _, e)| e + values[k - 1][y])
                        .collect();
                    let least = q.iter().copied().fold(f64::INFINITY, f64::min);
                    if least == f64::INFINITY {
                        return least;
                    }
                    least - q.iter().map(|&q| (least - q).exp()).sum::<f64>().ln()
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
        /// change nothing: against the naive passes in soft values, on cheap maps (which
        /// never settle), dear ones (which do) and maps so dear that exp(−cost) of every
        /// path is below the smallest float.
        #[test]
        fn restricted_and_settled_passes_match_the_naive_ones(
            width in 2u32..9,
            height in 2u32..9,
            scale in proptest::prop_oneof![0.2f32..1.0, 3.0f32..8.0, 150.0f32..400.0],
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
            // Infinite only against infinite.
            let close = |a: f64, b: f64| {
                a == b || (a.is_finite() && (a - b).abs() <= 1e-9 * a.abs().max(1.0))
            };
            for soft in [
                SoftGoal::new(&costs, window, goal, horizon),
                SoftGoal::between(&costs, window, start, goal, horizon),
            ] {
                // The layers where they are trusted, and the log-domain pass everywhere.
                let (exact_value, exact) = soft.exact(start, horizon);
                for (found, found_visits) in [
                    (soft.value(start), soft.visitation(start).visits),
                    (exact_value, exact.visits),
                ] {
                    proptest::prop_assert!(close(found, value), "{found} against {value}");
                    for (i, (&a, &b)) in found_visits.iter().zip(&visits).enumerate() {
                        proptest::prop_assert!(close(a, b), "cell {i}: {a} against {b}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_binding_horizon_on_a_dear_map_is_answered_in_the_log_domain() {
        // Dear cells and a horizon of the diagonal's steps: the one path allowed costs
        // some 1100 more than the cheapest path of any length, which the potential
        // measures against, so its weight underflows in the layers.
        let (width, height, seed) = (7u32, 7u32, 343u64);
        let data: Vec<f32> = (0..width * height)
            .map(|i| {
                390.3 * (0.5 + ((u64::from(i) * 2654435761 + seed * 40503) % 1000) as f32 / 1000.0)
            })
            .collect();
        let costs = grid(width, height, data);
        let (start, goal) = (Cell::new(0, 0), Cell::new(6, 6));
        let window = Window::around(&[start, goal], 0, width, height);
        let soft = SoftGoal::new(&costs, window, goal, 6);
        assert!(matches!(soft.answer_at(start, 6), StartAnswer::Exact));
        let diagonal: Vec<Cell> = (0..7).map(|i| Cell::new(i, i)).collect();
        let cost = path_cost(&costs, &diagonal);
        assert!(
            (soft.value(start) - cost).abs() <= 1e-9 * cost,
            "{} against {cost}",
            soft.value(start)
        );
        let visits = soft.visitation(start).visits;
        for (i, &v) in visits.iter().enumerate() {
            let on_diagonal = i % 8 == 0;
            assert!(
                (v - f64::from(u8::from(on_diagonal))).abs() < 1e-12,
                "cell {i}: {v}"
            );
        }
    }

    #[test]
    fn layers_that_grow_past_the_drift_are_scaled_back_and_still_match() {
        // Loops on cells this cheap gain weight at every step: Z grows some 7 times
        // per layer, past 2^64 within the horizon.
        let costs = grid(12, 12, vec![0.05; 144]);
        let (start, goal, horizon) = (Cell::new(0, 0), Cell::new(11, 11), 60);
        let window = Window::around(&[start, goal], 0, 12, 12);
        let (value, visits) = naive(&costs, start, goal, horizon);
        for soft in [
            SoftGoal::new(&costs, window, goal, horizon),
            SoftGoal::between(&costs, window, start, goal, horizon),
        ] {
            assert!(soft.layers.iter().any(|layer| layer.exponent > DRIFT));
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(1.0);
            assert!(
                close(soft.value(start), value),
                "{} against {value}",
                soft.value(start)
            );
            for (i, (&a, &b)) in soft
                .visitation(start)
                .visits
                .iter()
                .zip(&visits)
                .enumerate()
            {
                assert!(close(a, b), "cell {i}: {a} against {b}");
            }
        }
    }

    /// With AVX2 and without, the same bits: partition functions, values and visits.
    #[test]
    fn the_passes_compiled_for_avx2_give_the_same_bits() {
        let (width, height) = (23u32, 17u32);
        let data: Vec<f32> = (0..width * height)
            .map(|i| {
                let r = (u64::from(i) * 2654435761 % 1000) as f32 / 1000.0;
                if i % 29 == 7 {
                    f32::INFINITY
                } else {
                    0.3 + 2.0 * r
                }
            })
            .collect();
        let costs = grid(width, height, data);
        let (start, goal) = (Cell::new(2, 1), Cell::new(height - 3, width - 2));
        let window = Window::around(&[start, goal], 2, width, height);
        for horizon in [24, 40] {
            let auto = SoftGoal::between(&costs, window, start, goal, horizon);
            let mut plain = SoftGoal::between(&costs, window, start, goal, horizon);
            plain.layers.clear();
            plain.settled = horizon;
            plain.backward_rows();
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&plain.memory), bits(&auto.memory));
            assert_eq!(plain.value(start).to_bits(), auto.value(start).to_bits());
            let StartAnswer::Layers(z, exponent) = plain.answer_at(start, horizon) else {
                panic!("this map's layers answer for the start");
            };
            let (a, b) = (
                plain.visitation_rows(start, horizon, z, exponent),
                auto.visitation(start),
            );
            assert_eq!(bits(&a.visits), bits(&b.visits));
            assert_eq!(bits(&a.incidence), bits(&b.incidence));
        }
    }

    #[test]
    fn weights_compiled_for_avx2_have_the_same_bits() {
        let excess: Vec<f64> = (0..4099)
            .map(|i| match i % 97 {
                0 => f64::INFINITY,
                k => f64::from(i) * 0.1913 + f64::from(k) * 1e-3,
            })
            .collect();
        let (mut auto, mut plain) = (excess.clone(), excess);
        weights_from_excess(&mut auto);
        negated_exp_row(&mut plain);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&auto), bits(&plain));
        assert!(auto.iter().all(|w| (0.0..=1.0).contains(w)));
        assert_eq!(auto[0], 0.0);
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
