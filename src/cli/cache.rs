//! `imitate cache status | gc`: what the workspace's output cache holds, and bounding it.

use clap::Subcommand;

use crate::error::{Error, Result};
use crate::pipeline::{CachedOutput, cache_gc, cache_outputs};

#[derive(Subcommand, Debug)]
pub enum CacheCommand {
    /// The cached outputs, most recently used first, and their total size.
    Status {
        #[arg(long)]
        json: bool,
    },
    /// Remove cached outputs: all but the N most recently used, and/or the least
    /// recently used until the cache fits in SIZE (bytes, or with K, M, G: 500M, 2G).
    Gc {
        #[arg(long, value_name = "N")]
        keep_last: Option<usize>,
        #[arg(long, value_name = "SIZE", value_parser = parse_size)]
        max_size: Option<u64>,
    },
}

pub fn run(command: CacheCommand) -> Result<()> {
    match command {
        CacheCommand::Status { json } => {
            let outputs = cache_outputs()?;
            let total: u64 = outputs.iter().map(|o| o.bytes).sum();
            if json {
                let report = serde_json::json!({
                    "schema": "imitate.cache-status/1",
                    "outputs": outputs,
                    "bytes": total,
                });
                outln!("{report}");
            } else {
                for o in &outputs {
                    outln!("{}", line(o));
                }
                outln!("{} outputs, {}", outputs.len(), human(total));
            }
            Ok(())
        }
        CacheCommand::Gc {
            keep_last,
            max_size,
        } => {
            if keep_last.is_none() && max_size.is_none() {
                return Err(Error::Usage(
                    "cache gc needs --keep-last N and/or --max-size SIZE".into(),
                ));
            }
            let removed = cache_gc(keep_last, max_size)?;
            for o in &removed {
                outln!("removed {}", line(o));
            }
            let freed: u64 = removed.iter().map(|o| o.bytes).sum();
            eprintln!(
                "cache gc: removed {} outputs, {}",
                removed.len(),
                human(freed)
            );
            Ok(())
        }
    }
}

fn line(o: &CachedOutput) -> String {
    format!(
        "{}\t{}\t{}\t{} key(s)\tlast used {}",
        o.digest,
        o.kind,
        human(o.bytes),
        o.keys,
        o.last_used_unix_s
    )
}

fn human(bytes: u64) -> String {
    const UNITS: [&str; 4] = ["B", "KiB", "MiB", "GiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    match unit {
        0 => format!("{bytes} B"),
        _ => format!("{value:.1} {}", UNITS[unit]),
    }
}

/// Bytes from "1234", "500K", "500M", "2G" (powers of 1024).
fn parse_size(text: &str) -> std::result::Result<u64, String> {
    let text = text.trim();
    let (number, shift) = match text.chars().last().map(|c| c.to_ascii_uppercase()) {
        Some('K') => (&text[..text.len() - 1], 10),
        Some('M') => (&text[..text.len() - 1], 20),
        Some('G') => (&text[..text.len() - 1], 30),
        _ => (text, 0),
    };
    let value: f64 = number
        .trim()
        .parse()
        .map_err(|_| format!("'{text}' is not a size (as 1234, 500M or 2G)"))?;
    if !(value.is_finite() && value >= 0.0) {
        return Err(format!("'{text}' is not a size"));
    }
    Ok((value * (1u64 << shift) as f64) as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_units() {
        assert_eq!(parse_size("1234"), Ok(1234));
        assert_eq!(parse_size("500M"), Ok(500 << 20));
        assert_eq!(parse_size("2g"), Ok(2 << 30));
        assert_eq!(parse_size("1.5K"), Ok(1536));
        assert!(parse_size("lots").is_err());
        assert!(parse_size("-1").is_err());
    }
}
