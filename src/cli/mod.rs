//! The command line: one file per subcommand; `main.rs` only calls `run`.

mod bench;
mod plan;
mod testdata;

use std::path::PathBuf;

use clap::{Parser, Subcommand};

use crate::error::{Error, Result};
use crate::stage::{Stage, StageReport, features, ingest, learch};

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
    /// Run a pipeline file (default: imitate.yaml).
    Run {
        #[arg(default_value = "imitate.yaml")]
        pipeline: PathBuf,
    },
    /// Ingest maps and demonstrations into a dataset.
    Ingest(ingest::IngestParams),
    /// Compute per-cell feature stacks of a dataset's maps.
    Features(features::FeaturesParams),
    /// Learn a costmap with LEARCH.
    Learch(learch::LearchParams),
    /// Plan the cheapest path between two points on a costmap.
    Plan(plan::PlanArgs),
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
        Command::Run { pipeline } => {
            let reports = crate::pipeline::run(&pipeline, |name, report| {
                eprintln!("{name}: {}", report.summary);
            })?;
            for (name, report) in reports {
                print_report(&name, &report);
            }
            Ok(())
        }
        Command::Ingest(params) => run_stage(&params),
        Command::Features(params) => run_stage(&params),
        Command::Learch(params) => run_stage(&params),
        Command::Testdata(command) => testdata::run(command),
        Command::Bench(command) => bench::run(command),
        Command::Plan(args) => plan::run(args),
    }
}

fn run_stage(stage: &dyn Stage) -> Result<()> {
    let report = stage.run()?;
    eprintln!("{}: {}", stage.kind(), report.summary);
    print_report(stage.kind(), &report);
    Ok(())
}

/// stdout carries data: one line per output, "stage<TAB>path<TAB>digest".
fn print_report(name: &str, report: &StageReport) {
    println!("{name}\t{}\t{}", report.output.display(), report.digest);
}
