//! Inverse optimal control: learning cost functions under which demonstrations are optimal.

mod learch;
mod metrics;
mod model;
pub mod objectworld;
mod soft_math;
pub mod soft_paths;
pub mod tabular;

pub use learch::{
    AUTO_CORRIDOR_BELOW, AUTO_CORRIDOR_CELLS, Corridor, CorridorChoice, Example, ExampleStatistics,
    FittedRound, GridMethod, LearchConfig, LossKind, MAXENT_HORIZON_FACTOR, MEMBERS,
    OFF_TRACK_PREMIUM, PreparedExamples, Progress, RemoteRounds, RoundMetrics, StepSchedule,
    TREE_BINS, TREE_LEAF_L2, TrainedLearch, TrainedMember, WeakLearnerKind, choose_corridor,
    default_rounds_and_step, evaluate as learch_evaluate, fit_round, hold_out_every, train,
    train_with, waypoints_of,
};
pub use metrics::{AGREEMENT_RADIUS, Agreement, ExampleEvaluation, evaluate_example, summarize};
pub use model::{CostLink, LogCostModel, TreeSums, WeakLearner};
