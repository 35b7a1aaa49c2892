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
    pub name: String,
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

/// Lines on linear axes, into `path` in `format`.
pub fn lines(
    path: &Path,
    format: Format,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
) -> Result<(), String> {
    register_font();
    match format {
        Format::Svg => lines_on(
            SVGBackend::new(path, SIZE).into_drawing_area(),
            title,
            xlabel,
            ylabel,
            series,
        ),
        Format::Png => lines_on(
            BitMapBackend::new(path, SIZE).into_drawing_area(),
            title,
            xlabel,
            ylabel,
            series,
        ),
    }
}

fn lines_on<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
) -> Result<(), String> {
    let data: Vec<Vec<(f64, f64)>> = series.iter().map(|s| thin(&s.points)).collect();
    let (x0, x1) = range(data.iter().flatten().map(|p| p.0));
    let (y0, y1) = range(data.iter().flatten().map(|p| p.1));
    root.fill(&WHITE).map_err(err)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(xlabel)
        .y_desc(ylabel)
        .draw()
        .map_err(err)?;
    for (i, (s, pts)) in series.iter().zip(data).enumerate() {
        let color = COLORS[i % COLORS.len()];
        chart
            .draw_series(LineSeries::new(pts, color.stroke_width(2)))
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
    root.present().map_err(err)
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
    register_font();
    match format {
        Format::Svg => log_lines_on(
            SVGBackend::new(path, SIZE).into_drawing_area(),
            title,
            xlabel,
            ylabel,
            series,
            log_x,
        ),
        Format::Png => log_lines_on(
            BitMapBackend::new(path, SIZE).into_drawing_area(),
            title,
            xlabel,
            ylabel,
            series,
            log_x,
        ),
    }
}

fn log_lines_on<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
    log_x: bool,
) -> Result<(), String> {
    let data: Vec<Vec<(f64, f64)>> = series
        .iter()
        .map(|s| {
            thin(&s.points)
                .into_iter()
                .filter(|(x, y)| *y > 0.0 && (!log_x || *x > 0.0))
                .collect()
        })
        .collect();
    let ys = || data.iter().flatten().map(|p| p.1);
    let (ylo, yhi) = (ys().fold(f64::INFINITY, f64::min), ys().fold(0.0f64, f64::max));
    let (ylo, yhi) = if ylo.is_finite() && yhi > 0.0 {
        (ylo / 2.0, yhi * 2.0)
    } else {
        (1e-16, 1.0)
    };
    root.fill(&WHITE).map_err(err)?;
    let mut builder = ChartBuilder::on(&root);
    builder
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(85);
    macro_rules! draw {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(xlabel)
                .y_desc(ylabel)
                .y_label_formatter(&|v| format!("{v:.0e}"))
                .draw()
                .map_err(err)?;
            for (i, (s, pts)) in series.iter().zip(data.iter()).enumerate() {
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
    if log_x {
        let xs = || data.iter().flatten().map(|p| p.0);
        let (xlo, xhi) = (xs().fold(f64::INFINITY, f64::min), xs().fold(0.0f64, f64::max));
        let (xlo, xhi) = if xlo.is_finite() && xhi > 0.0 {
            (xlo / 1.5, xhi * 1.5)
        } else {
            (1e-3, 1.0)
        };
        draw!(builder
            .build_cartesian_2d((xlo..xhi).log_scale(), (ylo..yhi).log_scale())
            .map_err(err)?);
    } else {
        let (x0, x1) = range(data.iter().flatten().map(|p| p.0));
        draw!(builder
            .build_cartesian_2d(x0..x1, (ylo..yhi).log_scale())
            .map_err(err)?);
    }
    root.present().map_err(err)
}
