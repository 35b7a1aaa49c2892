//! `femvi bvp`: solves a two-point boundary value problem by the discrete variational
//! principle (the library's [`femvi::bvp::solve`]; with `[forces]`,
//! [`femvi::forces::solve_forced_bvp`]; with `[constraints]`, `crate::constrained::bvp`),
//! from the straight line or from a trajectory file interpolated onto the mesh; writes
//! trajectory.csv and summary.json and, with plots on, coordinates.svg (coordinates against
//! t) and, with a moving mesh, steps.svg.

use crate::plot::{file, lines, Format, Series};
use crate::problem::BvpProblem;
use femvi::bvp::{line_guess, node_times, BvpOptions};
use femvi::lagrangian::{hamiltonian, PointDerivatives};
use femvi::Lagrangian;
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

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

/// How a solve ended: Ok with the summary (also on numerical failure, with `error` set), or
/// Err with a message and an exit code for bad input.
pub fn run(problem: &BvpProblem, dir: &Path) -> Result<BvpSummary, (String, u8)> {
    run_plotted(problem, dir, None)
}

/// [`run`], drawing the plots in format `plot` if given.
pub fn run_plotted(problem: &BvpProblem, dir: &Path, plot: Option<Format>) -> Result<BvpSummary, (String, u8)> {
    if let Some(c) = &problem.terms.constraints {
        return crate::constrained::bvp::run(problem, c, dir, plot);
    }
    crate::with_system!(&problem.system, l => run_with(l, problem, dir, plot))
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

fn run_with<L: Lagrangian>(
    lag: &L,
    problem: &BvpProblem,
    dir: &Path,
    plot: Option<Format>,
) -> Result<BvpSummary, (String, u8)> {
    let clock = Instant::now();
    let (bv, el) = (&problem.boundary, &problem.element);
    let guess = match &problem.guess {
        None => line_guess(bv, el),
        Some(file) => guess_from_file(file, &problem.coordinates, &node_times(bv, el)).map_err(|e| (e, 2))?,
    };
    let opts = BvpOptions {
        tolerance: problem.options.tolerance,
        max_iterations: problem.options.max_iterations,
        moving_mesh: problem.moving_mesh,
    };
    let io = |e: std::io::Error| (format!("cannot write the output in {}: {e}", dir.display()), 2);
    std::fs::create_dir_all(dir).map_err(io)?;
    let mut summary = BvpSummary {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        elements: bv.elements,
        time_mode: if problem.moving_mesh { "energy" } else { "fixed" },
        action: None,
        residual_norm: None,
        scaled_residual: None,
        newton_iterations: 0,
        wall_seconds: 0.0,
        error: None,
        femvi_version: env!("CARGO_PKG_VERSION").to_string(),
        command_line: std::env::args().collect(),
        problem: problem.source.clone(),
    };
    match crate::forced::solve_bvp(lag, problem.terms.force.as_ref(), el, bv, &guess, opts) {
        Ok(sol) => {
            let n = lag.dim();
            let mut csv = csv::Writer::from_path(dir.join("trajectory.csv")).map_err(|e| (e.to_string(), 2))?;
            let mut header = vec!["step".to_string(), "t".to_string()];
            header.extend(problem.coordinates.iter().cloned());
            header.extend(problem.coordinates.iter().map(|c| format!("p_{c}")));
            header.push("energy".into());
            csv.write_record(&header).map_err(|e| (e.to_string(), 2))?;
            let mut work = PointDerivatives::new(n);
            let mut v = vec![0.0; n];
            for (k, t) in sol.times.iter().enumerate() {
                let (q, p) = (&sol.q[k * n..(k + 1) * n], &sol.p[k * n..(k + 1) * n]);
                let e = hamiltonian(lag, *t, q, p, &mut v, &mut work).unwrap_or(f64::NAN);
                let mut row = vec![k.to_string(), format!("{t:?}")];
                row.extend(q.iter().chain(p).map(|x| format!("{x:?}")));
                row.push(format!("{e:?}"));
                csv.write_record(&row).map_err(|e| (e.to_string(), 2))?;
            }
            csv.flush().map_err(io)?;
            if let Some(f) = plot {
                plots(problem, dir, f, &sol.times, &sol.q).map_err(|e| (e, 2))?;
            }
            summary.action = Some(sol.action);
            summary.residual_norm = Some(sol.residual_norm);
            summary.scaled_residual = Some(sol.scaled_residual);
            summary.newton_iterations = sol.newton_iterations;
        }
        Err(femvi::Error::Step(e)) => {
            summary.error = Some(format!("Newton's method on the discrete action failed: {e}"));
            summary.residual_norm = Some(e.residual);
            summary.newton_iterations = e.iterations;
        }
        Err(e) => return Err((e.to_string(), 2)),
    }
    summary.wall_seconds = clock.elapsed().as_secs_f64();
    let text = serde_json::to_string_pretty(&summary).map_err(|e| (e.to_string(), 2))?;
    std::fs::write(dir.join("summary.json"), text + "\n").map_err(io)?;
    Ok(summary)
}
