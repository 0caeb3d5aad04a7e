//! `imitate bench ...`: the benchmark commands. The harnesses are in `crate::bench`.

use std::path::PathBuf;

use clap::Subcommand;

use crate::bench;
use crate::error::Result;
use crate::plan::{Connectivity, SearchKind};

#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Solve every scenario of a MovingAI benchmark (8-connected, diagonal √2, no corner
    /// cutting) and compare with the optimal lengths (relative tolerance 1e-4).
    Movingai {
        map: PathBuf,
        scen: PathBuf,
        /// The planner to answer the queries with.
        #[arg(long, value_enum, default_value_t = SearchKind::Astar)]
        planner: SearchKind,
        #[arg(long)]
        json: bool,
    },
    /// Feature operators over a synthetic SIZE x SIZE map with 4 layers (about 32
    /// features), with peak memory against the size of the output stack.
    Features {
        #[arg(long, default_value_t = 4096)]
        size: u32,
        #[arg(long, default_value_t = 3)]
        repeat: usize,
        /// Write the layers (raw f32) and the spec here for the NumPy/SciPy peer script.
        #[arg(long, value_name = "DIR", conflicts_with = "bank")]
        dump: Option<PathBuf>,
        /// Time a feature bank on the map's four layers instead of the fixed spec.
        #[arg(long, value_enum)]
        bank: Option<crate::features::Bank>,
        #[arg(long)]
        json: bool,
    },
    /// Digest speed of input files (blake3, as the pipeline hashes them).
    Hash {
        /// A file to hash; without it, a temporary file of --size-mib random bytes.
        file: Option<PathBuf>,
        #[arg(long, default_value_t = 1024)]
        size_mib: usize,
        #[arg(long, default_value_t = 3)]
        repeat: usize,
        #[arg(long)]
        json: bool,
    },
    /// What checking an artifact's digests costs beside decoding its tables.
    Verify(bench::verify::VerifyBenchArgs),
    /// Inverse optimal control methods on the GPIRL objectworld benchmark: expected value
    /// difference per method and number of demonstrations, over seeds.
    Objectworld(bench::objectworld::ObjectworldArgs),
    /// Held-out path agreement of LEARCH (ridge, trees), MMP and MaxEnt on the
    /// quickstart terrain and on a GeoTIFF terrain, as one table.
    IocMethods(bench::ioc_methods::IocMethodsArgs),
    /// The hidden-teacher protocol on rasters: held-out agreement and true-cost ratio of
    /// every IOC method with the default feature bank, beside a uniform-cost baseline.
    Terrain(bench::terrain::TerrainArgs),
    /// Behaviour cloning against DAgger on the lane-keeping circuit: falls per lap per
    /// iteration, same teacher labels per iteration.
    Track(bench::track::TrackBenchArgs),
    /// Behaviour cloning against DAgger on gridnav: success rate and path-cost ratio
    /// per iteration, same teacher labels per iteration.
    Gridnav(bench::gridnav::GridnavBenchArgs),
    /// A DAgger dataset of many steps: append a round, retrain a ridge policy on all.
    DaggerScale(bench::dagger_scale::DaggerScaleArgs),
    /// One LEARCH round on many large examples, on 1 and on all threads, with the share
    /// spent planning.
    Learch(bench::learch::LearchBenchArgs),
    /// Decode and ingest a large robot log (MCAP: 100 Hz odometry, 10 Hz 512×512
    /// occupancy grids, zstd chunks): throughput and peak memory.
    Ingest(bench::ingest::IngestBenchArgs),
    /// Single-source Dijkstra over a whole costmap, one thread, best of several runs.
    Dijkstra {
        /// Raw little-endian f32 costs, row by row (e.g. numpy's `tofile`).
        #[arg(long, value_name = "FILE", requires_all = ["width", "height"])]
        costs: Option<PathBuf>,
        #[arg(long)]
        width: Option<u32>,
        #[arg(long)]
        height: Option<u32>,
        /// Without --costs: a SIZE x SIZE grid of costs uniform in [1, 10].
        #[arg(long, default_value_t = 1000)]
        size: u32,
        #[arg(long, default_value_t = 0)]
        seed: u64,
        #[arg(long, default_value_t = 5)]
        repeat: usize,
        #[arg(long, value_enum, default_value_t = Connectivity::Eight)]
        connectivity: Connectivity,
        #[arg(long)]
        json: bool,
    },
}

pub fn run(command: BenchCommand) -> Result<()> {
    match command {
        BenchCommand::Movingai {
            map,
            scen,
            planner,
            json,
        } => bench::movingai(map, scen, planner, json),
        BenchCommand::Ingest(args) => bench::ingest::run(args),
        BenchCommand::Verify(args) => bench::verify::run(args),
        BenchCommand::Learch(args) => bench::learch::run(args),
        BenchCommand::Objectworld(args) => bench::objectworld::run(args),
        BenchCommand::IocMethods(args) => bench::ioc_methods::run(args),
        BenchCommand::Terrain(args) => bench::terrain::run(args),
        BenchCommand::Track(args) => bench::track::run(args),
        BenchCommand::DaggerScale(args) => bench::dagger_scale::run(args),
        BenchCommand::Gridnav(args) => bench::gridnav::run(args),
        BenchCommand::Hash {
            file,
            size_mib,
            repeat,
            json,
        } => bench::hash(file, size_mib, repeat.max(1), json),
        BenchCommand::Features {
            size,
            repeat,
            dump,
            bank,
            json,
        } => bench::features(size, repeat.max(1), dump, bank, json),
        BenchCommand::Dijkstra {
            costs,
            width,
            height,
            size,
            seed,
            repeat,
            connectivity,
            json,
        } => {
            let grid = match costs {
                Some(path) => {
                    bench::read_raw_costs(&path, width.unwrap_or(0), height.unwrap_or(0))?
                }
                None => bench::uniform_costs(size, seed),
            };
            bench::dijkstra(&grid, repeat.max(1), connectivity, json)
        }
    }
}
