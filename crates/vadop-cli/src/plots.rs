//! PNG plots for the benchmarks: line charts on log axes and stacked bars, drawn with plotters
//! and an embedded DejaVu Sans font, so a fresh machine needs no system fonts. It owns chart
//! layout (title, axis labels with units, legend) and never reads or computes measurements.

use crate::CliResult;
use plotters::coord::ranged1d::SegmentValue;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::Once;

const SIZE: (u32, u32) = (1000, 640);
const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// One legend entry: a line through its points, or markers only.
pub struct Series {
    label: String,
    points: Vec<(f64, f64)>,
    markers_only: bool,
}

impl Series {
    pub fn new(label: &str, points: Vec<(f64, f64)>) -> Series {
        Series { label: label.to_string(), points, markers_only: false }
    }
    pub fn markers(label: &str, points: Vec<(f64, f64)>) -> Series {
        Series { label: label.to_string(), points, markers_only: true }
    }
}

fn register_font() -> CliResult<()> {
    static ONCE: Once = Once::new();
    let mut outcome = Ok(());
    ONCE.call_once(|| {
        outcome = plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .map_err(|_| "the embedded plot font could not be loaded".to_string());
    });
    outcome
}

fn plot_error(path: &Path, e: impl std::fmt::Display) -> String {
    format!("{}: could not draw the plot: {e}", path.display())
}

/// A log-axis range covering the positive `values` with a margin.
fn span(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !(lo.is_finite() && hi.is_finite()) {
        return (1.0, 10.0);
    }
    (lo / 1.5, hi * 1.5)
}

/// Line chart on log-log axes; points that a log axis cannot show (zero or negative) are left
/// out, and a series with none left says so in the legend.
pub fn line_chart(path: &Path, title: &str, x_label: &str, y_label: &str, series: &[Series]) -> CliResult<()> {
    register_font()?;
    let shown: Vec<Vec<(f64, f64)>> = series
        .iter()
        .map(|s| s.points.iter().copied().filter(|p| p.0 > 0.0 && p.1 > 0.0).collect())
        .collect();
    let (x0, x1) = span(shown.iter().flatten().map(|p| p.0));
    let (y0, y1) = span(shown.iter().flatten().map(|p| p.1));
    let root = BitMapBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_error(path, e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 26))
        .margin(16)
        .x_label_area_size(56)
        .y_label_area_size(80)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|e| plot_error(path, e))?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 18))
        .draw()
        .map_err(|e| plot_error(path, e))?;
    for (k, (s, points)) in series.iter().zip(&shown).enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let label = if points.is_empty() && !s.points.is_empty() { format!("{} — zero everywhere", s.label) } else { s.label.clone() };
        let style = colour.stroke_width(3);
        let drawn = if s.markers_only {
            chart.draw_series(points.iter().map(|&p| TriangleMarker::new(p, 12, colour.filled())))
        } else {
            chart.draw_series(LineSeries::new(points.iter().copied(), style).point_size(4))
        };
        drawn
            .map_err(|e| plot_error(path, e))?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(3)));
    }
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 16))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(|e| plot_error(path, e))?;
    root.present().map_err(|e| plot_error(path, e))
}

/// One stacked bar per entry of `bars`, its segments in the order of `parts`.
pub fn stacked_bars(path: &Path, title: &str, y_label: &str, parts: &[&str; 4], bars: &[(String, [f64; 4])]) -> CliResult<()> {
    register_font()?;
    let top = bars.iter().map(|(_, v)| v.iter().sum::<f64>()).fold(0.0, f64::max).max(1e-9) * 1.3;
    let root = BitMapBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_error(path, e))?;
    let count = bars.len().max(1) as u32;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 26))
        .margin(16)
        .x_label_area_size(56)
        .y_label_area_size(80)
        .build_cartesian_2d((0u32..count - 1).into_segmented(), 0.0..top)
        .map_err(|e| plot_error(path, e))?;
    let names: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
    let format_bar = |v: &SegmentValue<u32>| match v {
        SegmentValue::CenterOf(i) | SegmentValue::Exact(i) => names.get(*i as usize).cloned().unwrap_or_default(),
        SegmentValue::Last => String::new(),
    };
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_desc("method")
        .y_desc(y_label)
        .x_labels(bars.len())
        .x_label_formatter(&format_bar)
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 18))
        .draw()
        .map_err(|e| plot_error(path, e))?;
    for (k, part) in parts.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let rectangles = bars.iter().enumerate().map(|(i, (_, values))| {
            let base: f64 = values[..k].iter().sum();
            let i = i as u32;
            let mut bar = Rectangle::new([(SegmentValue::Exact(i), base), (SegmentValue::Exact(i + 1), base + values[k])], colour.filled());
            bar.set_margin(0, 0, 20, 20);
            bar
        });
        chart
            .draw_series(rectangles)
            .map_err(|e| plot_error(path, e))?
            .label(*part)
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 18, y + 6)], colour.filled()));
    }
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 16))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|e| plot_error(path, e))?;
    root.present().map_err(|e| plot_error(path, e))
}
