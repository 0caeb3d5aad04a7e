//! Raster kernels behind the feature operators. Each reads one layer (row-major,
//! `width` × `height`) and writes one plane; boundaries reflect about the edge
//! (scipy.ndimage's mode "reflect": d c b a | a b c d | d c b a), so the results match
//! `scipy.ndimage` and `numpy.gradient`, against which the benchmark checks them.

/// Index `i` (possibly outside 0..n) reflected into 0..n.
fn reflect(mut i: isize, n: usize) -> usize {
    let n = n as isize;
    let period = 2 * n;
    i = i.rem_euclid(period);
    (if i < n { i } else { period - 1 - i }) as usize
}

/// Copies `row` into `padded` with `r` reflected values on each side.
fn pad_row<T: Copy>(row: &[T], r: usize, padded: &mut [T]) {
    let n = row.len();
    padded[r..r + n].copy_from_slice(row);
    for j in 0..r {
        padded[j] = row[reflect(j as isize - r as isize, n)];
        padded[r + n + j] = row[reflect((n + j) as isize, n)];
    }
}

/// Symmetric 1-D kernel taps w[0..=radius] (w[k] applies at offsets ±k).
fn gaussian_taps(sigma: f64) -> Vec<f32> {
    let radius = (4.0 * sigma + 0.5) as usize;
    let raw: Vec<f64> = (0..=radius)
        .map(|k| (-0.5 * (k as f64 / sigma).powi(2)).exp())
        .collect();
    let total = raw[0] + 2.0 * raw[1..].iter().sum::<f64>();
    raw.iter().map(|w| (w / total) as f32).collect()
}

/// Rows of a raster filtered along themselves, computed on demand and kept in a ring
/// of `slots` rows, so that a vertical pass over a window of rows needs memory for the
/// window, not for a whole intermediate raster.
struct RowCache<T> {
    width: usize,
    rows: Vec<T>,
    tags: Vec<usize>,
}

impl<T: Copy + Default> RowCache<T> {
    fn new(width: usize, slots: usize) -> Self {
        RowCache {
            width,
            rows: vec![T::default(); width * slots],
            tags: vec![usize::MAX; slots],
        }
    }

    /// Row `row` filtered by `fill(row, out)`; a slot holds row `row % slots`.
    fn get(&mut self, row: usize, fill: &mut impl FnMut(usize, &mut [T])) -> &[T] {
        let slot = row % self.tags.len();
        let range = slot * self.width..(slot + 1) * self.width;
        if self.tags[slot] != row {
            fill(row, &mut self.rows[range.clone()]);
            self.tags[slot] = row;
        }
        &self.rows[range]
    }
}

/// The entry of `per_row` for `row`: one entry stands for every row.
fn of_row<T>(per_row: &[T], row: usize) -> &T {
    &per_row[if per_row.len() == 1 { 0 } else { row }]
}

/// Separable correlation with symmetric kernels: `taps_x` along rows, then `taps_y`
/// along columns (they differ where cells are not square), each one kernel for every
/// row or one per row (where the cells' ground size changes with latitude, each output
/// row takes its own).
fn separable(
    input: &[f32],
    width: usize,
    height: usize,
    taps_x: &[Vec<f32>],
    taps_y: &[Vec<f32>],
    out: &mut [f32],
) {
    let radius = |taps: &[Vec<f32>]| taps.iter().map(|t| t.len() - 1).max().unwrap_or(0);
    let (r, ry) = (radius(taps_x), radius(taps_y));
    let mut padded = vec![0.0f32; width + 2 * r];
    let mut across_row = |row: usize, dst: &mut [f32]| {
        pad_row(&input[row * width..(row + 1) * width], r, &mut padded);
        let taps = of_row(taps_x, row);
        // Tap by tap across the whole row, so the inner loop vectorises.
        for (d, &v) in dst.iter_mut().zip(&padded[r..r + width]) {
            *d = taps[0] * v;
        }
        for (k, &w) in taps.iter().enumerate().skip(1) {
            let (left, right) = (&padded[r - k..r - k + width], &padded[r + k..r + k + width]);
            for ((d, &a), &b) in dst.iter_mut().zip(left).zip(right) {
                *d += w * (a + b);
            }
        }
    };
    // Rows near an edge reflect onto rows within the same window, so 2r + 1 slots
    // always hold every row a window needs at once; a window taller than the raster
    // (a σ in metres toward a pole) needs no more slots than it has rows.
    let mut cache = RowCache::new(width, (2 * ry + 1).min(height.max(1)));
    let mut line = vec![0.0f32; width];
    for (row, dst) in out.chunks_exact_mut(width).enumerate() {
        let taps_y = of_row(taps_y, row);
        dst.copy_from_slice(cache.get(row, &mut across_row));
        for v in dst.iter_mut() {
            *v *= taps_y[0];
        }
        for (k, &w) in taps_y.iter().enumerate().skip(1) {
            line.copy_from_slice(
                cache.get(reflect(row as isize + k as isize, height), &mut across_row),
            );
            let below = cache.get(reflect(row as isize - k as isize, height), &mut across_row);
            for ((d, &a), &b) in dst.iter_mut().zip(&line).zip(below) {
                *d += w * (a + b);
            }
        }
    }
}

/// Gaussian blur with standard deviations `[σx, σy]` in cells (kernel radius 4σ, as
/// scipy); the two differ when a metric σ is taken on cells that are not square.
pub fn gaussian_blur(input: &[f32], width: usize, height: usize, sigma: [f64; 2], out: &mut [f32]) {
    gaussian_blur_by_row(input, width, height, &[sigma], out);
}

/// [`gaussian_blur`] with `[σx, σy]` in cells for every row (one pair for them all):
/// a σ in metres on a raster whose cells narrow with latitude spans more of them
/// toward the poles. Each row is blurred along itself with its own σx, and each row
/// of the result gathers the rows around it with its own σy.
pub fn gaussian_blur_by_row(
    input: &[f32],
    width: usize,
    height: usize,
    sigmas: &[[f64; 2]],
    out: &mut [f32],
) {
    let taps_x: Vec<Vec<f32>> = sigmas.iter().map(|s| gaussian_taps(s[0])).collect();
    let taps_y: Vec<Vec<f32>> = sigmas
        .iter()
        .zip(&taps_x)
        .map(|(s, x)| {
            if s[1] == s[0] {
                x.clone()
            } else {
                gaussian_taps(s[1])
            }
        })
        .collect();
    separable(input, width, height, &taps_x, &taps_y, out);
}

/// [`gaussian_blur`] of the cells with data (normalised convolution): each cell with
/// data the Gaussian-weighted mean of the data around it, cells without data (NaN)
/// left out rather than read as a fill value, whose cliff at the edge of every void a
/// blur would spread over σ. A cell without data is `fill`, as its own value reads:
/// a void stays as distinct from the ground around it as the fill makes it. Where
/// every cell has data it is `gaussian_blur`, to the bit.
pub fn gaussian_blur_of_data(
    input: &[f32],
    width: usize,
    height: usize,
    sigmas: &[[f64; 2]],
    fill: f32,
    out: &mut [f32],
) {
    if !input.iter().any(|v| v.is_nan()) {
        return gaussian_blur_by_row(input, width, height, sigmas, out);
    }
    let values: Vec<f32> = input
        .iter()
        .map(|&v| if v.is_nan() { 0.0 } else { v })
        .collect();
    let data: Vec<f32> = input
        .iter()
        .map(|&v| f32::from(u8::from(!v.is_nan())))
        .collect();
    let mut weight = vec![0.0f32; input.len()];
    gaussian_blur_by_row(&values, width, height, sigmas, out);
    gaussian_blur_by_row(&data, width, height, sigmas, &mut weight);
    for ((o, &w), v) in out.iter_mut().zip(&weight).zip(input) {
        *o = if v.is_nan() { fill } else { *o / w };
    }
}

/// Local standard deviation (roughness) over a `window` × `window` square (odd), of
/// the cells with data in it: a cell without data (NaN) is left out rather than read
/// as a fill value, which would make every edge of a void rough ground (and, running
/// through the sums, every cell after it); 0 on a cell without data, as the
/// gradient is.
pub fn local_std(input: &[f32], width: usize, height: usize, window: usize, out: &mut [f32]) {
    local_std_by_row(input, width, height, &[[window, window]], out);
}

/// [`local_std`] over windows of `[columns, rows]` (odd) for every row, or one pair
/// for them all: a window of so many metres on cells that are not square, or that
/// narrow with latitude, spans its own count of cells along each axis and row. Each
/// row is summed along itself over its own columns, and each row of the result gathers
/// its own count of rows around it, as [`gaussian_blur_by_row`] does.
/// Sums of x, x² and the cells with data run along rows, then down columns, in f64 so
/// that E[x²] − E[x]² stays accurate; each row's sums are recomputed when it leaves
/// the window instead of being stored, so memory is a few rows.
pub fn local_std_by_row(
    input: &[f32],
    width: usize,
    height: usize,
    windows: &[[usize; 2]],
    out: &mut [f32],
) {
    let max_rx = windows.iter().map(|w| w[0] / 2).max().unwrap_or(0);
    // (x, x², 1) of a cell with data, zeros of one without.
    let mut padded = vec![[0.0f64; 3]; width + 2 * max_rx];
    let mut row_sums = |row: usize, sums: &mut [[f64; 3]]| {
        let window = of_row(windows, row)[0];
        let r = window / 2;
        for (p, &v) in padded[r..r + width]
            .iter_mut()
            .zip(&input[row * width..(row + 1) * width])
        {
            let x = f64::from(v);
            *p = if v.is_nan() {
                [0.0; 3]
            } else {
                [x, x * x, 1.0]
            };
        }
        for j in 0..r {
            padded[j] = padded[r + reflect(j as isize - r as isize, width)];
            padded[r + width + j] = padded[r + reflect((width + j) as isize, width)];
        }
        let mut acc = [0.0f64; 3];
        for v in &padded[..window] {
            add(&mut acc, v, 1.0);
        }
        for c in 0..width {
            sums[c] = acc;
            if c + 1 < width {
                let (enter, leave) = (padded[c + window], padded[c]);
                for ((a, e), l) in acc.iter_mut().zip(enter).zip(leave) {
                    *a += e - l;
                }
            }
        }
    };
    fn add(acc: &mut [f64; 3], v: &[f64; 3], sign: f64) {
        for (a, x) in acc.iter_mut().zip(v) {
            *a += sign * x;
        }
    }
    let mut column = vec![[0.0f64; 3]; width];
    let mut sums = vec![[0.0f64; 3]; width];
    let mut add_row = |row: isize, sign: f64, column: &mut [[f64; 3]]| {
        row_sums(reflect(row, height), &mut sums);
        for (c, s) in column.iter_mut().zip(&sums) {
            add(c, s, sign);
        }
    };
    // The rows summed in `column`, before reflection: top..=bottom. Each output row
    // moves the window's ends to its own half-height, one row at a time (rows below
    // enter before rows above leave, so a window of one height for every row is
    // summed in the same order as a sliding one).
    let ry = |row: usize| (of_row(windows, row)[1] / 2) as isize;
    let (mut top, mut bottom) = (-ry(0), -ry(0) - 1);
    for (row, dst) in out.chunks_exact_mut(width).enumerate() {
        let (new_top, new_bottom) = (row as isize - ry(row), row as isize + ry(row));
        while bottom < new_bottom {
            bottom += 1;
            add_row(bottom, 1.0, &mut column);
        }
        while top < new_top {
            add_row(top, -1.0, &mut column);
            top += 1;
        }
        while top > new_top {
            top -= 1;
            add_row(top, 1.0, &mut column);
        }
        while bottom > new_bottom {
            add_row(bottom, -1.0, &mut column);
            bottom -= 1;
        }
        let here = &input[row * width..(row + 1) * width];
        for ((d, &[s, q, n]), v) in dst.iter_mut().zip(&column).zip(here) {
            *d = if v.is_nan() {
                0.0
            } else {
                let mean = s / n;
                (q / n - mean * mean).max(0.0).sqrt() as f32
            };
        }
    }
}

/// Derivative along one axis the way numpy.gradient takes it: central differences
/// inside, one-sided at the two ends; `before` and `after` are the neighbours. A
/// neighbour without data (NaN) is an end too, so that a DEM's voids do not read as
/// cliffs; a cell without data gets 0.
#[inline(always)]
fn difference(
    before: f32,
    here: f32,
    after: f32,
    at_start: bool,
    at_end: bool,
    spacing: f64,
) -> f64 {
    if here.is_nan() {
        return 0.0;
    }
    // A neighbour without data is an edge: the difference is one-sided there.
    let (at_start, at_end) = (at_start || before.is_nan(), at_end || after.is_nan());
    let (b, h, a) = (f64::from(before), f64::from(here), f64::from(after));
    match (at_start, at_end) {
        (true, true) => 0.0,
        (true, false) => (a - h) / spacing,
        (false, true) => (h - b) / spacing,
        (false, false) => (a - b) / (2.0 * spacing),
    }
}

/// Calls `each(dx, dy)` with the derivatives ∂z/∂x and ∂z/∂y (per metre; `spacing` is
/// the cell size (x, y) in metres, per row or for all) of every cell, writing what it
/// returns: the one traversal behind the gradient, slope and aspect.
fn from_derivatives(
    input: &[f32],
    width: usize,
    height: usize,
    spacing: &[[f64; 2]],
    out: &mut [f32],
    each: impl Fn(f64, f64) -> f64,
) {
    let line = |r: usize| &input[r * width..(r + 1) * width];
    for (row, dst) in out.chunks_exact_mut(width).enumerate() {
        let spacing = *of_row(spacing, row);
        let (here, below, above) = (
            line(row),
            line(row.saturating_sub(1)),
            line((row + 1).min(height - 1)),
        );
        for col in 0..width {
            let (left, right) = (here[col.saturating_sub(1)], here[(col + 1).min(width - 1)]);
            let dx = difference(
                left,
                here[col],
                right,
                col == 0,
                col == width - 1,
                spacing[0],
            );
            let dy = difference(
                below[col],
                here[col],
                above[col],
                row == 0,
                row == height - 1,
                spacing[1],
            );
            dst[col] = each(dx, dy) as f32;
        }
    }
}

/// Gradient magnitude |∇z| (units of z per metre) and, with `degrees`, the slope
/// atan |∇z| in degrees; `spacing` is the cell size (x, y) in metres, per row or for all.
pub fn gradient(
    input: &[f32],
    width: usize,
    height: usize,
    spacing: &[[f64; 2]],
    degrees: bool,
    out: &mut [f32],
) {
    from_derivatives(input, width, height, spacing, out, |dx, dy| {
        let magnitude = (dx * dx + dy * dy).sqrt();
        if degrees {
            magnitude.atan().to_degrees()
        } else {
            magnitude
        }
    });
}

/// Aspect: the direction of steepest descent in degrees clockwise from north (0–360),
/// 0 on flat cells; `spacing` is the cell size (x, y) in metres, per row or for all.
/// Rows grow north.
pub fn aspect(input: &[f32], width: usize, height: usize, spacing: &[[f64; 2]], out: &mut [f32]) {
    from_derivatives(input, width, height, spacing, out, |dx, dy| {
        // Downhill is −∇z; its bearing from north is atan2(east, north).
        if dx == 0.0 && dy == 0.0 {
            0.0
        } else {
            (-dx).atan2(-dy).to_degrees().rem_euclid(360.0)
        }
    });
}

/// The 5-point Laplacian per square metre (scipy.ndimage.laplace / resolution² on
/// square cells); `spacing` is the cell size (x, y) in metres, per row or for all.
/// Along an axis with a neighbour without data (NaN) there is no second difference
/// (0), so that a void's edge is no curvature, and a cell without data gets 0, as
/// [`gradient`] steps around gaps.
pub fn laplacian(
    input: &[f32],
    width: usize,
    height: usize,
    spacing: &[[f64; 2]],
    out: &mut [f32],
) {
    let line = |r: isize| {
        let rr = reflect(r, height);
        &input[rr * width..(rr + 1) * width]
    };
    let mut padded = vec![0.0f32; width + 2];
    for (row, dst) in out.chunks_exact_mut(width).enumerate() {
        let [sx, sy] = *of_row(spacing, row);
        let (scale, scale_y) = (1.0 / (sx * sx), 1.0 / (sy * sy));
        let here = line(row as isize);
        pad_row(here, 1, &mut padded);
        let (below, above) = (line(row as isize - 1), line(row as isize + 1));
        for c in 0..width {
            let h = f64::from(here[c]);
            let (left, right, down, up) = (padded[c], padded[c + 2], below[c], above[c]);
            dst[c] = if h.is_nan() {
                0.0
            } else if scale_y == scale && ![left, right, down, up].iter().any(|v| v.is_nan()) {
                let sum =
                    f64::from(down) + f64::from(up) + f64::from(left) + f64::from(right) - 4.0 * h;
                sum * scale
            } else {
                // Each axis's second difference where both its neighbours have data.
                let second = |a: f32, b: f32| {
                    if a.is_nan() || b.is_nan() {
                        0.0
                    } else {
                        f64::from(a) + f64::from(b) - 2.0 * h
                    }
                };
                second(left, right) * scale + second(down, up) * scale_y
            } as f32;
        }
    }
}

/// Exact Euclidean distance (metres) from every cell to the nearest target cell, by
/// Felzenszwalb and Huttenlocher's linear-time algorithm: distances along columns,
/// then the lower envelope of parabolas along rows. `spacing` is the cell size (x, y)
/// in metres, one pair for every row or one for them all: where the cells narrow with
/// latitude, a row's east-west lengths are its own and north-south lengths sum the
/// rows crossed (the ground distance on the query cell's tangent plane). Capped at
/// `cap`, which is also the value everywhere when there is no target at all.
pub fn distance_transform(
    target: &[bool],
    width: usize,
    height: usize,
    spacing: &[[f64; 2]],
    cap: f64,
    out: &mut [f32],
) {
    // Northings of the rows' centres in units of the first row's height: whole rows
    // (exact) where every row is alike.
    let unit = spacing[0][1];
    let mut northing = vec![0.0f64; height];
    for row in 1..height {
        northing[row] = if spacing.len() == 1 {
            row as f64
        } else {
            northing[row - 1] + 0.5 * (spacing[row - 1][1] + spacing[row][1]) / unit
        };
    }
    // Pass 1: distance along each column to its nearest target row, in those units,
    // as whole-row sweeps down then up.
    let mut along = vec![f64::INFINITY; width * height];
    let rows = 0..height;
    column_sweep(&mut along, target, width, &northing, rows.clone(), 1.0);
    column_sweep(&mut along, target, width, &northing, rows.rev(), -1.0);
    // Pass 2: per row, the lower envelope of parabolas (c - q)² + g(q)².
    let mut vertices = vec![0usize; width];
    let mut bounds = vec![0.0f64; width + 1];
    for row in 0..height {
        // Column distances count rows; in units of this row's cell width a row is
        // this long.
        let [resolution, _] = *of_row(spacing, row);
        let row_length = unit / resolution;
        let g = &along[row * width..(row + 1) * width];
        let f = |q: usize| {
            let rows = if row_length == 1.0 {
                g[q]
            } else {
                g[q] * row_length
            };
            rows * rows
        };
        let dst = &mut out[row * width..(row + 1) * width];
        let mut k: isize = -1;
        for (q, gq) in g.iter().enumerate() {
            if !gq.is_finite() {
                continue;
            }
            loop {
                if k < 0 {
                    k = 0;
                    vertices[0] = q;
                    bounds[0] = f64::NEG_INFINITY;
                    bounds[1] = f64::INFINITY;
                    break;
                }
                let v = vertices[k as usize];
                let s = ((f(q) + (q * q) as f64) - (f(v) + (v * v) as f64))
                    / (2.0 * (q as f64 - v as f64));
                if s <= bounds[k as usize] {
                    k -= 1;
                    continue;
                }
                k += 1;
                vertices[k as usize] = q;
                bounds[k as usize] = s;
                bounds[k as usize + 1] = f64::INFINITY;
                break;
            }
        }
        if k < 0 {
            dst.fill(cap as f32);
            continue;
        }
        let mut j = 0usize;
        for (c, d) in dst.iter_mut().enumerate() {
            while bounds[j + 1] < c as f64 {
                j += 1;
            }
            let v = vertices[j];
            let squared = (c as f64 - v as f64).powi(2) + f(v);
            *d = (squared.sqrt() * resolution).min(cap) as f32;
        }
    }
}

/// One sweep of the distance transform's first pass over `rows` (northward for
/// `sign` 1, southward for −1): each column keeps the northing of the last target row
/// it met, and every cell's distance along its column becomes at most the distance to
/// it (infinite before any).
fn column_sweep(
    along: &mut [f64],
    target: &[bool],
    width: usize,
    northing: &[f64],
    rows: impl Iterator<Item = usize>,
    sign: f64,
) {
    let mut nearest = vec![-sign * f64::INFINITY; width];
    for row in rows {
        let (y, cells) = (northing[row], row * width..(row + 1) * width);
        for ((d, t), &is_target) in along[cells.clone()]
            .iter_mut()
            .zip(nearest.iter_mut())
            .zip(&target[cells])
        {
            if is_target {
                *t = y;
            }
            *d = d.min(sign * (y - *t));
        }
    }
}

/// (x − median) / interquartile range, with quantiles at index ⌊q(n − 1)⌋ of the
/// sorted values (numpy's method "lower"); a zero range divides by 1.
pub fn robust_normalize(input: &[f32], out: &mut [f32]) {
    let mut sorted = input.to_vec();
    let n = sorted.len();
    let mut quantile = |q: f64| {
        let k = (q * (n - 1) as f64) as usize;
        *sorted.select_nth_unstable_by(k, f32::total_cmp).1
    };
    let (q25, q50, q75) = (quantile(0.25), quantile(0.5), quantile(0.75));
    let range = if q75 > q25 { q75 - q25 } else { 1.0 };
    for (o, &x) in out.iter_mut().zip(input) {
        *o = (x - q50) / range;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflection_is_half_sample_symmetric() {
        let mapped: Vec<usize> = (-3..7).map(|i| reflect(i, 4)).collect();
        assert_eq!(mapped, [2, 1, 0, 0, 1, 2, 3, 3, 2, 1]);
    }

    #[test]
    fn blur_keeps_constants_and_mass() {
        let (w, h) = (9, 7);
        let mut out = vec![0.0; w * h];
        gaussian_blur(&vec![3.0; w * h], w, h, [1.5; 2], &mut out);
        assert!(out.iter().all(|v| (v - 3.0).abs() < 1e-5));
        let mut impulse = vec![0.0; w * h];
        impulse[3 * w + 4] = 1.0;
        gaussian_blur(&impulse, w, h, [1.0; 2], &mut out);
        assert!(
            (out.iter().sum::<f32>() - 1.0).abs() < 1e-4,
            "mass is kept away from the edges"
        );
        assert!(out[3 * w + 4] > out[3 * w + 5] && out[3 * w + 5] > out[3 * w + 6]);
    }

    #[test]
    fn blurs_wider_than_the_raster_reflect_as_often_as_they_reach() {
        // Windows many times the raster's side (and a row cache no taller than it):
        // the separable pass against the plain double sum over reflected cells.
        let (w, h) = (5, 4);
        let input: Vec<f32> = (0..w * h).map(|i| ((i * 7) % 11) as f32).collect();
        let sigma = [6.0, 9.0];
        let mut out = vec![0.0; w * h];
        gaussian_blur(&input, w, h, sigma, &mut out);
        let (tx, ty) = (gaussian_taps(sigma[0]), gaussian_taps(sigma[1]));
        fn offsets(taps: &[f32]) -> impl Iterator<Item = (isize, f32)> + '_ {
            let r = taps.len() as isize - 1;
            (-r..=r).map(move |k| (k, taps[k.unsigned_abs()]))
        }
        for (i, &found) in out.iter().enumerate() {
            let (r, c) = ((i / w) as isize, (i % w) as isize);
            let mut sum = 0.0f64;
            for (k, wy) in offsets(&ty) {
                for (l, wx) in offsets(&tx) {
                    let cell = reflect(r + k, h) * w + reflect(c + l, w);
                    sum += f64::from(wy) * f64::from(wx) * f64::from(input[cell]);
                }
            }
            assert!(
                (f64::from(found) - sum).abs() < 1e-4,
                "cell {i}: {found} vs {sum}"
            );
        }
    }

    #[test]
    fn local_std_of_a_checkerboard() {
        let (w, h) = (6, 6);
        let input: Vec<f32> = (0..w * h).map(|i| ((i / w + i % w) % 2) as f32).collect();
        let mut out = vec![0.0; w * h];
        local_std(&input, w, h, 3, &mut out);
        // A 3x3 window in the interior holds 4 or 5 ones of 9.
        let interior = out[2 * w + 2];
        assert!(
            (interior - (20.0f32 / 81.0).sqrt()).abs() < 1e-5,
            "{interior}"
        );
    }

    #[test]
    fn gradient_and_slope_of_a_plane() {
        let (w, h) = (5, 4);
        // z = 2x metres per metre at resolution 0.5: one cell east raises z by 1.
        let input: Vec<f32> = (0..w * h).map(|i| (i % w) as f32).collect();
        let mut out = vec![0.0; w * h];
        gradient(&input, w, h, &[[0.5; 2]], false, &mut out);
        assert!(out.iter().all(|&g| (g - 2.0).abs() < 1e-6));
        gradient(&input, w, h, &[[0.5; 2]], true, &mut out);
        assert!(
            out.iter()
                .all(|&s| (s - 2f32.atan().to_degrees()).abs() < 1e-4)
        );
        laplacian(&input, w, h, &[[0.5; 2]], &mut out);
        assert!(out[w + 2].abs() < 1e-6, "a plane has no curvature inside");
    }

    #[test]
    fn derivatives_step_around_cells_without_data() {
        // One row 1, 2, void, 4, 6 on 1 m cells: the void's neighbours take one-sided
        // differences away from it, and the void itself is flat; no cliff to a fill.
        let input = [1.0, 2.0, f32::NAN, 4.0, 6.0];
        let mut out = [0.0; 5];
        gradient(&input, 5, 1, &[[1.0; 2]], false, &mut out);
        assert_eq!(out, [1.0, 1.0, 0.0, 2.0, 2.0]);
        // A cell between two voids has nothing to differ from.
        let island = [f32::NAN, 3.0, f32::NAN];
        let mut out = [9.0; 3];
        gradient(&island, 3, 1, &[[1.0; 2]], false, &mut out);
        assert_eq!(out, [0.0; 3]);
    }

    #[test]
    fn distance_transform_matches_brute_force() {
        let (w, h) = (13, 9);
        let target: Vec<bool> = (0..w * h).map(|i| i % 17 == 3 || i == 50).collect();
        let mut out = vec![0.0; w * h];
        distance_transform(&target, w, h, &[[0.5; 2]], 100.0, &mut out);
        for (i, &found) in out.iter().enumerate() {
            let (r, c) = ((i / w) as f64, (i % w) as f64);
            let best = (0..w * h)
                .filter(|&j| target[j])
                .map(|j| ((r - (j / w) as f64).powi(2) + (c - (j % w) as f64).powi(2)).sqrt())
                .fold(f64::INFINITY, f64::min);
            assert!(
                (f64::from(found) - 0.5 * best).abs() < 1e-5,
                "cell {i}: {found} vs {}",
                0.5 * best
            );
        }
        distance_transform(&vec![false; w * h], w, h, &[[1.0; 2]], 7.0, &mut out);
        assert!(out.iter().all(|&d| d == 7.0));
    }

    /// Cell sizes of a raster of half-degree cells from 50° N, row by row, on a sphere
    /// (2° rows, each narrower than the one south of it, by its latitude's cosine),
    /// and a little taller too, as on the ellipsoid.
    fn narrowing_rows(h: usize) -> Vec<[f64; 2]> {
        (0..h)
            .map(|r| {
                let latitude = (51.0 + 2.0 * r as f64).to_radians();
                [55_660.0 * latitude.cos(), 55_660.0 + 10.0 * r as f64]
            })
            .collect()
    }

    #[test]
    fn distances_measure_each_row_at_its_latitude() {
        // The brute force on the query cell's tangent plane: its own row's east-west
        // cell width, the rows' heights summed north-south.
        let (w, h) = (11, 11);
        let spacing = narrowing_rows(h);
        let mut northing = vec![0.0; h];
        for r in 1..h {
            northing[r] = northing[r - 1] + 0.5 * (spacing[r - 1][1] + spacing[r][1]);
        }
        let target: Vec<bool> = (0..w * h).map(|i| i % 13 == 5 || i == 64).collect();
        let mut out = vec![0.0; w * h];
        distance_transform(&target, w, h, &spacing, 1e9, &mut out);
        for (i, &found) in out.iter().enumerate() {
            let (r, c) = (i / w, (i % w) as f64);
            let best = (0..w * h)
                .filter(|&j| target[j])
                .map(|j| {
                    let east = spacing[r][0] * (c - (j % w) as f64);
                    east.hypot(northing[r] - northing[j / w])
                })
                .fold(f64::INFINITY, f64::min);
            let error = (f64::from(found) - best).abs() / best.max(1.0);
            assert!(error < 1e-6, "cell {i}: {found} vs {best}");
        }
        // Rows alike give what the one pair gives, to the bit.
        let mut one = vec![0.0; w * h];
        distance_transform(&target, w, h, &[spacing[3]], 1e9, &mut one);
        distance_transform(&target, w, h, &vec![spacing[3]; h], 1e9, &mut out);
        assert_eq!(one, out);
    }

    #[test]
    fn metric_blurs_widen_with_latitude() {
        // σ of 40 km in cells of each row, and no blur down the columns: every row is
        // its own 1-D Gaussian, wider in columns the narrower its cells.
        let (w, h) = (64, 11);
        let spacing = narrowing_rows(h);
        let sigmas: Vec<[f64; 2]> = spacing.iter().map(|s| [40e3 / s[0], 0.1]).collect();
        let mut impulse = vec![0.0f32; w * h];
        for r in 0..h {
            impulse[r * w + w / 2] = 1.0;
        }
        let mut out = vec![0.0; w * h];
        gaussian_blur_by_row(&impulse, w, h, &sigmas, &mut out);
        let mut widths = Vec::new();
        for r in 0..h {
            let mut alone = vec![0.0; w];
            gaussian_blur(&impulse[r * w..(r + 1) * w], w, 1, sigmas[r], &mut alone);
            assert_eq!(&out[r * w..(r + 1) * w], alone, "row {r}");
            let mass: f32 = alone.iter().sum();
            assert!((mass - 1.0).abs() < 1e-5);
            let spread: f32 = alone
                .iter()
                .enumerate()
                .map(|(c, &v)| v * (c as f32 - (w / 2) as f32).powi(2))
                .sum();
            widths.push(spread.sqrt());
        }
        assert!(widths.windows(2).all(|p| p[1] > p[0]), "{widths:?}");
    }

    #[test]
    fn aspect_points_downhill_from_north() {
        let (w, h) = (4, 4);
        let mut out = vec![0.0; w * h];
        // Rising to the east: downhill faces west (270°).
        let east: Vec<f32> = (0..w * h).map(|i| (i % w) as f32).collect();
        aspect(&east, w, h, &[[1.0; 2]], &mut out);
        assert!(out.iter().all(|&a| (a - 270.0).abs() < 1e-4), "{out:?}");
        // Rising to the north (rows grow north): downhill faces south (180°).
        let north: Vec<f32> = (0..w * h).map(|i| (i / w) as f32).collect();
        aspect(&north, w, h, &[[1.0; 2]], &mut out);
        assert!(out.iter().all(|&a| (a - 180.0).abs() < 1e-4));
        aspect(&vec![2.0; w * h], w, h, &[[1.0; 2]], &mut out);
        assert!(out.iter().all(|&a| a == 0.0));
    }

    #[test]
    fn kernels_measure_rectangular_cells_per_axis() {
        let (w, h) = (11, 9);
        let target: Vec<bool> = (0..w * h).map(|i| i % 23 == 5).collect();
        let mut out = vec![0.0; w * h];
        let (sx, sy) = (0.5, 1.25);
        distance_transform(&target, w, h, &[[sx, sy]], 100.0, &mut out);
        for (i, &found) in out.iter().enumerate() {
            let (r, c) = ((i / w) as f64, (i % w) as f64);
            let best = (0..w * h)
                .filter(|&j| target[j])
                .map(|j| {
                    (((r - (j / w) as f64) * sy).powi(2) + ((c - (j % w) as f64) * sx).powi(2))
                        .sqrt()
                })
                .fold(f64::INFINITY, f64::min);
            assert!(
                (f64::from(found) - best).abs() < 1e-5,
                "cell {i}: {found} vs {best}"
            );
        }
        // z = x + y in metres: the gradient is √2 whatever the cells.
        let z: Vec<f32> = (0..w * h)
            .map(|i| ((i % w) as f64 * sx + (i / w) as f64 * sy) as f32)
            .collect();
        gradient(&z, w, h, &[[sx, sy]], false, &mut out);
        assert!(out.iter().all(|&g| (g - 2f32.sqrt()).abs() < 1e-5));
        // Rows of different widths (degrees of longitude shorten towards the poles):
        // z climbing 1 per cell east climbs 1 / (the row's cell width) per metre.
        let by_row: Vec<[f64; 2]> = (0..h).map(|r| [sx * (1.0 + r as f64), sy]).collect();
        let z: Vec<f32> = (0..w * h).map(|i| (i % w) as f32).collect();
        gradient(&z, w, h, &by_row, false, &mut out);
        for (i, &g) in out.iter().enumerate() {
            let expected = 1.0 / by_row[i / w][0];
            assert!((f64::from(g) - expected).abs() < 1e-6, "cell {i}: {g}");
        }
        aspect(&z, w, h, &by_row, &mut out);
        assert!(
            out.iter().all(|&a| (a - 270.0).abs() < 1e-3),
            "downhill is west"
        );
        // z = x² + y²: the Laplacian is 4 per square metre inside.
        let z: Vec<f32> = (0..w * h)
            .map(|i| (((i % w) as f64 * sx).powi(2) + ((i / w) as f64 * sy).powi(2)) as f32)
            .collect();
        laplacian(&z, w, h, &[[sx, sy]], &mut out);
        assert!((out[4 * w + 5] - 4.0).abs() < 1e-3, "{}", out[4 * w + 5]);
        // A blur with σ of 2 cells across and 1 down spreads an impulse twice as far
        // along the row, and keeps its mass.
        let mut impulse = vec![0.0; w * h];
        impulse[4 * w + 5] = 1.0;
        gaussian_blur(&impulse, w, h, [2.0, 1.0], &mut out);
        assert!((out.iter().sum::<f32>() - 1.0).abs() < 1e-3);
        assert!(out[4 * w + 7] > out[6 * w + 5]);
    }

    /// A raster of `w` × `h` with a void (NaN) in the rows and columns given.
    fn with_void(
        w: usize,
        h: usize,
        value: impl Fn(usize, usize) -> f32,
        void: (std::ops::Range<usize>, std::ops::Range<usize>),
    ) -> Vec<f32> {
        (0..w * h)
            .map(|i| {
                let (r, c) = (i / w, i % w);
                if void.0.contains(&r) && void.1.contains(&c) {
                    f32::NAN
                } else {
                    value(r, c)
                }
            })
            .collect()
    }

    #[test]
    fn neighbourhoods_read_the_data_around_a_void_not_a_fill() {
        let (w, h) = (12, 10);
        let flat = with_void(w, h, |_, _| 50.0, (3..6, 4..8));
        let mut out = vec![f32::NAN; w * h];
        // Flat ground with a hole is nowhere rough, and blurs to itself; the hole reads
        // the fill.
        local_std(&flat, w, h, 5, &mut out);
        assert!(out.iter().all(|&v| v == 0.0), "{out:?}");
        gaussian_blur_of_data(&flat, w, h, &[[1.5; 2]], -1.0, &mut out);
        for (v, o) in flat.iter().zip(&out) {
            let expected = if v.is_nan() { -1.0 } else { 50.0 };
            assert!((o - expected).abs() < 1e-4, "{out:?}");
        }
        // A plane's curvature is 0 beside the hole as everywhere inside (the edges
        // reflect), and 0 in it.
        let plane = with_void(w, h, |r, c| (3 * c + r) as f32, (3..6, 4..8));
        laplacian(&plane, w, h, &[[1.0; 2]], &mut out);
        let inside = (1..h - 1).flat_map(|r| (1..w - 1).map(move |c| r * w + c));
        assert!(inside.map(|i| out[i]).all(|v| v.abs() < 1e-4), "{out:?}");
        // No data at all: the fill, and no roughness.
        let empty = vec![f32::NAN; w * h];
        gaussian_blur_of_data(&empty, w, h, &[[1.0; 2]], -1.0, &mut out);
        assert!(out.iter().all(|&v| v == -1.0));
        local_std(&empty, w, h, 3, &mut out);
        assert!(out.iter().all(|&v| v == 0.0));
    }

    /// The standard deviation of `data` (over its count, as roughness takes it).
    fn spread(data: &[f64]) -> f64 {
        let n = data.len() as f64;
        let mean = data.iter().sum::<f64>() / n;
        (data.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt()
    }

    proptest::proptest! {
        /// The roughness of a cell with data is the standard deviation of the cells with
        /// data in its window (reflected at the edges), and a raster without voids blurs as
        /// `gaussian_blur` does, to the bit.
        #[test]
        fn roughness_is_the_spread_of_the_data_in_the_window(
            cells in proptest::collection::vec(proptest::option::weighted(0.8, -100.0f32..100.0), 48),
            window in proptest::sample::select(vec![1usize, 3, 5]),
        ) {
            let (w, h) = (8, 6);
            let input: Vec<f32> = cells.iter().map(|v| v.unwrap_or(f32::NAN)).collect();
            let mut out = vec![0.0; w * h];
            local_std(&input, w, h, window, &mut out);
            let r = window as isize / 2;
            for (i, &got) in out.iter().enumerate() {
                let (row, col) = ((i / w) as isize, (i % w) as isize);
                let data: Vec<f64> = (-r..=r)
                    .flat_map(|dr| (-r..=r).map(move |dc| (dr, dc)))
                    .map(|(dr, dc)| input[reflect(row + dr, h) * w + reflect(col + dc, w)])
                    .filter(|v| !v.is_nan())
                    .map(f64::from)
                    .collect();
                let expected = if input[i].is_nan() { 0.0 } else { spread(&data) };
                proptest::prop_assert!((f64::from(got) - expected).abs() < 1e-3, "cell {i}: {got} vs {expected}");
            }
            let full: Vec<f32> = cells.iter().map(|v| v.unwrap_or(1.0)).collect();
            let (mut plain, mut of_data) = (vec![0.0; w * h], vec![0.0; w * h]);
            gaussian_blur(&full, w, h, [1.0; 2], &mut plain);
            gaussian_blur_of_data(&full, w, h, &[[1.0; 2]], 0.0, &mut of_data);
            proptest::prop_assert_eq!(plain, of_data);
        }
    }

    proptest::proptest! {
        /// With windows of their own per axis and row, each output row's roughness is
        /// the spread of the data in its own rows around it, each read over that input
        /// row's own columns (reflected at the edges), as `gaussian_blur_by_row`
        /// gathers rows blurred each with its own σ.
        #[test]
        fn roughness_by_row_reads_each_rows_own_window(
            cells in proptest::collection::vec(proptest::option::weighted(0.9, -100.0f32..100.0), 63),
            windows in proptest::collection::vec((0usize..9, 0usize..5), 7),
        ) {
            let (w, h) = (9, 7);
            let input: Vec<f32> = cells.iter().map(|v| v.unwrap_or(f32::NAN)).collect();
            let windows: Vec<[usize; 2]> =
                windows.iter().map(|&(x, y)| [2 * x + 1, 2 * y + 1]).collect();
            let mut out = vec![0.0; w * h];
            local_std_by_row(&input, w, h, &windows, &mut out);
            for (i, &got) in out.iter().enumerate() {
                let (row, col) = ((i / w) as isize, (i % w) as isize);
                let ry = (windows[row as usize][1] / 2) as isize;
                let data: Vec<f64> = (-ry..=ry)
                    .flat_map(|dr| {
                        let source = reflect(row + dr, h);
                        let rx = (windows[source][0] / 2) as isize;
                        (-rx..=rx).map(move |dc| source * w + reflect(col + dc, w))
                    })
                    .map(|j| input[j])
                    .filter(|v| !v.is_nan())
                    .map(f64::from)
                    .collect();
                let expected = if input[i].is_nan() { 0.0 } else { spread(&data) };
                proptest::prop_assert!((f64::from(got) - expected).abs() < 1e-3, "cell {i}: {got} vs {expected}");
            }
        }
    }

    #[test]
    fn robust_normalisation_centres_on_the_median() {
        let input: Vec<f32> = (0..9).map(|v| v as f32).collect();
        let mut out = vec![0.0; 9];
        robust_normalize(&input, &mut out);
        assert_eq!(out[4], 0.0);
        assert_eq!(out[8], 1.0); // (8 − 4) / (6 − 2)
    }
}
