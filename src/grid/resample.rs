//! One raster's layers laid on another's grid, so that rasters of one site as they
//! come (a DEM and an orthophoto: other cells, other extents, other CRSs) make one map.
//! As GDAL's warper does: each target cell's centre is found in the source (through
//! the CRSs where they differ); where the source's cells are as large as the target's
//! or larger, values are interpolated bilinearly (`bilinear`), where they are smaller,
//! averaged over the source cells whose centres the target cell holds (`average`).
//! Class layers take the nearest cell, or the most common class (`mode`). Cells the
//! source does not cover, or covers only with no-data, are NaN.

use rayon::prelude::*;

use super::coarsen::most_common;
use super::reproject::{Reprojection, same_crs};
use super::{GeoRef, Layer};

/// Where the target's cells lie in the source: continuous (column, row) coordinates
/// of each target cell's centre, cell centres at whole numbers, and per target row how
/// many source cells one target cell spans along each axis.
struct Footprints {
    centres: Vec<[f64; 2]>,
    spans: Vec<[f64; 2]>,
}

/// Continuous source (column, row) of a point of the source frame.
fn source_cell(source: &GeoRef, x: f64, y: f64) -> [f64; 2] {
    let [sx, sy] = source.cell_size();
    [
        (x - source.origin[0]) / sx - 0.5,
        (y - source.origin[1]) / sy - 0.5,
    ]
}

fn footprints(source: &GeoRef, target: &GeoRef) -> Result<Footprints, String> {
    let reprojection = if same_crs(source, target) {
        None
    } else {
        Some(
            Reprojection::between(target, source)
                .map_err(|why| format!("its CRS and the first raster's: {why}"))?,
        )
    };
    let locate = |x: f64, y: f64| -> [f64; 2] {
        let moved = match &reprojection {
            None => Some((x, y)),
            Some(r) => r.point(x, y).ok(),
        };
        moved.map_or([f64::NAN; 2], |(x, y)| source_cell(source, x, y))
    };
    let (w, h) = (target.width as usize, target.height as usize);
    let [tx, ty] = target.cell_size();
    let centres: Vec<[f64; 2]> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (row, col) = (i / w, i % w);
            let x = target.origin[0] + (col as f64 + 0.5) * tx;
            let y = target.origin[1] + (row as f64 + 0.5) * ty;
            locate(x, y)
        })
        .collect();
    // A target cell's sides, measured in source cells at its row's middle.
    let spans = (0..h)
        .into_par_iter()
        .map(|row| {
            let x = target.origin[0] + (w as f64 / 2.0) * tx;
            let y = target.origin[1] + (row as f64 + 0.5) * ty;
            let (a, east, north) = (locate(x, y), locate(x + tx, y), locate(x, y + ty));
            let length = |p: [f64; 2]| (p[0] - a[0]).hypot(p[1] - a[1]);
            let span = [length(east), length(north)];
            if span.iter().all(|s| s.is_finite()) {
                span
            } else {
                [1.0, 1.0]
            }
        })
        .collect();
    Ok(Footprints { centres, spans })
}

/// Each of `layers` of the `source` grid on the `target` grid. An error names what
/// keeps the CRSs apart.
pub fn resampled_layers(
    layers: &[Layer],
    source: &GeoRef,
    target: &GeoRef,
) -> Result<Vec<Layer>, String> {
    if source.same_grid(target) && same_crs(source, target) {
        return Ok(layers.to_vec());
    }
    let footprints = footprints(source, target)?;
    let w = target.width as usize;
    Ok(layers
        .iter()
        .map(|layer| {
            let classes = layer.classes().is_some();
            let values = footprints
                .centres
                .par_iter()
                .enumerate()
                .map(|(i, &at)| {
                    let span = footprints.spans[i / w];
                    sample(&layer.values, source, at, span, classes)
                })
                .collect();
            Layer {
                values,
                ..layer.clone()
            }
        })
        .collect())
}

/// The value at continuous source cell `at` for a target cell spanning `span` source
/// cells.
fn sample(values: &[f32], source: &GeoRef, at: [f64; 2], span: [f64; 2], classes: bool) -> f32 {
    let (w, h) = (source.width as i64, source.height as i64);
    let value = |col: i64, row: i64| -> f32 {
        if (0..w).contains(&col) && (0..h).contains(&row) {
            values[(row * w + col) as usize]
        } else {
            f32::NAN
        }
    };
    let [u, v] = at;
    // Target cells whose centre lies outside the source's extent are not covered.
    let inside = |c: f64, n: i64| c >= -0.5 && c < n as f64 - 0.5;
    if !(inside(u, w) && inside(v, h)) {
        return f32::NAN;
    }
    let nearest = || value(u.round() as i64, v.round() as i64);
    if span[0] > 1.0 + 1e-9 || span[1] > 1.0 + 1e-9 {
        // The source cells whose centres the target cell holds (at least the nearest
        // along an axis it does not span more than one of).
        let range = |centre: f64, span: f64| {
            let half = span.max(1.0) / 2.0;
            ((centre - half).ceil() as i64)..((centre + half).ceil() as i64)
        };
        let (cols, rows) = (range(u, span[0]), range(v, span[1]));
        let data = rows
            .flat_map(|row| cols.clone().map(move |col| (col, row)))
            .map(|(col, row)| value(col, row))
            .filter(|v| !v.is_nan());
        if classes {
            return most_common(data);
        }
        let (sum, n) = data.fold((0.0f64, 0usize), |(sum, n), v| (sum + f64::from(v), n + 1));
        return if n == 0 {
            f32::NAN
        } else {
            (sum / n as f64) as f32
        };
    }
    if classes {
        return nearest();
    }
    let (c0, r0) = (u.floor() as i64, v.floor() as i64);
    let (fu, fv) = (u - c0 as f64, v - r0 as f64);
    let corners = [
        (value(c0, r0), (1.0 - fu) * (1.0 - fv)),
        (value(c0 + 1, r0), fu * (1.0 - fv)),
        (value(c0, r0 + 1), (1.0 - fu) * fv),
        (value(c0 + 1, r0 + 1), fu * fv),
    ];
    // GDAL's bilinear leaves no-data corners out and weighs the rest.
    let (sum, weight) = corners
        .iter()
        .filter(|(v, weight)| !v.is_nan() && *weight > 0.0)
        .fold((0.0f64, 0.0f64), |(s, t), &(v, weight)| {
            (s + f64::from(v) * weight, t + weight)
        });
    if weight > 0.0 {
        (sum / weight) as f32
    } else {
        nearest()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(width: u32, height: u32, cell: f64, origin: [f64; 2]) -> GeoRef {
        GeoRef::square(width, height, cell, origin, "EPSG:32633")
    }

    #[test]
    fn finer_cells_are_averaged_and_classes_take_the_most_common() {
        // 4 × 4 cells of 1 m onto 2 × 2 of 2 m: each target cell averages a 2 × 2 block.
        let fine = grid(4, 4, 1.0, [0.0, 0.0]);
        let coarse = grid(2, 2, 2.0, [0.0, 0.0]);
        // Quarters, so that the values do not read as class codes.
        let values: Vec<f32> = (0..16).map(|i| i as f32 + 0.25).collect();
        let classes = vec![
            1.0, 1.0, 2.0, 3.0, //
            1.0, 2.0, 2.0, 2.0, //
            3.0, 3.0, 1.0, 1.0, //
            3.0, 1.0, 1.0, 2.0,
        ];
        let layers = [
            Layer::new("v", values),
            Layer::new("c", classes).declared_classes(),
        ];
        let out = resampled_layers(&layers, &fine, &coarse).unwrap();
        assert_eq!(out[0].values, vec![2.75, 4.75, 10.75, 12.75]);
        assert_eq!(out[1].values, vec![1.0, 2.0, 3.0, 1.0]);
        assert_eq!(out[1].kind, crate::grid::LayerKind::Classes);
    }

    #[test]
    fn coarser_cells_are_interpolated_and_uncovered_cells_are_nodata() {
        // 2 × 1 cells of 2 m (values 0.5 and 10.5) onto cells of 1 m, one column past the
        // source's east edge.
        let coarse = grid(2, 1, 2.0, [0.0, 0.0]);
        let fine = grid(6, 2, 1.0, [0.0, 0.0]);
        let out = resampled_layers(&[Layer::new("v", vec![0.5, 10.5])], &coarse, &fine).unwrap();
        let row = &out[0].values[..6];
        // Centres at x 0.5 .. 5.5; the source's centres are at 1 and 3.
        assert_eq!(row[1], 3.0);
        assert_eq!(row[2], 8.0);
        assert_eq!(row[0], 0.5, "edge cells weigh the corners the source has");
        assert_eq!(row[3], 10.5);
        assert!(row[4].is_nan() && row[5].is_nan(), "{row:?}");
    }

    #[test]
    fn identical_grids_copy_and_other_crss_are_transformed() {
        let geo = grid(3, 3, 10.0, [500_000.0, 5_000_000.0]);
        let layers = [Layer::new("v", (0..9).map(|i| i as f32 + 0.5).collect())];
        assert_eq!(resampled_layers(&layers, &geo, &geo).unwrap(), layers);
        // A cell in degrees of 1e-6° (0.1 m) centred, by PROJ, on UTM 33N's (500012,
        // 5000017): source cell (0.7, 1.2), where the bilinear value of the field
        // row × 3 + col + 0.5 is 4.8.
        let half = 0.5e-6;
        let degrees = GeoRef {
            degrees: true,
            ..GeoRef::square(
                1,
                1,
                1e-6,
                [15.000152663230077 - half, 45.153630211882735 - half],
                "EPSG:4326",
            )
        };
        let out = resampled_layers(&layers, &geo, &degrees).unwrap();
        assert!((out[0].values[0] - 4.8).abs() < 1e-4, "{:?}", out[0].values);
        let unnamed = GeoRef::unit(3, 3);
        let why = resampled_layers(&layers, &unnamed, &degrees).err().unwrap();
        assert!(why.contains("names no EPSG code"), "{why}");
    }
}
