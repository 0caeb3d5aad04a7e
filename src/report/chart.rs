//! Line charts people can read: a title, axes with tick labels and their units, grid
//! lines and a legend, drawn by `plotters` into an RGB picture. Text is set in DejaVu
//! Sans, bundled with the crate (`assets/fonts`, Bitstream Vera licence), so that a chart
//! is the same bytes on every machine whatever fonts it has installed.

use std::sync::OnceLock;

use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::io::png::Rgb;

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Registers the bundled font under "sans-serif" once per process.
pub(crate) fn font_ready() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
                .map_err(|_| "the bundled font cannot be read".to_string())
        })
        .clone()
}

/// One line of a chart.
pub struct Series {
    /// The legend's text.
    pub name: String,
    /// (x, y) points in order; points with a non-finite value break the line.
    pub points: Vec<(f64, f64)>,
    pub colour: [u8; 3],
}

/// A chart: title, axis descriptions (with their units) and lines.
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Where the legend goes: a corner the lines leave free.
    pub legend: Legend,
}

/// A corner of the plot for the legend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Legend {
    UpperRight,
    LowerRight,
}

/// A tick's text: whole numbers without a decimal point, others with up to 4 digits.
fn tick(value: &f64) -> String {
    if value.fract() == 0.0 && value.abs() < 1e15 {
        format!("{value:.0}")
    } else {
        let text = format!("{value:.4}");
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// The range of `values` (finite ones), padded by 5 % and never empty.
fn padded_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-9 * hi.abs().max(1.0));
    (lo - pad, hi + pad)
}

impl Chart {
    /// Draws the chart on a white picture of `width` × `height` pixels.
    pub fn draw(&self, width: u32, height: u32) -> Result<Rgb, String> {
        font_ready()?;
        let mut pixels = vec![255u8; width as usize * height as usize * 3];
        self.draw_into(&mut pixels, width, height)
            .map_err(|e| format!("drawing the chart '{}': {e}", self.title))?;
        Ok(Rgb {
            width,
            height,
            pixels,
        })
    }

    fn draw_into(
        &self,
        pixels: &mut [u8],
        width: u32,
        height: u32,
    ) -> Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::with_buffer(pixels, (width, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let points = || self.series.iter().flat_map(|s| s.points.iter());
        let (x0, x1) = padded_range(points().map(|p| p.0));
        let (y0, y1) = padded_range(points().map(|p| p.1));
        let mut chart = ChartBuilder::on(&root)
            .caption(&self.title, ("sans-serif", 15))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(62)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .label_style(("sans-serif", 11))
            .axis_desc_style(("sans-serif", 12))
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .light_line_style(TRANSPARENT)
            .bold_line_style(RGBColor(225, 225, 225))
            .draw()?;
        for series in &self.series {
            let [r, g, b] = series.colour;
            let colour = RGBColor(r, g, b);
            // Non-finite points break the line into runs.
            let runs = series
                .points
                .split(|p| !(p.0.is_finite() && p.1.is_finite()))
                .filter(|run| !run.is_empty());
            let mut first = true;
            for run in runs {
                let drawn = chart
                    .draw_series(LineSeries::new(run.iter().copied(), colour.stroke_width(2)))?;
                if std::mem::take(&mut first) {
                    drawn.label(&series.name).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
                    });
                }
            }
        }
        chart
            .configure_series_labels()
            .label_font(("sans-serif", 11))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(160, 160, 160))
            .position(match self.legend {
                Legend::UpperRight => SeriesLabelPosition::UpperRight,
                Legend::LowerRight => SeriesLabelPosition::LowerRight,
            })
            .draw()?;
        root.present()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pixels darker than mid-grey inside a rectangle.
    fn dark(picture: &Rgb, x: std::ops::Range<u32>, y: std::ops::Range<u32>) -> usize {
        y.flat_map(|row| x.clone().map(move |col| (col, row)))
            .filter(|&(col, row)| {
                let i = (row as usize * picture.width as usize + col as usize) * 3;
                picture.pixels[i..i + 3]
                    .iter()
                    .map(|&v| u32::from(v))
                    .sum::<u32>()
                    < 3 * 110
            })
            .count()
    }

    fn chart() -> Chart {
        Chart {
            title: "Training loss per round".into(),
            x_label: "round".into(),
            y_label: "margin (share of demo cost)".into(),
            series: vec![Series {
                name: "training".into(),
                points: (1..=40)
                    .map(|t| (f64::from(t), 1.0 / f64::from(t)))
                    .collect(),
                colour: [200, 40, 40],
            }],
            legend: Legend::UpperRight,
        }
    }

    #[test]
    fn axes_carry_text_and_the_same_chart_is_the_same_picture() {
        let picture = chart().draw(400, 260).unwrap();
        // Tick labels and the axis descriptions: dark pixels left of the plot and
        // below it, and the title above it.
        assert!(dark(&picture, 0..50, 30..220) > 150, "y axis text");
        let below = dark(&picture, 70..390, 215..260);
        assert!(below > 150, "x axis text: {below}");
        assert!(dark(&picture, 100..300, 0..22) > 100, "title");
        assert_eq!(picture.pixels, chart().draw(400, 260).unwrap().pixels);
    }

    #[test]
    fn gaps_and_empty_series_do_not_fail() {
        let mut gappy = chart();
        gappy.series[0].points[5].1 = f64::NAN;
        gappy.series.push(Series {
            name: "nothing yet".into(),
            points: Vec::new(),
            colour: [0, 0, 0],
        });
        assert!(gappy.draw(300, 200).is_ok());
        let empty = Chart {
            series: Vec::new(),
            ..chart()
        };
        assert!(empty.draw(300, 200).is_ok());
    }
}
