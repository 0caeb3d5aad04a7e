//! Points as users type them ("x,y" in metres, or "row,col" cells) turned into the open
//! cells of a costmap, with errors naming the map and the option.

use std::path::Path;

use super::{Cell, GeoRef, Grid, Reprojection};
use crate::error::{Error, Result};

fn parse_point(text: &str, what: &str) -> Result<[f64; 2]> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let numbers: Option<Vec<f64>> = parts.iter().map(|p| p.parse().ok()).collect();
    match numbers.as_deref() {
        Some(&[a, b]) if a.is_finite() && b.is_finite() => Ok([a, b]),
        _ => Err(Error::Usage(format!(
            "--{what} '{text}': expected two numbers separated by a comma"
        ))),
    }
}

/// How the points a user types are read on one costmap: as "row,col" cells, as "x,y"
/// in the map's frame, or as "x,y" in another CRS (`--crs`: GPS longitude and latitude
/// on a UTM costmap), and how the cells of an answer are written back.
pub struct PointReader<'a> {
    costs: &'a Grid<f32>,
    name: &'a str,
    source: &'a Path,
    cells: bool,
    /// The user's CRS, with the transformations into the map's frame and out of it.
    crs: Option<(String, Reprojection, Reprojection)>,
}

impl<'a> PointReader<'a> {
    /// A reader of points on the costmap `name` read from `source`; `cells` takes
    /// "row,col", `crs` (`EPSG:<code>` or a PROJ string) takes "x,y" in that CRS.
    pub fn new(
        costs: &'a Grid<f32>,
        name: &'a str,
        source: &'a Path,
        cells: bool,
        crs: Option<&str>,
    ) -> Result<Self> {
        let crs = match crs {
            None => None,
            Some(_) if cells => {
                return Err(Error::Usage(
                    "--crs reads points as x,y in a CRS; --cells reads them as row,col: \
                     give one of them"
                        .into(),
                ));
            }
            Some(spec) => {
                let moved = |why: String| {
                    Error::input(source, format!("--crs {spec} on map '{name}': {why}"))
                };
                let into = Reprojection::new(spec, &costs.geo).map_err(moved)?;
                let out = Reprojection::out_of(&costs.geo, spec).map_err(moved)?;
                Some((spec.to_string(), into, out))
            }
        };
        Ok(PointReader {
            costs,
            name,
            source,
            cells,
            crs,
        })
    }

    /// The CRS of the points read and written: the user's `--crs`, or the map's frame.
    pub fn crs(&self) -> &str {
        match &self.crs {
            Some((spec, ..)) => spec,
            None => &self.costs.geo.frame,
        }
    }

    /// The open cell at `text`, or an error naming the map and the option `what`.
    pub fn locate(&self, text: &str, what: &str) -> Result<Cell> {
        let geo = &self.costs.geo;
        let [a, b] = parse_point(text, what)?;
        let cell = if self.cells {
            let inside = a >= 0.0 && b >= 0.0 && a.fract() == 0.0 && b.fract() == 0.0;
            let cell = Cell::new(a as u32, b as u32);
            (inside && geo.contains(cell)).then_some(cell)
        } else if let Some((spec, into, _)) = &self.crs {
            let (x, y) = into.point(a, b).map_err(|why| {
                Error::input(
                    self.source,
                    format!(
                        "--{what} {text} of {spec} cannot be moved into map '{}' ({}): {why}",
                        self.name, geo.frame
                    ),
                )
            })?;
            geo.cell_of(x, y)
        } else {
            geo.cell_of(a, b)
        };
        let cell = cell.ok_or_else(|| {
            let [x0, y0, x1, y1] = geo.bounds();
            let hint = if self.crs.is_none() && !self.cells {
                degrees_hint(geo, a, b)
            } else {
                String::new()
            };
            Error::input(
                self.source,
                format!(
                    "--{what} {text} lies outside map '{}' ({}x{} cells, x {x0}..{x1}, y \
                     {y0}..{y1} in {}){hint}",
                    self.name, geo.width, geo.height, geo.frame
                ),
            )
        })?;
        let cost = self.costs.get(cell);
        if !(cost.is_finite() && cost > 0.0) {
            return Err(Error::input(
                self.source,
                format!("--{what} {text} is on a blocked cell {cell} (cost {cost})"),
            ));
        }
        Ok(cell)
    }

    /// The centre of `cell` in the reader's CRS (see [`PointReader::crs`]).
    pub fn world(&self, cell: Cell) -> Result<[f64; 2]> {
        let (x, y) = self.costs.geo.center_of(cell);
        match &self.crs {
            None => Ok([x, y]),
            Some((spec, _, out)) => out.point(x, y).map(|(x, y)| [x, y]).map_err(|why| {
                Error::input(
                    self.source,
                    format!(
                        "cell {cell} of map '{}' cannot be moved into {spec}: {why}",
                        self.name
                    ),
                )
            }),
        }
    }
}

/// Why a point may lie off a projected map although the user meant it on it: it looks
/// like longitude and latitude.
fn degrees_hint(geo: &GeoRef, x: f64, y: f64) -> String {
    if geo.degrees || !geo.frame.starts_with("EPSG:") || x.abs() > 180.0 || y.abs() > 90.0 {
        return String::new();
    }
    format!(
        "; it looks like longitude and latitude: name its CRS (--crs EPSG:4326) to move \
         it into the map's {}",
        geo.frame
    )
}
