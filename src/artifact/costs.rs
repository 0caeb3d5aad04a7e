//! The costmap a command or stage plans on: one map of a costmap artifact folder, a
//! costmap table, a cost raster (GeoTIFF, Esri ASCII grid, Zarr store...) or a MovingAI grid; and the reference costs
//! that plans are scored against.

use std::path::{Path, PathBuf};

use super::read_manifest;
use crate::error::{Error, Result};
use crate::grid::{GeoRef, Grid};
use crate::io::movingai::read_map;
use crate::io::tables::read_costmap;
use crate::io::{RASTER_EXTENSIONS, map_name, read_raster};

/// Loads the costmap named by `path` and its map name: an artifact folder (`map` picks
/// one of its maps), a `costmap/1` table, a raster of costs (any raster `ingest` reads;
/// `map` picks a band when it has several) or a MovingAI `.map` grid (passable cells
/// cost 1).
pub fn load_costs(path: &Path, map: Option<&str>) -> Result<(String, Grid<f32>)> {
    // A Zarr store is a raster in a folder, not an artifact.
    if !path.is_dir() || crate::io::zarr::is_zarr(path) {
        let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        return match extension.to_ascii_lowercase().as_str() {
            raster if RASTER_EXTENSIONS.contains(&raster) => raster_costs(path, map),
            "map" => Ok((map_name(path), read_map(path)?)),
            _ => read_costmap(path),
        };
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

/// A raster's band as costs: nodata cells are blocked (∞), as are zeros (a planner
/// cannot price a free cell); negative costs are refused.
fn raster_costs(path: &Path, band: Option<&str>) -> Result<(String, Grid<f32>)> {
    let name = map_name(path);
    let raster = read_raster(path, &name)?;
    let bands = || raster.layer_names().join(", ");
    let layer = match band {
        Some(b) => raster.layer(b).ok_or_else(|| {
            Error::Usage(format!(
                "{} has no band '{b}' (it has: {})",
                path.display(),
                bands()
            ))
        })?,
        None if raster.layers.len() == 1 => &raster.layers[0],
        None => {
            return Err(Error::Usage(format!(
                "{} holds {} bands; choose one with --map ({})",
                path.display(),
                raster.layers.len(),
                bands()
            )));
        }
    };
    if let Some(i) = layer.values.iter().position(|&c| c < 0.0) {
        let cell = raster.geo.cell_at(i);
        return Err(Error::input(
            path,
            format!(
                "band '{}', cell {cell}: cost {} is negative",
                layer.name, layer.values[i]
            ),
        ));
    }
    let costs = layer
        .values
        .iter()
        .map(|&c| if c.is_nan() { f32::INFINITY } else { c })
        .collect();
    Ok((name, Grid::from_vec(raster.geo.clone(), costs)))
}

/// Reference costmaps: the true costs that plans and demonstrations are scored against
/// (a synthetic world's, or a teacher's cost raster), each a `costmap/1` table (named
/// by the map it carries) or a one-band GeoTIFF of costs (named by its file; cells
/// without data and zeros are blocked).
#[derive(Debug, Default)]
pub struct References(Vec<(String, PathBuf, Grid<f32>)>);

impl References {
    /// Reads every reference given; an error names the file that cannot be read.
    pub fn load(paths: &[PathBuf]) -> Result<Self> {
        paths
            .iter()
            .map(|path| {
                let (name, costs) = load_costs(path, None)?;
                Ok((name, path.clone(), costs))
            })
            .collect::<Result<Vec<_>>>()
            .map(References)
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The reference of map `map` on grid `geo`, among the run's maps `maps`: the one
    /// named so; else the only one that is named after none of them and has that
    /// grid (a teacher's cost raster of the map, under a name of its own). An error
    /// where the one named so has another grid, or where none or several fit.
    pub fn for_map(&self, map: &str, geo: &GeoRef, maps: &[&str]) -> Result<&Grid<f32>> {
        if let Some((_, path, costs)) = self.0.iter().find(|(name, ..)| name == map) {
            if !costs.geo.same_grid(geo) {
                return Err(Error::input(
                    path,
                    format!("does not have the grid of map '{map}'"),
                ));
            }
            return Ok(costs);
        }
        let mut fitting = self
            .0
            .iter()
            .filter(|(name, _, costs)| !maps.contains(&name.as_str()) && costs.geo.same_grid(geo));
        match (fitting.next(), fitting.next()) {
            (Some((.., costs)), None) => Ok(costs),
            (None, _) => Err(Error::Usage(format!(
                "no reference costmap for map '{map}' among the references given (one \
                 named after the map, or the only one of its grid)"
            ))),
            (Some((_, a, _)), Some((_, b, _))) => Err(Error::Usage(format!(
                "map '{map}' has several references of its grid and none of its name \
                 ({} and {}): name one after the map",
                a.display(),
                b.display()
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reference(name: &str, geo: &GeoRef) -> (String, PathBuf, Grid<f32>) {
        let path = PathBuf::from(format!("{name}.tif"));
        (name.to_string(), path, Grid::filled(geo.clone(), 1.0))
    }

    #[test]
    fn references_are_matched_by_name_else_by_grid() {
        let small = GeoRef::square(4, 3, 10.0, [0.0, 0.0], "EPSG:32633");
        let large = GeoRef::square(8, 6, 10.0, [0.0, 0.0], "EPSG:32633");
        let maps = ["north", "south"];
        let refs = References(vec![
            reference("south", &large),
            reference("teacher", &small),
        ]);
        // By name, whatever the other references' grids.
        let found = refs.for_map("south", &large, &maps).unwrap();
        assert_eq!(found.geo, large);
        // Named after no map, and of the map's grid (a frame of another name, as a
        // GeoTIFF without a CRS reads, is the same grid).
        let table_frame = GeoRef::square(4, 3, 10.0, [0.0, 0.0], "map");
        let found = refs.for_map("north", &table_frame, &maps).unwrap();
        assert_eq!(found.geo, small);
        // A reference named after the map on another grid is refused, naming its file.
        let err = refs
            .for_map("south", &small, &maps)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("south.tif") && err.contains("grid of map 'south'"),
            "{err}"
        );
        // A reference named after another map is that map's, not a stray of this grid.
        let refs = References(vec![reference("south", &small)]);
        let err = refs
            .for_map("north", &small, &maps)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("no reference costmap for map 'north'"),
            "{err}"
        );
        // Two strays of the map's grid: it is not said which.
        let refs = References(vec![reference("a", &small), reference("b", &small)]);
        let err = refs
            .for_map("north", &small, &maps)
            .unwrap_err()
            .to_string();
        assert!(err.contains("several references of its grid"), "{err}");
    }
}
