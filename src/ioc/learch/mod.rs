//! LEARCH (learning to search), as in the seed's listing: boosting in the space of
//! log-cost functions, with the planner in the loop.
//!
//! Each round t, for every example i: plan on the loss-augmented costmap
//! exp(s_t(F_i)) − l_i, compare the planned visitation μ* with the demonstration's μ
//! (the length of each path's steps through a cell, half a step to each end), and emit
//! (f(s), sign(μ*−μ), |μ*−μ|) at the cells where they disagree. A weak learner
//! h_t (ridge regression or a regression tree) fitted to all examples' points gives
//! s_{t+1} = s_t + α_t h_t. With validation examples and a patience, training stops when
//! their agreement has not improved for that many rounds and keeps the best round; the
//! held-out examples are only ever measured.
//!
//! The same trainer (rounds, schedules, validation and early stopping, checkpoints)
//! also runs the two classic alternatives on grids, chosen by `GridMethod`:
//! - MMP (Ratliff, Bagnell & Zinkevich 2006): a linear cost 1 + w·f, loss-augmented
//!   planning, and the regularised subgradient w ← w − α(λw + Φ(demo) − Φ(plan)), Φ the
//!   path's feature counts weighted as the planner weighs cells (half a step's length to
//!   each end of every step);
//! - MaxEnt IOC (Ziebart et al. 2008): the soft backward pass and the expected
//!   visitation forward (`soft_paths`, within a horizon), and the gradient of the
//!   demonstrations' log-likelihood: per cell, expected minus demonstrated visits times
//!   the cost, which trees fit as LEARCH's do (a nonlinear log-cost, the default, as in
//!   deep MaxEnt IRL with trees for the network), or summed into feature counts for a
//!   log-linear cost (ridge).
//!
//! MMP's and linear MaxEnt's rounds are linear updates, kept as ridge-kind learners, so
//! the artifact, checkpoints and resuming are LEARCH's.
//!
//! Examples are planned in parallel; each returns its own sufficient statistics, and
//! they are merged in example order, so the result does not depend on the thread count.
//!
//! A round is a map step (`map_step`: every example planned and compared with its
//! demonstration, on this machine or on workers holding shards of the examples) and a
//! reduce step (`reduce_step`: the statistics merged and the next weak learner
//! fitted); this module runs the rounds, the members and the calibration around them.

mod corridor;
mod map_step;
mod reduce_step;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

pub use corridor::{
    AUTO_CORRIDOR_BELOW, AUTO_CORRIDOR_CELLS, Corridor, CorridorChoice, OFF_TRACK_PREMIUM,
    choose_corridor, waypoints_of,
};
pub use map_step::{ExampleStatistics, PreparedExamples};
use reduce_step::members_to_train;
pub use reduce_step::{FittedRound, fit_round};

use super::metrics::{Agreement, evaluate_example, summarize};
use super::model::{CostLink, LogCostModel, TreeSums, WeakLearner};
use crate::error::first_error_in_order;
use crate::features::scale_in_cells;
use crate::grid::{CellPath, FeatureStack, Grid};
use crate::learn::TreeConfig;

/// The most MaxEnt's log-cost may change on any cell in one round.
const MAXENT_LOG_COST_STEP: f64 = 10.0;

/// MaxEnt's paths may take up to this many times each demonstration's steps. The
/// passes' work grows with the square of the slack: 1.15 trained 1.2 to 1.4 times
/// faster than 1.25 and planned held-out paths closer to the teacher on every teacher
/// of `bench terrain` (six rasters: a mean ratio of 1.047 against 1.056, 21 of 48
/// pairs ≤ 1.03 against 17), as 1.25 had against 1.5 (BENCHMARKS.md, "MaxEnt's
/// horizon").
pub const MAXENT_HORIZON_FACTOR: f64 = 1.15;

/// MaxEnt with trees leaves out cells whose gradient (expected minus demonstrated
/// incidence, times the cost) is below this: they would only slow the trees.
const MAXENT_TREE_MIN_WEIGHT: f64 = 1e-3;

/// Split candidates of LEARCH's regression trees per feature. A threshold teacher's
/// step falls between two candidates, and the cells between are mis-costed: 32 (the
/// trees' default) cost held-out plans 2–15 % on real terrain (`bench terrain`), 256
/// brings the split within half a percentile. Distances are split between any two of
/// their values instead ([`split_candidates`]): a margin of 3 cells is the step between
/// two of hundreds of distances, which 256 candidates skip (`bench terrain`'s `margin`
/// teacher on MODIS learned its ring 2.9 cells wide).
pub const TREE_BINS: usize = 256;

/// L2 penalty on the leaves of LEARCH's trees (`TreeConfig::leaf_l2`, in straight
/// steps through the leaf's cells): a leaf backed by a handful of cells moves the cost
/// a little, not by a full step. With the trees' shorter steps it took the mean
/// held-out cost ratio of `bench terrain` over three seeds from 1.0175 to 1.0164. A
/// stronger penalty (50) gained a little more on moderate teachers but lost on the
/// `obstacle` teacher: the few cells where training plans cross an obstacle are
/// exactly the small leaves it damps.
pub const TREE_LEAF_L2: f64 = 5.0;

/// Rounds and first step size by default: LEARCH with trees takes steps of 0.5 for 80
/// rounds (shrinkage, as gradient-boosted trees do: over three seeds of
/// `bench terrain` the pairs whose held-out cost ratio is ≤ 1.03 went from 54 to 65
/// of 72 against steps of 1 for 40 rounds); with ridge and trees in turn, 160 of 0.5,
/// so that the trees get their 80 (over two seeds of the eight rasters' five
/// teachers, 69 pairs ≤ 1.03 against 66 with 80 rounds); ridge, MMP and MaxEnt (with
/// trees too: on SPOT's four teachers 80 rounds moved the held-out cost ratio by
/// under 0.01 at twice the time, steps of 2 made it worse) take steps of 1 for 40.
pub fn default_rounds_and_step(method: GridMethod, learner: WeakLearnerKind) -> (usize, f64) {
    match (method, learner) {
        (GridMethod::Learch, WeakLearnerKind::Tree) => (80, 0.5),
        (GridMethod::Learch, WeakLearnerKind::Alternate) => (160, 0.5),
        _ => (40, 1.0),
    }
}

/// Augmented costs never drop below this, so every cell stays passable.
const LOSS_FLOOR: f32 = 1e-6;

/// MMP keeps every cell's linear cost 1 + w·f at least this high by shortening steps
/// that would go below it (a projection along the step onto the positive costs): the
/// subgradient otherwise pushes the cost of whole regions to the floor, where every
/// path costs the same and nothing is learned.
pub const MMP_COST_MARGIN: f64 = 0.05;

/// Exponents γ on LEARCH's learned cost (c^γ: every learner's step times γ) among which
/// training ends by keeping the one whose plans come closest to the training paths
/// (the first of equals). Decaying steps stop short of the teacher's contrast: on the
/// aerial image of `bench terrain` the learned cost of cells without data was 2.2
/// times that of the cheapest cells where the teacher's is 12, and on SPOT 5.5 where
/// it is 7. The plans' geometry depends on that contrast and the training paths show
/// which one they follow. Over three seeds of `bench terrain` on six rasters it took
/// the mean held-out cost ratio from 1.0226 to 1.0199 and the pairs ≤ 1.03 from 53 to
/// 57 of 72; γ stays 1 on most pairs, and larger ones were chosen where they helped.
pub const CONTRASTS: [f64; 4] = [1.0, 1.25, 1.5, 2.0];

/// LEARCH's trees widen the features they may split on in stages: from round
/// `share × rounds` on, those of scale up to `cells` ([`scale_in_cells`]). A stray
/// plan is a corridor of cells that the per-cell targets all blame, and a regional
/// feature (a wide blur, a distance) separates a whole corridor in one split; given
/// every scale from the start, the trees fit the training paths' strays with regional
/// summaries that do not carry to other paths. Fitting the cells' own values first
/// and regional ones last took the held-out cost ratio on eight real rasters from
/// 1.0248 to 1.0220 over five seeds (BENCHMARKS.md, "Features widened in stages").
/// Before its stage opens a feature may still win a split whose gain, damped by the
/// stage's factor of the model's member (`MEMBERS`), beats the open features'
/// (distances wait, in the first member): a cost that truly is
/// regional, such as rough ground over a wide window, then gets more than the last
/// half of the rounds, whose steps are short. Over four seeds of the eight rasters'
/// eight teachers that took the pairs ≤ 1.03 from 201 to 209 of 256 and the texture
/// teacher's mean from 1.0364 to 1.0290 (BENCHMARKS.md, "Wider features before their
/// stage, at a tenth of their gain").
pub const SCALE_STAGES: [ScaleStage; 3] = [
    ScaleStage {
        from_share: 0.0,
        cells: 1.0,
    },
    ScaleStage {
        from_share: 0.25,
        cells: 4.0,
    },
    ScaleStage {
        from_share: 0.5,
        cells: f64::INFINITY,
    },
];

/// Features of scales up to `cells` (and above the stage before) are split on freely
/// from round `from_share × rounds`, and before it with their gains damped by the
/// member's factor for the stage (`MemberStages`).
#[derive(Debug, Clone, Copy)]
pub struct ScaleStage {
    pub from_share: f64,
    pub cells: f64,
}

/// The members of a LEARCH model with trees widened in stages (`LearchConfig::members`):
/// each is trained on its own, with the same rounds, and the costmap is the geometric
/// mean of their costs (one model: both members' learners, every step halved). The
/// stages trade the costs that truly are regional (rough ground over a wide window, a
/// shore) against the regional coincidences of the training paths; the first member
/// holds wide features back hard, the second lets them compete earlier, and their
/// mean errs less than the first alone. On fourteen real rasters with eight teachers
/// of `bench terrain`, two seeds, the pairs whose held-out cost ratio is ≤ 1.03 went from 177 to
/// 187 of 224 (the six rasters never tuned on: 73 to 77 of 96) at about twice the
/// training time (BENCHMARKS.md, "Two models averaged").
pub const MEMBERS: [MemberStages; 2] = [
    MemberStages {
        gain_before: [1.0, 0.3, 0.1],
        distances_before: 0.0,
    },
    MemberStages {
        gain_before: [1.0, 0.6, 0.3],
        distances_before: 0.3,
    },
];

/// How early one member's wider features compete: the factor on the split gains of
/// the features of each stage of `SCALE_STAGES` before the stage opens, and of
/// distances before theirs (0: they wait).
#[derive(Debug, Clone, Copy)]
pub struct MemberStages {
    pub gain_before: [f64; SCALE_STAGES.len()],
    pub distances_before: f64,
}

/// A demonstration on one of the maps.
#[derive(Debug, Clone)]
pub struct Example {
    pub id: String,
    /// Index into the maps / feature stacks the trainer is given.
    pub map: usize,
    pub path: CellPath,
    /// For a route given by sparse vertices (drawn by hand): the indices in `path` of
    /// its vertices' cells, the first and the last among them. Between two vertices
    /// the path is only their straight line, not what the demonstrator meant: each
    /// round re-plans it ([`corridor::waypoint_path`]). Empty for tracks.
    pub waypoints: Vec<usize>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum StepSchedule {
    /// α_t = step_size
    Constant,
    /// α_t = step_size / √(t + 1)
    InverseSqrt,
    /// α_t = step_size / (t + 1 + schedule_offset)
    InverseLinear,
}

/// Which inverse-optimal-control method learns the costmap.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum GridMethod {
    /// Functional-gradient boosting of the log-cost with a weak learner.
    Learch,
    /// Maximum-margin planning: linear cost, regularised subgradient.
    Mmp,
    /// Maximum-entropy IOC: soft paths, likelihood gradient (trees or log-linear).
    Maxent,
}

impl GridMethod {
    pub fn name(self) -> &'static str {
        match self {
            GridMethod::Learch => "learch",
            GridMethod::Mmp => "mmp",
            GridMethod::Maxent => "maxent",
        }
    }

    fn link(self) -> CostLink {
        match self {
            GridMethod::Mmp => CostLink::Linear,
            GridMethod::Learch | GridMethod::Maxent => CostLink::Exp,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum WeakLearnerKind {
    /// Ridge regression on the scaled features: a log-linear cost.
    Ridge,
    /// Depth-limited regression trees: a nonlinear cost.
    Tree,
    /// Ridge and trees in turn (ridge in rounds 1, 3, ...): a log-linear trend, and
    /// trees for the nonlinear rest.
    Alternate,
}

impl WeakLearnerKind {
    /// The learner fitted in round `t` (from 0).
    fn in_round(self, t: usize) -> WeakLearnerKind {
        match self {
            WeakLearnerKind::Alternate if t.is_multiple_of(2) => WeakLearnerKind::Ridge,
            WeakLearnerKind::Alternate => WeakLearnerKind::Tree,
            kind => kind,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum LossKind {
    /// Every cell off the demonstration.
    Hamming,
    /// 1 − exp(−d²/σ²) at distance d (cells) from the demonstration: near misses cost
    /// little.
    Dilated,
}

#[derive(Debug, Clone, PartialEq)]
pub struct LearchConfig {
    pub method: GridMethod,
    pub rounds: usize,
    pub step_size: f64,
    pub schedule: StepSchedule,
    /// Ridge penalty of the weak learner (on standardised features).
    pub ridge_lambda: f64,
    /// Hamming loss augmentation: while training, cells off the demonstration cost
    /// (1 − loss) times their learned cost, which asks the learned cost to prefer the
    /// demonstration by a margin. Relative to the cost so that it does not depend on
    /// the cost's overall scale; 0 turns augmentation off.
    pub loss: f64,
    pub loss_kind: LossKind,
    /// σ of the dilated loss, in cells.
    pub loss_sigma: f64,
    /// k of the inverse-linear schedule.
    pub schedule_offset: f64,
    pub weak_learner: WeakLearnerKind,
    pub tree: TreeConfig,
    /// Stop when validation agreement has not improved for this many rounds.
    pub patience: Option<usize>,
    /// MaxEnt: paths may take up to this many times the demonstration's steps.
    pub horizon_factor: f64,
    /// MaxEnt: cells around a demonstration's bounding box that its paths may use.
    pub window_margin: u32,
    /// LEARCH: end by choosing the exponent on the learned cost that plans the
    /// training paths best (`CONTRASTS`).
    pub calibrate_contrast: bool,
    /// LEARCH with trees: split on the cells' own values first and on wider
    /// neighbourhoods in later rounds (`SCALE_STAGES`).
    pub widen_in_stages: bool,
    /// LEARCH with trees widened in stages: how many of `MEMBERS` to train, in turn
    /// (1 or 2); the cost is the geometric mean of theirs.
    pub members: usize,
    /// LEARCH and MMP: each round compares the plan with the cheapest path under the
    /// current cost through the cells within this many cells of the demonstration,
    /// not with the demonstration itself: tracks that wander around the route meant
    /// (`corridor`); 0 takes demonstrations as they are.
    pub corridor: u32,
}

impl Default for LearchConfig {
    /// Ridge LEARCH's settings: 40 rounds, α 1/√t, Hamming loss 0.3 (trees take the
    /// steps of [`default_rounds_and_step`]).
    fn default() -> Self {
        LearchConfig {
            method: GridMethod::Learch,
            rounds: 40,
            step_size: 1.0,
            schedule: StepSchedule::InverseSqrt,
            ridge_lambda: 1e-3,
            loss: 0.3,
            loss_kind: LossKind::Hamming,
            loss_sigma: 2.0,
            schedule_offset: 1.0,
            weak_learner: WeakLearnerKind::Ridge,
            tree: TreeConfig {
                bins: TREE_BINS,
                leaf_l2: TREE_LEAF_L2,
                ..TreeConfig::default()
            },
            patience: None,
            horizon_factor: MAXENT_HORIZON_FACTOR,
            window_margin: 6,
            calibrate_contrast: true,
            widen_in_stages: true,
            members: MEMBERS.len(),
            corridor: 0,
        }
    }
}

impl LearchConfig {
    /// The members this configuration trains: several only where the stages make them
    /// differ (LEARCH with trees, widened in stages).
    pub fn member_count(&self) -> usize {
        let staged_trees = self.method == GridMethod::Learch
            && self.widen_in_stages
            && self.weak_learner != WeakLearnerKind::Ridge;
        if staged_trees {
            self.members.clamp(1, MEMBERS.len())
        } else {
            1
        }
    }

    fn step(&self, t: usize) -> f64 {
        let t = t as f64;
        match self.schedule {
            StepSchedule::Constant => self.step_size,
            StepSchedule::InverseSqrt => self.step_size / (t + 1.0).sqrt(),
            StepSchedule::InverseLinear => self.step_size / (t + 1.0 + self.schedule_offset),
        }
    }
}

/// What one round did.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RoundMetrics {
    /// The member of the model (`MEMBERS`) this round trained; absent for the first.
    #[serde(default, skip_serializing_if = "is_first_member")]
    pub member: usize,
    /// The member's round, from 1.
    pub round: usize,
    pub step: f64,
    /// Mean over training examples of (C(demo) − C(plan)) / C(demo) on the
    /// loss-augmented costmap before the update: 0 when every demonstration is optimal.
    pub training_loss: f64,
    /// Cells where planned and demonstrated visitation differ, over all examples.
    pub disagreeing_cells: usize,
    /// Agreement of plans on the updated costmap with the held-out demonstrations.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub holdout: Option<Agreement>,
    /// Agreement with the validation demonstrations, which early stopping watches.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub validation: Option<Agreement>,
    /// MMP: the subgradient step would have taken some cell's linear cost below
    /// `MMP_COST_MARGIN`, and was projected back onto the positive costs (absent when
    /// it was not).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub projected_to_margin: bool,
}

fn is_first_member(member: &usize) -> bool {
    *member == 0
}

/// Training so far: what a checkpoint holds and a resumed run starts from. Training is
/// deterministic given it, so a resumed run ends where an uninterrupted one would.
/// Every member's learners and rounds follow the earlier members'.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct Progress {
    pub learners: Vec<WeakLearner>,
    pub rounds: Vec<RoundMetrics>,
}

#[derive(Debug, Clone)]
pub struct TrainedLearch {
    pub model: LogCostModel,
    /// Every member's rounds, member after member.
    pub rounds: Vec<RoundMetrics>,
    pub members: Vec<TrainedMember>,
}

/// What training kept of one member of the model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrainedMember {
    /// Rounds run.
    pub rounds: usize,
    /// The round whose model was kept (the last, or the best on validation when early
    /// stopping is on).
    pub kept_round: usize,
    /// The exponent γ on the kept round's cost (`CONTRASTS`): the member's learners
    /// take γ times the steps their rounds record, divided by the number of members.
    /// 1 when not calibrated.
    pub contrast: f64,
}

/// Runs LEARCH. `stacks[i]` are the features of map `i` (named `map_names[i]`); the
/// optional `references` are costmaps to score plans against (e.g. a synthetic world's
/// true costs). `validation` examples steer early stopping; `holdout` ones are only
/// measured. Training continues from `resume` (an earlier run's progress) when given.
/// `on_round` sees the progress after each round, e.g. to write a checkpoint.
#[allow(clippy::too_many_arguments)]
pub fn train(
    stacks: &[FeatureStack],
    map_names: &[String],
    training: &[Example],
    validation: &[Example],
    holdout: &[Example],
    references: Option<&[Grid<f32>]>,
    config: &LearchConfig,
    resume: Option<Progress>,
    on_round: impl FnMut(&Progress),
) -> Result<TrainedLearch, String> {
    #[rustfmt::skip]
    let trained = train_with(
        stacks, map_names, training, validation, holdout, references, config, resume,
        on_round, None,
    );
    trained
}

/// The map step of a round done elsewhere: given the model and the corridor the round
/// takes demonstrations through (`LearchConfig::corridor`), the statistics of every
/// training example in order (e.g. gathered from workers that hold shards of them).
pub type RemoteRounds<'a> =
    dyn FnMut(&LogCostModel, u32) -> Result<Vec<ExampleStatistics>, String> + 'a;

/// `train`, with the map step of every round done by `remote` when given (the
/// training examples are then not planned here; the rest is as `train`).
#[allow(clippy::too_many_arguments)]
pub fn train_with(
    stacks: &[FeatureStack],
    map_names: &[String],
    training: &[Example],
    validation: &[Example],
    holdout: &[Example],
    references: Option<&[Grid<f32>]>,
    config: &LearchConfig,
    resume: Option<Progress>,
    mut on_round: impl FnMut(&Progress),
    mut remote: Option<&mut RemoteRounds<'_>>,
) -> Result<TrainedLearch, String> {
    if training.is_empty() {
        return Err("no training examples".into());
    }
    let names = stacks[0].names.clone();
    if let Some(k) = stacks.iter().position(|s| s.names != names) {
        let only = |a: &[String], b: &[String]| -> Vec<String> {
            a.iter().filter(|n| !b.contains(n)).cloned().collect()
        };
        let map = |i: usize| map_names.get(i).map_or("?", String::as_str);
        return Err(format!(
            "the feature stacks of maps '{}' and '{}' have different features (only in '{}': \
             {:?}; only in '{}': {:?}); make them with one feature spec",
            map(0),
            map(k),
            map(0),
            only(&names, &stacks[k].names),
            map(k),
            only(&stacks[k].names, &names)
        ));
    }
    if config.method == GridMethod::Mmp && config.weak_learner != WeakLearnerKind::Ridge {
        return Err("mmp learns a linear cost; its weak learner is ridge".into());
    }
    let zero = LogCostModel::zero_with(names, feature_scales(stacks), config.method.link());
    let resumed = resume.unwrap_or_default();
    let members = members_to_train(config, &zero.feature_names, stacks);
    let resumed_members = resumed_members(&resumed, members, config.rounds)?;
    let prepared = remote
        .is_none()
        .then(|| PreparedExamples::new(stacks, training.to_vec(), config));
    let mut progress = resumed;
    let mut kept_models = Vec::with_capacity(members);
    let mut trained_members = Vec::with_capacity(members);
    for (member, done) in resumed_members.into_iter().enumerate() {
        let mut member_run = MemberRun {
            member,
            model: zero.clone(),
            progress: &mut progress,
            on_round: &mut on_round,
            remote: remote.as_deref_mut(),
            prepared: prepared.as_ref(),
            stacks,
            map_names,
            training,
            validation,
            holdout,
            references,
            config,
        };
        let (kept, trained) = member_run.train(done)?;
        kept_models.push(kept);
        trained_members.push(trained);
    }
    Ok(TrainedLearch {
        model: LogCostModel::geometric_mean(&kept_models),
        rounds: progress.rounds,
        members: trained_members,
    })
}

/// One member's share of a checkpoint.
#[derive(Default)]
struct ResumedMember {
    learners: Vec<WeakLearner>,
    rounds: Vec<RoundMetrics>,
    /// A later member has begun: this one is finished, even where early stopping ended
    /// it before its last round.
    finished: bool,
}

/// Each member's share of a checkpoint.
fn resumed_members(
    resumed: &Progress,
    members: usize,
    rounds: usize,
) -> Result<Vec<ResumedMember>, String> {
    let mismatch = |what: String| {
        format!("the checkpoint {what}; this run trains {members} member(s) of {rounds} rounds")
    };
    if resumed.learners.len() != resumed.rounds.len() {
        return Err(mismatch(format!(
            "holds {} learners and {} rounds",
            resumed.learners.len(),
            resumed.rounds.len()
        )));
    }
    if resumed.rounds.windows(2).any(|w| w[1].member < w[0].member) {
        return Err(mismatch("holds members out of order".into()));
    }
    let last_member = resumed.rounds.last().map_or(0, |r| r.member);
    if last_member >= members {
        return Err(mismatch(format!(
            "holds rounds of member {}",
            last_member + 1
        )));
    }
    let mut per_member: Vec<ResumedMember> = (0..members)
        .map(|m| ResumedMember {
            finished: m < last_member,
            ..ResumedMember::default()
        })
        .collect();
    for (learner, round) in resumed.learners.iter().zip(&resumed.rounds) {
        let member = &mut per_member[round.member];
        member.learners.push(learner.clone());
        member.rounds.push(round.clone());
    }
    if let Some(over) = per_member.iter().find(|m| m.rounds.len() > rounds) {
        return Err(mismatch(format!(
            "holds {} rounds of a member",
            over.rounds.len()
        )));
    }
    Ok(per_member)
}

/// One member's training, adding its rounds to the progress of the whole model, and
/// what `train_with` was given.
struct MemberRun<'a, 'r, F: FnMut(&Progress)> {
    member: usize,
    model: LogCostModel,
    progress: &'a mut Progress,
    on_round: &'a mut F,
    remote: Option<&'a mut RemoteRounds<'r>>,
    prepared: Option<&'a PreparedExamples>,
    stacks: &'a [FeatureStack],
    map_names: &'a [String],
    training: &'a [Example],
    validation: &'a [Example],
    holdout: &'a [Example],
    references: Option<&'a [Grid<f32>]>,
    config: &'a LearchConfig,
}

impl<F: FnMut(&Progress)> MemberRun<'_, '_, F> {
    /// Runs the member's rounds after those `done` and returns its kept model,
    /// calibrated.
    fn train(&mut self, done: ResumedMember) -> Result<(LogCostModel, TrainedMember), String> {
        let (stacks, map_names, training, config) =
            (self.stacks, self.map_names, self.training, self.config);
        let (validation, holdout, references) = (self.validation, self.holdout, self.references);
        let ResumedMember {
            learners,
            mut rounds,
            finished,
        } = done;
        for learner in learners {
            self.model.push(learner);
        }
        // The trees' part of each map's costmap, from round to round.
        let mut tree_sums = vec![TreeSums::default(); stacks.len()];
        let mut best: Option<(f64, usize)> = None;
        let improves =
            |best: Option<(f64, usize)>, agreement: f64| best.is_none_or(|(b, _)| agreement > b);
        for (t, metrics) in rounds.iter().enumerate() {
            if let Some(v) = &metrics.validation
                && improves(best, v.within_radius)
            {
                best = Some((v.within_radius, t + 1));
            }
        }
        // Early stopping: the best round is `patience` rounds behind.
        let patience_spent = |best: Option<(f64, usize)>, t: usize| match (config.patience, best) {
            (Some(patience), Some((_, round))) => t - round >= patience,
            _ => false,
        };
        for t in rounds.len()..config.rounds {
            if finished || patience_spent(best, t) {
                break;
            }
            let statistics = match (&mut self.remote, self.prepared) {
                (Some(remote), _) => remote(&self.model, config.corridor)?,
                (None, Some(prepared)) => {
                    prepared.plan_growing(&self.model, stacks, config, &mut tree_sums)?
                }
                (None, None) => unreachable!("examples are prepared when planned here"),
            };
            if statistics.len() != training.len() {
                return Err(format!(
                    "round {}: {} examples' statistics came back for {} training examples",
                    t + 1,
                    statistics.len(),
                    training.len()
                ));
            }
            let round = fit_round(&self.model, stacks, &statistics, config, t, self.member)?;
            let (step, projected_to_margin) = (round.step, round.projected_to_margin);
            self.progress.learners.push(round.learner.clone());
            self.model.push(round.learner);
            let model = &self.model;
            let costmaps: Vec<Grid<f32>> = match holdout.is_empty() && validation.is_empty() {
                true => Vec::new(),
                false => (stacks.iter().zip(&mut tree_sums))
                    .map(|(s, sums)| model.costmap_growing(s, sums))
                    .collect(),
            };
            let agreement_on = |examples: &[Example]| {
                (!examples.is_empty())
                    .then(|| evaluate_on(&costmaps, map_names, examples, references))
                    .transpose()
                    .map(|e| e.map(|evaluations| summarize(&evaluations)))
            };
            let metrics = RoundMetrics {
                member: self.member,
                round: t + 1,
                step,
                training_loss: round.training_loss,
                disagreeing_cells: round.disagreeing_cells,
                holdout: agreement_on(holdout)?,
                validation: agreement_on(validation)?,
                projected_to_margin,
            };
            tracing::debug!(
                member = self.member,
                round = t + 1,
                weights = ?model.raw_weights,
                "learch model"
            );
            if let Some(v) = &metrics.validation
                && improves(best, v.within_radius)
            {
                best = Some((v.within_radius, t + 1));
            }
            rounds.push(metrics.clone());
            self.progress.rounds.push(metrics);
            (self.on_round)(self.progress);
        }
        let kept_round = match config.patience {
            Some(_) => best.map_or(rounds.len(), |(_, round)| round),
            None => rounds.len(),
        };
        let kept = self.model.truncated(kept_round);
        let (model, contrast) = if config.calibrate_contrast && config.method == GridMethod::Learch
        {
            calibrated_contrast(kept, stacks, map_names, training)?
        } else {
            (kept, 1.0)
        };
        let trained = TrainedMember {
            rounds: rounds.len(),
            kept_round,
            contrast,
        };
        Ok((model, trained))
    }
}

/// `model` with the exponent of `CONTRASTS` under which the plans between the ends
/// of the training paths keep the largest share of their cells within
/// `AGREEMENT_RADIUS` of the paths, and that exponent.
fn calibrated_contrast(
    model: LogCostModel,
    stacks: &[FeatureStack],
    map_names: &[String],
    training: &[Example],
) -> Result<(LogCostModel, f64), String> {
    let mut best: Option<(f64, f64, LogCostModel)> = None;
    for gamma in CONTRASTS {
        let candidate = model.with_contrast(gamma);
        let agreement = summarize(&evaluate(&candidate, stacks, map_names, training, None)?);
        if best
            .as_ref()
            .is_none_or(|(within, _, _)| agreement.within_radius > *within)
        {
            best = Some((agreement.within_radius, gamma, candidate));
        }
    }
    let (_, gamma, model) = best.expect("CONTRASTS is not empty");
    Ok((model, gamma))
}

/// Splits examples into (training, held out), holding out every `k`-th from the first:
/// a split without randomness, for tests and benchmarks.
pub fn hold_out_every(examples: Vec<Example>, k: usize) -> (Vec<Example>, Vec<Example>) {
    let (mut training, mut holdout) = (Vec::new(), Vec::new());
    for (i, example) in examples.into_iter().enumerate() {
        if i % k.max(1) == 0 {
            holdout.push(example)
        } else {
            training.push(example)
        }
    }
    (training, holdout)
}

/// Plans every example on the model's costmap and compares with its demonstration.
pub fn evaluate(
    model: &LogCostModel,
    stacks: &[FeatureStack],
    map_names: &[String],
    examples: &[Example],
    references: Option<&[Grid<f32>]>,
) -> Result<Vec<super::ExampleEvaluation>, String> {
    let costmaps: Vec<Grid<f32>> = stacks.iter().map(|s| model.costmap(s)).collect();
    evaluate_on(&costmaps, map_names, examples, references)
}

/// [`evaluate`] on the model's `costmaps`, one per map.
fn evaluate_on(
    costmaps: &[Grid<f32>],
    map_names: &[String],
    examples: &[Example],
    references: Option<&[Grid<f32>]>,
) -> Result<Vec<super::ExampleEvaluation>, String> {
    let evaluations = examples
        .par_iter()
        .map(|ex| {
            evaluate_example(
                &ex.id,
                &map_names[ex.map],
                &costmaps[ex.map],
                &ex.path,
                references.map(|r| &r[ex.map]),
            )
            .ok_or_else(|| unreachable(ex))
        })
        .collect::<Vec<_>>();
    first_error_in_order(evaluations)
}

fn unreachable(ex: &Example) -> String {
    format!(
        "example '{}': no path from {} to {} on the learned costmap",
        ex.id,
        ex.path[0],
        ex.path[ex.path.len() - 1]
    )
}

/// Per-feature standard deviation over all cells of all maps, so that the ridge
/// penalty treats features in metres and in [0, 1] alike; a constant feature is
/// scaled by its size (at least 1: the bias keeps scale 1), so that its scaled value is
/// at most 1, as the bias's is (a distance capped everywhere is a constant of thousands
/// of metres, which MMP's linear steps would otherwise weigh a thousandfold).
fn feature_scales(stacks: &[FeatureStack]) -> Vec<f64> {
    // Two passes (mean, then squared deviations): a constant feature then has a spread
    // of exactly 0, where E[x²] − E[x]² leaves rounding noise that would pass for a
    // tiny scale and blow the feature up (a distance capped everywhere, an indicator
    // that never fires).
    let dim = stacks[0].dim();
    let count: usize = stacks.iter().map(|s| s.geo.cell_count()).sum();
    let n = count.max(1) as f64;
    (0..dim)
        .map(|j| {
            let mean = stacks
                .iter()
                .map(|s| s.plane(j).iter().map(|&v| f64::from(v)).sum::<f64>())
                .sum::<f64>()
                / n;
            let variance = stacks
                .iter()
                .map(|s| {
                    s.plane(j)
                        .iter()
                        .map(|&v| (f64::from(v) - mean).powi(2))
                        .sum::<f64>()
                })
                .sum::<f64>()
                / n;
            let sd = variance.sqrt();
            if sd > 1e-6 * mean.abs().max(1.0) {
                sd
            } else {
                mean.abs().max(1.0)
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::map_step::{CompactShares, loss_shares};
    use super::*;
    use crate::features::{FeatureSpec, compute};
    use crate::grid::Cell;
    use crate::grid::rasterize;
    use crate::plan::{Moves, dijkstra};
    use crate::sim::{WorldConfig, generate_world};

    /// A small synthetic world: (stacks, map names, examples, true costs).
    fn small_world() -> (Vec<FeatureStack>, Vec<String>, Vec<Example>, Vec<Grid<f32>>) {
        small_world_with(Vec::new())
    }

    /// The small world with features made by `ops` besides the layers.
    fn small_world_with(
        ops: Vec<crate::features::Op>,
    ) -> (Vec<FeatureStack>, Vec<String>, Vec<Example>, Vec<Grid<f32>>) {
        let config = WorldConfig {
            seed: 11,
            maps: 4,
            width: 48,
            height: 48,
            demonstrations_per_map: 12,
            ..WorldConfig::default()
        };
        let world = generate_world(&config).unwrap();
        let spec = FeatureSpec {
            layers: Some(world.maps[0].layer_names()),
            ops,
            bias: true,
            nodata_fill: 0.0,
            bank: None,
        };
        let stacks: Vec<FeatureStack> = world
            .maps
            .iter()
            .map(|m| compute(m, &spec).unwrap())
            .collect();
        let names: Vec<String> = world.maps.iter().map(|m| m.name.clone()).collect();
        let examples = world
            .demonstrations
            .iter()
            .map(|d| {
                let map = names.iter().position(|n| *n == d.map).unwrap();
                let path = rasterize(&world.maps[map].geo, &d.xy()).unwrap();
                Example {
                    id: d.episode.clone(),
                    map,
                    path,
                    waypoints: Vec::new(),
                }
            })
            .collect();
        (stacks, names, examples, world.truth)
    }

    /// One member: the core loop (the members have their own test).
    fn config() -> LearchConfig {
        LearchConfig {
            members: 1,
            ..LearchConfig::default()
        }
    }

    /// (stacks, map names, training, held out, true costs).
    type HeldOutWorld = (
        Vec<FeatureStack>,
        Vec<String>,
        Vec<Example>,
        Vec<Example>,
        Vec<Grid<f32>>,
    );

    /// The small world with every fourth demonstration held out.
    fn held_out_world() -> HeldOutWorld {
        let (stacks, names, examples, truth) = small_world();
        let (training, holdout) = hold_out_every(examples, 4);
        (stacks, names, training, holdout, truth)
    }

    #[test]
    fn learns_costs_whose_plans_match_held_out_demonstrations() {
        let (stacks, names, training, holdout, truth) = held_out_world();
        let trained = train(
            &stacks,
            &names,
            &training,
            &[],
            &holdout,
            Some(&truth),
            &config(),
            None,
            |_| {},
        )
        .unwrap();
        let first = trained.rounds.first().unwrap();
        let last = trained.rounds.last().unwrap();
        assert!(
            last.training_loss < first.training_loss,
            "{first:?} -> {last:?}"
        );
        let agreement = last.holdout.clone().unwrap();
        assert_eq!(agreement.examples, holdout.len());
        assert!(agreement.within_radius >= 0.9, "{agreement:?}");
        assert!(
            agreement.mean_reference_cost_ratio.unwrap() <= 1.05,
            "{agreement:?}"
        );
        // Water is costly and roads are cheap in the true cost; the learned one agrees.
        let weight = |name: &str| {
            let j = trained
                .model
                .feature_names
                .iter()
                .position(|n| n == name)
                .unwrap();
            trained.model.raw_weights[j]
        };
        assert!(weight("water") > 0.0 && weight("road") < 0.0 && weight("vegetation") > 0.0);
    }

    #[test]
    fn tree_learners_learn_and_early_stopping_keeps_the_best_round() {
        let (stacks, names, mut training, holdout, truth) = held_out_world();
        let config = LearchConfig {
            weak_learner: WeakLearnerKind::Tree,
            loss_kind: LossKind::Dilated,
            patience: Some(4),
            rounds: 30,
            // The kept model is then the kept round's, as measured.
            calibrate_contrast: false,
            ..config()
        };
        // Validation steers the stopping; the held-out examples stay unseen.
        let validation = training.split_off(training.len() * 3 / 4);
        let trained = train(
            &stacks,
            &names,
            &training,
            &validation,
            &holdout,
            Some(&truth),
            &config,
            None,
            |_| {},
        )
        .unwrap();
        assert!(trained.model.learners.iter().all(|l| l.tree.is_some()));
        assert_eq!(trained.model.learners.len(), trained.members[0].kept_round);
        let best = trained
            .rounds
            .iter()
            .map(|r| r.validation.as_ref().unwrap().within_radius)
            .fold(0.0, f64::max);
        let kept = &trained.rounds[trained.members[0].kept_round - 1];
        assert_eq!(kept.validation.as_ref().unwrap().within_radius, best);
        assert!(best >= 0.9, "{best}");
        // The kept model evaluates to what was measured at that round.
        let again = evaluate(&trained.model, &stacks, &names, &holdout, Some(&truth)).unwrap();
        assert_eq!(
            summarize(&again).within_radius,
            kept.holdout.as_ref().unwrap().within_radius
        );
    }

    /// Trains on all `examples`, with nothing held out or validated.
    fn train_without_evaluation(
        stacks: &[FeatureStack],
        names: &[String],
        examples: &[Example],
        config: &LearchConfig,
    ) -> Result<TrainedLearch, String> {
        train(
            stacks,
            names,
            examples,
            &[],
            &[],
            None,
            config,
            None,
            |_| {},
        )
    }

    /// Trains `method` on three quarters of the small world and measures the rest.
    fn learn_with(method: GridMethod, rounds: usize) -> TrainedLearch {
        let config = LearchConfig {
            method,
            rounds,
            ..config()
        };
        train_measured(&held_out_world(), &config)
    }

    /// Trains on a world's training examples, measuring its held-out ones against its
    /// true costs every round.
    fn train_measured(world: &HeldOutWorld, config: &LearchConfig) -> TrainedLearch {
        let (stacks, names, training, holdout, truth) = world;
        train(
            stacks,
            names,
            training,
            &[],
            holdout,
            Some(truth),
            config,
            None,
            |_| {},
        )
        .unwrap()
    }

    #[test]
    fn calibration_restores_a_flattened_contrast_and_keeps_a_uniform_cost() {
        let (stacks, names, training, _, _) = held_out_world();
        let config = LearchConfig {
            calibrate_contrast: false,
            ..config()
        };
        let trained = train_without_evaluation(&stacks, &names, &training, &config).unwrap();
        assert_eq!(trained.members[0].contrast, 1.0);
        let within = |model: &LogCostModel| {
            summarize(&evaluate(model, &stacks, &names, &training, None).unwrap()).within_radius
        };
        // The learned cost's square root plans the training paths worse; calibration
        // takes it back up and plans them at least as well as the square root does.
        let flat = trained.model.with_contrast(0.5);
        assert!(within(&flat) < within(&trained.model));
        let (calibrated, gamma) =
            calibrated_contrast(flat.clone(), &stacks, &names, &training).unwrap();
        assert!(gamma > 1.0, "{gamma}");
        assert!(within(&calibrated) > within(&flat));
        assert_eq!(calibrated, flat.with_contrast(gamma));
        // A uniform cost plans alike at every exponent: the first, 1, stays.
        let uniform = trained.model.truncated(0);
        let (kept, gamma) =
            calibrated_contrast(uniform.clone(), &stacks, &names, &training).unwrap();
        assert_eq!((gamma, kept), (1.0, uniform));
    }

    #[test]
    fn constant_features_are_scaled_to_their_size() {
        // A distance capped everywhere (its target is nowhere on the map) is a constant
        // in metres: scaled to 1, as the bias is, not left at 1234.567, where a linear
        // step on it would move every cell's cost a thousand times as far as on any
        // other feature.
        let mut stack = FeatureStack {
            geo: crate::grid::GeoRef::unit(3, 3),
            names: vec![
                "capped".into(),
                "varied".into(),
                "never".into(),
                "small".into(),
            ],
            data: vec![1234.567f32; 36],
        };
        for (i, v) in stack.data[9..18].iter_mut().enumerate() {
            *v = i as f32;
        }
        stack.data[18..27].fill(0.0);
        stack.data[27..].fill(-0.25);
        let scales = feature_scales(&[stack]);
        assert!((scales[0] - 1234.567).abs() < 1e-3, "{scales:?}");
        assert!((scales[1] - (60.0f64 / 9.0).sqrt()).abs() < 1e-12);
        assert_eq!(scales[2..], [1.0, 1.0]);
    }

    #[test]
    fn mmp_learns_a_linear_cost_that_plans_like_the_demonstrations() {
        assert_mmp_learns(&held_out_world());
    }

    #[test]
    fn mmp_learns_beside_a_constant_feature_of_thousands() {
        // A distance to ground the maps do not have is capped everywhere: a constant
        // (the map's diagonal, in metres; squared, thousands) that must not swamp MMP's
        // linear steps.
        let distance = "water/distance_to_above_10_m";
        let (stacks, names, examples, truth) = small_world_with(vec![
            crate::features::Op::Distance {
                layer: "water".into(),
                class: None,
                above: Some(10.0),
                below: None,
                max: None,
                max_cells: None,
            },
            crate::features::Op::Product {
                a: distance.into(),
                b: distance.into(),
            },
        ]);
        let squared = stacks[0]
            .names
            .iter()
            .position(|n| n.contains('*'))
            .unwrap();
        let plane = stacks[0].plane(squared);
        assert!(plane[0] > 4000.0 && plane.iter().all(|&d| d == plane[0]));
        let (training, holdout) = hold_out_every(examples, 4);
        assert_mmp_learns(&(stacks, names, training, holdout, truth));
    }

    /// MMP on `world` plans its held-out demonstrations' cells, and no cell's cost sits
    /// at the floor.
    fn assert_mmp_learns(world: &HeldOutWorld) {
        let config = LearchConfig {
            method: GridMethod::Mmp,
            rounds: 20,
            ..config()
        };
        let trained = train_measured(world, &config);
        assert_eq!(trained.model.link, CostLink::Linear);
        let (first, last) = (&trained.rounds[0], trained.rounds.last().unwrap());
        assert!(
            last.training_loss < first.training_loss,
            "{first:?} -> {last:?}"
        );
        let agreement = last.holdout.clone().unwrap();
        assert!(agreement.within_radius >= 0.85, "{agreement:?}");
        assert!(trained.model.learners.iter().all(|l| l.tree.is_none()));
        // Projected onto the positive costs: no cell ever sits at the floor.
        for stack in &world.0 {
            let lowest = trained
                .model
                .costmap(stack)
                .data
                .into_iter()
                .fold(f32::INFINITY, f32::min);
            assert!(f64::from(lowest) >= 0.999 * MMP_COST_MARGIN, "{lowest}");
        }
    }

    #[test]
    fn maxent_raises_the_likelihood_and_plans_like_the_demonstrations() {
        let trained = learn_with(GridMethod::Maxent, 15);
        assert_eq!(trained.model.link, CostLink::Exp);
        // The loss is the negative log-likelihood per step: it must fall.
        let (first, last) = (&trained.rounds[0], trained.rounds.last().unwrap());
        assert!(
            last.training_loss < 0.5 * first.training_loss,
            "{first:?} -> {last:?}"
        );
        let agreement = last.holdout.clone().unwrap();
        assert!(agreement.within_radius >= 0.85, "{agreement:?}");
        assert!(
            agreement.mean_reference_cost_ratio.unwrap() <= 1.1,
            "{agreement:?}"
        );
    }

    #[test]
    fn weak_learners_other_than_ridge_are_refused_for_mmp() {
        let (stacks, names, examples, _) = small_world();
        let config = LearchConfig {
            method: GridMethod::Mmp,
            weak_learner: WeakLearnerKind::Tree,
            ..config()
        };
        let refused = train_without_evaluation(&stacks, &names, &examples, &config);
        assert!(refused.unwrap_err().contains("linear cost"));
    }

    /// One 40² map whose only feature is a smooth field f in [0, 1], a teacher whose
    /// cost is a bowl in f (cheap in the middle band, dear at both ends: no log-linear
    /// cost in f states it), and its optimal paths between opposite edges, every
    /// fourth held out: (stacks, names, training, held out, true costs).
    fn bowl_world() -> HeldOutWorld {
        let (w, h) = (40u32, 40u32);
        let geo = crate::grid::GeoRef::unit(w, h);
        let field: Vec<f32> = (0..w * h)
            .map(|i| {
                let (r, c) = (f64::from(i / w), f64::from(i % w));
                (0.5 + 0.25 * (r / 4.0).sin() + 0.25 * (c / 5.0 + r / 9.0).cos()) as f32
            })
            .collect();
        let truth: Vec<f32> = field
            .iter()
            .map(|&f| if (f - 0.5).abs() < 0.2 { 1.0 } else { 6.0 })
            .collect();
        let truth = Grid::from_vec(geo.clone(), truth);
        let mut data = field;
        data.extend(std::iter::repeat_n(1.0f32, (w * h) as usize));
        let stack = FeatureStack {
            geo,
            names: vec!["f".into(), "bias".into()],
            data,
        };
        let examples: Vec<Example> = (0..24u32)
            .map(|k| {
                let (a, b) = ((k * 7) % h, (k * 13 + 5) % h);
                let (start, goal) = if k % 2 == 0 {
                    (Cell { row: a, col: 0 }, Cell { row: b, col: w - 1 })
                } else {
                    (Cell { row: 0, col: a }, Cell { row: h - 1, col: b })
                };
                let route = dijkstra(&truth, start, goal, Moves::default()).unwrap();
                Example {
                    id: format!("teacher-{k}"),
                    map: 0,
                    path: route.cells,
                    waypoints: Vec::new(),
                }
            })
            .collect();
        let (training, holdout) = hold_out_every(examples, 4);
        (
            vec![stack],
            vec!["bowl".into()],
            training,
            holdout,
            vec![truth],
        )
    }

    #[test]
    fn maxent_with_trees_learns_a_cost_a_log_linear_one_cannot_state() {
        let world = bowl_world();
        let held_out_ratio = |weak_learner: WeakLearnerKind| {
            let (rounds, step_size) = default_rounds_and_step(GridMethod::Maxent, weak_learner);
            let config = LearchConfig {
                method: GridMethod::Maxent,
                weak_learner,
                rounds,
                step_size,
                ..config()
            };
            let trained = train_measured(&world, &config);
            let last = trained.rounds.last().unwrap().clone();
            assert!(
                last.training_loss < trained.rounds[0].training_loss,
                "{weak_learner:?}: the likelihood must rise"
            );
            let trees = trained.model.learners.iter().filter(|l| l.tree.is_some());
            assert_eq!(trees.count() > 0, weak_learner == WeakLearnerKind::Tree);
            last.holdout.unwrap().mean_reference_cost_ratio.unwrap()
        };
        let (trees, linear) = (
            held_out_ratio(WeakLearnerKind::Tree),
            held_out_ratio(WeakLearnerKind::Ridge),
        );
        assert!(trees <= 1.05, "trees: {trees}, linear: {linear}");
        assert!(trees < linear, "trees: {trees}, linear: {linear}");
    }

    #[test]
    fn the_dilated_loss_grows_with_distance_from_the_demonstration() {
        let (stacks, _, examples, _) = small_world();
        let ex = &examples[0];
        let stack = &stacks[ex.map];
        let shares = loss_shares(
            stack,
            ex,
            &LearchConfig {
                loss_kind: LossKind::Dilated,
                ..config()
            },
        );
        let geo = &stack.geo;
        for &cell in &ex.path {
            assert_eq!(shares[geo.index(cell)], 0.0);
        }
        let hamming = loss_shares(stack, ex, &config());
        let off = (0..geo.cell_count()).find(|&i| hamming[i] == 1.0).unwrap();
        assert!(shares[off] > 0.0 && shares[off] <= 1.0);
        assert!(shares.iter().all(|s| (0.0..=1.0).contains(s)));
        // Kept compact, they read back as they were, far cells (exactly 1) included.
        for dense in [&shares, &hamming] {
            let compact = CompactShares::new(dense, geo.width as usize);
            assert!(compact.values.len() < dense.len());
            assert_eq!(compact.iter().collect::<Vec<_>>(), *dense);
        }
    }

    #[test]
    fn the_model_does_not_depend_on_the_thread_count() {
        let (stacks, names, examples, _) = small_world();
        let config = LearchConfig {
            rounds: 5,
            ..config()
        };
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                train_without_evaluation(&stacks, &names, &examples, &config)
                    .unwrap()
                    .model
            })
        };
        assert_eq!(run(1), run(2));
        assert_eq!(run(2), run(3));
    }

    #[test]
    fn rounds_split_into_shards_give_the_trainers_model() {
        // The map step on uneven shards of the examples (as workers on other machines
        // would run it), statistics put back in example order, the reduce step on the
        // driver: the same learners, bit for bit, as the trainer, for each method.
        let (stacks, names, examples, _) = small_world();
        for (method, weak_learner) in [
            (GridMethod::Learch, WeakLearnerKind::Ridge),
            (GridMethod::Learch, WeakLearnerKind::Tree),
            (GridMethod::Mmp, WeakLearnerKind::Ridge),
        ] {
            let config = LearchConfig {
                method,
                weak_learner,
                rounds: 3,
                ..config()
            };
            let trained = train_without_evaluation(&stacks, &names, &examples, &config).unwrap();
            let shards: Vec<&[Example]> = vec![&examples[..5], &examples[5..6], &examples[6..]];
            let prepared: Vec<PreparedExamples> = (shards.iter())
                .map(|shard| PreparedExamples::new(&stacks, shard.to_vec(), &config))
                .collect();
            let mut model = LogCostModel::zero_with(
                stacks[0].names.clone(),
                feature_scales(&stacks),
                method.link(),
            );
            for t in 0..config.rounds {
                let statistics: Vec<ExampleStatistics> = (prepared.iter().rev())
                    .map(|p| p.plan(&model, &stacks, &config).unwrap())
                    .collect::<Vec<_>>()
                    .into_iter()
                    .rev()
                    .flatten()
                    .collect();
                let round = fit_round(&model, &stacks, &statistics, &config, t, 0).unwrap();
                model.push(round.learner);
            }
            // The trainer ends by choosing the contrast on the training paths.
            assert_eq!(
                model.with_contrast(trained.members[0].contrast),
                trained.model,
                "{method:?} with {weak_learner:?}"
            );
        }
    }

    #[test]
    fn two_members_average_their_costs_and_resume_across_them() {
        // A regional feature, which the stages hold back (by each member's factors, as
        // `trees_widen_the_features_they_split_on_in_stages` checks).
        let (stacks, names, examples, _) = small_world_with(vec![crate::features::Op::Blur {
            layer: "elevation".into(),
            sigmas: Vec::new(),
            cells: vec![6.0],
        }]);
        let one = LearchConfig {
            weak_learner: WeakLearnerKind::Tree,
            rounds: 4,
            ..config()
        };
        let two = LearchConfig {
            members: 2,
            ..one.clone()
        };
        assert_eq!(two.member_count(), 2);
        let first = train_without_evaluation(&stacks, &names, &examples, &one).unwrap();
        let mut checkpoints = Vec::new();
        let both = train(
            &stacks,
            &names,
            &examples,
            &[],
            &[],
            None,
            &two,
            None,
            |progress| checkpoints.push(progress.clone()),
        )
        .unwrap();
        // The first member is the staged model alone; the second's rounds follow.
        assert_eq!(both.members.len(), 2);
        assert_eq!(both.members[0], first.members[0]);
        let rounds: Vec<_> = both.rounds.iter().map(|r| (r.member, r.round)).collect();
        assert_eq!(
            rounds,
            [
                (0, 1),
                (0, 2),
                (0, 3),
                (0, 4),
                (1, 1),
                (1, 2),
                (1, 3),
                (1, 4)
            ]
        );
        // The geometric mean of the two costs: each member's learners at half their steps.
        assert_eq!(both.model.learners.len(), 8);
        for (mean, alone) in both.model.learners.iter().zip(&first.model.learners) {
            assert_eq!(mean.step, alone.step / 2.0);
            assert_eq!(mean.tree, alone.tree);
        }
        // Resumed from a checkpoint in either member, or between them, training ends
        // where it did.
        let resume = |config: &LearchConfig, done: usize| {
            let checkpoint = Some(checkpoints[done - 1].clone());
            train(
                &stacks,
                &names,
                &examples,
                &[],
                &[],
                None,
                config,
                checkpoint,
                |_| {},
            )
        };
        for done in [2, 4, 6] {
            let resumed = resume(&two, done).unwrap();
            assert_eq!(resumed.model, both.model, "resumed after {done} rounds");
            assert_eq!(resumed.rounds, both.rounds);
        }
        // A checkpoint of more members than the run trains is refused.
        let err = resume(&one, 6).unwrap_err();
        assert!(err.contains("member 2"), "{err}");
        // Where no feature is wider than a cell, the members would be the same: one is
        // trained.
        let (stacks, names, examples, _) = small_world();
        let alone = train_without_evaluation(&stacks, &names, &examples, &two).unwrap();
        assert_eq!(alone.members.len(), 1);
        // Where there are no stages to differ by, one member is trained.
        for config in [
            LearchConfig {
                weak_learner: WeakLearnerKind::Ridge,
                ..two.clone()
            },
            LearchConfig {
                widen_in_stages: false,
                ..two.clone()
            },
            LearchConfig {
                method: GridMethod::Maxent,
                ..two.clone()
            },
        ] {
            assert_eq!(config.member_count(), 1, "{config:?}");
        }
    }

    #[test]
    fn unreachable_goals_are_reported() {
        let (mut stacks, names, examples, _) = small_world();
        let example = examples[0].clone();
        // Wall off the goal: non-finite features make every neighbour's cost infinite.
        let goal = *example.path.last().unwrap();
        let geo = stacks[example.map].geo.clone();
        for i in 0..geo.cell_count() {
            let cell = geo.cell_at(i);
            if cell.chebyshev(goal) == 1 {
                let n = geo.cell_count();
                for j in 0..stacks[example.map].dim() {
                    stacks[example.map].data[j * n + i] = f32::INFINITY;
                }
            }
        }
        let err = train(
            &stacks,
            &names,
            &[example],
            &[],
            &[],
            None,
            &config(),
            None,
            |_| {},
        )
        .unwrap_err();
        assert!(err.contains("no path"), "{err}");
    }
}
