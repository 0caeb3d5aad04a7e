//! Planners on in-memory costmaps and tabular MDPs. They never touch files.
//!
//! Grid planning uses per-cell costs: the cost of a step between neighbouring cells is
//! the step length (1 or √2 cells) times the mean of the two cells' costs, the usual
//! discretisation of a line integral of cost. Cells whose cost is not a finite positive
//! number are blocked.

mod grid;
mod mdp;
pub(crate) mod queue;
mod relax;
mod steps;

pub use grid::{
    Connectivity, CostField, GridPlanner, Moves, Route, astar, augmented_cost, cost_to_go,
    dijkstra, edge_cost, loss_augmented, path_cost, shortest_path, visitation,
};
pub use mdp::{Backup, TabularMdp, Values, value_iteration, value_iteration_from};
pub use relax::RowSteps;
pub use steps::{StepLengths, unit_step_metres};

use serde::Serialize;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
/// Which exact search answers a query: A* with the octile heuristic, or Dijkstra
/// stopping at the goal.
pub enum SearchKind {
    Astar,
    Dijkstra,
}
