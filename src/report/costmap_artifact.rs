//! A costmap artifact read back whole: manifest, costmaps, example paths and metrics,
//! for diff, report and export.

use std::path::{Path, PathBuf};

use crate::artifact::{MANIFEST, Manifest};
use crate::error::{Error, Result, read_input};
use crate::grid::Grid;
use crate::io::tables::{EpisodePath, read_costmap, read_paths};

/// The artifact schema major version this build reads.
const COSTMAP_SCHEMA_MAJOR: &str = "1";

pub struct CostmapArtifact {
    pub dir: PathBuf,
    pub manifest: Manifest,
    /// (map name, costs), in the manifest's order.
    pub costmaps: Vec<(String, Grid<f32>)>,
    /// Demonstrated cell paths (training, then held out); empty for artifacts made
    /// before they were stored.
    pub paths: Vec<EpisodePath>,
    pub metrics: serde_json::Value,
}

/// Any artifact's manifest, with errors that name the folder.
pub fn read_any_manifest(dir: &Path) -> Result<Manifest> {
    if !dir.is_dir() {
        return Err(Error::input(dir, "no such artifact folder"));
    }
    let path = dir.join(MANIFEST);
    let manifest: Manifest = serde_json::from_slice(&read_input(&path)?)
        .map_err(|e| Error::input(&path, format!("not a valid manifest: {e}")))?;
    // Compared, reported or exported, the contents are what the manifest says.
    crate::artifact::verify_entries(dir, &manifest.files)?;
    Ok(manifest)
}

impl CostmapArtifact {
    pub fn load(dir: &Path) -> Result<Self> {
        let manifest = read_any_manifest(dir)?;
        if manifest.kind != "costmap" {
            return Err(Error::input(
                dir,
                format!("is a '{}' artifact, not a costmap", manifest.kind),
            ));
        }
        let major = manifest
            .schema_version
            .split('.')
            .next()
            .unwrap_or_default();
        if major != COSTMAP_SCHEMA_MAJOR {
            return Err(Error::input(
                dir,
                format!(
                    "costmap schema version {} is not one this imitate reads ({COSTMAP_SCHEMA_MAJOR}.x)",
                    manifest.schema_version
                ),
            ));
        }
        let costmaps = manifest
            .files_with_role("costmap")
            .map(|f| {
                let path = dir.join(&f.path);
                let (name, grid) = read_costmap(&path)?;
                // Exports and reports name files after the map.
                crate::grid::check_map_name(&name).map_err(|why| Error::input(&path, why))?;
                Ok((name, grid))
            })
            .collect::<Result<Vec<_>>>()?;
        let paths = match manifest.files_with_role("paths").next() {
            Some(f) => read_paths(&dir.join(&f.path))?,
            None => Vec::new(),
        };
        let metrics = match manifest.files_with_role("metrics").next() {
            Some(f) => {
                let path = dir.join(&f.path);
                serde_json::from_slice(&read_input(&path)?)
                    .map_err(|e| Error::input(&path, format!("not JSON: {e}")))?
            }
            None => serde_json::Value::Null,
        };
        Ok(CostmapArtifact {
            dir: dir.to_path_buf(),
            manifest,
            costmaps,
            paths,
            metrics,
        })
    }

    pub fn costmap(&self, map: &str) -> Option<&Grid<f32>> {
        self.costmaps.iter().find(|(n, _)| n == map).map(|(_, g)| g)
    }

    /// Names of the held-out examples, from the metrics.
    pub fn holdout_names(&self) -> Vec<String> {
        self.metrics
            .pointer("/holdout/examples")
            .and_then(|e| e.as_array())
            .map(|examples| {
                examples
                    .iter()
                    .filter_map(|e| e.get("example").and_then(|n| n.as_str()))
                    .map(String::from)
                    .collect()
            })
            .unwrap_or_default()
    }

    /// A number of the held-out summary (e.g. `within_radius`); none when nothing was
    /// held out, whose summary's zeros measure nothing.
    pub fn holdout_metric(&self, name: &str) -> Option<f64> {
        let summary = self.metrics.pointer("/holdout/summary")?;
        if summary.get("examples").and_then(|n| n.as_u64()) == Some(0) {
            return None;
        }
        summary.get(name).and_then(|v| v.as_f64())
    }
}
