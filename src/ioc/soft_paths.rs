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
        let length = match (dr != 0, dc != 0) {
            (true, true) => lengths.diagonal,
            (true, false) => lengths.y,
            _ => lengths.x,
        };
        let cols = self.cols as i64;
        let (r, c) = (
            (index as i64) / cols + dr as i64,
            (index as i64) % cols + dc as i64,
        );
        (r >= 0 && c >= 0 && r < self.rows as i64 && c < cols)
            .then(|| ((r * cols + c) as usize, length))
    }
}

/// Soft values towards one goal on one window.
pub struct SoftGoal {
    window: Window,
    /// For cell x and move m at x * 8 + m: the neighbour (x itself where the move
    /// leaves the window), the step's cost (∞ where blocked or outside) and its length,
    /// so that the passes are straight loops without tests.
    next: Vec<u32>,
    edge: Vec<f64>,
    length: Vec<f64>,
    goal: usize,
    horizon: usize,
    /// V_k for k = 0..=horizon, each a window's worth.
    values: Vec<Vec<f64>>,
}

/// What the forward pass found.
pub struct Visitation {
    /// Expected visits of each window cell (the start counts once).
    pub visits: Vec<f64>,
    /// Expected edge incidence: for every step a→b, half its length added to a and to
    /// b, so that Σ incidence(x) · cost(x) is the expected path cost.
    pub incidence: Vec<f64>,
}

/// The window cells within `k` moves (Chebyshev distance) of `center`: only they can
/// hold finite values after k backward steps, or mass after k forward ones.
fn within(window: &Window, center: Cell, k: usize) -> impl Iterator<Item = usize> + '_ {
    let k = k.min(u32::MAX as usize) as u32;
    let (r, c) = (center.row - window.row0, center.col - window.col0);
    let rows = r.saturating_sub(k)..r.saturating_add(k).saturating_add(1).min(window.rows);
    let cols = c.saturating_sub(k)..c.saturating_add(k).saturating_add(1).min(window.cols);
    let width = window.cols as usize;
    rows.flat_map(move |row| {
        cols.clone()
            .map(move |col| row as usize * width + col as usize)
    })
}

impl SoftGoal {
    /// The backward pass towards `goal` with at most `horizon` steps; `goal` must lie in
    /// the window.
    pub fn new(costs: &Grid<f32>, window: Window, goal_cell: Cell, horizon: usize) -> Self {
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
        let mut next = vec![0u32; n * 8];
        let (mut edge, mut length) = (vec![0.0; n * 8], vec![0.0; n * 8]);
        for x in 0..n {
            for m in 0..8 {
                let (y, l) = window.step(x, m, &lengths).unwrap_or((x, 0.0));
                next[x * 8 + m] = y as u32;
                length[x * 8 + m] = l;
                edge[x * 8 + m] = if l == 0.0 {
                    f64::INFINITY
                } else {
                    l * 0.5 * (cell_costs[x] + cell_costs[y])
                };
            }
        }
        let goal = window.index(goal_cell);
        let mut first = vec![f64::INFINITY; n];
        first[goal] = 0.0;
        let mut values = vec![first];
        for k in 1..=horizon {
            let previous = values.last().expect("V_0 is there");
            let mut current = vec![f64::INFINITY; n];
            for x in within(&window, goal_cell, k) {
                current[x] = if x == goal {
                    0.0
                } else {
                    let q = |m: usize| edge[x * 8 + m] + previous[next[x * 8 + m] as usize];
                    let least = (0..8).map(q).fold(f64::INFINITY, f64::min);
                    if least == f64::INFINITY {
                        least
                    } else {
                        least - (0..8).map(|m| (least - q(m)).exp()).sum::<f64>().ln()
                    }
                };
            }
            values.push(current);
        }
        SoftGoal {
            window,
            next,
            edge,
            length,
            goal,
            horizon,
            values,
        }
    }

    /// Soft cost-to-go from `cell` with the full horizon: −log of the summed
    /// exp(−cost) of the paths from it; ∞ when the goal is out of reach.
    pub fn value(&self, cell: Cell) -> f64 {
        self.value_within(cell, self.horizon)
    }

    /// Soft cost-to-go from `cell` with at most `steps` steps (capped at the horizon).
    pub fn value_within(&self, cell: Cell, steps: usize) -> f64 {
        if !self.window.contains(cell) {
            return f64::INFINITY;
        }
        self.values[steps.min(self.horizon)][self.window.index(cell)]
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
        let mut visits = vec![0.0; n];
        let mut incidence = vec![0.0; n];
        if self.value_within(start, steps) == f64::INFINITY {
            return Visitation { visits, incidence };
        }
        let mut mass = vec![0.0; n];
        mass[self.window.index(start)] = 1.0;
        visits[self.window.index(start)] = 1.0;
        let mut moved = vec![0.0; n];
        for (taken, left) in (1..=steps).rev().enumerate() {
            let (here, next_values) = (&self.values[left], &self.values[left - 1]);
            moved.iter_mut().for_each(|m| *m = 0.0);
            for x in within(&self.window, start, taken) {
                let m = mass[x];
                if m == 0.0 || x == self.goal {
                    continue;
                }
                for e in x * 8..x * 8 + 8 {
                    let y = self.next[e] as usize;
                    let p = (here[x] - self.edge[e] - next_values[y]).exp();
                    if p > 0.0 {
                        let flow = m * p;
                        let half = flow * self.length[e] * 0.5;
                        moved[y] += flow;
                        incidence[x] += half;
                        incidence[y] += half;
                    }
                }
            }
            // Arrivals are visits; mass already at the goal rests there uncounted.
            for (v, &arrived) in visits.iter_mut().zip(&moved) {
                *v += arrived;
            }
            moved[self.goal] += mass[self.goal];
            std::mem::swap(&mut mass, &mut moved);
        }
        Visitation { visits, incidence }
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
