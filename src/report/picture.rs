//! Pictures people read: costmaps on a shared colour scale, signed difference heat maps,
//! colour bars and pictures side by side, all north up (charts with axes: `chart`).

use crate::grid::{Cell, Grid};
use crate::io::png::Rgb;

use super::preview::viridis;

/// The log-cost range a picture's colours span: the 2nd to 98th percentile over every
/// given costmap, so that two costmaps drawn with it compare colour for colour.
pub fn log_cost_range(costmaps: &[&Grid<f32>]) -> (f32, f32) {
    let mut sorted: Vec<f32> = costmaps
        .iter()
        .flat_map(|g| g.data.iter())
        .map(|c| c.max(f32::MIN_POSITIVE).ln())
        .filter(|v| v.is_finite())
        .collect();
    sorted.sort_by(f32::total_cmp);
    let pick = |q: f32| {
        sorted
            .get(((sorted.len().saturating_sub(1)) as f32 * q) as usize)
            .copied()
    };
    let (lo, hi) = (pick(0.02).unwrap_or(0.0), pick(0.98).unwrap_or(1.0));
    (lo, hi.max(lo + 1e-6))
}

/// Paints one colour per cell, `scale` pixels square, north up.
fn paint(width: u32, height: u32, scale: u32, colour: impl Fn(usize) -> [u8; 3]) -> Rgb {
    let mut picture = Rgb::new(width * scale, height * scale);
    for row in 0..height {
        for col in 0..width {
            let c = colour((row * width + col) as usize);
            let top = (height - 1 - row) * scale;
            for y in top..top + scale {
                for x in col * scale..(col + 1) * scale {
                    picture.put(x, y, c);
                }
            }
        }
    }
    picture
}

/// A costmap in viridis over `range` of log-cost (blocked cells: the top colour).
pub fn paint_costs(costs: &Grid<f32>, range: (f32, f32), scale: u32) -> Rgb {
    let (lo, hi) = range;
    paint(costs.geo.width, costs.geo.height, scale, |i| {
        viridis((costs.data[i].max(f32::MIN_POSITIVE).ln() - lo) / (hi - lo))
    })
}

/// A non-negative quantity per cell (visits, probabilities) in viridis from 0 to its
/// largest value, with some cells painted over in their own colours.
pub fn paint_heat(values: &Grid<f32>, marks: &[(Cell, [u8; 3])], scale: u32) -> Rgb {
    let top = values.data.iter().fold(0.0f32, |m, &v| m.max(v)).max(1e-12);
    let mut colours: Vec<[u8; 3]> = values.data.iter().map(|&v| viridis(v / top)).collect();
    for &(cell, colour) in marks {
        colours[values.geo.index(cell)] = colour;
    }
    paint(values.geo.width, values.geo.height, scale, |i| colours[i])
}

/// Blue where `new` is cheaper than `old`, red where costlier, white where equal; full
/// colour at `span` log units (the largest difference when `None`).
pub fn paint_difference(old: &Grid<f32>, new: &Grid<f32>, span: Option<f32>, scale: u32) -> Rgb {
    let delta: Vec<f32> = old
        .data
        .iter()
        .zip(&new.data)
        .map(|(a, b)| {
            let d = b.max(f32::MIN_POSITIVE).ln() - a.max(f32::MIN_POSITIVE).ln();
            if d.is_finite() { d } else { 0.0 }
        })
        .collect();
    let span = span
        .unwrap_or_else(|| delta.iter().fold(0.0f32, |m, d| m.max(d.abs())))
        .max(1e-6);
    paint(old.geo.width, old.geo.height, scale, |i| {
        let t = (delta[i] / span).clamp(-1.0, 1.0);
        let fade = |full: f32| (255.0 - t.abs() * (255.0 - full)).round() as u8;
        if t >= 0.0 {
            [255, fade(30.0), fade(30.0)]
        } else {
            [fade(30.0), fade(60.0), 255]
        }
    })
}

/// A vertical viridis colour bar, cheap at the bottom.
pub fn colour_bar(width: u32, height: u32) -> Rgb {
    let mut bar = Rgb::new(width, height);
    for y in 0..height {
        let c = viridis(1.0 - y as f32 / (height.max(2) - 1) as f32);
        for x in 0..width {
            bar.put(x, y, c);
        }
    }
    bar
}

/// Pictures left to right on white, `gap` pixels apart, tops aligned.
pub fn side_by_side(pictures: &[&Rgb], gap: u32) -> Rgb {
    let width = pictures.iter().map(|p| p.width).sum::<u32>()
        + gap * pictures.len().saturating_sub(1) as u32;
    let height = pictures.iter().map(|p| p.height).max().unwrap_or(0);
    let mut out = Rgb::new(width, height);
    for y in 0..height {
        for x in 0..width {
            out.put(x, y, [255, 255, 255]);
        }
    }
    let mut left = 0;
    for picture in pictures {
        for y in 0..picture.height {
            for x in 0..picture.width {
                out.put(left + x, y, picture.get(x, y));
            }
        }
        left += picture.width + gap;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GeoRef;

    fn grid(values: Vec<f32>) -> Grid<f32> {
        let geo = GeoRef::square(2, 2, 1.0, [0.0, 0.0], "m");
        Grid::from_vec(geo, values)
    }

    #[test]
    fn difference_is_red_where_costlier_blue_where_cheaper_white_where_equal() {
        let old = grid(vec![1.0, 1.0, 1.0, 1.0]);
        let new = grid(vec![1.0, 4.0, 0.25, 1.0]);
        let picture = paint_difference(&old, &new, None, 1);
        // Row 0 (south) is the bottom picture row.
        assert_eq!(picture.get(0, 1), [255, 255, 255]);
        assert_eq!(picture.get(1, 1), [255, 30, 30]);
        assert_eq!(picture.get(0, 0), [30, 60, 255]);
    }

    #[test]
    fn the_colour_bar_is_costly_at_the_top() {
        let bar = colour_bar(4, 50);
        assert!(bar.get(0, 0)[1] > bar.get(0, 49)[1] + 100);
    }
}
