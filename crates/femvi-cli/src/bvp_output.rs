//! What `femvi bvp` writes and reads besides the solve: summary.json's fields
//! ([`BvpSummary`]), the plots of a solution (`plots`) and the guess read from a trajectory
//! file (`guess_from_file`); shared by the unconstrained solve (`bvp.rs`) and the
//! constrained one (`bvp_constrained.rs`), which `bvp.rs` dispatches to.

use crate::plot::{file, lines, Format, Series};
use crate::problem::BvpProblem;
use serde::Serialize;
use std::path::Path;

/// What summary.json holds for a boundary value problem.
#[derive(Debug, Serialize)]
pub struct BvpSummary {
    /// The problem's name.
    pub name: String,
    /// The element used.
    pub scheme: String,
    /// Number of elements.
    pub elements: usize,
    /// "fixed" (uniform mesh) or "energy" (moving mesh).
    pub time_mode: &'static str,
    /// The discrete action S of the solution.
    pub action: Option<f64>,
    /// max |∂S/∂Q| over the unknowns at the solution (or where Newton's method stopped).
    pub residual_norm: Option<f64>,
    /// The residual scaled by the size of the Hessian of the action and of the nodal values,
    /// max|∂S/∂Q| / (‖J‖∞ · max|Q|), independent of the number of elements
    /// ([`femvi::bvp::BvpSolution::scaled_residual`]); none if the solve failed.
    pub scaled_residual: Option<f64>,
    /// Newton iterations taken.
    pub newton_iterations: usize,
    /// Run time.
    pub wall_seconds: f64,
    /// The message of the error that stopped the solve, if any.
    pub error: Option<String>,
    /// The femvi version that solved the problem.
    pub femvi_version: String,
    /// The command line (program and arguments).
    pub command_line: Vec<String>,
    /// The problem's TOML text as solved, after `--set` overrides.
    pub problem: String,
}

/// coordinates.svg and, with a moving mesh, steps.svg of a solution at the element ends.
pub(crate) fn plots(problem: &BvpProblem, dir: &Path, f: Format, times: &[f64], q: &[f64]) -> Result<(), String> {
    let n = problem.coordinates.len();
    let h = (problem.boundary.t1 - problem.boundary.t0) / problem.boundary.elements as f64;
    let what = format!(
        "{}, {} elements, h = {h}{}",
        problem.scheme_label,
        problem.boundary.elements,
        if problem.moving_mesh {
            " (initial; moving mesh)"
        } else {
            ""
        }
    );
    let coords: Vec<Series> = (0..n)
        .map(|c| Series {
            name: problem.coordinates[c].clone(),
            points: times.iter().enumerate().map(|(k, t)| (*t, q[k * n + c])).collect(),
        })
        .collect();
    let title = format!("{}: boundary value problem, {what}", problem.name);
    lines(&file(dir, "coordinates", f), f, &title, "t", "q", &coords)?;
    if problem.moving_mesh {
        let steps = [Series {
            name: "step".into(),
            points: times.windows(2).map(|w| (w[1], w[1] - w[0])).collect(),
        }];
        let title = format!("{}: steps of the moving mesh, {what}", problem.name);
        lines(&file(dir, "steps", f), f, &title, "t", "h", &steps)?;
    }
    Ok(())
}

/// Reads a trajectory.csv and interpolates q linearly at `times` (constant beyond its ends).
pub(crate) fn guess_from_file(path: &Path, names: &[String], times: &[f64]) -> Result<Vec<f64>, String> {
    let file = crate::bounded::open(path, crate::bounded::Limits::CSV)
        .map_err(|e| format!("cannot read the guess {}: {e}", path.display()))?;
    let mut rdr = csv::Reader::from_reader(file);
    let header = rdr
        .headers()
        .map_err(|e| format!("the guess {}: {e}", path.display()))?
        .clone();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| format!("the guess {} has no column '{name}'", path.display()))
    };
    let tc = col("t")?;
    let qc: Vec<usize> = names.iter().map(|n| col(n)).collect::<Result<_, _>>()?;
    let (mut ts, mut qs) = (vec![], vec![]);
    for (line, rec) in rdr.records().enumerate() {
        let rec = rec.map_err(|e| format!("the guess {}: {e}", path.display()))?;
        let num = |i: usize| -> Result<f64, String> {
            rec.get(i)
                .and_then(|v| v.trim().parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    format!(
                        "{}: row {}: column {} is not a finite number",
                        path.display(),
                        line + 2,
                        i + 1
                    )
                })
        };
        let t = num(tc)?;
        if ts.last().is_some_and(|&last| t <= last) {
            return Err(format!("{}: row {}: times must increase", path.display(), line + 2));
        }
        ts.push(t);
        qs.push(qc.iter().map(|&i| num(i)).collect::<Result<Vec<f64>, _>>()?);
    }
    if ts.is_empty() {
        return Err(format!("the guess {} has no rows", path.display()));
    }
    let mut out = Vec::with_capacity(times.len() * names.len());
    for &t in times {
        let k = ts.partition_point(|&x| x <= t);
        let row: Vec<f64> = if k == 0 {
            qs[0].clone()
        } else if k == ts.len() {
            qs[k - 1].clone()
        } else {
            let a = (t - ts[k - 1]) / (ts[k] - ts[k - 1]);
            qs[k - 1].iter().zip(&qs[k]).map(|(x, y)| x + a * (y - x)).collect()
        };
        out.extend(row);
    }
    Ok(out)
}
