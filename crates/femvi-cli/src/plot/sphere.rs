//! Curves on the unit sphere in a 3-D view (issue 37, item 5: the tip of each body axis of a
//! rotation, R e_a, as the body turns): a wire frame of the sphere (the equator and two
//! meridians, in grey), the space axes x, y, z (z up), and one coloured curve per series with
//! the legend of the other plots.

use super::{color, err, register_font, Format, LEGEND_WIDTH, SIZE};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// A curve in space, (x, y, z) points.
pub struct Curve {
    /// Legend entry.
    pub name: String,
    /// Points (x, y, z), on or near the unit sphere.
    pub points: Vec<[f64; 3]>,
}

/// At most this many points per curve are drawn (evenly spaced, the last one kept).
const MAX_POINTS: usize = 5_000;

/// Draws `curves` on the unit sphere into `path` in `format`, titled `title`.
///
/// # Errors
/// The file cannot be written.
///
/// # Example
///
/// ```
/// use femvi_cli::plot::{sphere::{sphere, Curve}, Format};
/// let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
/// let equator = Curve {
///     name: "e1".into(),
///     points: (0..64).map(|k| { let a = 0.1 * k as f64; [a.cos(), a.sin(), 0.0] }).collect(),
/// };
/// sphere(&dir.path().join("axes.svg"), Format::Svg, "a turn about z", &[equator])?;
/// assert!(dir.path().join("axes.svg").exists());
/// # Ok::<(), String>(())
/// ```
pub fn sphere(path: &Path, format: Format, title: &str, curves: &[Curve]) -> Result<(), String> {
    register_font();
    match format {
        Format::Svg => draw_on(SVGBackend::new(path, SIZE).into_drawing_area(), title, curves),
        Format::Png => draw_on(BitMapBackend::new(path, SIZE).into_drawing_area(), title, curves),
    }
}

/// Every k-th point of `points` (k so that at most [`MAX_POINTS`] remain) and the last.
fn thinned(points: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let k = points.len().div_ceil(MAX_POINTS).max(1);
    let mut out: Vec<[f64; 3]> = points.iter().step_by(k).copied().collect();
    if let (Some(last), Some(kept)) = (points.last(), out.last()) {
        if last != kept {
            out.push(*last);
        }
    }
    out.retain(|p| p.iter().all(|x| x.is_finite()));
    out
}

/// A circle of the sphere: the points c cos φ + d sin φ.
fn circle(c: [f64; 3], d: [f64; 3]) -> Vec<(f64, f64, f64)> {
    (0..=120)
        .map(|i| {
            let phi = std::f64::consts::TAU * f64::from(i) / 120.0;
            let (s, co) = phi.sin_cos();
            // Plot coordinates (x, z, y): plotters' second axis is vertical.
            (c[0] * co + d[0] * s, c[2] * co + d[2] * s, c[1] * co + d[1] * s)
        })
        .collect()
}

fn draw_on<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, title: &str, curves: &[Curve]) -> Result<(), String> {
    root.fill(&WHITE).map_err(err)?;
    let size = (f64::from(SIZE.0 - 30) / (0.55 * title.chars().count().max(1) as f64)).clamp(11.0, 20.0);
    let root = root.titled(title, ("sans-serif", size)).map_err(err)?;
    let (w, _) = root.dim_in_pixel();
    let (area, legend) = root.split_horizontally(w.saturating_sub(LEGEND_WIDTH));
    let r = -1.1..1.1;
    let mut chart = ChartBuilder::on(&area)
        .margin(12)
        .build_cartesian_3d(r.clone(), r.clone(), r)
        .map_err(err)?;
    chart.with_projection(|mut p| {
        p.yaw = 0.6;
        p.pitch = 0.35;
        p.scale = 0.85;
        p.into_matrix()
    });
    chart
        .configure_axes()
        .light_grid_style(WHITE.mix(0.0))
        .max_light_lines(0)
        .x_labels(3)
        .y_labels(3)
        .z_labels(3)
        .draw()
        .map_err(err)?;
    let grey = RGBColor(190, 190, 190);
    let frame = [
        ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
    ];
    for (c, d) in frame {
        chart
            .draw_series(LineSeries::new(circle(c, d), grey.stroke_width(1)))
            .map_err(err)?;
    }
    for (i, curve) in curves.iter().enumerate() {
        let points = thinned(&curve.points).into_iter().map(|p| (p[0], p[2], p[1]));
        chart
            .draw_series(LineSeries::new(points, color(i).stroke_width(2)))
            .map_err(err)?;
    }
    let font = ("sans-serif", 14).into_font().color(&BLACK);
    for (i, curve) in curves.iter().enumerate() {
        let y = 30 + 20 * i as i32;
        legend
            .draw(&PathElement::new(vec![(4, y), (28, y)], color(i).stroke_width(2)))
            .map_err(err)?;
        legend
            .draw(&Text::new(curve.name.clone(), (34, y - 8), font.clone()))
            .map_err(err)?;
    }
    let note = ("sans-serif", 12).into_font().color(&BLACK);
    legend
        .draw(&Text::new(
            "z is up".to_string(),
            (4, 30 + 20 * curves.len() as i32),
            note,
        ))
        .map_err(err)?;
    root.present().map_err(err)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_at_most_the_limit_and_the_last_point() {
        let points: Vec<[f64; 3]> = (0..12_345).map(|i| [f64::from(i), 0.0, 0.0]).collect();
        let kept = thinned(&points);
        assert!(kept.len() <= MAX_POINTS + 1);
        assert_eq!(kept.last(), points.last());
        assert_eq!(kept.first(), points.first());
    }

    #[test]
    fn a_sphere_plot_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.svg");
        let c = Curve {
            name: "e1".into(),
            points: (0..100)
                .map(|i| {
                    let a = f64::from(i) * 0.1;
                    [a.cos(), a.sin(), 0.0]
                })
                .collect(),
        };
        sphere(&path, Format::Svg, "test", &[c]).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.contains("<svg") && svg.contains("e1"));
    }
}
