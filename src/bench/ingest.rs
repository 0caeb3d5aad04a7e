//! `imitate bench ingest`: decode and ingest a large robot log (100 Hz odometry, 10 Hz
//! 512×512 occupancy grids, zstd chunks), with throughput and peak memory.

use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::{memory, reset_peak_memory};
use crate::cli::emit;
use crate::error::{Error, Result};
use crate::grid::GeoRef;
use crate::io::mcap::episodes::{Split, TopicMapping, read_log};
use crate::io::mcap::inspect::{Source, inspect};
use crate::io::mcap::ros2;
use crate::io::mcap::writer::write_log;

#[derive(Debug, clap::Args)]
pub struct IngestBenchArgs {
    /// The log to read (made first with --generate).
    pub file: PathBuf,
    /// Write a log of at least --megabytes to FILE and stop.
    #[arg(long)]
    pub generate: bool,
    #[arg(long, default_value_t = 200)]
    pub megabytes: u64,
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    #[arg(long)]
    pub json: bool,
}

const GRID: u32 = 512;
const SECOND: u64 = 1_000_000_000;

/// Writes the benchmark log: per 0.1 s one grid on /map and ten odometry messages on
/// /odom, until the file holds `megabytes`. Grid cells are random occupancies (0–100,
/// with 5 % unknown), which zstd cannot shrink much: the file size is mostly grid bytes.
fn generate(path: &Path, megabytes: u64) -> Result<()> {
    let geo = GeoRef::square(GRID, GRID, 0.05, [-12.8, -12.8], "map");
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    // zstd takes about 17 % off random occupancies: write enough grids for the size.
    let grids = (megabytes * 1_000_000).div_ceil(u64::from(GRID * GRID) * 83 / 100);
    write_log(path, |log| {
        let map = log.channel(
            "/map",
            "nav_msgs/msg/OccupancyGrid",
            &ros2::schemas::occupancy_grid(),
        )?;
        let odom = log.channel("/odom", "nav_msgs/msg/Odometry", &ros2::schemas::odometry())?;
        let start = 1_700_000_000 * SECOND;
        for k in 0..grids {
            let t = start + k * SECOND / 10;
            let cells: Vec<i8> = (0..GRID * GRID)
                .map(|_| {
                    let v: u8 = rng.random_range(0..105);
                    if v > 100 { -1 } else { v as i8 }
                })
                .collect();
            log.write(map, t, &ros2::occupancy_grid(t, &geo, cells))?;
            for step in 0..10 {
                let ts = t + step * SECOND / 100;
                let angle = ts as f64 * 1e-9 * 0.05;
                let message = ros2::odometry(
                    ts,
                    "map",
                    "base_link",
                    10.0 * angle.cos(),
                    10.0 * angle.sin(),
                    angle + 1.57,
                );
                log.write(odom, ts, &message)?;
            }
        }
        Ok(())
    })
}

#[derive(Serialize)]
struct IngestBenchReport {
    schema: &'static str,
    file: String,
    file_bytes: u64,
    messages: u64,
    chunks: u64,
    largest_chunk_bytes: u64,
    poses: usize,
    grid_cells: usize,
    seconds: f64,
    megabytes_per_second: f64,
    /// Peak resident memory while reading, above what the process held before.
    peak_extra_bytes: u64,
}

pub fn run(args: IngestBenchArgs) -> Result<()> {
    if args.generate {
        generate(&args.file, args.megabytes)?;
        eprintln!("bench ingest: wrote {}", args.file.display());
        return Ok(());
    }
    let report = inspect(&args.file, Source::Summary, false)?;
    if !report.channels.iter().any(|c| c.topic == "/map") {
        return Err(Error::input(
            &args.file,
            "is not a benchmark log (no /map topic); make one with --generate",
        ));
    }
    let mapping = TopicMapping {
        map_topic: Some("/map".into()),
        pose_topic: Some("/odom".into()),
        goal_topic: None,
        split: Split::File,
        gap_seconds: 1.0,
        transform: None,
        allow_truncated: false,
    };
    let largest_chunk = largest_chunk(&args.file)?;
    let mut best = f64::INFINITY;
    let mut peak_extra = 0;
    let mut contents = None;
    for _ in 0..args.repeat.max(1) {
        drop(contents.take());
        reset_peak_memory();
        let (before, _) = memory();
        let start = Instant::now();
        let read = read_log(&args.file, &mapping, None)?;
        best = best.min(start.elapsed().as_secs_f64());
        let (_, peak) = memory();
        peak_extra = peak_extra.max(peak.saturating_sub(before));
        contents = Some(read);
    }
    let contents = contents.expect("at least one run");
    let result = IngestBenchReport {
        schema: "imitate.bench.ingest/1",
        file: args.file.display().to_string(),
        file_bytes: report.bytes,
        messages: report.message_count,
        chunks: report.chunks.count,
        largest_chunk_bytes: largest_chunk,
        poses: contents.demonstrations.iter().map(|d| d.poses.len()).sum(),
        grid_cells: contents.map.as_ref().map_or(0, |m| m.geo.cell_count()),
        seconds: best,
        megabytes_per_second: report.bytes as f64 / 1e6 / best,
        peak_extra_bytes: peak_extra,
    };
    emit(&result, args.json, |r| {
        format!(
            "ingest {}: {:.1} MB, {} messages in {} chunks (largest {:.1} MB uncompressed)\n\
             {:.3} s, {:.0} MB/s; peak extra memory {:.1} MB; {} poses, last grid {} cells",
            r.file,
            r.file_bytes as f64 / 1e6,
            r.messages,
            r.chunks,
            r.largest_chunk_bytes as f64 / 1e6,
            r.seconds,
            r.megabytes_per_second,
            r.peak_extra_bytes as f64 / 1e6,
            r.poses,
            r.grid_cells
        )
    });
    Ok(())
}

/// The largest uncompressed chunk: what bounds the reader's memory.
fn largest_chunk(path: &Path) -> Result<u64> {
    let mut largest = 0;
    crate::io::mcap::scan(path, |event| {
        if let crate::io::mcap::Event::Chunk { uncompressed, .. } = event {
            largest = largest.max(uncompressed);
        }
        Ok(())
    })?;
    Ok(largest)
}
