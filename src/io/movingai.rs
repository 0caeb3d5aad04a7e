//! MovingAI grid benchmark files (movingai.com/benchmarks): `.map` grids and `.scen`
//! scenario lists. In `.map` files `.`, `G` and `S` are passable; the first map line is
//! the northern edge, so file line y becomes grid row (height − 1 − y).

use std::path::Path;

use crate::error::{Error, Result, read_input};
use crate::grid::{Cell, GeoRef, Grid, Layer, Map};

/// A passable cell costs 1, so path costs are path lengths in cells.
pub fn read_map(path: &Path) -> Result<Grid<f32>> {
    let text = read_text(path)?;
    let mut lines = text.lines().enumerate();
    let mut header = |key: &str| -> Result<String> {
        let (n, line) = lines
            .next()
            .ok_or_else(|| Error::input(path, format!("ends before the '{key}' header line")))?;
        let line = line.trim_end();
        let value = line
            .strip_prefix(key)
            .map(str::trim)
            .filter(|v| !v.is_empty() || key == "map");
        value.map(String::from).ok_or_else(|| {
            Error::input(
                path,
                format!("line {}: expected '{key} ...', found '{line}'", n + 1),
            )
        })
    };
    header("type")?;
    let height: u32 = parse_number(path, 2, &header("height")?)?;
    let width: u32 = parse_number(path, 3, &header("width")?)?;
    header("map")?;
    if width == 0 || height == 0 {
        return Err(Error::input(path, format!("empty map ({width}x{height})")));
    }
    let rows: Vec<(usize, &str)> = lines
        .map(|(n, l)| (n, l.trim_end()))
        .filter(|(_, l)| !l.is_empty())
        .collect();
    if rows.len() != height as usize {
        return Err(Error::input(
            path,
            format!(
                "has {} map lines, the header says height {height}",
                rows.len()
            ),
        ));
    }
    let geo = GeoRef {
        width,
        height,
        resolution: 1.0,
        resolution_y: None,
        origin: [0.0, 0.0],
        frame: "movingai".into(),
        degrees: false,
        web_mercator: false,
        ground_scale: None,
        tiff_crs: None,
    };
    let mut grid = Grid::filled(geo, f32::INFINITY);
    for (y, (n, line)) in rows.iter().enumerate() {
        if line.len() != width as usize {
            return Err(Error::input(
                path,
                format!(
                    "line {}: {} cells, the header says width {width}",
                    n + 1,
                    line.len()
                ),
            ));
        }
        let row = height - 1 - y as u32;
        for (x, ch) in line.bytes().enumerate() {
            if matches!(ch, b'.' | b'G' | b'S') {
                grid.set(Cell::new(row, x as u32), 1.0);
            }
        }
    }
    Ok(grid)
}

/// The map as a map layer `blocked`: 1 where the cell is blocked, 0 where passable.
pub fn read_map_layer(path: &Path, name: &str) -> Result<Map> {
    let grid = read_map(path)?;
    Ok(Map {
        name: name.to_string(),
        layers: vec![Layer::new(
            "blocked",
            grid.data
                .iter()
                .map(|&c| if c.is_finite() { 0.0 } else { 1.0 })
                .collect(),
        )],
        geo: grid.geo,
    })
}

/// One query of a `.scen` file.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    pub bucket: u32,
    pub start: Cell,
    pub goal: Cell,
    pub optimal_length: f64,
}

/// Reads a `.scen` file (version 1) for a map of the given height.
pub fn read_scenarios(path: &Path, map: &GeoRef) -> Result<Vec<Scenario>> {
    let text = read_text(path)?;
    let mut scenarios = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim_end();
        if line.is_empty() || (n == 0 && line.starts_with("version")) {
            continue;
        }
        let fields: Vec<&str> = line.split('\t').collect();
        if fields.len() != 9 {
            return Err(Error::input(
                path,
                format!(
                    "line {}: {} tab-separated fields, expected 9",
                    n + 1,
                    fields.len()
                ),
            ));
        }
        let number = |i: usize| parse_number::<f64>(path, n + 1, fields[i]);
        let (w, h) = (number(2)? as u32, number(3)? as u32);
        if (w, h) != (map.width, map.height) {
            return Err(Error::input(
                path,
                format!(
                    "line {}: scenario for a {w}x{h} map, the map is {}x{}",
                    n + 1,
                    map.width,
                    map.height
                ),
            ));
        }
        let cell = |x: f64, y: f64| -> Result<Cell> {
            if x < 0.0 || y < 0.0 || x >= f64::from(w) || y >= f64::from(h) {
                return Err(Error::input(
                    path,
                    format!("line {}: ({x}, {y}) is off the map", n + 1),
                ));
            }
            Ok(Cell::new(h - 1 - y as u32, x as u32))
        };
        scenarios.push(Scenario {
            bucket: number(0)? as u32,
            start: cell(number(4)?, number(5)?)?,
            goal: cell(number(6)?, number(7)?)?,
            optimal_length: number(8)?,
        });
    }
    Ok(scenarios)
}

fn read_text(path: &Path) -> Result<String> {
    String::from_utf8(read_input(path)?).map_err(|_| Error::input(path, "is not text"))
}

fn parse_number<T: std::str::FromStr>(path: &Path, line: usize, text: &str) -> Result<T> {
    text.trim()
        .parse()
        .map_err(|_| Error::input(path, format!("line {line}: '{text}' is not a number")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_maps_north_up_and_scenarios() {
        let dir = tempfile::tempdir().unwrap();
        let map = dir.path().join("t.map");
        std::fs::write(&map, "type octile\nheight 2\nwidth 3\nmap\n.@T\nG.S\n").unwrap();
        let grid = read_map(&map).unwrap();
        assert_eq!(
            grid.data,
            [1.0, 1.0, 1.0, 1.0, f32::INFINITY, f32::INFINITY]
        );
        let scen = dir.path().join("t.scen");
        std::fs::write(&scen, "version 1\n0\tt.map\t3\t2\t0\t0\t2\t1\t2.41421\n").unwrap();
        let s = read_scenarios(&scen, &grid.geo).unwrap();
        assert_eq!(s[0].start, Cell::new(1, 0));
        assert_eq!(s[0].goal, Cell::new(0, 2));
        std::fs::write(&map, "type octile\nheight 3\nwidth 3\nmap\n...\n").unwrap();
        assert!(read_map(&map).unwrap_err().to_string().contains("height 3"));
    }
}
