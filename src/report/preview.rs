//! Costmap previews: log-cost as a colour map (viridis: dark is cheap, yellow is
//! costly), demonstrations in red, planned paths in green, cells on both in white.
//! North is up, as in the georeference (row 0 is the southern edge).

use crate::error::{Error, Result};
use crate::grid::{Cell, Grid};
use crate::io::png::Rgb;

pub const COLOUR_DEMONSTRATION: [u8; 3] = [230, 25, 25];
pub const COLOUR_PLAN: [u8; 3] = [30, 220, 60];
pub const COLOUR_BOTH: [u8; 3] = [255, 255, 255];

/// Viridis, sampled at nine points.
const VIRIDIS: [[f32; 3]; 9] = [
    [68.0, 1.0, 84.0],
    [71.0, 44.0, 122.0],
    [59.0, 81.0, 139.0],
    [44.0, 113.0, 142.0],
    [33.0, 144.0, 141.0],
    [39.0, 173.0, 129.0],
    [92.0, 200.0, 99.0],
    [170.0, 220.0, 50.0],
    [253.0, 231.0, 37.0],
];

pub(crate) fn viridis(t: f32) -> [u8; 3] {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let x = t * (VIRIDIS.len() - 1) as f32;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f32;
    let mix = |k: usize| (VIRIDIS[i][k] * (1.0 - f) + VIRIDIS[i + 1][k] * f).round() as u8;
    [mix(0), mix(1), mix(2)]
}

/// What to draw on top of one map's costmap.
pub struct Preview<'a> {
    pub costs: &'a Grid<f32>,
    pub demonstrations: Vec<&'a [Cell]>,
    pub plans: Vec<&'a [Cell]>,
}

/// Renders at `scale` pixels per cell, with a colour bar labelled in cost and a scale
/// bar in metres. Colours span the 2nd to 98th percentile of log-cost, so one extreme
/// cell does not wash out the rest.
pub fn render_preview(preview: &Preview<'_>, scale: u32) -> Result<Rgb> {
    let range = super::picture::log_cost_range(&[preview.costs]);
    let map = paint_preview(preview, range, scale);
    super::legend::with_legend(&map, &preview.costs.geo, range, scale).map_err(Error::Failed)
}

/// The map alone: `scale` pixels per cell, colours over `range` of log-cost.
fn paint_preview(preview: &Preview<'_>, (lo, hi): (f32, f32), scale: u32) -> Rgb {
    let geo = &preview.costs.geo;
    let log: Vec<f32> = preview
        .costs
        .data
        .iter()
        .map(|c| c.max(f32::MIN_POSITIVE).ln())
        .collect();
    let span = hi - lo;

    let mut marks = vec![[false; 2]; geo.cell_count()];
    for path in &preview.demonstrations {
        path.iter().for_each(|&c| marks[geo.index(c)][0] = true);
    }
    for path in &preview.plans {
        path.iter().for_each(|&c| marks[geo.index(c)][1] = true);
    }
    let mut picture = Rgb::new(geo.width * scale, geo.height * scale);
    for i in 0..geo.cell_count() {
        let cell = geo.cell_at(i);
        let colour = match marks[i] {
            [true, true] => COLOUR_BOTH,
            [true, false] => COLOUR_DEMONSTRATION,
            [false, true] => COLOUR_PLAN,
            [false, false] => viridis((log[i] - lo) / span),
        };
        // North up: the top picture row shows the northernmost map row.
        let top = (geo.height - 1 - cell.row) * scale;
        let left = cell.col * scale;
        for y in top..top + scale {
            for x in left..left + scale {
                picture.put(x, y, colour);
            }
        }
    }
    picture
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GeoRef;

    #[test]
    fn north_is_up_and_paths_are_drawn() {
        let geo = GeoRef::square(4, 3, 1.0, [0.0, 0.0], "m");
        // Cost grows to the north.
        let costs = Grid::from_vec(
            geo.clone(),
            (0..12).map(|i| 1.0 + (i / 4) as f32 * 10.0).collect(),
        );
        let demo = [Cell::new(0, 0), Cell::new(0, 1)];
        let plan = [Cell::new(0, 1), Cell::new(1, 2)];
        let preview = Preview {
            costs: &costs,
            demonstrations: vec![&demo],
            plans: vec![&plan],
        };
        let range = crate::report::picture::log_cost_range(&[&costs]);
        let pic = paint_preview(&preview, range, 2);
        assert_eq!((pic.width, pic.height), (8, 6));
        // The top-right pixel shows row 2 (costly, yellow); the bottom-right row 0 (cheap, purple).
        let top = pic.get(7, 0);
        let bottom = pic.get(7, 5);
        assert!(top[1] > bottom[1] + 100, "{top:?} vs {bottom:?}");
        assert_eq!(pic.get(0, 5), COLOUR_DEMONSTRATION);
        assert_eq!(pic.get(2, 5), COLOUR_BOTH);
        assert_eq!(pic.get(4, 3), COLOUR_PLAN);
        // With its legend: the same map at the figure's margin, labels beside it.
        let figure = render_preview(&preview, 2).unwrap();
        assert!(figure.width > pic.width + 60 && figure.height > pic.height + 20);
        assert_eq!(figure.get(8 + 4, 8 + 3), COLOUR_PLAN);
    }
}
