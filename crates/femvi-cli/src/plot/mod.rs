//! Plots with plotters (SVG, or PNG): coordinates against time, phase portraits, the relative
//! energy error on a log scale, step sizes in energy mode, orbits (equal scales), Poincaré
//! sections (points), and convergence studies on log–log axes (markers on the measured
//! points). Axes carry the names from the problem file; several series get a legend in a strip
//! to the right of the data area and colours that never repeat ([`palette`]). Text is set in
//! DejaVu Sans, bundled (its licence is in assets/), so that PNG output needs no fonts on the
//! machine.

use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Once;

pub mod palette;
pub mod sphere;
pub use palette::{color, step_label};

/// The image format of plots.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Scalable vector graphics (the default).
    Svg,
    /// Portable network graphics.
    Png,
}

impl Format {
    /// The file extension.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Svg => "svg",
            Format::Png => "png",
        }
    }
}

const SIZE: (u32, u32) = (900, 540);

pub(crate) fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let font: &'static [u8] = include_bytes!("../../assets/DejaVuSans.ttf");
        // The bundled font is valid; if registration failed, text would be missing, not wrong.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, font);
    });
}

/// `dir/stem.ext` for the format.
pub fn file(dir: &Path, stem: &str, format: Format) -> PathBuf {
    dir.join(format!("{stem}.{}", format.extension()))
}

/// One line of a plot.
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// (x, y) points.
    pub points: Vec<(f64, f64)>,
}

/// At most this many points per line (evenly strided).
const MAX_POINTS: usize = 5000;

fn thin(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let stride = points.len().div_ceil(MAX_POINTS).max(1);
    let mut out: Vec<(f64, f64)> = points
        .iter()
        .step_by(stride)
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    if let Some(last) = points.last() {
        if out.last() != Some(last) && last.0.is_finite() && last.1.is_finite() {
            out.push(*last);
        }
    }
    out
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if !lo.is_finite() || !hi.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo <= f64::EPSILON * hi.abs().max(lo.abs()).max(1e-300) {
        let pad = if lo == 0.0 { 1.0 } else { lo.abs() * 0.01 };
        return (lo - pad, hi + pad);
    }
    let pad = 0.03 * (hi - lo);
    (lo - pad, hi + pad)
}

fn err(e: impl std::fmt::Display) -> String {
    format!("cannot draw the plot: {e}")
}

/// The axes of a plot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Axes {
    Linear,
    LogY,
    LogXY,
}

/// How the series are drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Style {
    /// Lines through the points.
    Lines,
    /// Points only (Poincaré sections).
    Points,
    /// Lines with a marker on every point (measured values).
    Markers,
}

/// What a plot shows besides its data.
struct Spec<'a> {
    title: &'a str,
    xlabel: &'a str,
    ylabel: &'a str,
    axes: Axes,
    style: Style,
    /// Equal scales on both axes (orbits).
    equal: bool,
}

/// Lines on linear axes, into `path` in `format`.
pub fn lines(
    path: &Path,
    format: Format,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
) -> Result<(), String> {
    let spec = Spec {
        title,
        xlabel,
        ylabel,
        axes: Axes::Linear,
        style: Style::Lines,
        equal: false,
    };
    draw(path, format, &spec, series)
}

/// Orbits in a plane: lines on linear axes with equal scales.
pub fn orbits(
    path: &Path,
    format: Format,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
) -> Result<(), String> {
    let spec = Spec {
        title,
        xlabel,
        ylabel,
        axes: Axes::Linear,
        style: Style::Lines,
        equal: true,
    };
    draw(path, format, &spec, series)
}

/// Points (no lines) on linear axes.
pub fn scatter(
    path: &Path,
    format: Format,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
) -> Result<(), String> {
    let spec = Spec {
        title,
        xlabel,
        ylabel,
        axes: Axes::Linear,
        style: Style::Points,
        equal: false,
    };
    draw(path, format, &spec, series)
}

/// Lines with a logarithmic y axis (and optionally x axis); non-positive values are dropped.
pub fn log_lines(
    path: &Path,
    format: Format,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
    log_x: bool,
) -> Result<(), String> {
    let axes = if log_x { Axes::LogXY } else { Axes::LogY };
    let spec = Spec {
        title,
        xlabel,
        ylabel,
        axes,
        style: Style::Lines,
        equal: false,
    };
    draw(path, format, &spec, series)
}

/// Log–log lines where the series at even positions (the measured values) carry a marker
/// on every point and those at odd positions (fits) do not. `labels`: title, x and y label.
pub fn log_log_measured(
    path: &Path,
    format: Format,
    labels: (&str, &str, &str),
    series: &[Series],
) -> Result<(), String> {
    let spec = Spec {
        title: labels.0,
        xlabel: labels.1,
        ylabel: labels.2,
        axes: Axes::LogXY,
        style: Style::Markers,
        equal: false,
    };
    draw(path, format, &spec, series)
}

fn draw(path: &Path, format: Format, spec: &Spec, series: &[Series]) -> Result<(), String> {
    register_font();
    match format {
        Format::Svg => draw_on(SVGBackend::new(path, SIZE).into_drawing_area(), spec, series),
        Format::Png => draw_on(BitMapBackend::new(path, SIZE).into_drawing_area(), spec, series),
    }
}

/// Range of positive values on a log axis, widened by `pad` on both sides.
fn log_range(values: impl Iterator<Item = f64>, pad: f64, fallback: (f64, f64)) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if lo.is_finite() && hi > 0.0 {
        (lo / pad, hi * pad)
    } else {
        fallback
    }
}

/// The points of each series that are drawn: thinned, and positive on log axes.
fn plotted(series: &[Series], axes: Axes) -> Vec<Vec<(f64, f64)>> {
    series
        .iter()
        .map(|s| {
            thin(&s.points)
                .into_iter()
                .filter(|(x, y)| match axes {
                    Axes::Linear => true,
                    Axes::LogY => *y > 0.0,
                    Axes::LogXY => *y > 0.0 && *x > 0.0,
                })
                .collect()
        })
        .collect()
}

/// Width of the legend strip to the right of the data area.
const LEGEND_WIDTH: u32 = 190;

/// Draws `series` with a title, axis labels and (several series) a legend to the right of
/// the chart, outside the data area, on `root`.
fn draw_on<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, spec: &Spec, series: &[Series]) -> Result<(), String> {
    let data = plotted(series, spec.axes);
    root.fill(&WHITE).map_err(err)?;
    // The title fits the width: about 0.55 em per character.
    let size = (f64::from(SIZE.0 - 30) / (0.55 * spec.title.chars().count().max(1) as f64)).clamp(11.0, 20.0);
    let root = root.titled(spec.title, ("sans-serif", size)).map_err(err)?;
    let (area, legend) = if series.len() > 1 {
        let (w, _) = root.dim_in_pixel();
        let (a, l) = root.split_horizontally(w.saturating_sub(LEGEND_WIDTH));
        (a, Some(l))
    } else {
        (root.clone(), None)
    };
    let mut builder = ChartBuilder::on(&area);
    let y_area = if spec.axes == Axes::Linear { 75 } else { 85 };
    builder.margin(12).x_label_area_size(45).y_label_area_size(y_area);
    let xs = || data.iter().flatten().map(|p| p.0);
    let ys = || data.iter().flatten().map(|p| p.1);
    match spec.axes {
        Axes::Linear => {
            let ((mut x0, mut x1), (mut y0, mut y1)) = (range(xs()), range(ys()));
            if spec.equal {
                (x0, x1, y0, y1) = equalise(area.dim_in_pixel(), (x0, x1), (y0, y1));
            }
            let chart = builder.build_cartesian_2d(x0..x1, y0..y1).map_err(err)?;
            finish(chart, spec, &data, false)?;
        }
        Axes::LogY => {
            let (x0, x1) = range(xs());
            let (y0, y1) = log_range(ys(), 2.0, (1e-16, 1.0));
            let chart = builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale()).map_err(err)?;
            finish(chart, spec, &data, false)?;
        }
        Axes::LogXY => {
            let (x0, x1) = log_range(xs(), 1.5, (1e-3, 1.0));
            let (y0, y1) = log_range(ys(), 2.0, (1e-16, 1.0));
            // Ticks at the measured abscissae (steps rarely span a decade).
            let mut ticks: Vec<f64> = xs().collect();
            ticks.sort_by(f64::total_cmp);
            ticks.dedup();
            let chart = builder
                .build_cartesian_2d((x0..x1).log_scale().with_key_points(ticks), (y0..y1).log_scale())
                .map_err(err)?;
            finish(chart, spec, &data, true)?;
        }
    }
    if let Some(l) = legend {
        draw_legend(&l, spec.style, series)?;
    }
    root.present().map_err(err)
}

/// Widens one range so that a unit is as long on both axes of an area of `size` pixels
/// (an approximation: the label areas are not subtracted exactly).
fn equalise(size: (u32, u32), x: (f64, f64), y: (f64, f64)) -> (f64, f64, f64, f64) {
    let (w, h) = (
        (f64::from(size.0) - 100.0).max(1.0),
        (f64::from(size.1) - 70.0).max(1.0),
    );
    let (dx, dy) = (x.1 - x.0, y.1 - y.0);
    if dx / w > dy / h {
        let pad = 0.5 * (dx * h / w - dy);
        (x.0, x.1, y.0 - pad, y.1 + pad)
    } else {
        let pad = 0.5 * (dy * w / h - dx);
        (x.0 - pad, x.1 + pad, y.0, y.1)
    }
}

/// The mesh and the series of a chart.
fn finish<DB, X, Y>(
    mut chart: ChartContext<'_, DB, Cartesian2d<X, Y>>,
    spec: &Spec,
    data: &[Vec<(f64, f64)>],
    log_x: bool,
) -> Result<(), String>
where
    DB: DrawingBackend,
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(spec.xlabel).y_desc(spec.ylabel);
    if spec.axes != Axes::Linear {
        mesh.y_label_formatter(&|v| format!("{v:.0e}"));
    }
    if log_x {
        mesh.x_label_formatter(&|v| format!("{v}"));
    }
    mesh.draw().map_err(err)?;
    for (i, pts) in data.iter().enumerate() {
        let c = color(i);
        let marked = match spec.style {
            Style::Lines => false,
            Style::Points => true,
            Style::Markers => i % 2 == 0,
        };
        // Orbits that share a path (choreographies) stay visible: earlier ones are wider.
        let width = if spec.equal {
            2 + 2 * (data.len() - 1 - i).min(3) as u32
        } else {
            2
        };
        if spec.style != Style::Points {
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(width)))
                .map_err(err)?;
        }
        if marked {
            let r = if spec.style == Style::Points { 2 } else { 4 };
            chart
                .draw_series(pts.iter().map(|p| Circle::new(*p, r, c.filled())))
                .map_err(err)?;
        }
    }
    Ok(())
}

/// The legend in its own strip: a sample of each series' line or marker and its name.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    style: Style,
    series: &[Series],
) -> Result<(), String> {
    let font = ("sans-serif", 14).into_font().color(&BLACK);
    for (i, s) in series.iter().enumerate() {
        let y = 30 + 20 * i as i32;
        let c = color(i);
        if style != Style::Points {
            area.draw(&PathElement::new(vec![(4, y), (28, y)], c.stroke_width(2)))
                .map_err(err)?;
        }
        if style == Style::Points || (style == Style::Markers && i % 2 == 0) {
            area.draw(&Circle::new((16, y), 4, c.filled())).map_err(err)?;
        }
        area.draw(&Text::new(s.name.clone(), (34, y - 8), font.clone()))
            .map_err(err)?;
    }
    Ok(())
}
