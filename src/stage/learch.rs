//! `learch`: a dataset's demonstrations and their maps' features in, a costmap
//! artifact out: the learned cost function, the evaluated costmap of every map,
//! previews, and metrics on held-out demonstrations.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::{StageParams, StageReport, commit_artifact};
use rayon::prelude::*;

use crate::artifact::{ArtifactBuilder, References, read_manifest};
use crate::error::{Error, Result, first_error_in_order};
use crate::grid::{Cell, FeatureStack, Grid};
use crate::io::demo_tables::read_demonstrations;
use crate::io::fs::{to_json_bytes, write_bytes_atomic};
use crate::io::png::write_png;
use crate::io::tables::{
    EpisodePath, read_features, read_features_header, read_paths, write_costmap, write_paths,
};
use crate::ioc::{
    self, Corridor, Example, ExampleEvaluation, GridMethod, LearchConfig, LossKind, StepSchedule,
    TrainedLearch, WeakLearnerKind, waypoints_of,
};
use crate::learn::TreeConfig;
use crate::report::{Preview, render_preview};

pub const KIND: &str = "learch";
/// 7: previews with a colour bar and a scale bar; MaxEnt's own exponential; step
/// lengths per row in geographic frames. 8: MaxEnt's forward pass drops negligible
/// mass. 9: LEARCH plans its examples with Dijkstra (other ties than A*'s). 10: cells
/// weighed by their steps' lengths, trees widened in stages, ridge and trees in turn
/// for 160 rounds by default. 11: trees split distances between any two of their
/// values. 12: LEARCH with trees trains two members and averages their costs. 13: a
/// feature constant over every map is scaled by its size (MMP's and ridge's steps).
/// 14: MaxEnt answers an example whose paths within the horizon its layers cannot hold
/// (a horizon that binds on a dear map) in the log domain. 15: MaxEnt's trees are
/// fitted on one point per cell (their sums rounded in another order). 16: metrics.json
/// says which corridor the model was trained with (`--corridor auto`). 17: a
/// corridor prices the cells off the track 5 % dearer. 18: routes given by sparse
/// vertices (drawn by hand) are re-planned between them every round.
const VERSION: u32 = 18;

mod defaults {
    use crate::ioc::Corridor;

    pub fn schedule() -> crate::ioc::StepSchedule {
        crate::ioc::StepSchedule::InverseSqrt
    }
    pub fn ridge_lambda() -> f64 {
        1e-3
    }
    pub fn loss() -> f64 {
        0.3
    }
    /// Every demonstration trains the costmap unless the user holds some out to
    /// measure it: a quarter set aside by default would learn from three quarters of
    /// what they gave, and demonstrations are the dear input (BENCHMARKS.md, "Every
    /// demonstration trains the costmap").
    pub fn holdout() -> f64 {
        0.0
    }
    pub fn preview_scale() -> u32 {
        4
    }
    /// Ridge and trees in turn for LEARCH (a log-linear trend that keeps rising where
    /// the demonstrations only avoid, and trees for the nonlinear rest), trees for
    /// MaxEnt; MMP learns a linear cost.
    pub fn weak_learner(method: crate::ioc::GridMethod) -> crate::ioc::WeakLearnerKind {
        match method {
            crate::ioc::GridMethod::Mmp => crate::ioc::WeakLearnerKind::Ridge,
            crate::ioc::GridMethod::Learch => crate::ioc::WeakLearnerKind::Alternate,
            crate::ioc::GridMethod::Maxent => crate::ioc::WeakLearnerKind::Tree,
        }
    }
    pub fn tree_depth() -> usize {
        3
    }
    pub fn loss_kind() -> crate::ioc::LossKind {
        crate::ioc::LossKind::Hamming
    }
    pub fn loss_sigma() -> f64 {
        2.0
    }
    pub fn schedule_offset() -> f64 {
        1.0
    }
    pub fn members() -> usize {
        crate::ioc::MEMBERS.len()
    }
    pub fn method() -> crate::ioc::GridMethod {
        crate::ioc::GridMethod::Learch
    }
    pub fn horizon_factor() -> f64 {
        crate::ioc::MAXENT_HORIZON_FACTOR
    }
    pub fn corridor() -> Corridor {
        Corridor::Auto
    }
    pub fn window_margin() -> u32 {
        6
    }
}

/// Parameters of `imitate learch` and of `uses: learch`.
#[derive(Debug, Clone, clap::Args, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LearchParams {
    /// The dataset folder written by `ingest`.
    #[arg(long, value_name = "DIR")]
    pub dataset: PathBuf,
    /// The features folder written by `features`.
    #[arg(long, value_name = "DIR")]
    pub features: PathBuf,
    /// The costmap artifact folder to write.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// The method: LEARCH (boosted log-cost), MMP (linear cost, subgradient) or MaxEnt
    /// IOC (log-linear cost, likelihood gradient). All write the same artifact.
    #[arg(long, value_enum, default_value_t = defaults::method())]
    #[serde(default = "defaults::method")]
    pub method: GridMethod,
    /// Rounds T (boosting rounds, or gradient steps for MMP and MaxEnt); default 160
    /// for LEARCH with ridge and trees in turn, 80 for LEARCH with trees, 40 otherwise.
    #[arg(long)]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rounds: Option<usize>,
    /// Step size α (the first round's, under inverse-sqrt); default 0.5 for LEARCH with trees or ridge and trees in turn (shrinkage), 1 otherwise.
    #[arg(long)]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step_size: Option<f64>,
    #[arg(long, value_enum, default_value_t = defaults::schedule())]
    #[serde(default = "defaults::schedule")]
    pub schedule: StepSchedule,
    /// k of the inverse-linear schedule α / (t + 1 + k).
    #[arg(long, default_value_t = defaults::schedule_offset())]
    #[serde(default = "defaults::schedule_offset")]
    pub schedule_offset: f64,
    /// The weak learner of LEARCH and MaxEnt: regression trees (a nonlinear cost; MaxEnt's
    /// default), ridge regression (a log-linear cost) or both in turn (alternate,
    /// LEARCH's default); MMP's is ridge. Ridge and trees in turn imitate best across
    /// real terrains and teachers (`imitate bench terrain`, BENCHMARKS.md): trees alone
    /// raise the cost of what the demonstrations avoid only as far as the training
    /// plans need, ridge alone only fits a cost log-linear in the features. MaxEnt's
    /// trees fit its functional gradient, expected minus demonstrated visits times the
    /// cost, per cell.
    #[arg(long, value_enum)]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weak_learner: Option<WeakLearnerKind>,
    /// Depth of the regression trees.
    #[arg(long, default_value_t = defaults::tree_depth())]
    #[serde(default = "defaults::tree_depth")]
    pub tree_depth: usize,
    /// Ridge penalty of the linear weak learner (standardised features).
    #[arg(long, default_value_t = defaults::ridge_lambda())]
    #[serde(default = "defaults::ridge_lambda")]
    pub ridge_lambda: f64,
    /// Loss augmentation: cells off a demonstration are made up to this fraction
    /// cheaper while training; 0 turns it off.
    #[arg(long, default_value_t = defaults::loss())]
    #[serde(default = "defaults::loss")]
    pub loss: f64,
    /// Hamming (every cell off the demonstration) or dilated (1 − exp(−d²/σ²) at
    /// distance d cells from it).
    #[arg(long, value_enum, default_value_t = defaults::loss_kind())]
    #[serde(default = "defaults::loss_kind")]
    pub loss_kind: LossKind,
    /// σ of the dilated loss, in cells.
    #[arg(long, default_value_t = defaults::loss_sigma())]
    #[serde(default = "defaults::loss_sigma")]
    pub loss_sigma: f64,
    /// MaxEnt: paths may take up to this many times a demonstration's steps.
    #[arg(long, default_value_t = defaults::horizon_factor())]
    #[serde(default = "defaults::horizon_factor")]
    pub horizon_factor: f64,
    /// MaxEnt: cells around a demonstration's bounding box that its paths may use.
    #[arg(long, default_value_t = defaults::window_margin())]
    #[serde(default = "defaults::window_margin")]
    pub window_margin: u32,
    /// Fraction of the (not held-out) demonstrations set aside for validation, which
    /// early stopping watches.
    #[arg(long, default_value_t = 0.0)]
    #[serde(default)]
    pub validation: f64,
    /// Early stopping: end when validation agreement has not improved for this many
    /// rounds, and keep the best round's model.
    #[arg(long)]
    #[serde(default)]
    pub patience: Option<usize>,
    /// LEARCH: keep the learned cost's contrast as the rounds left it, instead of
    /// ending with the exponent on the cost (1, 1.25, 1.5 or 2) whose plans follow the
    /// training paths best (`contrast` in metrics.json).
    #[arg(long)]
    #[serde(default)]
    pub keep_contrast: bool,
    /// LEARCH with trees: split on features of every scale alike from the first
    /// round, instead of on the cells' own values first and on wider neighbourhoods
    /// (at a damped gain before then) from a quarter and half of the rounds on.
    #[arg(long)]
    #[serde(default)]
    pub all_scales_at_once: bool,
    /// LEARCH with trees widened in stages: how many models to train and plan on the
    /// geometric mean of (`members` in metrics.json). 2 adds a model whose wider
    /// features compete earlier to the staged one, at twice the training time, and
    /// imitates real terrain better across teachers (BENCHMARKS.md); 1 trains the
    /// staged model alone.
    #[arg(long, default_value_t = defaults::members())]
    #[serde(default = "defaults::members")]
    pub members: usize,
    /// LEARCH and MMP: take each demonstration as the cheapest path, under the cost
    /// learned so far, through the cells within this many cells of it (those off the
    /// track priced 5 % dearer, so that it keeps to the track unless the detour is
    /// clearly dear): for tracks that wander around the route driven (GNSS or odometry
    /// noise, a driver's weaving), which LEARCH would otherwise learn every wobble of.
    /// 0 takes the demonstrations as they are. `auto` (the default) trains without one
    /// and, where the plans on the learned cost shorten most training demonstrations
    /// (tracks that wander do; exact ones do not), trains again with a corridor of 1
    /// and keeps that model (`corridor` in metrics.json says which and why).
    #[arg(long, value_name = "CELLS|auto", default_value_t = defaults::corridor())]
    #[serde(default = "defaults::corridor")]
    pub corridor: Corridor,
    /// Fraction of demonstrations held out to measure the costmap on paths it never
    /// learned from (`holdout` in metrics.json); 0 trains on every one. Early stopping
    /// watches `validation`, not these.
    #[arg(long, default_value_t = defaults::holdout())]
    #[serde(default = "defaults::holdout")]
    pub holdout: f64,
    /// Seed of the hold-out split.
    #[arg(long, default_value_t = 0)]
    #[serde(default)]
    pub seed: u64,
    /// Reference costmaps to score plans against, e.g. a synthetic world's true costs or
    /// a teacher's cost raster: `costmap/1` tables or one-band GeoTIFFs of costs, each
    /// matched to the map of its name (a GeoTIFF's is its file's), else to the only map
    /// of its grid. Evaluation only.
    #[arg(long = "reference", value_name = "FILE")]
    #[serde(default)]
    pub references: Vec<PathBuf>,
    /// Continue from this run's checkpoint (written after every round under
    /// .imitate/checkpoints, for the same inputs and parameters) instead of starting
    /// over; the artifact is the one an uninterrupted run writes.
    #[arg(long)]
    #[serde(skip)]
    pub resume: bool,
    /// Pixels per cell in the previews.
    #[arg(long, default_value_t = defaults::preview_scale())]
    #[serde(default = "defaults::preview_scale")]
    pub preview_scale: u32,
}

impl LearchParams {
    fn weak_learner(&self) -> WeakLearnerKind {
        self.weak_learner
            .unwrap_or_else(|| defaults::weak_learner(self.method))
    }

    /// The rounds to run: the given ones, or the method's and learner's default.
    fn rounds(&self) -> usize {
        self.rounds
            .unwrap_or_else(|| ioc::default_rounds_and_step(self.method, self.weak_learner()).0)
    }

    fn step_size(&self) -> f64 {
        self.step_size
            .unwrap_or_else(|| ioc::default_rounds_and_step(self.method, self.weak_learner()).1)
    }

    fn validate(&self) -> Result<()> {
        let bad = |what: &str| Err(Error::Usage(format!("learch: {what}")));
        if self.rounds() == 0 {
            return bad("rounds must be at least 1");
        }
        if !(self.step_size().is_finite() && self.step_size() > 0.0) {
            return bad("step_size must be a positive number");
        }
        if !(self.ridge_lambda.is_finite() && self.ridge_lambda >= 0.0) {
            return bad("ridge_lambda must be >= 0");
        }
        if !(1..=ioc::MEMBERS.len()).contains(&self.members) {
            return bad(&format!("members must be 1 to {}", ioc::MEMBERS.len()));
        }
        if !(0.0..1.0).contains(&self.loss) {
            return bad("loss must be in [0, 1)");
        }
        if !(0.0..1.0).contains(&self.holdout) {
            return bad("holdout must be in [0, 1)");
        }
        if !(self.loss_sigma.is_finite() && self.loss_sigma > 0.0) {
            return bad("loss_sigma must be a positive number");
        }
        if !(self.schedule_offset.is_finite() && self.schedule_offset >= 0.0) {
            return bad("schedule_offset must be >= 0");
        }
        if self.method == GridMethod::Mmp
            && self
                .weak_learner
                .is_some_and(|w| w != WeakLearnerKind::Ridge)
        {
            return bad("mmp learns a linear cost: its weak_learner is ridge");
        }
        if !(self.horizon_factor.is_finite() && self.horizon_factor >= 1.0) {
            return bad("horizon_factor must be at least 1");
        }
        if self.tree_depth == 0 || self.tree_depth > 16 {
            return bad("tree_depth must be in 1..=16");
        }
        if self.patience == Some(0) {
            return bad("patience must be at least 1");
        }
        if !(0.0..1.0).contains(&self.validation) {
            return bad("validation must be in [0, 1)");
        }
        if self.patience.is_some() != (self.validation > 0.0) {
            return bad("patience and validation go together (early stopping watches validation)");
        }
        if !(1..=64).contains(&self.preview_scale) {
            return bad("preview_scale must be in 1..=64");
        }
        Ok(())
    }
}

/// Splits examples into training and held-out sets with a seeded shuffle.
fn split(examples: Vec<Example>, fraction: f64, seed: u64) -> (Vec<Example>, Vec<Example>) {
    let n = examples.len();
    let held = if n < 2 {
        0
    } else {
        ((n as f64 * fraction).round() as usize).min(n - 1)
    };
    let mut order: Vec<usize> = (0..n).collect();
    order.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    let holdout_set: std::collections::BTreeSet<usize> = order[..held].iter().copied().collect();
    let (mut training, mut holdout) = (Vec::new(), Vec::new());
    for (i, ex) in examples.into_iter().enumerate() {
        if holdout_set.contains(&i) {
            holdout.push(ex)
        } else {
            training.push(ex)
        }
    }
    (training, holdout)
}

impl StageParams for LearchParams {
    const KIND: &'static str = KIND;
    const VERSION: u32 = VERSION;

    fn deps(&self) -> Vec<PathBuf> {
        let mut deps = vec![self.dataset.clone(), self.features.clone()];
        deps.extend(self.references.iter().cloned());
        deps
    }

    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport> {
        self.run_with(extra_deps, None)
    }
}

/// What a LEARCH run reads: every map's features, and the demonstrations split into
/// training, validation and held-out examples.
/// A map's features and the bank's spec, refused where a feature is not finite.
fn read_checked_features(path: &Path) -> Result<(FeatureStack, serde_json::Value)> {
    let (name, stack, spec) = read_features(path)?;
    for (j, plane) in stack.planes().enumerate() {
        if let Some(i) = plane.iter().position(|v| !v.is_finite()) {
            return Err(Error::input(
                path,
                format!(
                    "feature '{}' is {} at cell {} of map '{name}': features must be finite \
                     (the features stage fills no-data cells)",
                    stack.names[j],
                    plane[i],
                    stack.geo.cell_at(i)
                ),
            ));
        }
    }
    Ok((stack, spec))
}

pub struct LearchInputs {
    pub map_names: Vec<String>,
    pub stacks: Vec<FeatureStack>,
    pub feature_spec: serde_json::Value,
    pub references: Option<Vec<Grid<f32>>>,
    pub training: Vec<Example>,
    pub validation: Vec<Example>,
    pub holdout: Vec<Example>,
}

impl LearchParams {
    /// Reads and checks the inputs, and splits the examples as every run of these
    /// parameters does (seeded), so that workers elsewhere find the same training set.
    pub fn inputs(&self) -> Result<LearchInputs> {
        self.read_inputs(None)
    }

    /// The inputs a worker planning training examples `shard` needs: every map's name
    /// and georeference, but features only for the maps those examples lie on (the
    /// others' stacks hold no features), and no reference costmaps.
    pub fn shard_inputs(&self, shard: std::ops::Range<usize>) -> Result<LearchInputs> {
        self.read_inputs(Some(shard))
    }

    /// How many training examples the split gives, reading no features.
    pub fn training_examples(&self) -> Result<usize> {
        Ok(self.read_inputs(Some(0..0))?.training.len())
    }

    fn read_inputs(&self, shard: Option<std::ops::Range<usize>>) -> Result<LearchInputs> {
        self.validate()?;
        let dataset = read_manifest(&self.dataset, "dataset")?;
        let features = read_manifest(&self.features, "features")?;
        let files: Vec<PathBuf> = features
            .files_with_role("features")
            .map(|f| self.features.join(&f.path))
            .collect();
        if files.is_empty() {
            return Err(Error::input(&self.features, "lists no feature stacks"));
        }
        let headers = first_error_in_order(
            files
                .par_iter()
                .map(|path| read_features_header(path))
                .collect(),
        )?;
        let map_names: Vec<String> = headers.iter().map(|(name, _)| name.clone()).collect();
        let paths_file = dataset
            .files_with_role("paths")
            .next()
            .map(|f| self.dataset.join(&f.path))
            .ok_or_else(|| Error::input(&self.dataset, "dataset lists no 'paths' file"))?;
        // Routes given by sparse vertices (drawn by hand) keep them: LEARCH re-plans
        // the stretches between them.
        let vertices: BTreeMap<String, Vec<(f64, f64)>> =
            match dataset.files_with_role("demonstrations").next() {
                Some(file) => read_demonstrations(&self.dataset.join(&file.path))?
                    .into_iter()
                    .map(|d| (d.episode.clone(), d.xy()))
                    .collect(),
                None => BTreeMap::new(),
            };
        let mut examples = Vec::new();
        for p in read_paths(&paths_file)? {
            let map = map_names.iter().position(|n| *n == p.map).ok_or_else(|| {
                Error::input(
                    &self.features,
                    format!(
                        "has no features for map '{}' of episode '{}'",
                        p.map, p.episode
                    ),
                )
            })?;
            let geo = &headers[map].1;
            if let Some(cell) = p.cells.iter().find(|c| !geo.contains(**c)) {
                return Err(Error::input(
                    &paths_file,
                    format!(
                        "episode '{}': cell {cell} is off map '{}'",
                        p.episode, p.map
                    ),
                ));
            }
            let vertex_cells: Vec<Cell> = vertices
                .get(&p.episode)
                .map(|xy| xy.iter().filter_map(|&(x, y)| geo.cell_of(x, y)).collect())
                .unwrap_or_default();
            examples.push(Example {
                id: p.episode,
                map,
                waypoints: waypoints_of(&p.cells, &vertex_cells),
                path: p.cells,
            });
        }
        if examples.is_empty() {
            return Err(Error::input(
                &paths_file,
                "holds no demonstrations to learn from",
            ));
        }
        let (training, holdout) = split(examples, self.holdout, self.seed);
        let (training, validation) = split(training, self.validation, self.seed.wrapping_add(1));
        let mut needed = vec![shard.is_none(); files.len()];
        if let Some(shard) = &shard {
            let examples = training.get(shard.clone()).ok_or_else(|| {
                Error::Usage(format!(
                    "examples {}..{} of a run with {} training examples",
                    shard.start,
                    shard.end,
                    training.len()
                ))
            })?;
            examples.iter().for_each(|ex| needed[ex.map] = true);
        }
        let loaded = first_error_in_order(
            files
                .par_iter()
                .zip(&needed)
                .map(|(path, &needed)| needed.then(|| read_checked_features(path)).transpose())
                .collect(),
        )?;
        let mut feature_spec = serde_json::Value::Null;
        let mut stacks = Vec::with_capacity(files.len());
        for (stack, (_, geo)) in loaded.into_iter().zip(headers) {
            stacks.push(match stack {
                Some((stack, spec)) => {
                    feature_spec = spec;
                    stack
                }
                None => FeatureStack {
                    geo,
                    names: Vec::new(),
                    data: Vec::new(),
                },
            });
        }
        let references = match shard {
            None => self.load_references(&map_names, &stacks)?,
            Some(_) => None,
        };
        Ok(LearchInputs {
            map_names,
            stacks,
            feature_spec,
            references,
            training,
            validation,
            holdout,
        })
    }

    /// The trainer's configuration.
    pub fn config(&self) -> LearchConfig {
        LearchConfig {
            method: self.method,
            horizon_factor: self.horizon_factor,
            window_margin: self.window_margin,
            rounds: self.rounds(),
            step_size: self.step_size(),
            schedule: self.schedule,
            ridge_lambda: self.ridge_lambda,
            loss: self.loss,
            loss_kind: self.loss_kind,
            loss_sigma: self.loss_sigma,
            schedule_offset: self.schedule_offset,
            weak_learner: self.weak_learner(),
            tree: TreeConfig {
                max_depth: self.tree_depth,
                bins: crate::ioc::TREE_BINS,
                leaf_l2: crate::ioc::TREE_LEAF_L2,
                ..TreeConfig::default()
            },
            patience: self.patience,
            calibrate_contrast: !self.keep_contrast,
            widen_in_stages: !self.all_scales_at_once,
            members: self.members,
            corridor: match self.corridor {
                Corridor::Cells(cells) => cells,
                Corridor::Auto => 0,
            },
        }
    }

    /// Runs the stage, with the map step of every round done by `remote` when given
    /// (workers elsewhere planning shards of `inputs().training`): the same artifact.
    pub fn run_with(
        &self,
        extra_deps: &[PathBuf],
        remote: Option<&mut ioc::RemoteRounds<'_>>,
    ) -> Result<StageReport> {
        let inputs = self.inputs()?;
        let stage_key = super::lineage(self, extra_deps)?.stage_key;
        let all: Vec<Example> = (inputs.training.iter())
            .chain(&inputs.validation)
            .chain(&inputs.holdout)
            .cloned()
            .collect();
        let mut remote = remote;
        let mut checkpoints = Vec::new();
        let ((trained, evaluations), corridor) = ioc::choose_corridor(
            self.corridor,
            self.method,
            |cells| {
                // The retrain `auto` chooses keeps its own checkpoint beside the first.
                let retrain = (self.corridor == Corridor::Auto && cells != 0).then_some(cells);
                let checkpoint = checkpoint_path(&stage_key, retrain);
                checkpoints.push(checkpoint.clone());
                let trained =
                    self.train_pass(&inputs, cells, &checkpoint, remote.as_deref_mut())?;
                let evaluations = ioc::learch_evaluate(
                    &trained.model,
                    &inputs.stacks,
                    &inputs.map_names,
                    &all,
                    inputs.references.as_deref(),
                )
                .map_err(|e| Error::input(&self.dataset, e))?;
                Ok::<_, Error>((trained, evaluations))
            },
            |(_, evaluations)| &evaluations[..inputs.training.len()],
        )?;
        let LearchInputs {
            map_names,
            stacks,
            feature_spec,
            training,
            validation,
            holdout,
            ..
        } = inputs;
        let model = &trained.model;
        let (train_eval, rest) = evaluations.split_at(training.len());
        let (validation_eval, holdout_eval) = rest.split_at(validation.len());

        let mut out = ArtifactBuilder::new(&self.out)?;
        let model_json = serde_json::json!({ "kind": self.method.name(), "feature_spec": feature_spec, "feature_names": model.feature_names, "cost": model });
        write_bytes_atomic(
            &out.file("model.json", "model")?,
            &to_json_bytes(&model_json),
        )?;
        for (m, stack) in stacks.iter().enumerate() {
            let costs = model.costmap(stack);
            let name = &map_names[m];
            write_costmap(
                &out.file(&format!("costmaps/{name}.parquet"), "costmap")?,
                name,
                &costs,
            )?;
            let on_map = |e: &&ExampleEvaluation| e.map == *name;
            let preview = Preview {
                costs: &costs,
                demonstrations: all
                    .iter()
                    .filter(|e| e.map == m)
                    .map(|e| e.path.as_slice())
                    .collect(),
                plans: evaluations
                    .iter()
                    .filter(on_map)
                    .map(|e| e.planned.as_slice())
                    .collect(),
            };
            let picture = render_preview(&preview, self.preview_scale)?;
            write_png(
                &out.file(&format!("previews/{name}.png"), "preview")?,
                &picture,
            )?;
        }
        // The demonstrations themselves, so that diff, export and report need nothing
        // but the artifact: training, then validation, then held-out examples.
        let example_paths: Vec<EpisodePath> = all
            .iter()
            .map(|e| EpisodePath {
                episode: e.id.clone(),
                map: map_names[e.map].clone(),
                cells: e.path.clone(),
            })
            .collect();
        write_paths(&out.file("paths.parquet", "paths")?, &example_paths)?;
        let holdout_summary = ioc::summarize(holdout_eval);
        let training_summary = ioc::summarize(train_eval);
        let metrics = serde_json::json!({
            "schema": "imitate.learch-metrics/1",
            "rounds": trained.rounds,
            "members": trained.members,
            "corridor": corridor,
            // Demonstrations given by sparse vertices, re-planned between them.
            "drawn_routes": all.iter().filter(|e| !e.waypoints.is_empty()).count(),
            "training": { "summary": training_summary, "examples": train_eval },
            "validation": { "summary": ioc::summarize(validation_eval), "examples": validation_eval },
            "holdout": { "summary": holdout_summary, "examples": holdout_eval },
        });
        write_bytes_atomic(
            &out.file("metrics.json", "metrics")?,
            &to_json_bytes(&metrics),
        )?;
        let final_loss = trained.rounds.last().map(|r| r.training_loss);
        let summary_metrics = serde_json::json!({
            "rounds": self.rounds(),
            "kept_rounds": trained.members.iter().map(|m| m.kept_round).collect::<Vec<_>>(),
            "training_examples": training.len(),
            "holdout_examples": holdout.len(),
            "final_training_loss": final_loss,
            "holdout": (!holdout.is_empty()).then_some(&holdout_summary),
        });
        let stopped_early =
            |m: &ioc::TrainedMember| m.rounds < self.rounds() || m.kept_round < m.rounds;
        let rounds = match trained.members.as_slice() {
            [one] if stopped_early(one) => format!(
                "stopped early after {} of {} rounds, kept round {}",
                one.rounds,
                self.rounds(),
                one.kept_round
            ),
            [_] => format!("{} rounds", self.rounds()),
            members if members.iter().any(stopped_early) => {
                let listed = |of: fn(&ioc::TrainedMember) -> usize| {
                    let numbers: Vec<String> = members.iter().map(|m| of(m).to_string()).collect();
                    numbers.join(" and ")
                };
                format!(
                    "{} models averaged, stopped early after {} of {} rounds, kept rounds {}",
                    members.len(),
                    listed(|m| m.rounds),
                    self.rounds(),
                    listed(|m| m.kept_round),
                )
            }
            members => format!(
                "{} models averaged, {} rounds each",
                members.len(),
                self.rounds()
            ),
        };
        // Figures on the held-out paths when there are some, else on the training
        // paths, said as such: they measure the fit, not how it generalises.
        let (scored, scored_on) = match holdout.is_empty() {
            false => (&holdout_summary, "held-out"),
            true => (
                &training_summary,
                "none held out (--holdout 0.25 measures unseen paths); training",
            ),
        };
        let mut summary = format!(
            "{rounds}, {} training / {} held-out demonstrations; {scored_on}: {:.1}% of planned cells within {} cells",
            training.len(),
            holdout.len(),
            100.0 * scored.within_radius,
            ioc::AGREEMENT_RADIUS,
        );
        if let Some(ratio) = scored.mean_reference_cost_ratio {
            summary.push_str(&format!(", reference cost ratio {ratio:.3}"));
        }
        if let (Corridor::Auto, Some(share), 1..) =
            (corridor.requested, corridor.plans_as_long, corridor.cells)
        {
            summary.push_str(&format!(
                "; the tracks wander ({:.0}% of plans as long as their demonstrations): \
                 trained again through a corridor of {} cell(s)",
                100.0 * share,
                corridor.cells
            ));
        }
        let report = commit_artifact(self, extra_deps, out, "costmap", summary_metrics, summary)?;
        // The artifact is in place: the checkpoints have served.
        for checkpoint in &checkpoints {
            let _ = std::fs::remove_file(checkpoint);
        }
        Ok(report)
    }

    /// One training of the model with a corridor of `corridor` cells, checkpointed after
    /// every round at `checkpoint` (and resumed from it with `--resume`).
    fn train_pass(
        &self,
        inputs: &LearchInputs,
        corridor: u32,
        checkpoint: &Path,
        remote: Option<&mut ioc::RemoteRounds<'_>>,
    ) -> Result<TrainedLearch> {
        let config = LearchConfig {
            corridor,
            ..self.config()
        };
        let title = match self.corridor {
            Corridor::Auto if corridor != 0 => format!("learch rounds, corridor {corridor}"),
            _ => "learch rounds".into(),
        };
        let progress = super::progress_bar(self.rounds(), title);
        let resume = if self.resume {
            read_checkpoint(checkpoint)?
        } else {
            None
        };
        if let Some(resumed) = &resume {
            tracing::info!("resuming after round {}", resumed.rounds.len());
            progress.inc(resumed.rounds.len() as u64);
        }
        let mut checkpoint_error = None;
        let trained = ioc::train_with(
            &inputs.stacks,
            &inputs.map_names,
            &inputs.training,
            &inputs.validation,
            &inputs.holdout,
            inputs.references.as_deref(),
            &config,
            resume,
            |state| {
                progress.inc(1);
                if checkpoint_error.is_none()
                    && let Err(e) = write_bytes_atomic(checkpoint, &to_json_bytes(state))
                {
                    checkpoint_error = Some(e);
                }
            },
            remote,
        )
        // Everything train refuses is about what it was given (no examples, stacks
        // that disagree, a demonstration whose goal cannot be reached).
        .map_err(|e| Error::input(&self.dataset, e))?;
        progress.finish_and_clear();
        match checkpoint_error {
            Some(e) => Err(e),
            None => Ok(trained),
        }
    }
}

/// Where the checkpoint of a run with this stage key lives (in the workspace, beside the
/// output cache): the key covers inputs, parameters and version, so a checkpoint never
/// resumes a different run.
/// The retrain `--corridor auto` chooses (`retrain`: its corridor) has its own.
fn checkpoint_path(stage_key: &str, retrain: Option<u32>) -> PathBuf {
    let hex = stage_key.strip_prefix("blake3:").unwrap_or(stage_key);
    let name = match retrain {
        Some(cells) => format!("learch-{hex}-corridor-{cells}.json"),
        None => format!("learch-{hex}.json"),
    };
    PathBuf::from(".imitate/checkpoints").join(name)
}

fn read_checkpoint(path: &std::path::Path) -> Result<Option<ioc::Progress>> {
    match std::fs::read(path) {
        Ok(bytes) => serde_json::from_slice(&bytes)
            .map(Some)
            .map_err(|e| Error::input(path, format!("not a learch checkpoint: {e}"))),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            tracing::warn!(
                "no checkpoint of this run to resume ({}): starting over",
                path.display()
            );
            Ok(None)
        }
        Err(e) => Err(Error::io(format!("reading {}", path.display()), e)),
    }
}

impl LearchParams {
    /// Loads the reference costmaps, one per map ([`References::for_map`]), or `None`
    /// when none were given.
    fn load_references(
        &self,
        map_names: &[String],
        stacks: &[FeatureStack],
    ) -> Result<Option<Vec<Grid<f32>>>> {
        let references = References::load(&self.references)?;
        if references.is_empty() {
            return Ok(None);
        }
        let maps: Vec<&str> = map_names.iter().map(String::as_str).collect();
        map_names
            .iter()
            .zip(stacks)
            .map(|(name, stack)| Ok(references.for_map(name, &stack.geo, &maps)?.clone()))
            .collect::<Result<Vec<_>>>()
            .map(Some)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_is_seeded_and_keeps_a_training_set() {
        let ex = |i: usize| Example {
            id: format!("e{i}"),
            map: 0,
            path: vec![],
            waypoints: Vec::new(),
        };
        let (t1, h1) = split((0..10).map(ex).collect(), 0.3, 4);
        let (t2, h2) = split((0..10).map(ex).collect(), 0.3, 4);
        assert_eq!((t1.len(), h1.len()), (7, 3));
        assert_eq!(
            h1.iter().map(|e| &e.id).collect::<Vec<_>>(),
            h2.iter().map(|e| &e.id).collect::<Vec<_>>()
        );
        assert_eq!(t1.len(), t2.len());
        let (t, h) = split((0..1).map(ex).collect(), 0.9, 0);
        assert_eq!((t.len(), h.len()), (1, 0));
    }
}
