//! Maps coarsened by whole blocks of cells: a raster finer than the planner needs
//! (imagery at 0.3 m for a costmap of 2 m, a Landsat scene of 7000² cells for a route
//! of kilometres), averaged as GDAL's `average` resampling does on whole blocks.

use rayon::prelude::*;

use super::{GeoRef, Layer, Map};

/// What becomes of the cells past the last whole block along an axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Edges {
    /// Left out: every coarse cell is a whole block counted from the south-west
    /// corner (the map loses up to a block less one cell along its north and east
    /// edges). An axis shorter than one block is one cell.
    Whole,
    /// Kept, as GDAL's grid keeps them (`gdalwarp -tr`, rasterio's `reproject` to a
    /// transform scaled by the factor): blocks counted from the north-west corner,
    /// the last along the south and the east edge clipped to the mean of the cells it
    /// holds. The coarse map covers all of the raster, so every pose on it is on the
    /// map.
    Kept,
}

/// The block side, in cells, that brings the longer side of `geo` to at most `cells`
/// cells (1 when it already is, or when `cells` is 0).
pub fn factor_for_cells(geo: &GeoRef, cells: u32) -> usize {
    if cells == 0 {
        return 1;
    }
    (geo.width.max(geo.height).div_ceil(cells)).max(1) as usize
}

/// The block side, in cells, whose blocks come nearest to squares of `metres` on the
/// ground (the cells' mean side; at least 1).
pub fn factor_for_metres(geo: &GeoRef, metres: f64) -> usize {
    let [sx, sy] = geo.cell_metres();
    let side = (sx * sy).sqrt();
    let factor = (metres / side).round();
    if factor.is_finite() && factor >= 1.0 {
        factor.min(f64::from(u32::MAX)) as usize
    } else {
        1
    }
}

/// The map with its layers averaged over blocks of `factor` × `factor` cells (NaN
/// cells left out; a block with no data is NaN), the cells growing by the same
/// factor. Class layers (land cover, masks: [`Layer::classes`]) take each block's most
/// common class instead, as GDAL's `mode` resampling does: a mean of class codes is
/// no class, and a mean of a binary mask is a value the raster never holds.
pub fn coarsened(map: Map, factor: usize, edges: Edges) -> Map {
    let (w, h) = (map.geo.width as usize, map.geo.height as usize);
    if factor <= 1 {
        return map;
    }
    let blocks = |n: usize| match edges {
        Edges::Whole => (n / factor).max(1),
        Edges::Kept => n.div_ceil(factor),
    };
    let (pw, ph) = (blocks(w), blocks(h));
    // Fine rows the southern coarse row lacks: blocks are counted from the north.
    let skip = match edges {
        Edges::Kept if h > factor => ph * factor - h,
        _ => 0,
    };
    let layers = map
        .layers
        .iter()
        .map(|layer| {
            let classes = layer.classes().is_some();
            let values = (0..pw * ph)
                .into_par_iter()
                .map(|i| {
                    let (r, c) = (i / pw, i % pw);
                    let rows = (r * factor).saturating_sub(skip)..((r + 1) * factor - skip).min(h);
                    let block = rows.flat_map(|rr| {
                        (c * factor..((c + 1) * factor).min(w))
                            .map(move |cc| layer.values[rr * w + cc])
                    });
                    let data = block.filter(|v| !v.is_nan());
                    if classes {
                        most_common(data)
                    } else {
                        let (sum, n) =
                            data.fold((0.0f64, 0usize), |(sum, n), v| (sum + f64::from(v), n + 1));
                        if n == 0 {
                            f32::NAN
                        } else {
                            (sum / n as f64) as f32
                        }
                    }
                })
                .collect();
            Layer {
                name: layer.name.clone(),
                values,
                kind: layer.kind,
            }
        })
        .collect();
    let [sx, sy] = map.geo.cell_size();
    // An axis shorter than a block is one cell spanning only the cells it holds.
    let (fx, fy) = (factor.min(w) as f64, factor.min(h) as f64);
    let geo = GeoRef {
        width: pw as u32,
        height: ph as u32,
        resolution: sx * fx,
        resolution_y: (map.geo.resolution_y.is_some() || fx != fy).then_some(sy * fy),
        origin: [map.geo.origin[0], map.geo.origin[1] - skip as f64 * sy],
        ..map.geo
    };
    Map {
        name: map.name,
        geo,
        layers,
    }
}

/// The most common of `values` (the smallest of equals; NaN when there are none).
pub(super) fn most_common(values: impl Iterator<Item = f32>) -> f32 {
    let mut counts: Vec<(f32, usize)> = Vec::new();
    for v in values {
        match counts.iter_mut().find(|(c, _)| *c == v) {
            Some((_, n)) => *n += 1,
            None => counts.push((v, 1)),
        }
    }
    counts
        .into_iter()
        .max_by(|(a, m), (b, n)| m.cmp(n).then(b.total_cmp(a)))
        .map_or(f32::NAN, |(v, _)| v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strip(width: u32, height: u32) -> Map {
        let geo = GeoRef::square(width, height, 30.0, [0.0, 0.0], "map");
        Map {
            name: "strip".into(),
            layers: vec![Layer::new(
                "band1",
                (0..geo.cell_count()).map(|i| i as f32).collect(),
            )],
            geo,
        }
    }

    #[test]
    fn a_raster_thinner_than_a_block_keeps_one_cell_across() {
        // One row of 500 cells, by 4 (at most 160 a side): 125 cells, each the mean of
        // its four, spanning one row's height (it panicked as zero rows).
        let row = strip(500, 1);
        let row = coarsened(row.clone(), factor_for_cells(&row.geo, 160), Edges::Whole);
        assert_eq!((row.geo.width, row.geo.height), (125, 1));
        assert_eq!(row.geo.cell_size(), [120.0, 30.0]);
        assert_eq!(row.layers[0].values[0], 1.5);
        assert_eq!(row.layers[0].values[124], 497.5);
        // Whole blocks otherwise: 330 × 170 by 3, the last 2 rows left out.
        let block = coarsened(strip(330, 170), 3, Edges::Whole);
        assert_eq!((block.geo.width, block.geo.height), (110, 56));
        assert_eq!(block.geo.cell_size(), [90.0, 90.0]);
    }

    #[test]
    fn kept_edges_cover_the_whole_raster_with_clipped_blocks() {
        // 10 × 7 cells (values row · 10 + column, row 0 the southern) by 4: 3 × 2
        // cells. Blocks count from the north-west corner: the northern row of blocks
        // holds rows 3–6, the southern one rows 0–2 and reaches a row past the
        // raster; the eastern column holds columns 8 and 9.
        let map = coarsened(strip(10, 7), 4, Edges::Kept);
        assert_eq!((map.geo.width, map.geo.height), (3, 2));
        assert_eq!(map.geo.cell_size(), [120.0, 120.0]);
        assert_eq!(map.geo.origin, [0.0, -30.0]);
        let v = &map.layers[0].values;
        assert_eq!(v[0], 10.0 + 1.5);
        assert_eq!(v[2], 10.0 + 8.5);
        assert_eq!(v[3], 45.0 + 1.5);
        assert_eq!(v[5], 45.0 + 8.5);
        // The north edge stays where it was.
        assert_eq!(map.geo.bounds()[3], 210.0);
        // Every cell of the raster lies in a coarse cell.
        let [x0, y0, x1, y1] = map.geo.bounds();
        assert!(x0 <= 0.0 && y0 <= 0.0 && x1 >= 300.0 && y1 >= 210.0);
    }

    #[test]
    fn factors_come_from_a_side_in_cells_or_in_metres() {
        let geo = GeoRef::square(1000, 600, 0.5, [0.0, 0.0], "map");
        assert_eq!(factor_for_cells(&geo, 0), 1);
        assert_eq!(factor_for_cells(&geo, 400), 3);
        assert_eq!(factor_for_cells(&geo, 2000), 1);
        assert_eq!(factor_for_metres(&geo, 2.0), 4);
        assert_eq!(factor_for_metres(&geo, 2.2), 4);
        assert_eq!(factor_for_metres(&geo, 0.1), 1);
    }

    #[test]
    fn class_layers_take_their_most_common_class() {
        // 322 × 2 cells of classes 3 and 7 (the first block of two columns: 3, 3, 7
        // and nodata), by 3 to 107 × 1 (a 2-row raster keeps one block row).
        let mut map = strip(322, 2);
        let values = &mut map.layers[0].values;
        for (i, v) in values.iter_mut().enumerate() {
            *v = if i % 3 == 2 { 7.0 } else { 3.0 };
        }
        values[0] = f32::NAN;
        values[322] = 7.0;
        values[323] = 7.0;
        assert!(crate::grid::classes_of(values).is_some());
        let pooled = coarsened(map, 3, Edges::Whole);
        assert_eq!((pooled.geo.width, pooled.geo.height), (107, 1));
        // Block 0 holds 3, 7, 7, 7, 3 (and nodata): 7; every value is a class.
        assert_eq!(pooled.layers[0].values[0], 7.0);
        assert!(
            pooled.layers[0]
                .values
                .iter()
                .all(|&v| v == 3.0 || v == 7.0)
        );
        // Equal counts: the smaller class.
        assert_eq!(most_common([7.0, 3.0, 3.0, 7.0].into_iter()), 3.0);
        assert!(most_common(std::iter::empty()).is_nan());
    }
}
