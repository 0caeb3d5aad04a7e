//! `imitate log ARTIFACT`: the stored versions of an artifact (from the workspace's
//! output cache), oldest first, with what changed between them.

use std::path::{Path, PathBuf};

use clap::Args;
use serde::Serialize;

use crate::artifact::{MANIFEST, Manifest, RUN_INFO};
use crate::error::{Error, Result};
use crate::pipeline::differences;

#[derive(Debug, Args)]
pub struct LogArgs {
    /// The artifact folder, as the pipeline names it (e.g. out/quickstart/costmap).
    pub artifact: PathBuf,
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Version {
    digest: String,
    finished_unix_s: u64,
    finished: String,
    current: bool,
    changes: Vec<String>,
}

/// Days since 1970-01-01 to a (year, month, day) date (H. Hinnant's civil_from_days).
fn civil(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let month = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(month <= 2), month, day)
}

fn timestamp(unix: u64) -> String {
    let (y, m, d) = civil((unix / 86_400) as i64);
    let s = unix % 86_400;
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        s / 3600,
        s / 60 % 60,
        s % 60
    )
}

/// When a version was made, in milliseconds since 1970 (0 when unknown).
fn finished_ms(dir: &Path) -> u64 {
    let run = std::fs::read(dir.join(RUN_INFO))
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok());
    run.and_then(|v| {
        v["finished_unix_ms"]
            .as_u64()
            .or_else(|| v["finished_unix_s"].as_u64().map(|s| s * 1000))
    })
    .unwrap_or(0)
}

pub fn run(args: LogArgs) -> Result<()> {
    let wanted = args
        .artifact
        .to_string_lossy()
        .trim_end_matches('/')
        .to_string();
    let cache = Path::new(".imitate/cache/outputs");
    let mut versions: Vec<(u64, Manifest)> = Vec::new();
    if let Ok(entries) = std::fs::read_dir(cache) {
        for entry in entries.flatten() {
            let dir = entry.path();
            let Some(manifest) = std::fs::read(dir.join(MANIFEST))
                .ok()
                .and_then(|b| serde_json::from_slice::<Manifest>(&b).ok())
            else {
                continue;
            };
            if manifest.lineage.params["out"].as_str() == Some(wanted.as_str()) {
                versions.push((finished_ms(&dir), manifest));
            }
        }
    }
    if versions.is_empty() {
        return Err(Error::input(
            &args.artifact,
            "no stored versions in this workspace's output cache (.imitate/cache): run the pipeline that makes it",
        ));
    }
    versions.sort_by(|a, b| (a.0, &a.1.digest).cmp(&(b.0, &b.1.digest)));
    let current = std::fs::read(args.artifact.join(MANIFEST))
        .ok()
        .and_then(|b| serde_json::from_slice::<Manifest>(&b).ok())
        .map(|m| m.digest);
    let report: Vec<Version> = versions
        .iter()
        .enumerate()
        .map(|(k, (when, manifest))| Version {
            digest: manifest.digest.clone(),
            finished_unix_s: when / 1000,
            finished: timestamp(when / 1000),
            current: current.as_deref() == Some(manifest.digest.as_str()),
            changes: match k {
                0 => vec!["first version".into()],
                _ => differences(
                    &manifest.lineage.stage,
                    &versions[k - 1].1.lineage,
                    &manifest.lineage,
                ),
            },
        })
        .collect();
    if args.json {
        let json = serde_json::json!({ "schema": "imitate.log/1", "artifact": wanted, "versions": report });
        outln!("{json}");
    } else {
        for v in &report {
            let mark = if v.current { " (current)" } else { "" };
            outln!(
                "{} {}{mark}: {}",
                v.finished,
                v.digest,
                v.changes.join("; ")
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timestamps_are_utc_iso_8601() {
        assert_eq!(timestamp(0), "1970-01-01T00:00:00Z");
        assert_eq!(timestamp(951_782_400), "2000-02-29T00:00:00Z");
        // Checked against Python: datetime.fromtimestamp(1795162756, timezone.utc).
        assert_eq!(timestamp(1_795_162_756), "2026-11-20T08:19:16Z");
    }
}
