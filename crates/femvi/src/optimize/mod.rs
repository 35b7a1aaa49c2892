//! Optimal control by discrete mechanics (DMOC: Ober-Blöbaum, Junge, Marsden, ESAIM COCV 17,
//! 2011; for Galerkin elements Campos, Ober-Blöbaum, Trélat, DCDS-A 35, 2015): the forced
//! discrete Euler–Lagrange equations of femvi's elements are the constraints, the cost is
//! integrated by the element's own quadrature, and Newton's method on the KKT system keeps
//! the block-banded structure of the boundary value solver ([`crate::bvp`]), so an iteration
//! costs O(N) for N elements.
//!
//! **The discrete problem.** Mesh t_k = t0 + k h, h = (t1 − t0)/N, elements of degree s with
//! nodal values Q (the paper's (2.24)–(2.27)) and an r-point quadrature (c_j, b_j). Controls
//! u ∈ Rᵐ live at the quadrature points: U_{k,j} is u(t_k + c_j h). They act through the
//! generalised force F(t, q, v, u) of the discrete Lagrange–d'Alembert principle (DESIGN §4):
//! with q_h the element polynomial, for every node a of element k the force contributes
//! f^a = h Σ_j b_j F(t_j, q_h, q̇_h, U_{k,j}) ℓ_a(c_j). The constraints c(Q, U) = 0 are
//! - at every interior node, the forced discrete Euler–Lagrange equation
//!   ∂L_d/∂Q^a + f^a = 0 summed over the elements sharing the node;
//! - at the ends, the boundary momenta (DESIGN §4): ∂L_d/∂Q^0 + f^0 + p_0 = 0 on the first
//!   element and ∂L_d/∂Q^s + f^s − p_N = 0 on the last, with p_0 = ∂L/∂v(t0, q0, v0) and
//!   p_N = ∂L/∂v(t1, q1, v1) (the given velocities enter through their momenta);
//! - and the positions at the ends are the given q0, q1.
//!
//! The objective is J = Σ_k h Σ_j b_j C(t_j, q_h, q̇_h, U_{k,j}) + w·t1.
//!
//! **KKT.** With multipliers Λ at every node, ℒ = J + Λ·c. Interpolating Λ with the same
//! basis, Λ·c is a sum over quadrature points of h b_j [∂L/∂q·λ + ∂L/∂v·λ̇ + F·λ], so ℒ is a
//! sum of point terms Ψ (`point.rs`) and its Hessian over all unknowns (Q, U, Λ) is block
//! banded, one element wide (`layout.rs`). Newton's method on ∇ℒ = 0, with bounds by an
//! interior-point barrier and a merit line search, is in `solver.rs`.
//!
//! **Free final time.** t1 is one more unknown; every element is scaled with it,
//! t_k = t0 + (t1 − t0) k/N (DESIGN §5), so h is a variable of every point term. Its row and
//! column couple with all blocks; the KKT system is bordered and solved in O(N) by block
//! elimination (`kkt.rs`). With the time weight w (minimum time for C = 0, w = 1) the
//! stationarity in t1 is the discrete counterpart of the transversality condition H(t1) = −w
//! of the continuous problem.
//!
//! The discretisation and the dualisation commute for these elements (Campos et al.), so the
//! optimal cost converges with the integrator's order.

mod assemble;
mod kkt;
mod layout;
mod point;
mod solver;
mod system;

pub use system::{Controls, ExprControls, WithForce};

use crate::discrete::Element;
use crate::error::{check_len, invalid, Error, Result};
use crate::lagrangian::Lagrangian;
use assemble::Model;
use layout::Layout;
use solver::{Bound, Iterate, Settings};

/// The final time: given, or an unknown between bounds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FinalTime {
    /// t1 is given.
    Fixed(f64),
    /// t1 is free in [min, max]; the iteration starts from `guess`.
    Free {
        /// Smallest t1.
        min: f64,
        /// Largest t1.
        max: f64,
        /// The starting value, strictly inside (min, max).
        guess: f64,
    },
}

/// An optimal control problem: boundary data, mesh, bounds on the controls, the weight of t1.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlProblem {
    /// Start time.
    pub t0: f64,
    /// Final time.
    pub t1: FinalTime,
    /// Positions and velocities at t0.
    pub q0: Vec<f64>,
    /// Velocities at t0.
    pub v0: Vec<f64>,
    /// Positions at t1.
    pub q1: Vec<f64>,
    /// Velocities at t1.
    pub v1: Vec<f64>,
    /// Number of elements N.
    pub elements: usize,
    /// Lower bounds of the controls (m entries; −∞ for none).
    pub lower: Vec<f64>,
    /// Upper bounds of the controls (m entries; +∞ for none).
    pub upper: Vec<f64>,
    /// The weight w of w·t1 in the objective.
    pub time_weight: f64,
}

/// A starting trajectory: positions (and optionally controls) at increasing times,
/// interpolated linearly; outside its times the end values are held.
#[derive(Debug, Clone, PartialEq)]
pub struct Guess {
    /// Times, increasing.
    pub t: Vec<f64>,
    /// Positions, row-major (a row of n per time).
    pub q: Vec<f64>,
    /// Controls, row-major (a row of m per time), or none (zero, moved inside the bounds).
    pub u: Option<Vec<f64>>,
}

/// Options of [`optimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct OptimizeOptions {
    /// Stop when the constraint violation, the scaled optimality residual and the
    /// complementarity are at most this.
    pub tolerance: f64,
    /// Newton iterations at most.
    pub max_iterations: usize,
    /// The start; `None`: straight lines between the end positions, zero controls.
    pub guess: Option<Guess>,
}

impl Default for OptimizeOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-9,
            max_iterations: 200,
            guess: None,
        }
    }
}

/// The result of [`optimize`]: the optimum, or the best iterate with `error` set.
#[derive(Debug, Clone, PartialEq)]
pub struct Optimum {
    /// J at the returned iterate.
    pub objective: f64,
    /// The final time.
    pub t1: f64,
    /// Newton iterations.
    pub iterations: usize,
    /// max |c|: the largest violation of the discrete equations (momentum units).
    pub violation: f64,
    /// The optimality residual ‖∇ₓℒ − z‖∞ / h.
    pub optimality: f64,
    /// Times of the element end nodes t_0 … t_N.
    pub t: Vec<f64>,
    /// Positions at the element end nodes, (N + 1) rows of n.
    pub q: Vec<f64>,
    /// Discrete momenta at the element end nodes, (N + 1) rows of n.
    pub p: Vec<f64>,
    /// Times of the quadrature points, where the controls live (N·r).
    pub control_t: Vec<f64>,
    /// Controls at the quadrature points, N·r rows of m.
    pub u: Vec<f64>,
    /// Why the iteration stopped short, if it did; the fields above are its best iterate.
    pub error: Option<Error>,
}

/// Solves the optimal control problem of the system `lag` with `controls` on the mesh of
/// `element`s.
///
/// # Errors
/// Invalid data (dimensions, non-finite values, t1 ≤ t0, bounds that exclude zero width,
/// a free t1 whose guess is not inside its bounds, a guess of the wrong shape), or a mesh
/// too large for memory. A run that does not converge is not an error: its best iterate is
/// returned with [`Optimum::error`] set.
///
/// # Example
///
/// The double integrator x″ = u from rest at 0 to rest at 1 in unit time, minimising ∫u²:
/// the optimum is u = 6 − 12t with J = 12.
///
/// ```
/// use femvi::optimize::{optimize, ControlProblem, ExprControls, FinalTime, OptimizeOptions};
/// use femvi::expr::ExprLagrangian;
///
/// let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
/// let lag = ExprLagrangian::new("0.5*x_dot^2", &s(&["x"]), &[])?;
/// let ctl = ExprControls::new(&s(&["x"]), &s(&["u"]), &s(&["u"]), "u^2", &[])?;
/// let problem = ControlProblem {
///     t0: 0.0, t1: FinalTime::Fixed(1.0),
///     q0: vec![0.0], v0: vec![0.0], q1: vec![1.0], v1: vec![0.0],
///     elements: 20, lower: vec![f64::NEG_INFINITY], upper: vec![f64::INFINITY], time_weight: 0.0,
/// };
/// let element = femvi::Element::with_order(4)?;
/// let best = optimize(&lag, &ctl, &element, &problem, &OptimizeOptions::default())?;
/// assert!(best.error.is_none());
/// assert!((best.objective - 12.0).abs() < 1e-9);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn optimize<L: Lagrangian + ?Sized, C: Controls>(
    lag: &L,
    controls: &C,
    element: &Element,
    problem: &ControlProblem,
    options: &OptimizeOptions,
) -> Result<Optimum> {
    validate(lag, controls, problem, options)?;
    let (n, m) = (lag.dim(), controls.controls());
    let layout = Layout {
        n,
        m,
        s: element.degree(),
        r: element.points(),
        elements: problem.elements,
    };
    let (free, t1) = match problem.t1 {
        FinalTime::Fixed(t1) => (false, t1),
        FinalTime::Free { guess, .. } => (true, guess),
    };
    let p0 = momentum(lag, problem.t0, &problem.q0, &problem.v0);
    let model = Model {
        lag,
        ctl: controls,
        element,
        layout,
        t0: problem.t0,
        free,
        q0: problem.q0.clone(),
        q1: problem.q1.clone(),
        v1: problem.v1.clone(),
        p0,
        time_weight: problem.time_weight,
    };
    let (start, bounds) = start(&model, problem, options.guess.as_ref(), t1)?;
    let settings = Settings {
        tolerance: options.tolerance,
        max_iterations: options.max_iterations,
    };
    let out = solver::solve(&model, &bounds, start, settings)?;
    let it = &out.best;
    let vals = model.values(&it.x, it.t1);
    let h = model.step(it.t1);
    let nodes = model.positions(&it.x);
    let q: Vec<f64> = (0..=problem.elements)
        .flat_map(|k| nodes[k * layout.s * n..(k * layout.s + 1) * n].to_vec())
        .collect();
    let mut u = Vec::with_capacity(problem.elements * layout.r * m);
    let mut control_t = Vec::with_capacity(problem.elements * layout.r);
    for k in 0..problem.elements {
        for j in 0..layout.r {
            control_t.push(problem.t0 + (k as f64 + element.rule.nodes[j]) * h);
            u.extend_from_slice(&it.x[layout.u(k, j)..layout.u(k, j) + m]);
        }
    }
    let error = (!out.converged).then(|| Error::NotConverged {
        what: "optimal control".to_string(),
        iterations: out.iterations,
        residual: out.violation.max(out.optimality),
        reason: out.reason.clone().unwrap_or_default(),
    });
    Ok(Optimum {
        objective: vals.objective,
        t1: it.t1,
        iterations: out.iterations,
        violation: out.violation,
        optimality: out.optimality,
        t: (0..=problem.elements).map(|k| problem.t0 + k as f64 * h).collect(),
        q,
        p: model.momenta(&it.x, it.t1),
        control_t,
        u,
        error,
    })
}

fn momentum<L: Lagrangian + ?Sized>(lag: &L, t: f64, q: &[f64], v: &[f64]) -> Vec<f64> {
    use num_dual::Dual64;
    let qd: Vec<Dual64> = q.iter().map(|&x| Dual64::from(x)).collect();
    let mut vd: Vec<Dual64> = v.iter().map(|&x| Dual64::from(x)).collect();
    (0..q.len())
        .map(|i| {
            vd[i].eps = 1.0;
            let p = lag.value(Dual64::from(t), &qd, &vd).eps;
            vd[i].eps = 0.0;
            p
        })
        .collect()
}

fn validate<L: Lagrangian + ?Sized, C: Controls>(
    lag: &L,
    controls: &C,
    p: &ControlProblem,
    o: &OptimizeOptions,
) -> Result<()> {
    let (n, m) = (lag.dim(), controls.controls());
    if n == 0 || controls.dim() != n {
        return Err(invalid(
            "controls",
            format!(
                "the controls are for {} coordinates, the Lagrangian has {n}",
                controls.dim()
            ),
        ));
    }
    for (what, v) in [("q0", &p.q0), ("v0", &p.v0), ("q1", &p.q1), ("v1", &p.v1)] {
        check_len(&format!("boundary {what}"), n, v.len())?;
        if v.iter().any(|x| !x.is_finite()) {
            return Err(invalid(&format!("boundary {what}"), "all values must be finite"));
        }
    }
    check_len("lower bounds", m, p.lower.len())?;
    check_len("upper bounds", m, p.upper.len())?;
    for (c, (lo, up)) in p.lower.iter().zip(&p.upper).enumerate() {
        if lo.is_nan() || up.is_nan() || lo >= up || *lo == f64::INFINITY || *up == f64::NEG_INFINITY {
            return Err(invalid(
                "control bounds",
                format!("control {c}: lower {lo} must be below upper {up}"),
            ));
        }
    }
    if p.elements == 0 {
        return Err(invalid("elements", "at least one element is needed"));
    }
    if !p.t0.is_finite() || !p.time_weight.is_finite() {
        return Err(invalid("t0 and the time weight", "must be finite"));
    }
    match p.t1 {
        FinalTime::Fixed(t1) if !(t1.is_finite() && t1 > p.t0) => {
            return Err(invalid(
                "t1",
                format!("t1 = {t1} is not a finite time after t0 = {}", p.t0),
            ));
        }
        FinalTime::Free { min, max, guess } if !(min > p.t0 && min < guess && guess < max && min.is_finite()) => {
            return Err(invalid(
                "free t1",
                format!("need t0 = {} < t1_min = {min} < guess = {guess} < t1_max = {max}", p.t0),
            ));
        }
        _ => {}
    }
    if o.tolerance.is_nan() || o.tolerance <= 0.0 || o.max_iterations == 0 {
        return Err(invalid(
            "options",
            "the tolerance must be positive and the iteration limit at least 1",
        ));
    }
    if let Some(g) = &o.guess {
        check_guess(g, n, m)?;
    }
    Ok(())
}

fn check_guess(g: &Guess, n: usize, m: usize) -> Result<()> {
    if g.t.is_empty()
        || g.t
            .windows(2)
            .any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
        || g.t.iter().any(|x| !x.is_finite())
    {
        return Err(invalid(
            "guess",
            "its times must be finite and increasing, at least one",
        ));
    }
    check_len("guess positions", g.t.len() * n, g.q.len())?;
    if let Some(u) = &g.u {
        check_len("guess controls", g.t.len() * m, u.len())?;
    }
    if g.q.iter().chain(g.u.iter().flatten()).any(|x| !x.is_finite()) {
        return Err(invalid("guess", "all values must be finite"));
    }
    Ok(())
}

/// Linear interpolation of row-major `rows` (width w) at t, ends held.
fn interpolate(times: &[f64], rows: &[f64], w: usize, t: f64, out: &mut [f64]) {
    let k = times.partition_point(|&s| s <= t);
    let (i, j, a) = if k == 0 {
        (0, 0, 0.0)
    } else if k >= times.len() {
        (times.len() - 1, times.len() - 1, 0.0)
    } else {
        (k - 1, k, (t - times[k - 1]) / (times[k] - times[k - 1]))
    };
    for c in 0..w {
        out[c] = (1.0 - a) * rows[i * w + c] + a * rows[j * w + c];
    }
}

/// The first iterate and the bounded unknowns.
fn start<L: Lagrangian + ?Sized, C: Controls>(
    model: &Model<'_, L, C>,
    problem: &ControlProblem,
    guess: Option<&Guess>,
    t1: f64,
) -> Result<(Iterate, Vec<Bound>)> {
    let l = model.layout;
    let (n, m) = (l.n, l.m);
    let mut x = vec![0.0; l.size()];
    let h = (t1 - problem.t0) / l.elements as f64;
    let line = Guess {
        t: vec![problem.t0, t1],
        q: problem.q0.iter().chain(&problem.q1).copied().collect(),
        u: None,
    };
    let g = guess.unwrap_or(&line);
    let mut row = vec![0.0; n.max(m)];
    for node in 0..l.nodes() {
        if let Some(i) = l.q(node) {
            let (k, a) = (node / l.s, node % l.s);
            let tau = model.element.basis.nodes.get(a).copied().unwrap_or(0.0);
            interpolate(&g.t, &g.q, n, problem.t0 + (k as f64 + tau) * h, &mut row);
            x[i..i + n].copy_from_slice(&row[..n]);
        }
    }
    let mut bounds = Vec::new();
    for k in 0..l.elements {
        for j in 0..l.r {
            let t = problem.t0 + (k as f64 + model.element.rule.nodes[j]) * h;
            row.iter_mut().for_each(|v| *v = 0.0);
            if let Some(u) = &g.u {
                interpolate(&g.t, u, m, t, &mut row);
            }
            for c in 0..m {
                let (lo, up) = (problem.lower[c], problem.upper[c]);
                x[l.u(k, j) + c] = inside(row[c], lo, up);
                if lo.is_finite() || up.is_finite() {
                    bounds.push(Bound {
                        var: Some(l.u(k, j) + c),
                        lo,
                        up,
                    });
                }
            }
        }
    }
    if let FinalTime::Free { min, max, .. } = problem.t1 {
        bounds.push(Bound {
            var: None,
            lo: min,
            up: max,
        });
    }
    let mu = 0.1;
    let zl = bounds
        .iter()
        .map(|b| {
            if b.lo.is_finite() {
                mu / (value(&x, t1, b) - b.lo)
            } else {
                0.0
            }
        })
        .collect();
    let zu = bounds
        .iter()
        .map(|b| {
            if b.up.is_finite() {
                mu / (b.up - value(&x, t1, b))
            } else {
                0.0
            }
        })
        .collect();
    Ok((Iterate { x, t1, zl, zu }, bounds))
}

fn value(x: &[f64], t1: f64, b: &Bound) -> f64 {
    b.var.map_or(t1, |i| x[i])
}

/// x moved strictly inside [lo, up] (by 1% of the width, or of max(1, |bound|) for one bound).
fn inside(x: f64, lo: f64, up: f64) -> f64 {
    let width = up - lo;
    let (lo_in, up_in) = if width.is_finite() {
        (lo + 0.01 * width, up - 0.01 * width)
    } else {
        (lo + 0.01 * lo.abs().max(1.0), up - 0.01 * up.abs().max(1.0))
    };
    x.max(lo_in).min(up_in)
}

#[cfg(test)]
mod tests {
    use super::assemble::{Border, Model};
    use super::*;
    use crate::expr::ExprLagrangian;
    use crate::solve::BandMatrix;

    /// The assembled Hessian is the derivative of the assembled gradient (central
    /// differences), free final time included.
    #[test]
    fn hessian_matches_differences_of_the_gradient() {
        let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let coords = names(&["x", "th"]);
        let lag = ExprLagrangian::new(
            "0.5*2.5*x_dot^2 + 0.25*x_dot*th_dot*cos(th) + 0.0625*th_dot^2 + 2.4*cos(th) + t*x",
            &coords,
            &[],
        )
        .unwrap();
        let ctl = ExprControls::new(
            &coords,
            &names(&["u"]),
            &names(&["u*(1+0.1*x)", "0.2*u*th_dot"]),
            "u^2 + x*th_dot^2 + t*u",
            &[],
        )
        .unwrap();
        for (order, free) in [(2, false), (4, false), (6, true)] {
            let element = Element::with_order(order).unwrap();
            let layout = Layout {
                n: 2,
                m: 1,
                s: element.degree(),
                r: element.points(),
                elements: 3,
            };
            let model = Model {
                lag: &lag,
                ctl: &ctl,
                element: &element,
                layout,
                t0: 0.1,
                free,
                q0: vec![0.1, 0.2],
                q1: vec![0.8, 3.0],
                v1: vec![0.3, -0.2],
                p0: vec![0.5, 0.1],
                time_weight: 0.7,
            };
            let size = layout.size();
            let x: Vec<f64> = (0..size).map(|i| ((i * 7919) % 97) as f64 / 97.0 - 0.5).collect();
            let t1 = 2.0;
            let bw = layout.bandwidth();
            let mut band = BandMatrix::zeros(size, bw, bw).unwrap();
            let mut grad = vec![0.0; size];
            let mut border = Border {
                col: vec![0.0; size],
                diag: 0.0,
                grad: 0.0,
            };
            model.assemble(&x, t1, &mut band, &mut grad, &mut border).unwrap();
            let eps = 1e-6;
            let grad_at = |x: &[f64], t1: f64| {
                let mut b = BandMatrix::zeros(size, bw, bw).unwrap();
                let mut g = vec![0.0; size];
                let mut bd = Border {
                    col: vec![0.0; size],
                    diag: 0.0,
                    grad: 0.0,
                };
                model.assemble(x, t1, &mut b, &mut g, &mut bd).unwrap();
                (g, bd.grad)
            };
            let mut worst = 0.0f64;
            for j in 0..size {
                let (mut xp, mut xm) = (x.clone(), x.clone());
                xp[j] += eps;
                xm[j] -= eps;
                let ((gp, tp), (gm, tm)) = (grad_at(&xp, t1), grad_at(&xm, t1));
                for i in 0..size {
                    let fd = (gp[i] - gm[i]) / (2.0 * eps);
                    worst = worst.max((fd - band.get(i, j)).abs() / (1.0 + fd.abs()));
                }
                if free {
                    worst = worst.max(((tp - tm) / (2.0 * eps) - border.col[j]).abs());
                }
            }
            if free {
                let ((gp, tp), (gm, tm)) = (grad_at(&x, t1 + eps), grad_at(&x, t1 - eps));
                for i in 0..size {
                    worst = worst.max(((gp[i] - gm[i]) / (2.0 * eps) - border.col[i]).abs());
                }
                worst = worst.max(((tp - tm) / (2.0 * eps) - border.diag).abs() / (1.0 + border.diag.abs()));
            }
            assert!(worst < 1e-6, "order {order}: worst relative difference {worst:.3e}");
        }
    }
}
