//! The heat map of a two-axis chaos map (`femvi chaos --grid A --grid B --plot`): one cell per
//! grid point coloured by the indicator (viridis; MEGNO clipped to [0, 8] so that regular
//! orbits, ⟨Y⟩ ≈ 2, stand apart from chaotic ones), failed points in grey, and a colour bar.

use crate::chaos::Axis;
use crate::plot::Format;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

const SIZE: (u32, u32) = (820, 700);

/// What the map shows: values row-major with the first axis fastest (as `chaos_map.csv`),
/// None for a failed point, and the colour range.
pub struct HeatMap<'a> {
    /// The horizontal (first) and vertical (second) axes.
    pub axes: (&'a Axis, &'a Axis),
    /// One value per grid point.
    pub values: &'a [Option<f64>],
    /// The indicator's name (the colour bar's label).
    pub label: &'a str,
    /// Values are clipped to this range.
    pub range: (f64, f64),
    /// The title.
    pub title: &'a str,
}

/// Draws `map` into `path`. Err: the message of a drawing failure.
pub fn heat_map(path: &Path, format: Format, map: &HeatMap<'_>) -> Result<(), String> {
    crate::plot::register_font();
    match format {
        Format::Svg => draw(SVGBackend::new(path, SIZE).into_drawing_area(), map),
        Format::Png => draw(BitMapBackend::new(path, SIZE).into_drawing_area(), map),
    }
}

/// The cell edges of an axis: midway between points, half a spacing beyond the ends.
fn edges(a: &Axis) -> Vec<f64> {
    let values: Vec<f64> = (0..a.n).map(|i| a.value(i)).collect();
    let half = if a.n > 1 {
        0.5 * (a.hi - a.lo) / (a.n - 1) as f64
    } else {
        0.5
    };
    let mut e = vec![values[0] - half];
    e.extend(values.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    e.push(values[a.n - 1] + half);
    e
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, map: &HeatMap<'_>) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("cannot draw the plot: {e}");
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let (plot, bar) = root.split_horizontally(SIZE.0 - 110);
    let (ax, ay) = map.axes;
    let (ex, ey) = (edges(ax), edges(ay));
    let (x0, x1) = (ex[0].min(ex[ax.n]), ex[0].max(ex[ax.n]));
    let (y0, y1) = (ey[0].min(ey[ay.n]), ey[0].max(ey[ay.n]));
    let mut chart = ChartBuilder::on(&plot)
        .caption(map.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(ax.name.as_str())
        .y_desc(ay.name.as_str())
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .draw()
        .map_err(|e| err(&e))?;
    let (lo, hi) = map.range;
    let colour = |v: Option<f64>| match v {
        Some(v) if v.is_finite() => ViridisRGB.get_color_normalized(v.clamp(lo, hi) as f32, lo as f32, hi as f32),
        _ => RGBColor(190, 190, 190),
    };
    let cells = (0..ay.n).flat_map(|j| (0..ax.n).map(move |i| (i, j)));
    chart
        .draw_series(cells.map(|(i, j)| {
            let v = map.values.get(j * ax.n + i).copied().flatten();
            Rectangle::new([(ex[i], ey[j]), (ex[i + 1], ey[j + 1])], colour(v).filled())
        }))
        .map_err(|e| err(&e))?;
    colour_bar(&bar, map, &colour).map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))
}

fn colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    map: &HeatMap<'_>,
    colour: &dyn Fn(Option<f64>) -> RGBColor,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (lo, hi) = map.range;
    let mut chart = ChartBuilder::on(area)
        .margin_top(45)
        .margin_bottom(57)
        .margin_right(10)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..1.0, lo..hi)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(map.label)
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .draw()?;
    let k = 200;
    chart.draw_series((0..k).map(|i| {
        let a = lo + (hi - lo) * i as f64 / k as f64;
        let b = lo + (hi - lo) * (i + 1) as f64 / k as f64;
        Rectangle::new([(0.0, a), (1.0, b)], colour(Some(0.5 * (a + b))).filled())
    }))?;
    Ok(())
}
