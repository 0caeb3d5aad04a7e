//! `ingest`: maps and demonstrations in, a dataset out: the maps, the demonstrations,
//! and each demonstration rasterised into a connected 8-neighbour cell path.

use std::collections::BTreeSet;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::{Stage, StageReport, commit_artifact, resolved};
use crate::artifact::ArtifactBuilder;
use crate::error::{Error, Result};
use crate::grid::{PathError, rasterize};
use crate::io::tables::{
    EpisodePath, read_demonstrations, read_map, write_demonstrations, write_map, write_paths,
};

pub const KIND: &str = "ingest";
const VERSION: u32 = 1;

/// Parameters of `imitate ingest` and of `uses: ingest`.
#[derive(Debug, Clone, clap::Args, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IngestParams {
    /// Map rasters (Parquet `map/1` tables); repeat for several maps.
    #[arg(long = "map", required = true, value_name = "FILE")]
    pub maps: Vec<PathBuf>,
    /// Demonstrations (Parquet: episode, map, t, x, y[, yaw]).
    #[arg(long, value_name = "FILE")]
    pub demonstrations: PathBuf,
    /// The dataset folder to write.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

impl Stage for IngestParams {
    fn kind(&self) -> &'static str {
        KIND
    }

    fn version(&self) -> u32 {
        VERSION
    }

    fn params(&self) -> serde_json::Value {
        resolved(self)
    }

    fn deps(&self) -> Vec<PathBuf> {
        let mut deps = self.maps.clone();
        deps.push(self.demonstrations.clone());
        deps
    }

    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport> {
        let maps = self
            .maps
            .iter()
            .map(|p| read_map(p))
            .collect::<Result<Vec<_>>>()?;
        let mut names = BTreeSet::new();
        for (map, path) in maps.iter().zip(&self.maps) {
            if !names.insert(map.name.clone()) {
                return Err(Error::input(
                    path,
                    format!("a second map named '{}'", map.name),
                ));
            }
        }
        let demos = read_demonstrations(&self.demonstrations)?;
        let mut paths = Vec::with_capacity(demos.len());
        for demo in &demos {
            let problem = |message: String| {
                Error::input(
                    &self.demonstrations,
                    format!("episode '{}': {message}", demo.episode),
                )
            };
            let map = maps.iter().find(|m| m.name == demo.map).ok_or_else(|| {
                problem(format!(
                    "refers to map '{}', which is not among the maps given ({})",
                    demo.map,
                    names.iter().cloned().collect::<Vec<_>>().join(", ")
                ))
            })?;
            let cells = rasterize(&map.geo, &demo.xy()).map_err(|e| match e {
                PathError::OffMap { .. } => {
                    let [x0, y0, x1, y1] = map.geo.bounds();
                    problem(format!("{e} '{}' (x {x0}..{x1}, y {y0}..{y1})", map.name))
                }
                PathError::TooFewPoses(_) => problem(e.to_string()),
            })?;
            if cells.len() < 2 {
                return Err(problem(format!(
                    "starts and ends in the same cell {}",
                    cells[0]
                )));
            }
            paths.push(EpisodePath {
                episode: demo.episode.clone(),
                map: demo.map.clone(),
                cells,
            });
        }

        let mut out = ArtifactBuilder::new(&self.out)?;
        for map in &maps {
            write_map(
                &out.file(&format!("maps/{}.parquet", map.name), "map")?,
                map,
            )?;
        }
        write_demonstrations(
            &out.file("demonstrations.parquet", "demonstrations")?,
            &demos,
        )?;
        write_paths(&out.file("paths.parquet", "paths")?, &paths)?;
        let metrics = serde_json::json!({
            "maps": maps.len(),
            "demonstrations": demos.len(),
            "path_cells": paths.iter().map(|p| p.cells.len()).sum::<usize>(),
        });
        let summary = format!("{} maps, {} demonstrations", maps.len(), demos.len());
        commit_artifact(self, extra_deps, out, "dataset", metrics, summary)
    }
}
