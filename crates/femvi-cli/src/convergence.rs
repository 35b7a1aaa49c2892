//! `femvi convergence`: runs a problem's scheme at several step sizes over the same time span,
//! measures the final nodal error in phase space, ‖(q, p) − (q, p)_ref‖₂, and fits observed
//! orders. The reference is a closed form where the model has one (harmonic, kepler), or a
//! run with a finer step and an element of degree s + 2. With --l2 it also measures the L²
//! error of the piecewise-polynomial trajectory over the whole span ((2.33), (2.56)); with
//! --plot it draws the errors against the step with the fitted slopes ([`plot`]).

use crate::problem::Problem;
use femvi::diagnostics::{exact, fit_order, PiecewiseTrajectory};
use femvi::{Element, Integrator, Lagrangian, NodeFamily, QuadratureKind, Start, TimeGrid};
use serde::Serialize;

/// A closed-form state (q, p) as a function of time.
type ExactState = Box<dyn Fn(f64) -> Option<Vec<f64>>>;
/// q_ref(t) written into a buffer.
type Path = Box<dyn Fn(f64, &mut [f64])>;

/// Which reference the errors are measured against.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reference {
    /// The closed form of the model.
    Exact,
    /// A run with a quarter of the finest step and degree s + 2.
    Finest,
    /// A run with this step and degree s + 2.
    Step(f64),
}

impl std::str::FromStr for Reference {
    type Err = String;

    /// `exact`, `finest` or a positive step (the `--reference` argument).
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "exact" => Ok(Reference::Exact),
            "finest" => Ok(Reference::Finest),
            other => match other.parse::<f64>() {
                Ok(h) if h > 0.0 && h.is_finite() => Ok(Reference::Step(h)),
                _ => Err(format!(
                    "--reference must be exact, finest or a positive step, not '{other}'"
                )),
            },
        }
    }
}

/// One run of the study.
#[derive(Debug, Serialize)]
pub struct Run {
    /// The step size.
    pub step: f64,
    /// ‖(q, p) − (q, p)_ref‖₂ at the end.
    pub error: f64,
    /// The order measured against the previous run.
    pub order_from_previous: Option<f64>,
    /// With --l2: the L² distance of the piecewise-polynomial q_h to the reference over [t0, T].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub l2_error: Option<f64>,
}

/// The study, printed as JSON with `--json`.
#[derive(Debug, Serialize)]
pub struct Study {
    /// The problem's name.
    pub name: String,
    /// The element used.
    pub scheme: String,
    /// Least-squares slope of ln(error) against ln(step) over all runs.
    pub order: f64,
    /// What the errors were measured against.
    pub reference: String,
    /// The end time of every run.
    pub t_end: f64,
    /// With --l2: the least-squares order of the L² errors.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub l2_order: Option<f64>,
    /// One entry per step size, in the order given.
    pub runs: Vec<Run>,
}

/// Runs the study; Err carries a message and an exit code.
pub fn study(problem: &Problem, steps: &[f64], reference: Option<Reference>, l2: bool) -> Result<Study, (String, u8)> {
    if problem.energy.is_some() {
        return Err((
            "convergence studies use fixed steps: set [time] mode = \"fixed\"".into(),
            2,
        ));
    }
    if steps.len() < 2 {
        return Err(("--steps needs at least two step sizes".into(), 2));
    }
    if let Some(h) = steps.iter().find(|h| !(h.is_finite() && **h > 0.0)) {
        return Err((format!("--steps: {h} is not a positive number"), 2));
    }
    crate::with_system!(&problem.system, l => study_with(l, problem, steps, reference, l2))
}

fn fail(e: femvi::Error) -> (String, u8) {
    let code = if matches!(e, femvi::Error::Step(_)) { 1 } else { 2 };
    (e.to_string(), code)
}

/// Final state (q, p) of a run with step h, and its piecewise trajectory.
fn run<L: Lagrangian>(
    lag: &L,
    el: &Element,
    problem: &Problem,
    h: f64,
) -> Result<(Vec<f64>, PiecewiseTrajectory), (String, u8)> {
    let grid = TimeGrid::uniform(problem.grid.t0(), h, problem.grid.end()).map_err(fail)?;
    let mut it = Integrator::new(lag, el, grid, problem.start.clone(), problem.options).map_err(fail)?;
    let trajectory = PiecewiseTrajectory::record(&mut it, &el.basis, lag.dim()).map_err(fail)?;
    let n = it.node();
    Ok((n.q.iter().chain(n.p).cloned().collect(), trajectory))
}

/// The closed-form state (q, p) as a function of t, if the model has one and the start gives
/// (q0, p0).
fn exact_state<L: Lagrangian>(lag: &L, problem: &Problem) -> Option<ExactState> {
    let (model, params) = problem.model.as_ref()?;
    let (q0, p0) = match &problem.start {
        Start::Momentum { q, p } => (q.clone(), p.clone()),
        Start::Velocity { q, v } => {
            let mut work = femvi::lagrangian::PointDerivatives::new(lag.dim());
            lag.first_derivatives(problem.grid.t0(), q, v, false, &mut work);
            (q.clone(), work.l_v().to_vec())
        }
        Start::Positions { .. } => return None,
    };
    let t0 = problem.grid.t0();
    let params = params.clone();
    match model.as_str() {
        "harmonic" => Some(Box::new(move |t| {
            let (q, p) = exact::harmonic(params[0], params[1], t0, q0[0], p0[0], t);
            Some(vec![q, p])
        })),
        "kepler" => {
            // Bound orbits only.
            exact::kepler(params[0], t0, [q0[0], q0[1]], [p0[0], p0[1]], t0)?;
            Some(Box::new(move |t| {
                let (q, p) = exact::kepler(params[0], t0, [q0[0], q0[1]], [p0[0], p0[1]], t)?;
                Some(vec![q[0], q[1], p[0], p[1]])
            }))
        }
        _ => None,
    }
}

fn study_with<L: Lagrangian>(
    lag: &L,
    problem: &Problem,
    steps: &[f64],
    reference: Option<Reference>,
    l2: bool,
) -> Result<Study, (String, u8)> {
    let exact = exact_state(lag, problem);
    let reference = reference.unwrap_or(if exact.is_some() {
        Reference::Exact
    } else {
        Reference::Finest
    });
    let finest = steps.iter().cloned().fold(f64::INFINITY, f64::min);
    let t_end = problem.grid.end();
    // The reference: its final state, and q_ref(t) for the L² errors.
    let (reference_state, reference_path, label): (Vec<f64>, Path, String) = match reference {
        Reference::Exact => match exact {
            Some(f) => {
                let end = f(t_end).ok_or_else(|| ("the closed form failed at the end time".to_string(), 1))?;
                let path = move |t: f64, out: &mut [f64]| {
                    let s = f(t).unwrap_or_else(|| vec![f64::NAN; 2 * out.len()]);
                    out.copy_from_slice(&s[..out.len()]);
                };
                (end, Box::new(path), "exact (closed form)".to_string())
            }
            None => {
                return Err((
                    "no closed form for this problem (only the harmonic and kepler models, started from v or p, have one); use --reference finest or a step".into(),
                    2,
                ))
            }
        },
        Reference::Finest | Reference::Step(_) => {
            let h = match reference {
                Reference::Step(h) => h,
                _ => finest / 4.0,
            };
            let s = problem.element.degree() + 2;
            let el = Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).map_err(fail)?;
            let (end, trajectory) = run(lag, &el, problem, h)?;
            let label = format!("galerkin degree {s} with {s}-point Gauss-Legendre, step {h}");
            (end, Box::new(move |t: f64, out: &mut [f64]| trajectory.eval(t, out)), label)
        }
    };
    let points = problem.element.degree() + 3;
    let mut runs: Vec<Run> = vec![];
    for &h in steps {
        let (state, trajectory) = run(lag, &problem.element, problem, h)?;
        let error = state
            .iter()
            .zip(&reference_state)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        let order_from_previous = runs.last().map(|r: &Run| (error / r.error).ln() / (h / r.step).ln());
        let l2_error = l2.then(|| trajectory.l2_distance(points, |t, out| reference_path(t, out)));
        runs.push(Run {
            step: h,
            error,
            order_from_previous,
            l2_error,
        });
    }
    let hs: Vec<f64> = runs.iter().map(|r| r.step).collect();
    let es: Vec<f64> = runs.iter().map(|r| r.error).collect();
    let l2_order = l2.then(|| {
        let e2: Vec<f64> = runs.iter().map(|r| r.l2_error.unwrap_or(f64::NAN)).collect();
        fit_order(&hs, &e2)
    });
    Ok(Study {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        order: fit_order(&hs, &es),
        reference: label,
        t_end,
        l2_order,
        runs,
    })
}

/// Error against step on log-log axes, with the least-squares line of each fit.
pub fn plot(dir: &std::path::Path, study: &Study, f: crate::plot::Format) -> Result<(), String> {
    use crate::plot::{self, Series};
    let pts: Vec<(f64, f64)> = study.runs.iter().map(|r| (r.step, r.error)).collect();
    let fit_line = |pts: &[(f64, f64)], order: f64| -> Vec<(f64, f64)> {
        // Through the geometric mean of the points with the fitted slope.
        let k = pts.len() as f64;
        let (mx, my) = pts
            .iter()
            .fold((0.0, 0.0), |(a, b), (x, y)| (a + x.ln() / k, b + y.ln() / k));
        pts.iter()
            .map(|(x, _)| (*x, (my + order * (x.ln() - mx)).exp()))
            .collect()
    };
    let mut series = vec![
        Series {
            name: "final nodal error".into(),
            points: pts.clone(),
        },
        Series {
            name: format!("fit: order {:.2}", study.order),
            points: fit_line(&pts, study.order),
        },
    ];
    if let Some(o) = study.l2_order {
        let l2: Vec<(f64, f64)> = study
            .runs
            .iter()
            .map(|r| (r.step, r.l2_error.unwrap_or(f64::NAN)))
            .collect();
        series.push(Series {
            name: "L2 error".into(),
            points: l2.clone(),
        });
        series.push(Series {
            name: format!("fit: L2 order {o:.2}"),
            points: fit_line(&l2, o),
        });
    }
    // Measured series at even positions carry markers; the fits (odd) are plain lines.
    let steps: Vec<String> = study.runs.iter().map(|r| format!("{}", r.step)).collect();
    let title = format!(
        "{}: convergence, {}, h = {}",
        study.name,
        study.scheme,
        steps.join(", ")
    );
    plot::log_log_measured(
        &plot::file(dir, "convergence", f),
        f,
        (&title, "step h", "error"),
        &series,
    )
}

/// convergence.csv's text: step, error, order from the previous run (and the L² error).
pub fn csv(study: &Study, l2: bool) -> String {
    let mut csv = String::from(if l2 {
        "step,error,order_from_previous,l2_error\n"
    } else {
        "step,error,order_from_previous\n"
    });
    for r in &study.runs {
        let o = r.order_from_previous.map(|o| format!("{o:?}")).unwrap_or_default();
        let l2e = r.l2_error.map(|e| format!(",{e:?}")).unwrap_or_default();
        csv.push_str(&format!("{:?},{:?},{o}{l2e}\n", r.step, r.error));
    }
    csv
}

/// Prints the study for a person (`femvi convergence` without `--json`); `dir` holds
/// convergence.csv.
pub fn print(study: &Study, dir: &std::path::Path) {
    println!("{} ({}), reference: {}", study.name, study.scheme, study.reference);
    println!("{:>14} {:>14} {:>8}", "step", "error", "order");
    for r in &study.runs {
        let o = r.order_from_previous.map(|o| format!("{o:.3}")).unwrap_or_default();
        println!("{:>14.6e} {:>14.6e} {:>8}", r.step, r.error, o);
    }
    if let Some(o) = study.l2_order {
        let e: Vec<String> = study
            .runs
            .iter()
            .map(|r| format!("{:.3e}", r.l2_error.unwrap_or(f64::NAN)))
            .collect();
        println!("L2 errors {}; fitted L2 order {o:.3}", e.join(" "));
    }
    println!(
        "fitted order {:.3}; wrote {}",
        study.order,
        dir.join("convergence.csv").display()
    );
}
