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
///
/// A densely logged track crosses a cell's row and column edges one pose apart, so a
/// diagonal drive reads as a staircase of orthogonal steps. The corners of such a
/// staircase, cells the track only clipped near the vertex their neighbours on the path
/// share (`Traced::clipped_depth`), are left out, leaving the diagonal steps the
/// planner would take: compared cell by cell with 8-connected plans, a staircase reads
/// as a path up to √2 times as long through cells the drive only clipped, and LEARCH
/// learns those cells as cheap (BENCHMARKS.md, "Densely logged tracks").
pub fn rasterize(geo: &GeoRef, poses: &[(f64, f64)]) -> Result<CellPath, PathError> {
    let traced = trace(geo, poses)?;
    let dropped = traced.corners_to_leave_out();
    Ok(traced
        .cells
        .iter()
        .zip(&dropped)
        .filter(|&(_, &drop)| !drop)
        .map(|(&cell, _)| cell)
        .collect())
}

/// The cells the poses visit, joined by Bresenham lines, corners and all: the cells a
/// polyline through the poses crosses (a road drawn through waypoints).
pub fn rasterize_polyline(geo: &GeoRef, poses: &[(f64, f64)]) -> Result<CellPath, PathError> {
    trace(geo, poses).map(|traced| traced.cells)
}

/// A track's cells, each with the poses logged in it.
struct Traced {
    cells: CellPath,
    /// Per cell of `cells`, the range of `positions` logged in it (empty for a cell a
    /// Bresenham line filled in between two poses).
    logged: Vec<std::ops::Range<usize>>,
    /// The poses in fractional cells: (column, row), the cell (⌊row⌋, ⌊column⌋).
    positions: Vec<(f64, f64)>,
}

impl Traced {
    /// How deep into cell `k` the track went, if it only clipped the cell's corner:
    /// its neighbours on the path are diagonal neighbours of each other, and every pose
    /// in it lies within the triangle cut off by the line through the far ends of the
    /// two edges meeting at their shared vertex (u + v < 1, u and v a pose's distances
    /// from the vertex along the axes, in cells). A straight drive between the two
    /// neighbours stays in that triangle; a track that reached the cell's centre
    /// (u + v = 1) or went deeper did not. The depth is the largest u + v.
    fn clipped_depth(&self, k: usize) -> Option<f64> {
        let (before, after) = (*self.cells.get(k.checked_sub(1)?)?, *self.cells.get(k + 1)?);
        if before.row.abs_diff(after.row) != 1 || before.col.abs_diff(after.col) != 1 {
            return None;
        }
        let vertex = (
            f64::from(before.col.max(after.col)),
            f64::from(before.row.max(after.row)),
        );
        let depth = self.positions[self.logged[k].clone()]
            .iter()
            .map(|&(col, row)| (col - vertex.0).abs() + (row - vertex.1).abs())
            .fold(0.0, f64::max);
        (depth < REACHED_CENTRE).then_some(depth)
    }

    /// Which cells to leave out: clipped corners, no two side by side (each left-out
    /// cell's neighbours stay on the path and become a diagonal step). Where clipped
    /// corners follow one another, as along a diagonal drive off the cells' centres
    /// (cell, corner, cell, corner, …), as many as can go are left out, the shallowest
    /// first: the corners the drive cut, not the cells it crossed.
    fn corners_to_leave_out(&self) -> Vec<bool> {
        let depths: Vec<Option<f64>> = (0..self.cells.len())
            .map(|k| self.clipped_depth(k))
            .collect();
        let mut dropped = vec![false; self.cells.len()];
        let mut k = 0;
        while k < depths.len() {
            if depths[k].is_none() {
                k += 1;
                continue;
            }
            let run_end = (k..depths.len())
                .find(|&j| depths[j].is_none())
                .unwrap_or(depths.len());
            let run: Vec<f64> = depths[k..run_end]
                .iter()
                .map(|d| d.expect("in the run"))
                .collect();
            for (i, drop) in most_shallow_apart(&run).into_iter().enumerate() {
                dropped[k + i] = drop;
            }
            k = run_end;
        }
        dropped
    }
}

/// Of a run of corners' depths, the corners to leave out, no two side by side: the
/// most corners clipped clearly (`CLEARLY_CLIPPED`), then the most corners, then the
/// least total depth (dynamic programming over the run; ties keep the earlier choice,
/// so the result is fixed). Clear corners first keeps a diagonal drive off the cells'
/// centres on the cells it crossed deeply, where leaving out the most cells would take
/// the corners it clipped instead and cut the turns at both ends of the run; a drive
/// along the cells' vertices clips both alike, and the most cells go.
fn most_shallow_apart(depths: &[f64]) -> Vec<bool> {
    #[derive(Clone, Copy)]
    struct Choice {
        shallow: usize,
        count: usize,
        depth: f64,
        taken: bool,
    }
    let better = |a: &Choice, b: &Choice| {
        (a.shallow, a.count) > (b.shallow, b.count)
            || ((a.shallow, a.count) == (b.shallow, b.count) && a.depth < b.depth)
    };
    let none = Choice {
        shallow: 0,
        count: 0,
        depth: 0.0,
        taken: false,
    };
    // best[i]: the best choice over depths[..i].
    let mut best = vec![none; depths.len() + 1];
    for i in 1..=depths.len() {
        let before = if i >= 2 { best[i - 2] } else { none };
        let d = depths[i - 1];
        let take = Choice {
            shallow: before.shallow + usize::from(d < CLEARLY_CLIPPED),
            count: before.count + 1,
            depth: before.depth + d,
            taken: true,
        };
        let skip = Choice {
            taken: false,
            ..best[i - 1]
        };
        best[i] = if better(&take, &skip) { take } else { skip };
    }
    let mut chosen = vec![false; depths.len()];
    let mut i = depths.len();
    while i > 0 {
        if best[i].taken {
            chosen[i - 1] = true;
            i = i.saturating_sub(2);
        } else {
            i -= 1;
        }
    }
    chosen
}

/// A corner whose poses lie within a third of a cell of its vertex (u + v): the drive
/// cut it, where the cells beside it it crossed past their middle.
const CLEARLY_CLIPPED: f64 = 1.0 / 3.0;

/// A pose whose distances from the corner vertex add up to a whole cell reached the
/// cell's centre line; the margin keeps a pose logged at the centre itself there.
const REACHED_CENTRE: f64 = 1.0 - 1e-6;

fn trace(geo: &GeoRef, poses: &[(f64, f64)]) -> Result<Traced, PathError> {
    if poses.len() < 2 {
        return Err(PathError::TooFewPoses(poses.len()));
    }
    let [sx, sy] = geo.cell_size();
    let mut traced = Traced {
        cells: Vec::with_capacity(poses.len()),
        logged: Vec::with_capacity(poses.len()),
        positions: Vec::with_capacity(poses.len()),
    };
    for (i, &(x, y)) in poses.iter().enumerate() {
        let cell = geo
            .cell_of(x, y)
            .ok_or(PathError::OffMap { pose: i, x, y })?;
        match traced.cells.last() {
            Some(&last) if last == cell => {}
            Some(&last) => bresenham(last, cell, &mut traced.cells),
            None => traced.cells.push(cell),
        }
        let at = traced.positions.len();
        traced.logged.resize(traced.cells.len(), at..at);
        traced.logged.last_mut().expect("a cell per pose").end = at + 1;
        traced
            .positions
            .push(((x - geo.origin[0]) / sx, (y - geo.origin[1]) / sy));
    }
    Ok(traced)
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
    fn a_staircase_logged_pose_by_pose_becomes_a_diagonal() {
        let g = geo(10, 10);
        // Right, down, right, down: each pose crosses one edge.
        let poses = [(0.5, 0.5), (1.2, 0.6), (1.3, 1.2), (2.2, 1.3), (2.3, 2.2)];
        let p = rasterize(&g, &poses).unwrap();
        assert_eq!(p, vec![Cell::new(0, 0), Cell::new(1, 1), Cell::new(2, 2)]);
        // A track that turns back keeps its cells.
        let back = [(0.5, 0.5), (1.5, 0.5), (0.5, 0.5)];
        assert_eq!(rasterize(&g, &back).unwrap().len(), 3);
        // A turn logged at its corner cell's centre keeps the corner; one that cut
        // across near the vertex is a diagonal step.
        let turn = [(0.5, 0.5), (2.5, 0.5), (2.5, 2.5)];
        assert_eq!(rasterize(&g, &turn).unwrap().len(), 5);
        let cut = [(0.5, 0.5), (2.2, 0.8), (2.5, 2.5)];
        let p = rasterize(&g, &cut).unwrap();
        assert_eq!(p.len(), 4);
        assert!(!p.contains(&Cell::new(0, 2)), "{p:?}");
        // The polyline keeps every cell it crosses.
        assert_eq!(rasterize_polyline(&g, &cut).unwrap().len(), 5);
    }

    #[test]
    fn a_diagonal_drive_off_the_centres_keeps_the_cells_it_crossed() {
        let g = geo(12, 12);
        // A diagonal from cell (1, 1) to (8, 8), logged five poses a cell, a fifth of
        // a cell right of and a tenth above the centres: it crosses each column edge
        // before the row edge, clipping the corner cell to the right of each step.
        let poses: Vec<(f64, f64)> = (0..=35)
            .map(|k| {
                let t = f64::from(k) / 5.0;
                (1.7 + t, 1.4 + t)
            })
            .collect();
        let p = rasterize(&g, &poses).unwrap();
        assert_eq!(p, (1..=8).map(|i| Cell::new(i, i)).collect::<Vec<_>>());
    }

    #[test]
    fn corners_apart_the_shallowest_first() {
        assert_eq!(most_shallow_apart(&[0.5]), [true]);
        assert_eq!(most_shallow_apart(&[0.9, 0.1]), [false, true]);
        assert_eq!(most_shallow_apart(&[0.3, 0.9, 0.3]), [true, false, true]);
        // A diagonal run between two turns: its cells (0.8) stay, its corners go.
        assert_eq!(
            most_shallow_apart(&[0.8, 0.2, 0.8, 0.2, 0.8]),
            [false, true, false, true, false]
        );
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
                let cell = g.cell_of(x, y).unwrap();
                prop_assert!(
                    path.iter().any(|p| p.chebyshev(cell) <= 1),
                    "every pose's cell is on the path or a corner beside it"
                );
            }
        }

        #[test]
        fn a_densely_logged_drive_between_cells_is_the_line_drawn_at_once(
            a in (0u32..30, 0u32..40),
            b in (0u32..30, 0u32..40),
            offset in (-0.3f64..0.3, -0.3f64..0.3),
            per_cell in 4usize..12,
        ) {
            // A straight drive from one cell to another, its poses a fixed sub-cell
            // offset off the line between their centres.
            let g = geo(40, 30);
            let (a, b) = (Cell::new(a.0, a.1), Cell::new(b.0, b.1));
            let centre = |c: Cell| (f64::from(c.col) + 0.5 + offset.0, f64::from(c.row) + 0.5 + offset.1);
            let ((x0, y0), (x1, y1)) = (centre(a), centre(b));
            let n = per_cell * (a.chebyshev(b) as usize + 1);
            let dense: Vec<(f64, f64)> = (0..=n)
                .map(|k| {
                    let t = k as f64 / n as f64;
                    (x0 + t * (x1 - x0), y0 + t * (y1 - y0))
                })
                .collect();
            let path = rasterize(&g, &dense).unwrap();
            // As many cells as the 8-connected line between its ends: no staircase.
            prop_assert_eq!(path.len(), a.chebyshev(b) as usize + 1, "{:?}", path);
        }
    }
}
