//! The trajectory of an adaptive run as a table: the kept nodes with their physical t and
//! fictitious s (columns step, t, q, p, energy, s), or the rows at the requested uniform
//! physical times (columns row, t, q, p, energy, with H from the inverse Legendre
//! transform there), written as trajectory.csv (numbers in shortest round-trip form) and, when
//! NPY output is on, as trajectory.npy (float64, the same columns) with columns.txt.

use crate::problem::Problem;
use crate::run_output::RunOutput;
use femvi::adaptive::AdaptiveSolution;
use femvi::Lagrangian;
use std::path::Path;

use super::AdaptiveTime;

/// Writes trajectory.csv (if `out.csv`) and trajectory.npy with columns.txt (if `out.npy`).
pub(super) fn write_trajectory<L: Lagrangian>(
    dir: &Path,
    problem: &Problem,
    lag: &L,
    sol: &AdaptiveSolution,
    settings: &AdaptiveTime,
    out: RunOutput,
) -> std::io::Result<()> {
    let (header, rows) = table(problem, lag, sol, settings);
    crate::record::write_trajectory(dir, &header, &rows, &out)
}

/// The column names and the row-major values (the first column, the node or row index, as a
/// float).
fn table<L: Lagrangian>(
    problem: &Problem,
    lag: &L,
    sol: &AdaptiveSolution,
    settings: &AdaptiveTime,
) -> (Vec<String>, Vec<f64>) {
    let (n, uniform) = (sol.n, settings.output_step.is_some());
    let mut header = vec![if uniform { "row" } else { "step" }.to_string(), "t".to_string()];
    header.extend(problem.coordinates.iter().cloned());
    header.extend(problem.coordinates.iter().map(|c| format!("p_{c}")));
    header.push("energy".into());
    if !uniform {
        header.push("s".into());
    }
    let mut work = femvi::lagrangian::PointDerivatives::new(n);
    let mut v = vec![0.0; n];
    let (t, q, p) = if uniform {
        (&sol.saved.t, &sol.saved.q, &sol.saved.p)
    } else {
        (&sol.t, &sol.q, &sol.p)
    };
    let mut rows = Vec::with_capacity(t.len() * header.len());
    for (i, &ti) in t.iter().enumerate() {
        let (qi, pi) = (&q[i * n..(i + 1) * n], &p[i * n..(i + 1) * n]);
        let energy = if uniform {
            femvi::lagrangian::hamiltonian(lag, ti, qi, pi, &mut v, &mut work).unwrap_or(f64::NAN)
        } else {
            sol.energy[i]
        };
        // The node index: s = k ds.
        let index = if uniform {
            i as f64
        } else {
            (sol.s[i] / settings.ds).round()
        };
        rows.push(index);
        rows.push(ti);
        rows.extend_from_slice(qi);
        rows.extend_from_slice(pi);
        rows.push(energy);
        if !uniform {
            rows.push(sol.s[i]);
        }
    }
    (header, rows)
}
