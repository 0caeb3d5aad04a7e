//! The costmap a command or stage plans on: a costmap table, or one map of a costmap
//! artifact folder.

use std::path::Path;

use super::read_manifest;
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::io::tables::read_costmap;

/// Loads the costmap named by `path` (an artifact folder or a table) and its map name.
pub fn load_costs(path: &Path, map: Option<&str>) -> Result<(String, Grid<f32>)> {
    if !path.is_dir() {
        return read_costmap(path);
    }
    let manifest = read_manifest(path, "costmap")?;
    let files: Vec<_> = manifest.files_with_role("costmap").collect();
    let names: Vec<String> = files
        .iter()
        .map(|f| {
            f.path
                .trim_start_matches("costmaps/")
                .trim_end_matches(".parquet")
                .to_string()
        })
        .collect();
    let chosen = match map {
        Some(m) => names.iter().position(|n| n == m).ok_or_else(|| {
            Error::Usage(format!(
                "{} has no map '{m}' (it has: {})",
                path.display(),
                names.join(", ")
            ))
        })?,
        None if files.len() == 1 => 0,
        None => {
            return Err(Error::Usage(format!(
                "{} holds {} maps; choose one with --map ({})",
                path.display(),
                files.len(),
                names.join(", ")
            )));
        }
    };
    read_costmap(&path.join(&files[chosen].path))
}
