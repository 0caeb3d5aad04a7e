//! `imitate bench verify ARTIFACT`: what checking an artifact's digests costs beside
//! reading it, the figure behind "readers verify as they read".

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;

use crate::artifact::verify_entries;
use crate::error::{Error, Result, read_input};
use crate::io::tables::{read_costmap, read_features, read_map};

#[derive(Args, Debug)]
pub struct VerifyBenchArgs {
    /// An artifact folder holding maps, features or costmaps (a dataset, features or
    /// costmap artifact).
    pub artifact: PathBuf,
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: VerifyBenchArgs) -> Result<()> {
    let manifest: crate::artifact::Manifest =
        serde_json::from_slice(&read_input(&args.artifact.join(crate::artifact::MANIFEST))?)
            .map_err(|e| Error::input(&args.artifact, format!("not a valid manifest: {e}")))?;
    let tables: Vec<_> = manifest
        .files
        .iter()
        .filter(|f| matches!(f.role.as_str(), "map" | "features" | "costmap"))
        .cloned()
        .collect();
    if tables.is_empty() {
        return Err(Error::input(
            &args.artifact,
            "holds no map, features or costmap tables to read",
        ));
    }
    let bytes: u64 = tables.iter().map(|f| f.size).sum();
    let best = |work: &dyn Fn() -> Result<()>| -> Result<f64> {
        let mut best = f64::INFINITY;
        for _ in 0..args.repeat.max(1) {
            let started = Instant::now();
            work()?;
            best = best.min(started.elapsed().as_secs_f64());
        }
        Ok(best)
    };
    // Both in parallel over the files, as the stages read and verify them.
    let read = best(&|| {
        use rayon::prelude::*;
        let results: Vec<Result<()>> = tables
            .par_iter()
            .map(|f| {
                let path = args.artifact.join(&f.path);
                match f.role.as_str() {
                    "map" => read_map(&path).map(drop),
                    "features" => read_features(&path).map(drop),
                    _ => read_costmap(&path).map(drop),
                }
            })
            .collect();
        results.into_iter().collect()
    })?;
    let verify = best(&|| verify_entries(&args.artifact, &tables))?;
    let share = verify / read;
    if args.json {
        outln!(
            "{}",
            serde_json::json!({
                "artifact": args.artifact.display().to_string(),
                "files": tables.len(),
                "bytes": bytes,
                "threads": rayon::current_num_threads(),
                "read_s": read,
                "verify_s": verify,
                "verify_over_read": share,
            })
        );
    } else {
        outln!(
            "{}: {} tables, {:.1} MiB; read {read:.3} s, verify {verify:.3} s ({:.1} % of the read; best of {}, {} threads)",
            args.artifact.display(),
            tables.len(),
            bytes as f64 / (1 << 20) as f64,
            100.0 * share,
            args.repeat.max(1),
            rayon::current_num_threads()
        );
    }
    Ok(())
}
