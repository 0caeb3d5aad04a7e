//! Gridded XYZ text (`.xyz`), as national mapping agencies hand out LiDAR DEMs (one
//! `x y z` line a cell, separated by spaces, tabs, commas or semicolons, an optional
//! header naming the columns) and as GDAL's XYZ driver reads and writes them: the points
//! are the centres of a regular grid, whose spacing is the smallest step between them
//! along each axis; cells with no point are no data; rows may run from the north or from
//! the south. The file says nothing of its CRS: a `.prj` beside it gives one, as for an
//! ASCII grid; without it, coordinates are metres. The one band is layer `band1`.

use std::path::Path;

use super::FileOrder;
use super::ascii_grid::crs_keys;
use super::geotiff::{Georeferencing, georeference};
use crate::error::{Error, Result, read_input};
use crate::grid::{Layer, Map};

/// A grid's cells may outnumber its points by this much (a DEM clipped to a coastline
/// or a survey's outline); more is a scattered point cloud, which is not a grid.
const MOST_CELLS_PER_POINT: usize = 16;

/// Header names of the columns, as GDAL recognises them (lowercase).
const X_NAMES: [&str; 5] = ["x", "lon", "longitude", "east", "easting"];
const Y_NAMES: [&str; 5] = ["y", "lat", "latitude", "north", "northing"];
const Z_NAMES: [&str; 8] = [
    "z",
    "alt",
    "altitude",
    "height",
    "elev",
    "elevation",
    "value",
    "h",
];

/// The XYZ grid at `path` as map `name`, with whether its rows ran from the north.
pub fn read_xyz_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let bytes = read_input(path)?;
    let text = std::str::from_utf8(&bytes)
        .map_err(|e| problem(format!("is not an XYZ grid (not text: {e})")))?;
    let points = read_points(text).map_err(problem)?;
    let grid = Grid::of(&points).map_err(problem)?;
    let (width, height) = (grid.columns, grid.rows);
    let mut values = vec![f32::NAN; width * height];
    for &[x, y, z] in &points {
        let (column, row) = (
            grid.index(x, grid.x0, grid.dx),
            grid.index(y, grid.y0, grid.dy),
        );
        values[row * width + column] = z as f32;
    }
    let north_first = points.first().map(|p| p[1]) > points.last().map(|p| p[1]);
    let (keys, ascii) = crs_keys(path).map_err(problem)?;
    let (geo, heights) = georeference(
        path,
        width as u32,
        height as u32,
        Georeferencing::of_grid(
            [
                grid.dx,
                0.0,
                grid.x0 - grid.dx / 2.0,
                0.0,
                -grid.dy,
                grid.y0 + (height as f64 - 0.5) * grid.dy,
            ],
            &keys,
            ascii,
        ),
    )?;
    if heights != 1.0 {
        values
            .iter_mut()
            .for_each(|v| *v = (f64::from(*v) * heights) as f32);
    }
    let map = Map {
        name: name.to_string(),
        geo,
        layers: vec![Layer::new("band1", values)],
    };
    Ok((map, FileOrder::rows(north_first)))
}

/// The points of an XYZ text: the columns a header names (else the first three), one
/// point a line; an error names the line and what is wrong with it.
fn read_points(text: &str) -> std::result::Result<Vec<[f64; 3]>, String> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .peekable();
    let mut columns = [0, 1, 2];
    if let Some((_, first)) = lines.peek()
        && fields(first).iter().any(|f| f.parse::<f64>().is_err())
    {
        let names: Vec<String> = fields(first)
            .iter()
            .map(|f| f.trim_matches('"').to_ascii_lowercase())
            .collect();
        for (column, known) in columns
            .iter_mut()
            .zip([&X_NAMES[..], &Y_NAMES[..], &Z_NAMES[..]])
        {
            if let Some(at) = names.iter().position(|n| known.contains(&n.as_str())) {
                *column = at;
            }
        }
        lines.next();
    }
    let mut points = Vec::new();
    for (index, line) in lines {
        let values = fields(line);
        let mut point = [0.0; 3];
        for (value, &column) in point.iter_mut().zip(&columns) {
            let field = values.get(column).ok_or_else(|| {
                format!(
                    "line {}: {} values, no column {}",
                    index + 1,
                    values.len(),
                    column + 1
                )
            })?;
            *value = field
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("line {}: '{field}' is not a number", index + 1))?;
        }
        points.push(point);
    }
    if points.is_empty() {
        return Err("is not an XYZ grid: it holds no points".into());
    }
    Ok(points)
}

/// A line's fields, between spaces, tabs, commas or semicolons.
fn fields(line: &str) -> Vec<&str> {
    line.split([' ', '\t', ',', ';'])
        .filter(|f| !f.is_empty())
        .collect()
}

/// A regular grid through points: its first centres, spacings and size.
#[derive(Debug, PartialEq)]
struct Grid {
    x0: f64,
    y0: f64,
    dx: f64,
    dy: f64,
    columns: usize,
    rows: usize,
}

impl Grid {
    /// The grid the points are the centres of: along each axis, the smallest step
    /// between distinct coordinates (1 where there is only one), which every point
    /// must lie on a whole number of steps from the first.
    fn of(points: &[[f64; 3]]) -> std::result::Result<Grid, String> {
        let axis = |k: usize| -> std::result::Result<(f64, f64, usize), String> {
            let mut values: Vec<f64> = points.iter().map(|p| p[k]).collect();
            values.sort_by(f64::total_cmp);
            values.dedup();
            let step = values
                .windows(2)
                .map(|w| w[1] - w[0])
                .fold(f64::INFINITY, f64::min);
            let step = if step.is_finite() { step } else { 1.0 };
            let (first, last) = (values[0], values[values.len() - 1]);
            let count = ((last - first) / step).round() + 1.0;
            if count > u32::MAX as f64 {
                return Err(format!("its points span {count} steps of {step}"));
            }
            Ok((first, step, count as usize))
        };
        let (x0, dx, columns) = axis(0)?;
        let (y0, dy, rows) = axis(1)?;
        if columns.saturating_mul(rows) > points.len().saturating_mul(MOST_CELLS_PER_POINT) {
            return Err(format!(
                "is not a grid: its {} points would lie scattered over {columns} × {rows} \
                 cells of {dx} × {dy}",
                points.len()
            ));
        }
        let grid = Grid {
            x0,
            y0,
            dx,
            dy,
            columns,
            rows,
        };
        for (i, &[x, y, _]) in points.iter().enumerate() {
            let off = |v: f64, v0: f64, d: f64| ((v - v0) / d - ((v - v0) / d).round()).abs();
            if off(x, x0, dx) > 1e-3 || off(y, y0, dy) > 1e-3 {
                return Err(format!(
                    "point {} ({x}, {y}) is off the grid its points make (steps of {dx} × \
                     {dy} from ({x0}, {y0})): not a regular grid",
                    i + 1
                ));
            }
        }
        Ok(grid)
    }

    /// The index along an axis of coordinate `v` (first centre `v0`, step `d`).
    fn index(&self, v: f64, v0: f64, d: f64) -> usize {
        ((v - v0) / d).round() as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_separators_and_missing_cells_as_gdal_reads_them() {
        let points = read_points("X;Y;Z\n1;10;5\n3;10;6\n\n1;12;7\n").unwrap();
        assert_eq!(
            points,
            [[1.0, 10.0, 5.0], [3.0, 10.0, 6.0], [1.0, 12.0, 7.0]]
        );
        let grid = Grid::of(&points).unwrap();
        assert_eq!(
            (grid.dx, grid.dy, grid.columns, grid.rows),
            (2.0, 2.0, 2, 2)
        );
        // Columns named in another order.
        let named = read_points("elevation northing easting\n5 10 1\n").unwrap();
        assert_eq!(named, [[1.0, 10.0, 5.0]]);
    }

    #[test]
    fn what_is_not_a_grid_is_explained() {
        assert!(
            read_points("1 2 3\n1 2 x\n")
                .unwrap_err()
                .contains("line 2: 'x'")
        );
        assert!(read_points("x y z\n1 2\n").unwrap_err().contains("line 2"));
        assert!(read_points("x y z\n").unwrap_err().contains("no points"));
        let off = read_points("0 0 1\n2 0 1\n3.5 0 1\n").unwrap();
        assert!(Grid::of(&off).unwrap_err().contains("off the grid"));
        let scattered = read_points("0 0 1\n1000 1000 1\n1 1 1\n").unwrap();
        assert!(Grid::of(&scattered).unwrap_err().contains("scattered"));
    }

    proptest::proptest! {
        /// Any text of numbers and separators is points or an error, and any points a
        /// grid or an error: never a panic.
        #[test]
        fn any_text_is_points_or_an_error(text in "[0-9 .,;\t\n\\-eExyz]{0,300}") {
            if let Ok(points) = read_points(&text)
                && let Ok(grid) = Grid::of(&points)
            {
                for &[x, y, _] in &points {
                    proptest::prop_assert!(grid.index(x, grid.x0, grid.dx) < grid.columns);
                    proptest::prop_assert!(grid.index(y, grid.y0, grid.dy) < grid.rows);
                }
            }
        }
    }
}
