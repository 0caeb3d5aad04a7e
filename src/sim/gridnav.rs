//! `gridnav`: a reactive policy walks a terrain costmap to a goal, one of 8 moves per
//! step, seeing only its surroundings: the goal's direction and distance and the costs
//! of the 8 neighbouring cells. The teacher is the planner on the true costmap: the
//! move that starts a cheapest path to the goal (from the goal's cost-to-go field). An
//! episode ends at the goal (a success) or after three times the teacher's number of
//! steps (a failure).

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::grid::{Cell, Grid};
use crate::plan::{CostField, Moves, StepLengths, cost_to_go, edge_cost};

/// The 8 moves (row, column offsets), the action's index.
pub const MOVES: [(i32, i32); 8] = [
    (-1, 0),
    (0, -1),
    (0, 1),
    (1, 0),
    (-1, -1),
    (-1, 1),
    (1, -1),
    (1, 1),
];

/// The observation: goal direction (row, column; unit), log of the goal distance + 1,
/// and the log-cost of each neighbour relative to the current cell (cells off the map
/// count as 10).
pub const OBSERVATION_DIMS: usize = 11;

/// Names of the observation's values, in order.
pub const OBSERVATION_NAMES: [&str; OBSERVATION_DIMS] = [
    "goal_row",
    "goal_col",
    "log_goal_distance",
    "cost_up",
    "cost_left",
    "cost_right",
    "cost_down",
    "cost_up_left",
    "cost_up_right",
    "cost_down_left",
    "cost_down_right",
];

/// Tries for a reachable random pair before a map is declared unusable.
const PAIR_ATTEMPTS: usize = 1000;

/// A random start and goal at least a third of the map's smaller side apart (they may
/// be blocked or disconnected: `episode` checks).
pub fn random_pair(costs: &Grid<f32>, rng: &mut ChaCha8Rng) -> (Cell, Cell) {
    let (w, h) = (costs.geo.width, costs.geo.height);
    loop {
        let a = Cell::new(rng.random_range(0..h), rng.random_range(0..w));
        let b = Cell::new(rng.random_range(0..h), rng.random_range(0..w));
        if (a.distance_squared(b) as f64).sqrt() >= f64::from(w.min(h)) / 3.0 {
            return (a, b);
        }
    }
}

/// An episode between a random reachable pair, or `None` when a thousand tries found
/// none (a map mostly blocked, or too small).
pub fn random_episode<'a>(costs: &'a Grid<f32>, rng: &mut ChaCha8Rng) -> Option<GridNav<'a>> {
    if costs.geo.width.min(costs.geo.height) < 3 {
        return None;
    }
    (0..PAIR_ATTEMPTS).find_map(|_| {
        let (a, b) = random_pair(costs, rng);
        GridNav::new(costs, a, b)
    })
}

/// How a policy does on a set of start/goal pairs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Evaluation {
    pub success_rate: f64,
    /// Mean over successful episodes of the policy's path cost over the teacher's
    /// (NaN when none succeeded).
    pub cost_ratio: f64,
}

/// Drives `act` (observation → move) from each start to its goal.
pub fn evaluate(
    costs: &Grid<f32>,
    pairs: &[(Cell, Cell)],
    act: impl Fn(&[f64]) -> usize,
) -> Evaluation {
    let (mut successes, mut ratios) = (0usize, Vec::new());
    for &(a, b) in pairs {
        let Some(mut nav) = GridNav::new(costs, a, b) else {
            continue;
        };
        while !nav.over() {
            nav.step(act(&nav.observation()));
        }
        if nav.reached() {
            successes += 1;
            ratios.push(nav.cost / nav.optimal_cost.max(f64::MIN_POSITIVE));
        }
    }
    Evaluation {
        success_rate: successes as f64 / pairs.len().max(1) as f64,
        cost_ratio: if ratios.is_empty() {
            f64::NAN
        } else {
            ratios.iter().sum::<f64>() / ratios.len() as f64
        },
    }
}

/// One episode on one map.
pub struct GridNav<'a> {
    costs: &'a Grid<f32>,
    lengths: StepLengths,
    field: CostField,
    pub goal: Cell,
    pub position: Cell,
    pub steps: usize,
    pub cost: f64,
    /// The teacher's cost from the start: the optimum.
    pub optimal_cost: f64,
    pub max_steps: usize,
}

impl<'a> GridNav<'a> {
    /// An episode from `start` to `goal`, or `None` when the goal is unreachable.
    pub fn new(costs: &'a Grid<f32>, start: Cell, goal: Cell) -> Option<Self> {
        let field = cost_to_go(costs, &[goal], Moves::default());
        let optimal_cost = field.cost_at(start);
        let teacher_steps = field.path_to(start)?.len().saturating_sub(1);
        optimal_cost.is_finite().then_some(GridNav {
            costs,
            lengths: StepLengths::of(&costs.geo),
            field,
            goal,
            position: start,
            steps: 0,
            cost: 0.0,
            optimal_cost,
            max_steps: 3 * teacher_steps.max(1),
        })
    }

    pub fn reached(&self) -> bool {
        self.position == self.goal
    }

    pub fn over(&self) -> bool {
        self.reached() || self.steps >= self.max_steps
    }

    fn neighbour(&self, m: usize) -> Option<Cell> {
        let (dr, dc) = MOVES[m];
        let (r, c) = (
            self.position.row as i64 + dr as i64,
            self.position.col as i64 + dc as i64,
        );
        let cell = Cell::new(r as u32, c as u32);
        (r >= 0 && c >= 0 && self.costs.geo.contains(cell) && self.costs.get(cell).is_finite())
            .then_some(cell)
    }

    pub fn observation(&self) -> Vec<f64> {
        let (dr, dc) = (
            f64::from(self.goal.row) - f64::from(self.position.row),
            f64::from(self.goal.col) - f64::from(self.position.col),
        );
        let distance = (dr * dr + dc * dc).sqrt();
        let unit = distance.max(1e-9);
        let here = f64::from(self.costs.get(self.position)).ln();
        let mut x = vec![dr / unit, dc / unit, (distance + 1.0).ln()];
        for m in 0..8 {
            x.push(
                self.neighbour(m)
                    .map_or(10.0, |cell| f64::from(self.costs.get(cell)).ln() - here),
            );
        }
        x
    }

    /// The move that starts a cheapest path to the goal (the first in `MOVES` order on
    /// ties).
    pub fn teacher(&self) -> usize {
        let mut best = (f64::INFINITY, 0);
        for m in 0..8 {
            if let Some(cell) = self.neighbour(m) {
                let total = edge_cost(
                    self.costs.get(self.position),
                    self.costs.get(cell),
                    self.lengths.between(self.position, cell),
                ) + self.field.cost_at(cell);
                if total < best.0 {
                    best = (total, m);
                }
            }
        }
        best.1
    }

    /// Takes move `m` (a move off the map or into a blocked cell stays put); true when
    /// the episode just failed (ran out of steps).
    pub fn step(&mut self, m: usize) -> bool {
        if let Some(cell) = self.neighbour(m % 8) {
            self.cost += edge_cost(
                self.costs.get(self.position),
                self.costs.get(cell),
                self.lengths.between(self.position, cell),
            );
            self.position = cell;
        }
        self.steps += 1;
        self.steps >= self.max_steps && !self.reached()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GeoRef;

    #[test]
    fn the_teacher_walks_a_cheapest_path() {
        let mut data = vec![1.0f32; 100];
        for row in 0..8 {
            data[row * 10 + 5] = 50.0; // a costly wall with a gap at the bottom rows
        }
        let costs = Grid::from_vec(GeoRef::unit(10, 10), data);
        let mut nav = GridNav::new(&costs, Cell::new(2, 1), Cell::new(2, 8)).unwrap();
        while !nav.over() {
            let m = nav.teacher();
            nav.step(m);
        }
        assert!(nav.reached());
        assert!(
            (nav.cost - nav.optimal_cost).abs() < 1e-9,
            "{} {}",
            nav.cost,
            nav.optimal_cost
        );
        assert_eq!(nav.observation().len(), OBSERVATION_DIMS);
    }
}
