//! Points as users type them ("x,y" in metres, or "row,col" cells) turned into the open
//! cells of a costmap, with errors naming the map and the option.

use std::path::Path;

use super::{Cell, Grid};
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

/// The open cell at `text` ("x,y" in metres, or "row,col" when `cells`) on the costmap
/// read from `source`, or an error naming the map and the option `what`.
pub fn locate(
    costs: &Grid<f32>,
    name: &str,
    source: &Path,
    text: &str,
    what: &str,
    cells: bool,
) -> Result<Cell> {
    let geo = &costs.geo;
    let [a, b] = parse_point(text, what)?;
    let cell = if cells {
        let inside = a >= 0.0 && b >= 0.0 && a.fract() == 0.0 && b.fract() == 0.0;
        let cell = Cell::new(a as u32, b as u32);
        (inside && geo.contains(cell)).then_some(cell)
    } else {
        geo.cell_of(a, b)
    };
    let cell = cell.ok_or_else(|| {
        let [x0, y0, x1, y1] = geo.bounds();
        Error::input(
            source,
            format!(
                "--{what} {text} lies outside map '{name}' ({}x{} cells, x {x0}..{x1}, y {y0}..{y1})",
                geo.width, geo.height
            ),
        )
    })?;
    let cost = costs.get(cell);
    if !(cost.is_finite() && cost > 0.0) {
        return Err(Error::input(
            source,
            format!("--{what} {text} is on a blocked cell {cell} (cost {cost})"),
        ));
    }
    Ok(cell)
}
