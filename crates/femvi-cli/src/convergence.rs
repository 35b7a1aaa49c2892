//! `femvi convergence`: runs a problem's scheme at several step sizes over the same time span,
//! measures the final nodal error in phase space, ‖(q, p) − (q, p)_ref‖₂, and fits observed
//! orders. The reference is a closed form where the model has one (harmonic, kepler, without
//! forces), or a run with a finer step and an element of degree s + 2. Every run, the
//! reference's too, is the one integrator with the problem's terms (`Integrator::with_force`,
//! `with_constraints`, `with_constraints_and_force`). With --l2 it also measures the L²
//! error of the piecewise-polynomial trajectory over the whole span ((2.33), (2.56)); with
//! --plot it draws the errors against the step with the fitted slopes ([`plot`]).
//!
//! The study streams: memory does not grow with the length of the runs. Without --l2 each run
//! keeps only its state; with --l2 the runs go in lockstep with the reference run, each
//! element's L² contribution summed as it is solved against a sliding window of the
//! reference's elements ([`femvi::diagnostics::L2Sum`]).

use crate::problem::Problem;
use femvi::diagnostics::{exact, fit_order, L2Sum, PiecewiseTrajectory};
use femvi::{Element, Integrator, Lagrangian, NodeFamily, QuadratureKind, Start, TimeGrid};
use serde::Serialize;

/// A run's final state (q, p) and its L² error.
type FinalState = (Vec<f64>, f64);
/// A closed-form state (q, p) as a function of time.
type ExactState = Box<dyn Fn(f64) -> Option<Vec<f64>>>;

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
    problem
        .refuse(crate::problem::capabilities::Use::Convergence, "femvi convergence")
        .map_err(|e| (e, crate::BAD_INPUT))?;
    if problem.energy.is_some() {
        return Err((
            "convergence studies use fixed steps: set [time] mode = \"fixed\"".into(),
            2,
        ));
    }
    if l2 {
        problem
            .refuse(
                crate::problem::capabilities::Use::ConvergenceL2,
                "femvi convergence --l2",
            )
            .map_err(|e| (e, crate::BAD_INPUT))?;
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

/// The integrator of a run with step h and element `el`.
fn integrator<'a, L: Lagrangian + Sync>(
    lag: &'a L,
    el: &'a Element,
    problem: &'a Problem,
    h: f64,
) -> Result<Integrator<'a, L>, (String, u8)> {
    let grid = TimeGrid::uniform(problem.grid.t0(), h, problem.grid.end()).map_err(fail)?;
    // Fixed steps h: the energy mode's steps are not the study's.
    problem
        .integrator(lag, el, grid, problem.start.clone(), None)
        .map_err(fail)
}

/// The state (q, p) of a run's current node.
fn state<L: Lagrangian>(it: &Integrator<'_, L>) -> Vec<f64> {
    let n = it.node();
    n.q.iter().chain(n.p).cloned().collect()
}

/// Final state (q, p) of a run to its end.
fn run_to_end<L: Lagrangian>(mut it: Integrator<'_, L>) -> Result<Vec<f64>, (String, u8)> {
    while it.step().map_err(fail)? {}
    Ok(state(&it))
}

/// The final state (q, p) of the run of `problem` with step `h` and element `el`, its terms
/// (forces, constraints) included: the integrator to the end.
fn final_state<L: Lagrangian + Sync>(
    lag: &L,
    el: &Element,
    problem: &Problem,
    h: f64,
) -> Result<Vec<f64>, (String, u8)> {
    run_to_end(integrator(lag, el, problem, h)?)
}

/// A run of the study with its L² sum (if measured).
struct Coarse<'a, L: Lagrangian> {
    it: Integrator<'a, L>,
    l2: L2Sum,
    done: bool,
}

/// The reference of the L² errors: the closed form, or a run kept as a sliding window of its
/// elements (those the coarse runs can still ask for).
enum Path<'a, L: Lagrangian> {
    Exact(ExactState),
    Run {
        it: Box<Integrator<'a, L>>,
        window: PiecewiseTrajectory,
        done: bool,
    },
}

impl<L: Lagrangian> Path<'_, L> {
    /// Makes q_ref(t) known for t ≤ `until`: advances the reference run until an element
    /// starts after `until` (or the run ends).
    fn cover(&mut self, until: f64) -> Result<(), (String, u8)> {
        if let Path::Run { it, window, done } = self {
            while !*done && window.last_start().is_none_or(|s| s <= until) {
                if it.step().map_err(fail)? {
                    if let Some(e) = it.last_element() {
                        window.push(&e).map_err(fail)?;
                    }
                } else {
                    *done = true;
                }
            }
        }
        Ok(())
    }

    /// q_ref(t) into `out`.
    fn eval(&self, t: f64, out: &mut [f64]) {
        match self {
            Path::Exact(f) => {
                let s = f(t).unwrap_or_else(|| vec![f64::NAN; 2 * out.len()]);
                out.copy_from_slice(&s[..out.len()]);
            }
            Path::Run { window, .. } => window.eval(t, out),
        }
    }
}

/// Runs `steps` in lockstep (always the one furthest behind), summing each element's L² error
/// against `path` as it is solved; the reference run's window forgets what no run can need.
/// Returns each run's final state and L² error.
fn lockstep<'a, L: Lagrangian + Sync>(
    lag: &'a L,
    problem: &'a Problem,
    steps: &[f64],
    path: &mut Path<'a, L>,
) -> Result<Vec<FinalState>, (String, u8)> {
    let (n, el) = (lag.dim(), &problem.element);
    let points = el.degree() + 3;
    let rotations = rotation_offsets(problem);
    let mut runs = steps
        .iter()
        .map(|&h| {
            Ok(Coarse {
                it: integrator(lag, el, problem, h)?,
                l2: L2Sum::new(points, n).with_rotations(&rotations),
                done: false,
            })
        })
        .collect::<Result<Vec<_>, (String, u8)>>()?;
    let mut nodes = vec![];
    let behind = |runs: &[Coarse<'a, L>]| {
        (0..runs.len())
            .filter(|&i| !runs[i].done)
            .min_by(|&i, &j| runs[i].it.node().t.total_cmp(&runs[j].it.node().t))
    };
    while let Some(i) = behind(&runs) {
        let run = &mut runs[i];
        if !run.it.step().map_err(fail)? {
            run.done = true;
            continue;
        }
        let Some(e) = run.it.last_element() else { continue };
        let (t0, h) = (e.t, e.h);
        nodes.clear();
        for j in 0..el.basis.len() {
            nodes.extend((0..n).map(|c| e.base[c] + e.incr[j * n + c]));
        }
        path.cover(t0 + h)?;
        run.l2.add(&el.basis, t0, h, &nodes, |t, out| path.eval(t, out));
        if let (Path::Run { window, .. }, Some(k)) = (&mut *path, behind(&runs)) {
            window.forget_before(runs[k].it.node().t);
        }
    }
    Ok(runs.iter().map(|r| (state(&r.it), r.l2.value())).collect())
}

/// The offsets of the problem's rotation blocks (none without rotations): the L² sums follow
/// their Lie-group paths between nodes.
fn rotation_offsets(problem: &Problem) -> Vec<usize> {
    problem
        .terms
        .rotations
        .as_ref()
        .map_or_else(Vec::new, |r| r.offsets().to_vec())
}

/// The closed-form state (q, p) as a function of t, if the model has one and the start gives
/// (q0, p0).
fn exact_state<L: Lagrangian>(lag: &L, problem: &Problem) -> Option<ExactState> {
    if problem.terms.force.is_some() || problem.terms.constraints.is_some() {
        // The closed forms are those of the free conservative models.
        return None;
    }
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

fn study_with<L: Lagrangian + Clone + Sync>(
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
    let s = problem.element.degree() + 2;
    let reference_element =
        Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).map_err(fail)?;
    // The reference: q_ref(t), and its label.
    let (mut path, label) = match reference {
        Reference::Exact => match exact {
            Some(f) => (Path::Exact(f), "exact (closed form)".to_string()),
            None => {
                return Err((
                    "no closed form for this problem (only the harmonic and kepler models without [forces], started from v or p, have one); use --reference finest or a step".into(),
                    2,
                ))
            }
        },
        Reference::Finest | Reference::Step(_) => {
            let h = match reference {
                Reference::Step(h) => h,
                _ => finest / 4.0,
            };
            let label = format!("galerkin degree {s} with {s}-point Gauss-Legendre, step {h}");
            let it = Box::new(integrator(lag, &reference_element, problem, h)?);
            let window =
                PiecewiseTrajectory::new(&reference_element.basis, lag.dim()).with_rotations(&rotation_offsets(problem));
            (Path::Run { it, window, done: false }, label)
        }
    };
    // Each run's final state and L² error (with --l2 in lockstep with the reference, which
    // then also ends; without, one after the other after the reference).
    let mut finals: Vec<(Vec<f64>, Option<f64>)> = vec![];
    if l2 {
        for (end, e) in lockstep(lag, problem, steps, &mut path)? {
            finals.push((end, Some(e)));
        }
    }
    let reference_state = match path {
        Path::Exact(f) => f(t_end).ok_or_else(|| ("the closed form failed at the end time".to_string(), 1))?,
        Path::Run { it, .. } => run_to_end(*it)?,
    };
    if !l2 {
        for &h in steps {
            finals.push((final_state(lag, &problem.element, problem, h)?, None));
        }
    }
    let mut runs: Vec<Run> = vec![];
    for (&h, (end, l2_error)) in steps.iter().zip(finals) {
        let error = end
            .iter()
            .zip(&reference_state)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        let order_from_previous = runs.last().map(|r: &Run| (error / r.error).ln() / (h / r.step).ln());
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
