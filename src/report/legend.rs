//! A costmap picture people can read: the map, a colour bar labelled in cost on its
//! right, and a scale bar in metres under it. Text is drawn by `plotters` in the bundled
//! font (`chart`), so the picture is the same bytes on every machine.

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::chart::font_ready;
use super::picture::colour_bar;
use crate::grid::GeoRef;
use crate::io::png::Rgb;

const MARGIN: u32 = 8;
const BAR_GAP: u32 = 10;
const BAR_WIDTH: u32 = 14;
/// Room for the colour bar's labels ("≥ 1.23e-4").
const LABEL_WIDTH: u32 = 74;
/// Room under the map for the scale bar and its label.
const SCALE_HEIGHT: u32 = 36;
const FONT_SIZE: u32 = 12;

/// `map` (a costmap painted at `scale` pixels per cell over `log_range` of log-cost, as
/// `picture::paint_costs` and `render_preview` do) with its colour bar and scale bar.
pub fn with_legend(
    map: &Rgb,
    geo: &GeoRef,
    log_range: (f32, f32),
    scale: u32,
) -> Result<Rgb, String> {
    font_ready()?;
    let width = MARGIN + map.width + BAR_GAP + BAR_WIDTH + LABEL_WIDTH + MARGIN;
    let height = MARGIN + map.height + SCALE_HEIGHT;
    let mut pixels = vec![255u8; width as usize * height as usize * 3];
    let metres_per_pixel = geo.cell_metres()[0] / f64::from(scale.max(1));
    draw_text(
        &mut pixels,
        (width, height),
        map,
        log_range,
        metres_per_pixel,
    )
    .map_err(|e| format!("drawing the costmap's legend: {e}"))?;
    let mut out = Rgb {
        width,
        height,
        pixels,
    };
    blit(&mut out, map, MARGIN, MARGIN);
    let bar = colour_bar(BAR_WIDTH, map.height);
    blit(&mut out, &bar, MARGIN + map.width + BAR_GAP, MARGIN);
    Ok(out)
}

/// The colour bar's labels and the scale bar, drawn before the pictures are copied in.
fn draw_text(
    pixels: &mut [u8],
    size: (u32, u32),
    map: &Rgb,
    (lo, hi): (f32, f32),
    metres_per_pixel: f64,
) -> Result<(), Box<dyn std::error::Error>> {
    let root = BitMapBackend::with_buffer(pixels, size).into_drawing_area();
    let font = ("sans-serif", FONT_SIZE).into_font().color(&BLACK);
    let label_x = (MARGIN + map.width + BAR_GAP + BAR_WIDTH + 4) as i32;
    let top = MARGIN as i32;
    let bar_height = map.height.max(2) as i32 - 1;
    // Five labels in cost, evenly spaced in log-cost as the colours are; the ends say
    // that the colours saturate there (2nd and 98th percentiles).
    for k in 0..=4 {
        let f = f64::from(k) / 4.0;
        let cost = (f64::from(lo) + f * f64::from(hi - lo)).exp();
        let text = match k {
            0 => format!("≤ {}", significant(cost)),
            4 => format!("≥ {}", significant(cost)),
            _ => significant(cost),
        };
        let y = top + bar_height - (f * f64::from(bar_height)).round() as i32;
        let anchor = Pos::new(HPos::Left, VPos::Center);
        root.draw(&Text::new(text, (label_x, y), font.clone().pos(anchor)))?;
    }
    // A scale bar of a round length near a quarter of the map's width.
    let map_metres = f64::from(map.width) * metres_per_pixel;
    if map_metres.is_finite() && map_metres > 0.0 {
        let length = round_length(map_metres / 4.0);
        let pixels_long = (length / metres_per_pixel).round().max(1.0) as i32;
        let (x0, y0) = (MARGIN as i32, (MARGIN + map.height + 8) as i32);
        root.draw(&Rectangle::new(
            [(x0, y0), (x0 + pixels_long, y0 + 4)],
            BLACK.filled(),
        ))?;
        for x in [x0, x0 + pixels_long] {
            root.draw(&Rectangle::new(
                [(x, y0 - 3), (x + 1, y0 + 4)],
                BLACK.filled(),
            ))?;
        }
        root.draw(&Text::new(
            metres_text(length),
            (x0, y0 + 9),
            font.pos(Pos::new(HPos::Left, VPos::Top)),
        ))?;
    }
    root.present()?;
    Ok(())
}

/// Copies `picture` into `out` with its top-left corner at (`left`, `top`).
fn blit(out: &mut Rgb, picture: &Rgb, left: u32, top: u32) {
    for y in 0..picture.height {
        for x in 0..picture.width {
            out.put(left + x, top + y, picture.get(x, y));
        }
    }
}

/// The largest 1, 2 or 5 × 10ⁿ metres not above `metres`.
fn round_length(metres: f64) -> f64 {
    let decade = 10f64.powf(metres.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * decade)
        .find(|&l| l <= metres * (1.0 + 1e-9))
        .unwrap_or(decade)
}

/// "250 m", "2 km", "0.5 m".
fn metres_text(metres: f64) -> String {
    if metres >= 1000.0 {
        format!("{} km", significant(metres / 1000.0))
    } else {
        format!("{} m", significant(metres))
    }
}

/// Three significant digits, without trailing zeros; powers of ten far from 1.
fn significant(value: f64) -> String {
    if value == 0.0 || !value.is_finite() {
        return format!("{value}");
    }
    let magnitude = value.abs().log10().floor();
    if !(-3.0..6.0).contains(&magnitude) {
        return format!("{value:.2e}");
    }
    let decimals = (2.0 - magnitude).max(0.0) as usize;
    let text = format!("{value:.decimals$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GeoRef;

    #[test]
    fn lengths_and_numbers_read_well() {
        assert_eq!(round_length(370.0), 200.0);
        assert_eq!(round_length(999.0), 500.0);
        assert_eq!(round_length(1000.0), 1000.0);
        assert_eq!(round_length(0.7), 0.5);
        assert_eq!(metres_text(2000.0), "2 km");
        assert_eq!(metres_text(0.5), "0.5 m");
        assert_eq!(significant(1.2345), "1.23");
        assert_eq!(significant(123.45), "123");
        assert_eq!(significant(0.012345), "0.0123");
        assert_eq!(significant(12_345_678.0), "1.23e7");
    }

    #[test]
    fn the_legend_is_drawn_beside_and_under_the_map() {
        let map = Rgb {
            width: 100,
            height: 80,
            pixels: vec![40; 100 * 80 * 3],
        };
        let geo = GeoRef::square(50, 40, 10.0, [0.0, 0.0], "map");
        let figure = with_legend(&map, &geo, (0.0, 2.0), 2).unwrap();
        // The map sits at the margin, unchanged.
        assert_eq!(figure.get(MARGIN, MARGIN), [40, 40, 40]);
        assert_eq!(figure.get(MARGIN + 99, MARGIN + 79), [40, 40, 40]);
        let dark = |x0: u32, x1: u32, y0: u32, y1: u32| {
            (y0..y1)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|&(x, y)| figure.get(x, y).iter().all(|&c| c < 120))
                .count()
        };
        // Labels right of the colour bar, and a scale bar with its text under the map:
        // 500 m wide at 5 m a pixel, so a 100 m bar of 20 pixels.
        let labels_left = MARGIN + 100 + BAR_GAP + BAR_WIDTH;
        assert!(dark(labels_left, figure.width, 0, figure.height) > 100);
        let under = MARGIN + 80;
        let bar = dark(MARGIN, MARGIN + 40, under + 8, under + 13);
        assert!(bar >= 20 * 4, "{bar}");
        assert!(dark(MARGIN, MARGIN + 60, under + 17, figure.height) > 20);
        // Same bytes every time.
        assert_eq!(
            figure.pixels,
            with_legend(&map, &geo, (0.0, 2.0), 2).unwrap().pixels
        );
    }
}
