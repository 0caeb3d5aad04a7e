//! The command line: one file per subcommand; `main.rs` only calls `run`.

mod bench;
mod cache;
mod dagger;
mod diff;
mod inspect_artifact;
mod log;
mod mcap;
mod plan;
mod testdata;
mod verify;

use std::path::PathBuf;

use clap::{Parser, Subcommand};

use crate::error::{Error, Result};
use crate::pipeline::RunOptions;
use crate::stage::{
    Stage, StageReport, evaluate, export, features, forecast, ingest, ioc, learch, report,
};

#[derive(Debug, Parser)]
#[command(
    name = "imitate",
    version,
    about = "Learn costmaps and policies from robot demonstrations"
)]
pub struct Cli {
    /// Run as if started in DIR (pipeline paths are relative to it).
    #[arg(short = 'C', global = true, value_name = "DIR")]
    pub directory: Option<PathBuf>,
    /// More log output on stderr (-v info, -vv debug).
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the stale stages of a pipeline file (default: imitate.yaml); the lock file
    /// beside it (imitate.lock) records what each stage last ran with.
    Run {
        #[arg(default_value = "imitate.yaml")]
        pipeline: PathBuf,
        /// Say which stages would run and why; run nothing.
        #[arg(long)]
        dry_run: bool,
        /// Rerun stages even when they are up to date.
        #[arg(long)]
        force: bool,
        /// Only this stage (its inputs must exist).
        #[arg(long, value_name = "NAME")]
        stage: Option<String>,
        /// With --stage: also every later stage that reads what it writes.
        #[arg(long, requires = "stage")]
        downstream: bool,
        /// Run up to this many independent stages at once.
        #[arg(short, long, default_value_t = 1)]
        jobs: usize,
        /// Let outputs resolve outside the workspace through symbolic links (an `out`
        /// folder linked to another disk, say); refused otherwise.
        #[arg(long)]
        allow_outside_workspace: bool,
    },
    /// Which stages of a pipeline are stale, and why.
    Status {
        #[arg(default_value = "imitate.yaml")]
        pipeline: PathBuf,
        #[arg(long)]
        json: bool,
        /// Exit with code 1 when a stage is stale (like `make -q`).
        #[arg(long)]
        exit_code: bool,
    },
    /// Ingest maps and demonstrations into a dataset.
    Ingest(ingest::IngestParams),
    /// Compute per-cell feature stacks of a dataset's maps.
    Features(features::FeaturesParams),
    /// Learn a costmap with LEARCH.
    Learch(learch::LearchParams),
    /// Learn a reward on a tabular MDP from Parquet (LEARCH, MMP or MaxEnt).
    Ioc(ioc::IocParams),
    /// The stored versions of an artifact, with what changed between them.
    Log(log::LogArgs),
    /// What an MCAP file holds (channels, schemas, counts, time range, chunks), a raster
    /// as imitate reads it (grid, CRS, ground cell size, layers' ranges), or an artifact
    /// or DAgger dataset folder (kind, digest, lineage, metrics, rounds).
    Inspect(mcap::InspectArgs),
    /// Decoded messages of an MCAP file (ROS 2 CDR, JSON, protobuf), one per line.
    Cat(mcap::CatArgs),
    /// What changed between two artifacts (folders or stored versions); thresholds set
    /// the exit code for CI.
    Diff(diff::DiffArgs),
    /// The workspace's output cache (`.imitate/cache`): its size, and garbage collection.
    #[command(subcommand)]
    Cache(cache::CacheCommand),
    /// Check artifacts and DAgger datasets against their manifests (every file's size and
    /// digest), and MCAP files against their chunk CRCs; exit 2 naming what is damaged.
    Verify(verify::VerifyArgs),
    /// A costmap artifact as PNG (with a colour bar), GeoTIFF, MCAP (for Foxglove) and
    /// Nav2 maps, or a policy artifact as an ONNX model: an artifact of those files.
    Export(export::ExportParams),
    /// A report on a costmap artifact: markdown and self-contained HTML with previews,
    /// learning curves and metrics.
    Report(report::ReportParams),
    /// Plan on a costmap between the ends of every path of a dataset (a fixed
    /// evaluation set) and score the plans: agreement with the paths, and cost ratios
    /// under reference costmaps.
    Evaluate(evaluate::EvaluateParams),
    /// Plan the cheapest path between two points on a costmap.
    Plan(plan::PlanArgs),
    /// Forecast where a partly walked path goes: the posterior over candidate
    /// destinations and the expected visitation, under a MaxEnt costmap.
    Forecast(forecast::ForecastParams),
    /// DAgger rounds on disk: init a dataset, add rounds driven by the teacher or a
    /// policy (labelled by the teacher), train a policy artifact, roll it out, status.
    #[command(subcommand)]
    Dagger(dagger::DaggerCommand),
    /// Generate synthetic test data.
    #[command(subcommand)]
    Testdata(testdata::TestdataCommand),
    /// Measure the core algorithms.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
}

/// Runs the parsed command; the caller maps the error to an exit code.
pub fn run(cli: Cli) -> Result<()> {
    if let Some(dir) = &cli.directory {
        std::env::set_current_dir(dir)
            .map_err(|e| Error::input(dir, format!("cannot change into it: {e}")))?;
    }
    match cli.command {
        Command::Run {
            pipeline,
            dry_run,
            force,
            stage,
            downstream,
            jobs,
            allow_outside_workspace,
        } => {
            let options = RunOptions {
                force,
                only: stage,
                downstream,
                jobs,
                dry_run,
                allow_outside_workspace,
            };
            let outcomes = crate::pipeline::run(&pipeline, &options, |o| {
                match (&o.summary, o.reasons.is_empty()) {
                    (_, true) => eprintln!("{}: up to date", o.name),
                    (Some(summary), false) => {
                        eprintln!("{}: {summary} ({})", o.name, o.reasons.join("; "))
                    }
                    (None, false) => eprintln!("{}: would run ({})", o.name, o.reasons.join("; ")),
                }
            })?;
            for o in outcomes {
                match &o.digest {
                    Some(digest) => outln!("{}\t{}\t{digest}", o.name, o.out.display()),
                    None => outln!(
                        "{}\t{}\twould run: {}",
                        o.name,
                        o.out.display(),
                        o.reasons.join("; ")
                    ),
                }
            }
            Ok(())
        }
        Command::Status {
            pipeline,
            json,
            exit_code,
        } => {
            let options = RunOptions {
                dry_run: true,
                ..RunOptions::default()
            };
            let outcomes = crate::pipeline::run(&pipeline, &options, |_| {})?;
            let stale = outcomes.iter().filter(|o| !o.reasons.is_empty()).count();
            if json {
                let report = serde_json::json!({ "schema": "imitate.status/1", "stale": stale, "stages": outcomes });
                outln!("{report}");
            } else {
                for o in &outcomes {
                    if o.reasons.is_empty() {
                        outln!("{}: up to date", o.name);
                    } else {
                        outln!("{}: stale: {}", o.name, o.reasons.join("; "));
                    }
                }
            }
            if exit_code && stale > 0 {
                return Err(Error::Stale(format!(
                    "{stale} stage(s) of {} are stale",
                    pipeline.display()
                )));
            }
            Ok(())
        }
        Command::Ingest(params) => run_stage(&params),
        Command::Features(params) => run_stage(&params),
        Command::Learch(params) => run_stage(&params),
        Command::Ioc(params) => run_stage(&params),
        Command::Testdata(command) => testdata::run(command),
        Command::Dagger(command) => dagger::run(command),
        Command::Bench(command) => bench::run(command),
        Command::Plan(args) => plan::run(args),
        Command::Forecast(args) => run_stage(&args),
        Command::Log(args) => log::run(args),
        Command::Inspect(args) => mcap::inspect_command(args),
        Command::Cat(args) => mcap::cat_command(args),
        Command::Diff(args) => diff::run(args),
        Command::Verify(args) => verify::run(args),
        Command::Cache(command) => cache::run(command),
        Command::Export(args) => run_stage(&args),
        Command::Report(args) => run_stage(&args),
        Command::Evaluate(args) => run_stage(&args),
    }
}

fn run_stage(stage: &dyn Stage) -> Result<()> {
    // A wrong --out fails here, before any work.
    crate::artifact::check_replaceable(&stage.out())?;
    let report = stage.run(&[])?;
    eprintln!("{}: {}", stage.kind(), report.summary);
    print_report(stage.kind(), &report);
    Ok(())
}

/// stdout carries data: one line per output, "stage<TAB>path<TAB>digest".
fn print_report(name: &str, report: &StageReport) {
    outln!("{name}\t{}\t{}", report.output.display(), report.digest);
}

/// Writes command output to stdout. A closed pipe ends the process with success, as
/// Unix tools do (the reader took what it wanted); any other failure is an error.
/// Prints a report: JSON for scripts, or the text `describe` makes for people.
pub(crate) fn emit<T: serde::Serialize>(
    report: &T,
    json: bool,
    describe: impl FnOnce(&T) -> String,
) {
    let text = if json {
        serde_json::to_string(report).expect("reports serialise")
    } else {
        describe(report)
    };
    crate::cli::write_stdout(format_args!("{text}\n"));
}

pub(crate) fn write_stdout(text: std::fmt::Arguments) {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    if let Err(e) = stdout.write_fmt(text).and_then(|()| stdout.flush()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("error: writing to stdout: {e}");
        std::process::exit(1);
    }
}
