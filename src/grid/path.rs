//! Demonstrations on a grid: ordered poses turned into connected 8-neighbour cell paths.

use super::{Cell, GeoRef};

/// A path of cells in which each step goes to one of the 8 neighbours.
pub type CellPath = Vec<Cell>;

#[derive(Debug, Clone, PartialEq)]
pub enum PathError {
    TooFewPoses(usize),
    OffMap { pose: usize, x: f64, y: f64 },
}

impl std::fmt::Display for PathError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PathError::TooFewPoses(n) => {
                write!(f, "has {n} pose(s); a demonstration needs at least 2")
            }
            PathError::OffMap { pose, x, y } => {
                write!(f, "pose {pose} at (x {x}, y {y}) lies outside the map")
            }
        }
    }
}

/// Turns world poses (x, y) into a connected 8-neighbour cell path with no gaps and no
/// repeated consecutive cells. Consecutive poses are joined by a Bresenham line, which
/// visits exactly the cells a straight drive between them would cross diagonally.
pub fn rasterize(geo: &GeoRef, poses: &[(f64, f64)]) -> Result<CellPath, PathError> {
    if poses.len() < 2 {
        return Err(PathError::TooFewPoses(poses.len()));
    }
    let mut path: CellPath = Vec::with_capacity(poses.len());
    for (i, &(x, y)) in poses.iter().enumerate() {
        let cell = geo
            .cell_of(x, y)
            .ok_or(PathError::OffMap { pose: i, x, y })?;
        match path.last() {
            None => path.push(cell),
            Some(&last) if last == cell => {}
            Some(&last) => bresenham(last, cell, &mut path),
        }
    }
    Ok(path)
}

/// Appends the cells after `from` up to and including `to` on the line between them.
fn bresenham(from: Cell, to: Cell, out: &mut CellPath) {
    let (mut r, mut c) = (i64::from(from.row), i64::from(from.col));
    let (r1, c1) = (i64::from(to.row), i64::from(to.col));
    let dr = (r1 - r).abs();
    let dc = (c1 - c).abs();
    let sr = (r1 - r).signum();
    let sc = (c1 - c).signum();
    let mut err = dc - dr;
    while (r, c) != (r1, c1) {
        let e2 = 2 * err;
        if e2 > -dr {
            err -= dr;
            c += sc;
        }
        if e2 < dc {
            err += dc;
            r += sr;
        }
        out.push(Cell::new(r as u32, c as u32));
    }
}

/// True when every step is to one of the 8 neighbours (no gaps, no repeats).
pub fn is_connected8(path: &[Cell]) -> bool {
    path.windows(2).all(|w| w[0].chebyshev(w[1]) == 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn geo(w: u32, h: u32) -> GeoRef {
        GeoRef::unit(w, h)
    }

    #[test]
    fn straight_and_diagonal_lines() {
        let g = geo(10, 10);
        let p = rasterize(&g, &[(0.5, 0.5), (3.5, 0.5)]).unwrap();
        assert_eq!(p.len(), 4);
        let p = rasterize(&g, &[(0.5, 0.5), (3.5, 3.5)]).unwrap();
        assert_eq!(p, (0..4).map(|i| Cell::new(i, i)).collect::<Vec<_>>());
    }

    #[test]
    fn repeated_poses_in_one_cell_collapse() {
        let g = geo(10, 10);
        let p = rasterize(&g, &[(0.2, 0.2), (0.7, 0.7), (1.5, 0.5), (1.6, 0.4)]).unwrap();
        assert_eq!(p, vec![Cell::new(0, 0), Cell::new(0, 1)]);
    }

    #[test]
    fn errors_name_the_problem() {
        let g = geo(10, 10);
        assert_eq!(rasterize(&g, &[(1.0, 1.0)]), Err(PathError::TooFewPoses(1)));
        assert_eq!(
            rasterize(&g, &[(1.0, 1.0), (10.5, 1.0)]),
            Err(PathError::OffMap {
                pose: 1,
                x: 10.5,
                y: 1.0
            })
        );
    }

    proptest! {
        #[test]
        fn rasterized_paths_are_connected(
            poses in prop::collection::vec((0.0f64..40.0, 0.0f64..30.0), 2..30)
        ) {
            let g = geo(40, 30);
            let path = rasterize(&g, &poses).unwrap();
            prop_assert!(is_connected8(&path));
            prop_assert_eq!(path[0], g.cell_of(poses[0].0, poses[0].1).unwrap());
            let last = poses[poses.len() - 1];
            prop_assert_eq!(*path.last().unwrap(), g.cell_of(last.0, last.1).unwrap());
            for &(x, y) in &poses {
                prop_assert!(path.contains(&g.cell_of(x, y).unwrap()), "every pose's cell is on the path");
            }
        }
    }
}
