//! `femvi optimize`: optimal control by discrete mechanics (the library's
//! [`femvi::optimize::optimize`]) for a problem file with `[boundary]` (positions and
//! velocities at both ends, t1 given or free), `[controls]` and `[objective]`; the system's
//! own `[forces]` act beside the controls. Writes trajectory.csv (the element end nodes: t,
//! positions, discrete momenta and the controls read off at the nodes), controls.csv (the
//! quadrature points, where the controls live as unknowns: t and a column per control) and
//! summary.json; with plots, coordinates and controls
//! against t and a phase portrait (q, p) per coordinate, as `femvi run` draws them.

use crate::plot::{file, lines, Format, Series};
use crate::problem::OptimizeProblem;
use femvi::optimize::{
    optimize, ControlProblem, Controls, Guess, OptimizeOptions, Optimum, WithConstraints, WithForce,
};
use femvi::Lagrangian;
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// summary.json of `femvi optimize`.
#[derive(Debug, Serialize)]
pub struct OptimizeSummary {
    /// The problem's name.
    pub name: String,
    /// The element.
    pub scheme: String,
    /// Number of elements.
    pub elements: usize,
    /// The objective at the returned iterate.
    pub objective: f64,
    /// The final time.
    pub t1: f64,
    /// The end velocity (given, or the optimiser's where `[boundary] v1` is "free").
    pub v1: Vec<f64>,
    /// Newton iterations (on the problem's mesh).
    pub iterations: usize,
    /// Mesh refinement's coarser stages (`[boundary] coarse`): elements, iterations,
    /// objective, converged.
    pub stages: Vec<StageSummary>,
    /// The largest violation of the discrete equations.
    pub violation: f64,
    /// The optimality residual.
    pub optimality: f64,
    /// Wall-clock seconds.
    pub wall_seconds: f64,
    /// Why the iteration stopped short (the files then hold its best iterate), if it did.
    pub error: Option<String>,
    /// femvi's version.
    pub femvi_version: String,
    /// The command line.
    pub command_line: Vec<String>,
    /// The problem file's text.
    pub problem: String,
}

/// One coarser stage of mesh refinement in summary.json.
#[derive(Debug, Serialize)]
pub struct StageSummary {
    /// Its elements.
    pub elements: usize,
    /// Its Newton iterations.
    pub iterations: usize,
    /// Its objective.
    pub objective: f64,
    /// Whether it converged.
    pub converged: bool,
}

/// Solves and writes; Ok with the summary and the optimum (also when the iteration did not
/// converge, with `error` set and the best iterate written), Err with a message and exit
/// code for bad input or output that cannot be written.
pub fn run(
    problem: &OptimizeProblem,
    dir: &Path,
    plot: Option<Format>,
) -> Result<(OptimizeSummary, Optimum), (String, u8)> {
    let ctl = &problem.control.controls;
    crate::with_system!(&problem.system, l => match (&problem.force, &problem.constraints) {
        (Some(f), None) => run_with(l, &WithForce { controls: ctl, force: f }, problem, dir, plot),
        (None, None) => run_with(l, ctl, problem, dir, plot),
        (Some(f), Some(k)) => {
            let forced = WithForce { controls: ctl, force: f };
            run_with(l, &WithConstraints { controls: &forced, constraints: k }, problem, dir, plot)
        }
        (None, Some(k)) => run_with(l, &WithConstraints { controls: ctl, constraints: k }, problem, dir, plot),
    })
}

fn run_with<L: Lagrangian, C: Controls>(
    lag: &L,
    controls: &C,
    problem: &OptimizeProblem,
    dir: &Path,
    plot: Option<Format>,
) -> Result<(OptimizeSummary, Optimum), (String, u8)> {
    let clock = Instant::now();
    let b = &problem.boundary;
    let guess = match &b.guess {
        None => None,
        Some(file) => Some(read_guess(file, &problem.coordinates, &problem.control.names)?),
    };
    let (v0, v1) = end_velocities(lag, b)?;
    let data = ControlProblem {
        t0: b.t0,
        t1: b.t1,
        q0: b.q0.clone(),
        v0,
        q1: b.q1.clone(),
        v1,
        elements: b.elements,
        lower: problem.control.lower.clone(),
        upper: problem.control.upper.clone(),
        q_lower: problem.coordinate_bounds.0.clone(),
        q_upper: problem.coordinate_bounds.1.clone(),
        time_weight: problem.control.time_weight,
    };
    let options = OptimizeOptions {
        guess,
        coarse: b.coarse.clone(),
        ..problem.options.clone()
    };
    let best = optimize(lag, controls, &problem.element, &data, &options).map_err(|e| (e.to_string(), 2))?;
    let io = |e: std::io::Error| (format!("cannot write the output in {}: {e}", dir.display()), 2);
    std::fs::create_dir_all(dir).map_err(io)?;
    write_files(problem, &best, dir)?;
    if let Some(f) = plot {
        let what = format!(
            "{}: optimal control, {}, {} elements",
            problem.name, problem.scheme_label, b.elements
        );
        plot_series(
            &problem.coordinates,
            dir,
            f,
            (&best.t, &best.q),
            ("coordinates", "q", &what),
        )?;
        plot_series(
            &problem.control.names,
            dir,
            f,
            (&best.control_t, &best.u),
            ("controls", "u", &what),
        )?;
        plot_phase(problem, &best, dir, f)?;
    }
    let summary = OptimizeSummary {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        elements: b.elements,
        objective: best.objective,
        t1: best.t1,
        v1: best.v1.clone(),
        iterations: best.iterations,
        stages: best
            .stages
            .iter()
            .map(|s| StageSummary {
                elements: s.elements,
                iterations: s.iterations,
                objective: s.objective,
                converged: s.converged,
            })
            .collect(),
        violation: best.violation,
        optimality: best.optimality,
        wall_seconds: clock.elapsed().as_secs_f64(),
        error: best.error.as_ref().map(|e| e.to_string()),
        femvi_version: env!("CARGO_PKG_VERSION").to_string(),
        command_line: std::env::args().collect(),
        problem: problem.source.clone(),
    };
    let text = serde_json::to_string_pretty(&summary).map_err(|e| (e.to_string(), 2))?;
    std::fs::write(dir.join("summary.json"), text + "\n").map_err(io)?;
    Ok((summary, best))
}

/// The velocities at t0 and t1 (a free component of the latter `None`).
type EndVelocities = (Vec<f64>, Vec<Option<f64>>);

/// The end velocities: as given, or from given momenta by the inverse Legendre transform
/// at the given positions (at t1 only where that does not depend on t1: a fixed t1 or an
/// autonomous L; and only with the end position given).
fn end_velocities<L: Lagrangian>(lag: &L, b: &crate::problem::ControlBoundary) -> Result<EndVelocities, (String, u8)> {
    let n = lag.dim();
    let bad = |m: String| (format!("[boundary] {m}"), 2);
    let invert = |t: f64, q: &[f64], p: &[f64], what: &str| -> Result<Vec<f64>, (String, u8)> {
        if q.len() != n || p.len() != n {
            return Err(bad(format!("{what} needs {n} entries")));
        }
        let mut v = vec![0.0; n];
        let mut work = femvi::lagrangian::PointDerivatives::new(n);
        femvi::lagrangian::velocity_from_momentum(lag, t, q, p, &mut v, &mut work)
            .map_err(|e| bad(format!("{what}: no velocity has these momenta: {e}")))?;
        Ok(v)
    };
    let v0 = match &b.p0 {
        Some(p) => invert(b.t0, &b.q0, p, "p0")?,
        None => b.v0.clone(),
    };
    let v1 = match &b.p1 {
        None => b.v1.clone(),
        Some(p) => {
            let q1: Option<Vec<f64>> = b.q1.iter().copied().collect();
            let Some(q1) = q1 else {
                return Err(bad(
                    "p1 needs q1 given in full (its velocity depends on the end position); give v1 with a free q1"
                        .into(),
                ));
            };
            let t1 = match b.t1 {
                femvi::optimize::FinalTime::Fixed(t) => t,
                femvi::optimize::FinalTime::Free { guess, .. } if lag.is_autonomous() => guess,
                femvi::optimize::FinalTime::Free { .. } => {
                    return Err(bad(
                        "p1 with a free t1 needs a Lagrangian without t (its velocity would depend on t1); give v1"
                            .into(),
                    ))
                }
            };
            invert(t1, &q1, p, "p1")?.into_iter().map(Some).collect()
        }
    };
    Ok((v0, v1))
}

/// One line per column of row-major `values` against `times`, into `<stem>.<format>`.
fn plot_series(
    names: &[String],
    dir: &Path,
    f: Format,
    (times, values): (&[f64], &[f64]),
    (stem, axis, title): (&str, &str, &str),
) -> Result<(), (String, u8)> {
    let w = names.len();
    let series: Vec<Series> = names
        .iter()
        .enumerate()
        .map(|(c, name)| Series {
            name: name.clone(),
            points: times.iter().enumerate().map(|(k, t)| (*t, values[k * w + c])).collect(),
        })
        .collect();
    lines(&file(dir, stem, f), f, title, "t", axis, &series).map_err(|e| (e, 2))
}

/// A phase portrait (q, p) per coordinate at the element end nodes, into `phase_<name>`.
fn plot_phase(problem: &OptimizeProblem, best: &Optimum, dir: &Path, f: Format) -> Result<(), (String, u8)> {
    let n = problem.coordinates.len();
    for (c, name) in problem.coordinates.iter().enumerate() {
        let series = [Series {
            name: name.clone(),
            points: (0..best.t.len())
                .map(|k| (best.q[k * n + c], best.p[k * n + c]))
                .collect(),
        }];
        let title = format!("{}: phase portrait of {name} (optimal control)", problem.name);
        lines(
            &file(dir, &format!("phase_{name}"), f),
            f,
            &title,
            name,
            &format!("p_{name}"),
            &series,
        )
        .map_err(|e| (e, 2))?;
    }
    Ok(())
}

fn write_files(problem: &OptimizeProblem, best: &Optimum, dir: &Path) -> Result<(), (String, u8)> {
    let err = |e: csv::Error| (format!("cannot write the output in {}: {e}", dir.display()), 2);
    let n = problem.coordinates.len();
    let mut csv = csv::Writer::from_path(dir.join("trajectory.csv")).map_err(err)?;
    let mut header = vec!["step".to_string(), "t".to_string()];
    header.extend(problem.coordinates.iter().cloned());
    header.extend(problem.coordinates.iter().map(|c| format!("p_{c}")));
    header.extend(problem.control.names.iter().cloned());
    csv.write_record(&header).map_err(err)?;
    let m = problem.control.names.len();
    for (k, t) in best.t.iter().enumerate() {
        let mut row = vec![k.to_string(), format!("{t:?}")];
        row.extend(
            best.q[k * n..(k + 1) * n]
                .iter()
                .chain(&best.p[k * n..(k + 1) * n])
                .chain(best.u_nodes.get(k * m..(k + 1) * m).unwrap_or(&[]))
                .map(|x| format!("{x:?}")),
        );
        csv.write_record(&row).map_err(err)?;
    }
    csv.flush().map_err(|e| (e.to_string(), 2))?;
    let mut csv = csv::Writer::from_path(dir.join("controls.csv")).map_err(err)?;
    let mut header = vec!["t".to_string()];
    header.extend(problem.control.names.iter().cloned());
    csv.write_record(&header).map_err(err)?;
    for (j, t) in best.control_t.iter().enumerate() {
        let mut row = vec![format!("{t:?}")];
        row.extend(best.u[j * m..(j + 1) * m].iter().map(|x| format!("{x:?}")));
        csv.write_record(&row).map_err(err)?;
    }
    csv.flush().map_err(|e| (e.to_string(), 2))
}

/// A guess file: a CSV with a column t, one per coordinate and optionally one per control
/// (named as in the problem; other columns are ignored), read within the CLI's size limit.
fn read_guess(path: &Path, coordinates: &[String], controls: &[String]) -> Result<Guess, (String, u8)> {
    let bad = |m: String| (format!("guess file {}: {m}", path.display()), 2);
    let source = crate::bounded::open(path, crate::bounded::Limits::CSV).map_err(|e| bad(e.to_string()))?;
    let mut reader = csv::Reader::from_reader(source);
    let header = reader.headers().map_err(|e| bad(e.to_string()))?.clone();
    let col = |name: &str| header.iter().position(|h| h.trim() == name);
    let t_col = col("t").ok_or_else(|| bad("no column t".into()))?;
    let q_cols = coordinates
        .iter()
        .map(|c| col(c).ok_or_else(|| bad(format!("no column {c}"))))
        .collect::<Result<Vec<_>, _>>()?;
    let u_cols: Option<Vec<usize>> = controls.iter().map(|c| col(c)).collect();
    let (mut t, mut q, mut u) = (Vec::new(), Vec::new(), Vec::new());
    for (i, rec) in reader.records().enumerate() {
        let rec = rec.map_err(|e| bad(e.to_string()))?;
        let num = |c: usize| -> Result<f64, (String, u8)> {
            rec.get(c)
                .and_then(|s| s.trim().parse::<f64>().ok())
                .ok_or_else(|| bad(format!("row {}: not a number in column {}", i + 2, c + 1)))
        };
        t.push(num(t_col)?);
        for &c in &q_cols {
            q.push(num(c)?);
        }
        if let Some(cols) = &u_cols {
            for &c in cols {
                u.push(num(c)?);
            }
        }
    }
    Ok(Guess {
        t,
        q,
        u: u_cols.map(|_| u),
    })
}
