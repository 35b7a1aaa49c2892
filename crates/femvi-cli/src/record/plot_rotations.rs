//! The plots of a run with rotations (issue 37, item 5), drawn with the run's other plots from
//! the nodes its [`PlotTrace`] kept: for each rotation X, its body angular velocity
//! X_w1 … X_w3 against time (`X_w.svg`, from the inverse Legendre transform at each kept node,
//! [`femvi::rotation::body_states`]) and the tips of its body axes X e_1, X e_2, X e_3 (the
//! columns of X) on the unit sphere (`X_axes.svg`). The energy error is `energy_error.svg`,
//! as for every run.

use super::plot_trace::PlotTrace;
use crate::plot::sphere::{sphere, Curve};
use crate::plot::{file, lines, Format, Series};
use crate::problem::Problem;
use femvi::Lagrangian;
use std::path::Path;

/// Draws the plots of each rotation of `problem` into `dir`; `name` heads the titles.
///
/// # Errors
/// A plot cannot be written.
pub fn draw<L: Lagrangian>(
    lag: &L,
    problem: &Problem,
    trace: &PlotTrace,
    (dir, format): (&Path, Format),
    name: &str,
) -> Result<(), String> {
    let Some(layout) = &problem.terms.rotations else {
        return Ok(());
    };
    let n = problem.coordinates.len();
    let nodes = trace.t.len();
    let states: Vec<Vec<femvi::rotation::BodyState>> = (0..nodes)
        .map(|k| {
            let (q, p) = (&trace.q[k * n..(k + 1) * n], &trace.p[k * n..(k + 1) * n]);
            femvi::rotation::body_states(lag, layout, trace.t[k], q, p)
        })
        .collect();
    let names = super::rotation_names(problem);
    for (r, (x, &o)) in names.iter().zip(layout.offsets()).enumerate() {
        let w: Vec<Series> = (0..3)
            .map(|c| Series {
                name: format!("{x}_w{}", c + 1),
                points: (0..nodes).map(|k| (trace.t[k], states[k][r].w[c])).collect(),
            })
            .collect();
        let title = format!("{name}: body angular velocity of {x}");
        lines(
            &file(dir, &format!("{x}_w"), format),
            format,
            &title,
            "t",
            "w (body frame)",
            &w,
        )?;
        let axes: Vec<Curve> = (0..3)
            .map(|a| Curve {
                name: format!("{x} e{}", a + 1),
                points: (0..nodes)
                    .map(|k| {
                        let q = &trace.q[k * n + o..k * n + o + 9];
                        [q[a], q[3 + a], q[6 + a]]
                    })
                    .collect(),
            })
            .collect();
        let title = format!("{name}: body axes of {x} on the unit sphere");
        sphere(&file(dir, &format!("{x}_axes"), format), format, &title, &axes)?;
    }
    Ok(())
}
