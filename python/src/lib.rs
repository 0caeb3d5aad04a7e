//! `imitate._native`: the Rust crate's functions for Python, as thin as they can be.
//! Arrays cross as NumPy arrays, parameters as JSON text (the Python layer turns dicts
//! into it), errors as `imitate.ImitateError` (or `InputError` for a bad file or value,
//! `UsageError` for parameters that cannot work) carrying the messages the command line
//! prints. Long work runs with the interpreter released, so other Python threads go on.

use std::path::PathBuf;

use std::sync::Mutex;

use imitate::Error;
use imitate::grid::{Cell, FeatureStack, GeoRef, Grid};
use imitate::ioc::{ExampleStatistics, LearchConfig, LogCostModel, PreparedExamples, TreeSums};
use imitate::plan::{Connectivity, GridPlanner, Moves, unit_step_metres};
use imitate::stage::StageReport;
use imitate::stage::ingest::{IngestParams, LogPart};
use imitate::stage::learch::LearchParams;
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(_native, ImitateError, PyException, "An error of imitate's.");
create_exception!(
    _native,
    InputError,
    ImitateError,
    "A file or value given to imitate is missing, unreadable or not what it should be."
);
create_exception!(
    _native,
    UsageError,
    ImitateError,
    "Parameters that cannot work together."
);

/// The command line's message, as the matching Python exception.
fn raise(error: Error) -> PyErr {
    let message = error.to_string();
    match error {
        Error::Input { .. } => InputError::new_err(message),
        Error::Usage(_) => UsageError::new_err(message),
        _ => ImitateError::new_err(message),
    }
}

/// Map name, feature names, values [features, rows, cols], spec as JSON.
type FeatureTable<'py> = (String, Vec<String>, Bound<'py, PyArray3<f32>>, String);
/// Episode, map name, cells [n, 2].
type NamedPath<'py> = (String, String, Bound<'py, PyArray2<u32>>);

fn json_text(value: &serde_json::Value) -> String {
    serde_json::to_string(value).expect("JSON values serialise")
}

fn parse_json(text: &str, what: &str) -> PyResult<serde_json::Value> {
    serde_json::from_str(text).map_err(|e| UsageError::new_err(format!("{what}: {e}")))
}

/// Runs one stage of kind `kind` with `params` (JSON: the parameters of its YAML entry
/// and command) and returns its report as JSON: output folder, digest, summary.
/// `extra_deps`: inputs a pipeline declares for the stage beyond those its parameters
/// name (they join its lineage).
#[pyfunction]
#[pyo3(signature = (kind, params, extra_deps = Vec::new()))]
fn run_stage(
    py: Python<'_>,
    kind: &str,
    params: &str,
    extra_deps: Vec<PathBuf>,
) -> PyResult<String> {
    let params = parse_json(params, "stage parameters")?;
    let stage = imitate::stage::build(kind, params).map_err(raise)?;
    let report = py.detach(|| stage.run(&extra_deps)).map_err(raise)?;
    Ok(json_text(
        &serde_json::to_value(&report).expect("reports serialise"),
    ))
}

/// The stage kinds `run_stage` knows.
#[pyfunction]
fn stage_kinds() -> Vec<&'static str> {
    imitate::stage::kinds().collect()
}

/// Runs a pipeline file as `imitate run` does (keys, lock file, cache, only what is
/// stale; paths relative to the working directory); returns each stage's outcome as
/// JSON, in the run's order. With `execute`, each stage that must run is handed to it
/// as (kind, resolved parameters as JSON, extra dependencies) and it returns the
/// stage's report as JSON (`run_stage`'s, run wherever it likes on a filesystem this
/// process sees); it may be called from several threads at once (`jobs`).
#[pyfunction]
#[pyo3(signature = (pipeline, force = false, only = None, jobs = 1, execute = None))]
fn run_pipeline(
    py: Python<'_>,
    pipeline: PathBuf,
    force: bool,
    only: Option<String>,
    jobs: usize,
    execute: Option<Py<PyAny>>,
) -> PyResult<String> {
    let options = imitate::pipeline::RunOptions {
        force,
        only,
        jobs,
        ..Default::default()
    };
    let outcomes = match execute {
        None => py
            .detach(|| imitate::pipeline::run(&pipeline, &options, |_| {}))
            .map_err(raise)?,
        Some(execute) => {
            let workers = Workers::new(execute);
            let executor = |stage: &dyn imitate::stage::Stage, extra: &[PathBuf]| {
                let params = json_text(&stage.params());
                let extra: Vec<String> = extra.iter().map(|p| p.display().to_string()).collect();
                let report: String = workers
                    .call(|py, execute| {
                        execute
                            .call1(py, (stage.kind(), params, extra))?
                            .extract(py)
                    })
                    .map_err(Error::Failed)?;
                serde_json::from_str::<StageReport>(&report)
                    .map_err(|e| Error::Failed(format!("stage {}'s report: {e}", stage.kind())))
            };
            let outcomes =
                py.detach(|| imitate::pipeline::run_with(&pipeline, &options, &executor, |_| {}));
            workers.failure()?;
            outcomes.map_err(raise)?
        }
    };
    Ok(json_text(
        &serde_json::to_value(&outcomes).expect("outcomes serialise"),
    ))
}

/// A costmap (an artifact folder, a costmap table, a GeoTIFF or a MovingAI map) as
/// (map name, costs [rows, cols] float32 with row 0 the southern edge, georeference JSON).
#[pyfunction]
#[pyo3(signature = (path, map = None))]
fn read_costmap<'py>(
    py: Python<'py>,
    path: PathBuf,
    map: Option<&str>,
) -> PyResult<(String, Bound<'py, PyArray2<f32>>, String)> {
    let (name, grid) = imitate::artifact::load_costs(&path, map).map_err(raise)?;
    let geo = json_text(&serde_json::to_value(&grid.geo).expect("georeferences serialise"));
    let shape = (grid.geo.height as usize, grid.geo.width as usize);
    let costs = Array2::from_shape_vec(shape, grid.data).expect("one value per cell");
    Ok((name, costs.into_pyarray(py), geo))
}

/// A feature table (from a features artifact) as (map name, feature names, values
/// [features, rows, cols] float32, the feature spec as JSON).
#[pyfunction]
fn read_features<'py>(py: Python<'py>, path: PathBuf) -> PyResult<FeatureTable<'py>> {
    let (name, stack, spec) = imitate::io::tables::read_features(&path).map_err(raise)?;
    let shape = (
        stack.names.len(),
        stack.geo.height as usize,
        stack.geo.width as usize,
    );
    let values = Array3::from_shape_vec(shape, stack.data).expect("one plane per feature");
    Ok((name, stack.names, values.into_pyarray(py), json_text(&spec)))
}

/// Features of the map table at `path` by `spec` (JSON, the features stage's `spec`):
/// (feature names, values [features, rows, cols] float32).
#[pyfunction]
fn compute_features<'py>(
    py: Python<'py>,
    path: PathBuf,
    spec: &str,
) -> PyResult<(Vec<String>, Bound<'py, PyArray3<f32>>)> {
    let spec: imitate::features::FeatureSpec =
        serde_json::from_value(parse_json(spec, "feature spec")?)
            .map_err(|e| UsageError::new_err(format!("feature spec: {e}")))?;
    let stack = py
        .detach(|| {
            let map = imitate::io::tables::read_map(&path)?;
            imitate::features::compute(&map, &spec).map_err(|e| Error::input(&path, e))
        })
        .map_err(raise)?;
    let shape = (
        stack.names.len(),
        stack.geo.height as usize,
        stack.geo.width as usize,
    );
    let values = Array3::from_shape_vec(shape, stack.data).expect("one plane per feature");
    Ok((stack.names, values.into_pyarray(py)))
}

/// A paths table (a dataset's or a costmap artifact's `paths.parquet`) as a list of
/// (episode, map name, cells [n, 2] (row, col)).
#[pyfunction]
fn read_paths<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Vec<NamedPath<'py>>> {
    let paths = imitate::io::tables::read_paths(&path).map_err(raise)?;
    Ok(paths
        .into_iter()
        .map(|p| (p.episode, p.map, cell_array(py, &p.cells)))
        .collect())
}

/// Cells as an [n, 2] array of (row, col).
fn cell_array<'py>(py: Python<'py>, cells: &[Cell]) -> Bound<'py, PyArray2<u32>> {
    let flat: Vec<u32> = cells.iter().flat_map(|c| [c.row, c.col]).collect();
    Array2::from_shape_vec((cells.len(), 2), flat)
        .expect("two numbers per cell")
        .into_pyarray(py)
}

/// The cheapest path on `costs` ([rows, cols], row 0 south; cells that are not finite
/// and positive are blocked) from `start` to `goal` ((row, col)): the cells [n, 2] and
/// the cost in cost × metres. Cells are `resolution` metres (x) by `resolution_y` (y).
#[pyfunction]
#[pyo3(signature = (costs, start, goal, resolution = 1.0, resolution_y = None, connectivity = 8, corner_cutting = true))]
#[allow(clippy::too_many_arguments)]
fn plan<'py>(
    py: Python<'py>,
    costs: PyReadonlyArray2<'py, f32>,
    start: (u32, u32),
    goal: (u32, u32),
    resolution: f64,
    resolution_y: Option<f64>,
    connectivity: u32,
    corner_cutting: bool,
) -> PyResult<Option<(Bound<'py, PyArray2<u32>>, f64)>> {
    let connectivity = match connectivity {
        4 => Connectivity::Four,
        8 => Connectivity::Eight,
        other => {
            return Err(UsageError::new_err(format!("connectivity {other}: 4 or 8")));
        }
    };
    let view = costs.as_array();
    let (rows, cols) = view.dim();
    let geo = GeoRef {
        resolution_y,
        ..GeoRef::square(cols as u32, rows as u32, resolution, [0.0, 0.0], "map")
    };
    geo.validate()
        .map_err(|e| InputError::new_err(format!("costs: {e}")))?;
    for (what, (row, col)) in [("start", start), ("goal", goal)] {
        if row as usize >= rows || col as usize >= cols {
            return Err(InputError::new_err(format!(
                "{what} ({row}, {col}) lies outside the {rows} x {cols} costmap"
            )));
        }
    }
    let grid = Grid::from_vec(geo, view.iter().copied().collect());
    let moves = Moves {
        connectivity,
        corner_cutting,
    };
    let route = py.detach(|| {
        GridPlanner::new(&grid, moves).astar(Cell::new(start.0, start.1), Cell::new(goal.0, goal.1))
    });
    Ok(route.map(|route| {
        (
            cell_array(py, &route.cells),
            route.cost * unit_step_metres(&grid.geo),
        )
    }))
}

/// LEARCH parameters (JSON, as the stage's) deserialised and checked as the stage is.
fn learch_params(text: &str) -> PyResult<LearchParams> {
    serde_json::from_value(parse_json(text, "learch parameters")?)
        .map_err(|e| UsageError::new_err(format!("learch parameters: {e}")))
}

/// How many training examples a LEARCH run of these parameters has (after its seeded
/// hold-out and validation splits): what workers divide between them.
#[pyfunction]
fn learch_training_examples(py: Python<'_>, params: &str) -> PyResult<usize> {
    let params = learch_params(params)?;
    py.detach(|| params.training_examples()).map_err(raise)
}

/// A worker's share of a LEARCH run: training examples `start..stop` with the features
/// of the maps they lie on, loaded and prepared once; `plan` is the map step of a round.
#[pyclass(frozen)]
struct LearchShard {
    stacks: Vec<FeatureStack>,
    prepared: PreparedExamples,
    config: LearchConfig,
    /// Each map's trees' part of the costmap, kept from round to round.
    tree_sums: Mutex<Vec<TreeSums>>,
}

#[pymethods]
impl LearchShard {
    #[new]
    fn new(py: Python<'_>, params: &str, start: usize, stop: usize) -> PyResult<Self> {
        let params = learch_params(params)?;
        // Features only for the maps of the shard's examples.
        let inputs = py
            .detach(|| params.shard_inputs(start..stop))
            .map_err(raise)?;
        let config = params.config();
        let examples = inputs.training[start..stop].to_vec();
        let prepared = py.detach(|| PreparedExamples::new(&inputs.stacks, examples, &config));
        Ok(LearchShard {
            tree_sums: Mutex::new(vec![TreeSums::default(); inputs.stacks.len()]),
            stacks: inputs.stacks,
            prepared,
            config,
        })
    }

    /// Plans the shard's examples under `model` (JSON, as the driver sends it), each
    /// demonstration taken through a corridor of `corridor` cells (the parameters' when
    /// not given; `corridor: auto` retrains with one), and returns their statistics
    /// (JSON), in example order.
    #[pyo3(signature = (model, corridor = None))]
    fn plan(&self, py: Python<'_>, model: &str, corridor: Option<u32>) -> PyResult<String> {
        let model: LogCostModel =
            serde_json::from_str(model).map_err(|e| UsageError::new_err(format!("model: {e}")))?;
        let statistics = py
            .detach(|| {
                // A plan that panicked may have left its sums half added: start again.
                let mut sums = self.tree_sums.lock().unwrap_or_else(|poisoned| {
                    let mut sums = poisoned.into_inner();
                    sums.fill(TreeSums::default());
                    sums
                });
                let config = LearchConfig {
                    corridor: corridor.unwrap_or(self.config.corridor),
                    ..self.config.clone()
                };
                (self.prepared).plan_growing(&model, &self.stacks, &config, &mut sums)
            })
            .map_err(ImitateError::new_err)?;
        serde_json::to_string(&statistics)
            .map_err(|e| ImitateError::new_err(format!("statistics: {e}")))
    }

    /// How many examples the shard holds.
    #[getter]
    fn examples(&self) -> usize {
        self.prepared.len()
    }
}

/// Runs the learch stage with `params` (JSON), the map step of every round done by
/// `plan`: a callable given the model (JSON) and the round's corridor in cells that
/// returns the statistics of every shard (JSON each, from `LearchShard.plan`), shards
/// in example order. The artifact is
/// the one `run_stage("learch", ...)` writes. Returns the stage's report (JSON).
/// `extra_deps`: inputs a pipeline declares for the stage beyond its parameters'.
#[pyfunction]
#[pyo3(signature = (params, plan, extra_deps = Vec::new()))]
fn run_learch_distributed(
    py: Python<'_>,
    params: &str,
    plan: Py<PyAny>,
    extra_deps: Vec<PathBuf>,
) -> PyResult<String> {
    let params = learch_params(params)?;
    let workers = Workers::new(plan);
    let mut remote =
        |model: &LogCostModel, corridor: u32| -> Result<Vec<ExampleStatistics>, String> {
            let model = serde_json::to_string(model).map_err(|e| e.to_string())?;
            let parts: Vec<String> =
                workers.call(|py, plan| plan.call1(py, (model, corridor))?.extract(py))?;
            let mut statistics = Vec::new();
            for part in parts {
                let shard: Vec<ExampleStatistics> = serde_json::from_str(&part)
                    .map_err(|e| format!("a shard's statistics: {e}"))?;
                statistics.extend(shard);
            }
            Ok(statistics)
        };
    let report = py.detach(|| params.run_with(&extra_deps, Some(&mut remote)));
    workers.report(report)
}

/// The Python callable that hands a stage's work to workers, called from Rust with the
/// interpreter released. Its exception is kept and raised as it is, not as a message.
struct Workers {
    callable: Py<PyAny>,
    failure: Mutex<Option<PyErr>>,
}

impl Workers {
    fn new(callable: Py<PyAny>) -> Self {
        Workers {
            callable,
            failure: Mutex::new(None),
        }
    }

    fn call<T>(
        &self,
        call: impl FnOnce(Python<'_>, &Py<PyAny>) -> PyResult<T>,
    ) -> Result<T, String> {
        Python::attach(|py| call(py, &self.callable)).map_err(|e| {
            let message = e.to_string();
            *self.failure.lock().expect("not poisoned") = Some(e);
            format!("the workers failed: {message}")
        })
    }

    /// The callable's exception, where it raised one.
    fn failure(self) -> PyResult<()> {
        match self.failure.into_inner().expect("not poisoned") {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// The stage's report (JSON), or the callable's exception where it raised one.
    fn report(self, report: imitate::Result<StageReport>) -> PyResult<String> {
        self.failure()?;
        let report = report.map_err(raise)?;
        Ok(json_text(
            &serde_json::to_value(&report).expect("reports serialise"),
        ))
    }
}

/// Ingest parameters (JSON, as the stage's).
fn ingest_params(text: &str) -> PyResult<IngestParams> {
    serde_json::from_value(parse_json(text, "ingest parameters")?)
        .map_err(|e| UsageError::new_err(format!("ingest parameters: {e}")))
}

/// A log's part as it travels from a worker: its map and its demonstrations as the
/// tables the dataset holds (Parquet bytes), which read back exactly.
type LogPartBytes = (Option<Vec<u8>>, Vec<u8>);

fn encode_part((map, demonstrations): LogPart) -> imitate::Result<LogPartBytes> {
    let folder = tempfile::tempdir().map_err(|e| Error::io("a temporary folder", e))?;
    let read = |path: &std::path::Path| {
        std::fs::read(path).map_err(|e| Error::io(format!("reading {}", path.display()), e))
    };
    let map = match map {
        Some(map) => {
            let path = folder.path().join("map.parquet");
            imitate::io::tables::write_map(&path, &map)?;
            Some(read(&path)?)
        }
        None => None,
    };
    let path = folder.path().join("demonstrations.parquet");
    imitate::io::tables::write_demonstrations(&path, &demonstrations)?;
    Ok((map, read(&path)?))
}

fn decode_part((map, demonstrations): LogPartBytes) -> imitate::Result<LogPart> {
    let folder = tempfile::tempdir().map_err(|e| Error::io("a temporary folder", e))?;
    let write = |name: &str, bytes: &[u8]| {
        let path = folder.path().join(name);
        std::fs::write(&path, bytes)
            .map_err(|e| Error::io(format!("writing {}", path.display()), e))
            .map(|()| path)
    };
    let map = match map {
        Some(bytes) => Some(imitate::io::tables::read_map(&write(
            "map.parquet",
            &bytes,
        )?)?),
        None => None,
    };
    let path = write("demonstrations.parquet", &demonstrations)?;
    Ok((map, imitate::io::demo_tables::read_demonstrations(&path)?))
}

/// Decodes log `index` of an ingest run's `logs` (what one worker does): its map and
/// demonstrations as Parquet bytes for `run_ingest_distributed`.
#[pyfunction]
fn ingest_log_part(py: Python<'_>, params: &str, index: usize) -> PyResult<LogPartBytes> {
    let params = ingest_params(params)?;
    py.detach(|| params.read_log_part(index).and_then(encode_part))
        .map_err(raise)
}

/// Runs the ingest stage with `params` (JSON), its logs decoded by `decode`: a callable
/// given the logs' paths that returns each log's part (from `ingest_log_part`), in
/// order. The artifact is the one `run_stage("ingest", ...)` writes. Returns the
/// stage's report (JSON).
#[pyfunction]
fn run_ingest_distributed(py: Python<'_>, params: &str, decode: Py<PyAny>) -> PyResult<String> {
    let params = ingest_params(params)?;
    let workers = Workers::new(decode);
    let mut remote = |logs: &[PathBuf]| -> imitate::Result<Vec<LogPart>> {
        let logs: Vec<String> = logs.iter().map(|l| l.display().to_string()).collect();
        let parts: Vec<LogPartBytes> = workers
            .call(|py, decode| decode.call1(py, (logs,))?.extract(py))
            .map_err(Error::Failed)?;
        parts.into_iter().map(decode_part).collect()
    };
    let report = py.detach(|| params.run_with(&[], Some(&mut remote)));
    workers.report(report)
}

/// A policy from a policy artifact (`dagger train`, the dagger stage).
#[pyclass(frozen)]
struct Policy {
    policy: imitate::dagger::Policy,
    /// The artifact's digest.
    #[pyo3(get)]
    digest: String,
    /// What each observation holds, in order (empty when the artifact does not say).
    #[pyo3(get)]
    observation_names: Vec<String>,
}

#[pymethods]
impl Policy {
    #[new]
    fn load(path: PathBuf) -> PyResult<Self> {
        let (policy, digest) = imitate::dagger::load_policy_artifact(&path).map_err(raise)?;
        let observation_names = imitate::dagger::policy_observation_names(&path);
        Ok(Policy {
            policy,
            digest,
            observation_names,
        })
    }

    /// Actions [n, actions] for observations [n, observations] (float64), as the
    /// policy acts in `dagger rollout` and its ONNX export.
    fn act<'py>(
        &self,
        py: Python<'py>,
        observations: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let view = observations.as_array();
        let expected = self.observation_names.len();
        if expected > 0 && view.ncols() != expected {
            return Err(InputError::new_err(format!(
                "observations hold {} numbers each; the policy reads {expected} ({})",
                view.ncols(),
                self.observation_names.join(", ")
            )));
        }
        let rows: Vec<Vec<f64>> = view.rows().into_iter().map(|r| r.to_vec()).collect();
        let actions: Vec<Vec<f64>> =
            py.detach(|| rows.iter().map(|x| self.policy.act_all(x)).collect());
        let width = actions.first().map_or(0, Vec::len);
        let flat: Vec<f64> = actions.into_iter().flatten().collect();
        Ok(
            Array2::from_shape_vec((flat.len() / width.max(1), width), flat)
                .expect("one action vector per observation")
                .into_pyarray(py),
        )
    }
}

/// Appends Parquet tables to the DAgger dataset at `dataset` as one round: expert
/// demonstrations, or with `executed` a round the learner drove and the teacher
/// labelled. Returns (round number, whether it is new).
#[pyfunction]
#[pyo3(signature = (dataset, tables, observations, action, episode = "episode_index".to_string(), executed = None))]
fn append_round(
    py: Python<'_>,
    dataset: PathBuf,
    tables: Vec<PathBuf>,
    observations: Vec<String>,
    action: String,
    episode: String,
    executed: Option<String>,
) -> PyResult<(u32, bool)> {
    use imitate::dagger::demo_round::{Appended, DemoColumns, append_demonstrations};
    let columns = DemoColumns::parse(&episode, &observations, &action, executed.as_deref())
        .map_err(UsageError::new_err)?;
    let appended = py
        .detach(|| append_demonstrations(&dataset, &[tables], &columns))
        .map_err(raise)?;
    Ok(match appended {
        Appended::Already { round } => (round, false),
        Appended::New { round, .. } => (round, true),
    })
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("ImitateError", m.py().get_type::<ImitateError>())?;
    m.add("InputError", m.py().get_type::<InputError>())?;
    m.add("UsageError", m.py().get_type::<UsageError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<Policy>()?;
    m.add_class::<LearchShard>()?;
    for f in [
        wrap_pyfunction!(run_stage, m)?,
        wrap_pyfunction!(stage_kinds, m)?,
        wrap_pyfunction!(run_pipeline, m)?,
        wrap_pyfunction!(read_costmap, m)?,
        wrap_pyfunction!(read_features, m)?,
        wrap_pyfunction!(read_paths, m)?,
        wrap_pyfunction!(compute_features, m)?,
        wrap_pyfunction!(plan, m)?,
        wrap_pyfunction!(append_round, m)?,
        wrap_pyfunction!(learch_training_examples, m)?,
        wrap_pyfunction!(run_learch_distributed, m)?,
        wrap_pyfunction!(ingest_log_part, m)?,
        wrap_pyfunction!(run_ingest_distributed, m)?,
    ] {
        m.add_function(f)?;
    }
    Ok(())
}
