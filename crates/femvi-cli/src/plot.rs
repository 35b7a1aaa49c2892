//! Plots with plotters (SVG, or PNG): coordinates against time, phase portraits, the relative
//! energy error on a log scale, step sizes in energy mode, and convergence studies on log–log
//! axes. Axes carry the names from the problem file. Text is set in DejaVu Sans, bundled (its
//! licence is in assets/), so that PNG output needs no fonts on the machine.

use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Once;

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

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let font: &'static [u8] = include_bytes!("../assets/DejaVuSans.ttf");
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

const COLORS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

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

/// Lines on linear axes, into `path` in `format`.
pub fn lines(
    path: &Path,
    format: Format,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
) -> Result<(), String> {
    draw(path, format, title, xlabel, ylabel, series, Axes::Linear)
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
    draw(path, format, title, xlabel, ylabel, series, axes)
}

fn draw(
    path: &Path,
    format: Format,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
    axes: Axes,
) -> Result<(), String> {
    register_font();
    match format {
        Format::Svg => draw_on(
            SVGBackend::new(path, SIZE).into_drawing_area(),
            title,
            xlabel,
            ylabel,
            series,
            axes,
        ),
        Format::Png => draw_on(
            BitMapBackend::new(path, SIZE).into_drawing_area(),
            title,
            xlabel,
            ylabel,
            series,
            axes,
        ),
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

/// Draws `series` with a title, axis labels and (several series) a legend on `root`.
fn draw_on<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
    axes: Axes,
) -> Result<(), String> {
    let data = plotted(series, axes);
    let xs = || data.iter().flatten().map(|p| p.0);
    let ys = || data.iter().flatten().map(|p| p.1);
    root.fill(&WHITE).map_err(err)?;
    let mut builder = ChartBuilder::on(&root);
    let y_area = if axes == Axes::Linear { 75 } else { 85 };
    builder
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(y_area);
    // The mesh, the lines and the legend, for each kind of coordinates.
    macro_rules! finish {
        ($chart:expr, $log_y:expr, $log_x:expr) => {{
            let mut chart = $chart;
            let mut mesh = chart.configure_mesh();
            mesh.x_desc(xlabel).y_desc(ylabel);
            if $log_y {
                mesh.y_label_formatter(&|v| format!("{v:.0e}"));
            }
            if $log_x {
                mesh.x_label_formatter(&|v| format!("{v:.3}"));
            }
            mesh.draw().map_err(err)?;
            for (i, (s, pts)) in series.iter().zip(&data).enumerate() {
                let color = COLORS[i % COLORS.len()];
                chart
                    .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
                    .map_err(err)?
                    .label(s.name.clone())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
            }
            if series.len() > 1 {
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .draw()
                    .map_err(err)?;
            }
        }};
    }
    match axes {
        Axes::Linear => {
            let ((x0, x1), (y0, y1)) = (range(xs()), range(ys()));
            finish!(builder.build_cartesian_2d(x0..x1, y0..y1).map_err(err)?, false, false)
        }
        Axes::LogY => {
            let (x0, x1) = range(xs());
            let (y0, y1) = log_range(ys(), 2.0, (1e-16, 1.0));
            finish!(
                builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale()).map_err(err)?,
                true,
                false
            )
        }
        Axes::LogXY => {
            let (x0, x1) = log_range(xs(), 1.5, (1e-3, 1.0));
            let (y0, y1) = log_range(ys(), 2.0, (1e-16, 1.0));
            finish!(
                builder
                    .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
                    .map_err(err)?,
                true,
                true
            )
        }
    }
    root.present().map_err(err)
}
