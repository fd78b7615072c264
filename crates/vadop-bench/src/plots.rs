//! PNG plots of every suite, drawn with plotters and an embedded DejaVu Sans font (a fresh
//! machine needs no system fonts and no plotting program): log-log line charts in one or more
//! panels, stacked bars and grouped bars. It owns chart layout (titles, axis labels with units,
//! legends, colours) and never reads or computes measurements.

use crate::CliResult;
use plotters::coord::ranged1d::SegmentValue;
use plotters::coord::CoordTranslate;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::Once;

const WIDTH: u32 = 1000;
const HEIGHT: u32 = 640;
const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stroke {
    Solid,
    /// For what is secondary or approximate, e.g. the discrete pipelines among the peers.
    Dashed,
    MarkersOnly,
}

/// One legend entry.
pub struct Series {
    label: String,
    points: Vec<(f64, f64)>,
    stroke: Stroke,
    colour: Option<RGBColor>,
}

impl Series {
    pub fn new(label: &str, points: Vec<(f64, f64)>) -> Series {
        Series { label: label.to_string(), points, stroke: Stroke::Solid, colour: None }
    }
    pub fn markers(label: &str, points: Vec<(f64, f64)>) -> Series {
        Series { stroke: Stroke::MarkersOnly, ..Series::new(label, points) }
    }
    /// The same series with a fixed colour (`#rrggbb`) and stroke.
    pub fn styled(self, colour: &str, stroke: Stroke) -> Series {
        let channel =
            |k: usize| u8::from_str_radix(colour.get(1 + 2 * k..3 + 2 * k).unwrap_or("7f"), 16).unwrap_or(127);
        Series { colour: Some(RGBColor(channel(0), channel(1), channel(2))), stroke, ..self }
    }
}

/// One panel of a line chart.
pub struct Panel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
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

/// The legend of `chart`, in its upper left corner.
fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    font: u32,
    path: &Path,
) -> CliResult<()> {
    chart
        .configure_series_labels()
        .label_font(("sans-serif", font))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(|e| plot_error(path, e))
}

/// A log-axis range covering the positive `values` with a margin, at least a decade wide so
/// that the axis has labelled ticks.
fn span(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !(lo.is_finite() && hi.is_finite()) {
        return (1.0, 10.0);
    }
    let widen = (10.0 / (hi / lo * 2.25)).max(1.0).sqrt();
    (lo / 1.5 / widen, hi * 1.5 * widen)
}

/// A log-log line chart titled `title`.
pub fn line_chart(path: &Path, title: &str, x_label: &str, y_label: &str, series: Vec<Series>) -> CliResult<()> {
    let panel = Panel { title: title.to_string(), x_label: x_label.to_string(), y_label: y_label.to_string(), series };
    line_panels(path, None, &[panel])
}

/// Log-log line charts side by side, under a common `title` when given. Points a log axis cannot
/// show (zero or negative) are left out, and a series with none left says so in the legend.
pub fn line_panels(path: &Path, title: Option<&str>, panels: &[Panel]) -> CliResult<()> {
    register_font()?;
    let wide = panels.len() > 1;
    let root =
        BitMapBackend::new(path, (if wide { 560 * panels.len() as u32 } else { WIDTH }, HEIGHT)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_error(path, e))?;
    let root = match title {
        Some(title) => root.titled(title, ("sans-serif", 26)).map_err(|e| plot_error(path, e))?,
        None => root,
    };
    let (caption, legend) = if wide { (20, 12) } else { (26, 16) };
    for (panel, area) in panels.iter().zip(root.split_evenly((1, panels.len()))) {
        let shown: Vec<Vec<(f64, f64)>> = panel
            .series
            .iter()
            .map(|s| s.points.iter().copied().filter(|p| p.0 > 0.0 && p.1 > 0.0).collect())
            .collect();
        let (x0, x1) = span(shown.iter().flatten().map(|p| p.0));
        let (y0, y1) = span(shown.iter().flatten().map(|p| p.1));
        let mut chart = ChartBuilder::on(&area)
            .caption(&panel.title, ("sans-serif", caption))
            .margin(16)
            .x_label_area_size(56)
            .y_label_area_size(80)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| plot_error(path, e))?;
        chart
            .configure_mesh()
            .x_desc(&panel.x_label)
            .y_desc(&panel.y_label)
            .x_label_formatter(&|x| significant(*x))
            .y_label_formatter(&|y| significant(*y))
            .label_style(("sans-serif", 16))
            .axis_desc_style(("sans-serif", 18))
            .draw()
            .map_err(|e| plot_error(path, e))?;
        for (k, (s, points)) in panel.series.iter().zip(&shown).enumerate() {
            let colour = s.colour.unwrap_or(PALETTE[k % PALETTE.len()]);
            let label = if points.is_empty() && !s.points.is_empty() {
                format!("{} — zero everywhere", s.label)
            } else {
                s.label.clone()
            };
            let line = colour.stroke_width(3);
            let dashed = s.stroke == Stroke::Dashed;
            let drawn = match s.stroke {
                Stroke::Solid => chart.draw_series(LineSeries::new(points.iter().copied(), line).point_size(4)),
                Stroke::Dashed => {
                    // A dashed line draws no points of its own: a lone point would not show.
                    chart
                        .draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.stroke_width(2))))
                        .map_err(|e| plot_error(path, e))?;
                    chart.draw_series(DashedLineSeries::new(points.iter().copied(), 8, 5, colour.stroke_width(2)))
                }
                Stroke::MarkersOnly => {
                    chart.draw_series(points.iter().map(|&p| TriangleMarker::new(p, 12, colour.filled())))
                }
            };
            drawn.map_err(|e| plot_error(path, e))?.label(label).legend(move |(x, y)| {
                // Dashed series show a gap in the middle of their legend line.
                let gap = if dashed { 6 } else { 0 };
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(0, 0), (12 - gap / 2, 0)], colour.stroke_width(3))
                    + PathElement::new(vec![(12 + gap / 2, 0), (24, 0)], colour.stroke_width(3))
            });
        }
        draw_legend(&mut chart, legend, path)?;
    }
    root.present().map_err(|e| plot_error(path, e))
}

/// One bar segment: the slot it stands in, its bottom and top, the legend entry it colours.
struct Segment {
    slot: u32,
    bottom: f64,
    top: f64,
    part: usize,
}

/// One stacked bar per entry of `bars`, its segments in the order of `parts`.
pub fn stacked_bars(
    path: &Path,
    title: &str,
    y_label: &str,
    parts: &[&str],
    bars: &[(String, Vec<f64>)],
) -> CliResult<()> {
    let mut segments = Vec::new();
    for (slot, (_, values)) in bars.iter().enumerate() {
        let mut bottom = 0.0;
        for (part, &value) in values.iter().enumerate() {
            segments.push(Segment { slot: slot as u32, bottom, top: bottom + value, part });
            bottom += value;
        }
    }
    let top = segments.iter().map(|s| s.top).fold(0.0, f64::max).max(1e-9) * 1.3;
    let labels: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
    draw_bars(path, title, "method", y_label, parts, &labels, &segments, 0.0..top, |y| format!("{y}"))
}

/// Groups of bars on a log axis: one group per entry of `groups`, one bar per entry of `members`
/// in each (a missing value leaves its place empty).
pub fn grouped_bars(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    members: &[&str],
    groups: &[(String, Vec<Option<f64>>)],
) -> CliResult<()> {
    // Log values on a linear axis: bars need a common floor, which a log axis has not.
    let logs: Vec<f64> =
        groups.iter().flat_map(|g| g.1.iter().flatten()).filter(|v| **v > 0.0).map(|v| v.log10()).collect();
    let (lo, hi) = logs.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    let (floor, ceiling) = if lo.is_finite() { (lo.floor() - 0.2, hi + 0.3) } else { (0.0, 1.0) };
    // Each group takes one slot per member and an empty one between groups.
    let stride = members.len() as u32 + 1;
    let mut segments = Vec::new();
    let mut labels = vec![String::new(); groups.len() * stride as usize];
    for (g, (name, values)) in groups.iter().enumerate() {
        labels[g * stride as usize + members.len() / 2] = name.clone();
        for (part, value) in values.iter().enumerate() {
            if let Some(v) = value.filter(|v| *v > 0.0) {
                segments.push(Segment { slot: g as u32 * stride + part as u32, bottom: floor, top: v.log10(), part });
            }
        }
    }
    draw_bars(path, title, x_label, y_label, members, &labels, &segments, floor..ceiling, |y| {
        significant(10f64.powf(*y))
    })
}

/// A tick value with at most three significant digits and no trailing zeros.
fn significant(value: f64) -> String {
    let decimals = (2.0 - value.abs().log10().floor()).clamp(0.0, 9.0) as usize;
    let text = format!("{value:.decimals$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

#[allow(clippy::too_many_arguments)]
fn draw_bars(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    parts: &[&str],
    slot_labels: &[String],
    segments: &[Segment],
    y_range: std::ops::Range<f64>,
    y_format: impl Fn(&f64) -> String,
) -> CliResult<()> {
    register_font()?;
    let root = BitMapBackend::new(path, (WIDTH.max(60 * slot_labels.len() as u32), HEIGHT)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_error(path, e))?;
    let slots = slot_labels.len().max(1) as u32;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 26))
        .margin(16)
        .x_label_area_size(56)
        .y_label_area_size(80)
        .build_cartesian_2d((0u32..slots - 1).into_segmented(), y_range)
        .map_err(|e| plot_error(path, e))?;
    let format_slot = |v: &SegmentValue<u32>| match v {
        SegmentValue::CenterOf(i) | SegmentValue::Exact(i) => slot_labels.get(*i as usize).cloned().unwrap_or_default(),
        SegmentValue::Last => String::new(),
    };
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .x_labels(slot_labels.len())
        .x_label_formatter(&format_slot)
        .y_label_formatter(&y_format)
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 18))
        .draw()
        .map_err(|e| plot_error(path, e))?;
    for (k, part) in parts.iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        let rectangles = segments.iter().filter(|s| s.part == k).map(|s| {
            let mut bar = Rectangle::new(
                [(SegmentValue::Exact(s.slot), s.bottom), (SegmentValue::Exact(s.slot + 1), s.top)],
                colour.filled(),
            );
            bar.set_margin(0, 0, 6, 6);
            bar
        });
        chart
            .draw_series(rectangles)
            .map_err(|e| plot_error(path, e))?
            .label(*part)
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 18, y + 6)], colour.filled()));
    }
    draw_legend(&mut chart, 16, path)?;
    root.present().map_err(|e| plot_error(path, e))
}
