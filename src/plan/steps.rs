//! How long each step between neighbouring cells is on the ground.
//!
//! Costs are per metre, so a step's cost is its length times the mean of its two cells'
//! costs. Lengths are kept in units of the grid's shortest step (so that square cells
//! step 1 and √2, as every grid planner's textbook has it) and `unit_step_metres` turns
//! them back into metres. In a projected frame every row is alike; in degrees a cell is
//! narrower the further it lies from the equator, so each row has lengths of its own,
//! measured at its latitude on the WGS 84 ellipsoid.

use std::borrow::Cow;

use super::relax::RowSteps;
use crate::grid::{Cell, GeoRef};

/// The step lengths of a whole grid: one `RowSteps` where every row is alike, one per
/// row in a geographic frame.
#[derive(Clone, Debug, PartialEq)]
pub struct StepLengths {
    rows: Cow<'static, [RowSteps]>,
}

impl StepLengths {
    /// Square cells everywhere.
    pub const SQUARE: StepLengths = StepLengths {
        rows: Cow::Borrowed(&[RowSteps::SQUARE]),
    };

    /// The steps of a raster's cells, in units of its shortest step.
    pub fn of(geo: &GeoRef) -> Self {
        if !geo.varies_by_row() {
            return StepLengths {
                rows: Cow::Owned(vec![RowSteps::of_cells(geo.cell_metres())]),
            };
        }
        let ground = RowMetres::of(geo);
        let unit = ground.unit();
        let h = ground.x.len();
        let rows = (0..h)
            .map(|r| {
                // Where a row has no neighbour on one side the step is never taken;
                // it is given the row's own height so that bounds stay meaningful.
                let before = if r > 0 { r - 1 } else { r };
                let after = if r + 1 < h { r } else { r.saturating_sub(1) };
                let band = |b: usize, exists: bool| {
                    if exists {
                        let x = 0.5 * (ground.x[b] + ground.x[b + 1]);
                        (ground.between[b], x.hypot(ground.between[b]))
                    } else {
                        let (x, y) = (ground.x[r], ground.y[r]);
                        (y, x.hypot(y))
                    }
                };
                let (y0, d0) = band(before, r > 0);
                let (y1, d1) = band(after, r + 1 < h);
                RowSteps {
                    x: ground.x[r] / unit,
                    y: [y0 / unit, y1 / unit],
                    diagonal: [d0 / unit, d1 / unit],
                }
            })
            .collect();
        StepLengths {
            rows: Cow::Owned(rows),
        }
    }

    /// Whether every row has the same steps (always, outside geographic frames).
    pub fn uniform(&self) -> Option<&RowSteps> {
        match &*self.rows {
            [one] => Some(one),
            _ => None,
        }
    }

    /// The steps out of row `row`'s cells.
    #[inline(always)]
    pub fn row(&self, row: usize) -> &RowSteps {
        match &*self.rows {
            [one] => one,
            rows => &rows[row],
        }
    }

    /// The length of the step between neighbours `a` and `b`.
    pub fn between(&self, a: Cell, b: Cell) -> f64 {
        let lower = a.row.min(b.row) as usize;
        match (a.row != b.row, a.col != b.col) {
            (true, true) => self.row(lower).diagonal[1],
            (true, false) => self.row(lower).y[1],
            _ => self.row(a.row as usize).x,
        }
    }

    /// Lower bounds on a step along x, along y and diagonally anywhere on the grid, for
    /// heuristics that must never overestimate. The diagonal bound is at most the two
    /// straight bounds together, so that replacing a diagonal by two straight steps
    /// never beats it.
    pub fn shortest(&self) -> RowSteps {
        let fold = |f: fn(&RowSteps) -> f64| self.rows.iter().map(f).fold(f64::INFINITY, f64::min);
        let x = fold(|r| r.x);
        let y = fold(|r| r.y[0].min(r.y[1]));
        let diagonal = fold(|r| r.diagonal[0].min(r.diagonal[1])).min(x + y);
        RowSteps {
            x,
            y: [y; 2],
            diagonal: [diagonal; 2],
        }
    }

    /// The longest single step along x or y, and the longest of any kind.
    pub fn longest(&self) -> (f64, f64) {
        let fold = |f: fn(&RowSteps) -> f64| self.rows.iter().map(f).fold(0.0, f64::max);
        let straight = fold(|r| r.x.max(r.y[0]).max(r.y[1]));
        let any = fold(|r| r.diagonal[0].max(r.diagonal[1])).max(straight);
        (straight, any)
    }
}

/// Metres on the ground per row of a geographic or Web Mercator raster: each row's cell width and
/// height at its middle latitude, and the distance between neighbouring rows' centres.
struct RowMetres {
    x: Vec<f64>,
    y: Vec<f64>,
    between: Vec<f64>,
}

impl RowMetres {
    fn of(geo: &GeoRef) -> Self {
        let (x, y) = geo
            .cell_metres_by_row()
            .into_iter()
            .map(|[x, y]| (x, y))
            .unzip();
        let between = (1..geo.height)
            .map(|r| geo.cell_metres_at(f64::from(r))[1])
            .collect();
        RowMetres { x, y, between }
    }

    /// The shortest cell side anywhere on the raster.
    fn unit(&self) -> f64 {
        self.x
            .iter()
            .chain(&self.y)
            .copied()
            .fold(f64::INFINITY, f64::min)
    }
}

/// Metres in one unit of step length on `geo`: costs of routes times this are cost ×
/// metres.
pub fn unit_step_metres(geo: &GeoRef) -> f64 {
    if geo.varies_by_row() {
        RowMetres::of(geo).unit()
    } else {
        let [mx, my] = geo.cell_metres();
        mx.min(my)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn degrees(height: u32, south: f64, cell: f64) -> GeoRef {
        GeoRef {
            degrees: true,
            ..GeoRef::square(4, height, cell, [10.0, south], "EPSG:4326")
        }
    }

    #[test]
    fn projected_grids_have_one_row_of_steps() {
        let geo = GeoRef {
            resolution_y: Some(2.0),
            ..GeoRef::square(5, 7, 1.0, [0.0, 0.0], "map")
        };
        let steps = StepLengths::of(&geo);
        assert_eq!(steps.uniform(), Some(&RowSteps::of_cells([1.0, 2.0])));
        assert_eq!(unit_step_metres(&geo), 1.0);
        assert_eq!(StepLengths::of(&GeoRef::unit(3, 3)), StepLengths::SQUARE);
    }

    #[test]
    fn degrees_shrink_east_west_towards_the_poles() {
        // 1° cells from 0° to 80° north: a cell at 75.5° is about a quarter as wide as
        // one at 0.5°, and the shortest step (the unit) is the northern row's width.
        let geo = degrees(80, 0.0, 1.0);
        let steps = StepLengths::of(&geo);
        assert!(steps.uniform().is_none());
        let (south, north) = (steps.row(0), steps.row(79));
        assert!((north.x - 1.0).abs() < 1e-12, "{north:?}");
        let ratio = south.x / north.x;
        let expected = 0.5f64.to_radians().cos() / 79.5f64.to_radians().cos();
        assert!(
            (ratio / expected - 1.0).abs() < 0.01,
            "{ratio} vs {expected}"
        );
        let unit = unit_step_metres(&geo);
        assert!(
            (unit - 111_319.5 * 79.5f64.to_radians().cos()).abs() < 200.0 * 1.0,
            "{unit}"
        );
        // A step north is the same length from either side, so paths cost the same
        // both ways.
        for r in 0..79 {
            assert_eq!(steps.row(r).y[1], steps.row(r + 1).y[0]);
            assert_eq!(steps.row(r).diagonal[1], steps.row(r + 1).diagonal[0]);
        }
        let (a, b) = (Cell::new(3, 1), Cell::new(4, 2));
        assert_eq!(steps.between(a, b), steps.between(b, a));
        assert_eq!(steps.between(a, b), steps.row(3).diagonal[1]);
    }

    #[test]
    fn bounds_hold_for_every_row() {
        let steps = StepLengths::of(&degrees(120, -60.0, 1.0));
        let low = steps.shortest();
        let (straight, any) = steps.longest();
        for r in 0..120 {
            let row = steps.row(r);
            for (k, length) in row.by_neighbour().into_iter().enumerate() {
                let bound = if k < 4 {
                    low.x.min(low.y[0])
                } else {
                    low.diagonal[0]
                };
                assert!(bound <= length && length <= any, "row {r}, step {k}");
                if k < 4 {
                    assert!(length <= straight);
                }
            }
        }
        assert!(low.diagonal[0] <= low.x + low.y[0]);
    }
}
