//! RATTLE steps solved on the multipliers only: degree 1 with the trapezoid rule on a
//! mechanical Lagrangian L = ½vᵀMv − V(t, q) (constant M, [`Lagrangian::mass_matrix`]) and no
//! discrete forces. There the step equations of [`crate::constraints`] are RATTLE (Andersen
//! 1983; Hairer–Lubich–Wanner, *Geometric Numerical Integration*, VII.1.4), with f = −∇V,
//! u = hλ̂ and W = M⁻¹G(q_k)ᵀ:
//!
//!   Δq = q_{k+1} − q_k = h M⁻¹(p_k + (h/2) f(t_k, q_k)) − W u,   g(q_k + Δq) = 0,
//!   p̃ = p_k + (h/2)(f(t_k, q_k) + f(t_{k+1}, q_{k+1})) − G(q_k)ᵀλ̂,
//!   p_{k+1} = p̃ − G(q_{k+1})ᵀμ̂,   G(q_{k+1}) M⁻¹ p_{k+1} = 0.
//!
//! The position constraint is m equations in the m unknowns u, solved by Newton with the
//! m×m matrix G(q_k + Δq) W (SHAKE's iteration with the exact Jacobian, quadratically
//! convergent); the hidden constraint is the linear m×m system
//! G(q_{k+1}) M⁻¹ G(q_{k+1})ᵀ μ̂ = G(q_{k+1}) M⁻¹ p̃. Both replace the dense Newton solve on
//! (Q^1, λ̂) and the Newton projection of `project.rs` by O(m n + m³) work per iteration,
//! with no allocation per step. The two paths solve the same equations to round-off (the same
//! tolerance on the increments of u = hλ̂, p̃ by the sums of `StepSystem::momentum_by_sums`);
//! here the end node's constraints are evaluated at the node that is stored (q_k + Δq with the
//! compensation of the summed increments), p is summed with compensation as q is
//! ([`RattleStep::project`]), and Newton starts from u extrapolated from the last steps (the
//! cubic through the last four with equal steps, [`extrapolate`]). Each iterate after the
//! first update is checked with the last matrix: if the correction it gives would move the
//! node by less than half an ulp of max(1, |q|∞) ([`ROUNDOFF`]), the iterate is the solution
//! and its jet is in hand (otherwise Newton goes on and stops when an update is within the
//! tolerance, evaluating the jet once more). On the spherical pendulum at h = 0.01 that is
//! 1.01 updates and 2 evaluations of g and G per step, against 1.98 and 3 with the line
//! through two values and the tolerance test alone. The nodes follow the RATTLE map evaluated
//! in double-double arithmetic to a few ulps over 10⁴ steps (`tests/all/rattle_exact.rs`,
//! `tests/all/constraints_rattle.rs`), as closely as before the check or closer.
//!
//! Small systems take these steps in a loop of their own over fixed-size arrays
//! (`rattle_loop.rs`, the same operations and bits); the fields it carries are `pub(super)`.
//!
//! [`choose`] decides when a constrained run takes these steps.

use super::jet::ConstraintJet;
use super::layout::Layout;
use super::small::{dot, solve_small};
use super::Constraints;
use crate::discrete::Element;
use crate::error::{invalid, Result, StepFailure};
use crate::fem::QuadratureKind;
use crate::lagrangian::{Lagrangian, MassMatrix};
use crate::solve::NewtonFailure;
use crate::step::Method;

/// The Newton guess for u = hλ̂ of the next step, into `u`, which holds the last step's:
/// with the last three steps of the same length h, the cubic through the last four values,
/// else the line through the last two (u varies smoothly; the closer guess lets the check of
/// the first iterate accept it). `hist` holds u of the three steps before the last one
/// (`[u_{k−1}, u_{k−2}, u_{k−3}]`, m each), `known` how many of them are known and `h_last`
/// their step; all three move on.
#[inline(always)]
pub(super) fn extrapolate(u: &mut [f64], hist: &mut [f64], (known, h_last): (&mut usize, &mut f64), h: f64) {
    let m = u.len();
    if h != *h_last {
        *known = (*known).min(1);
    }
    for (l, ul) in u.iter_mut().enumerate() {
        let (u1, u2, u3) = (hist[l], hist[m + l], hist[2 * m + l]);
        let guess = match *known {
            0 => *ul,
            1 | 2 => 2.0 * *ul - u1,
            _ => (4.0 * *ul - 6.0 * u1) + (4.0 * u2 - u3),
        };
        (hist[2 * m + l], hist[m + l], hist[l]) = (u2, u1, *ul);
        *ul = guess;
    }
    *known = (*known + 1).min(3);
    *h_last = h;
}

/// The check of an iterate accepts it when the correction would move q_{k+1} by less than
/// this fraction of an ulp of the step's scale max(1, |q|∞): the iterate is then the solution
/// to the resolution of the stored node.
pub(super) const ROUNDOFF: f64 = 0.5 * f64::EPSILON;

/// |W δ|∞ bounded by Σ_l |δ_l| max_a |W_al| for the columns W_l = `w[l n..(l + 1) n]`: how far
/// a correction δ of u moves the node.
#[inline(always)]
pub(super) fn moves_node(delta: &[f64], w: &[f64], n: usize) -> f64 {
    delta
        .iter()
        .enumerate()
        .map(|(l, d)| d.abs() * max_abs(&w[l * n..(l + 1) * n]))
        .sum()
}

/// The largest |x| of a few numbers.
#[inline(always)]
pub(super) fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |a, &b| a.max(b.abs()))
}

/// How a constrained run solves its steps ([`choose`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Path {
    /// RATTLE on the multipliers ([`RattleStep`]).
    Rattle,
    /// Fixed point on the forces, linearised multipliers (`shake/`).
    Shake,
    /// Dense Newton on the whole step (`step.rs`).
    Newton,
}

/// How a constrained run takes its steps. On a mechanical Lagrangian without forces
/// (`forced`), `Method::Auto` and `Method::FixedPoint` take RATTLE steps on degree 1 with the
/// trapezoid rule (no interior multipliers) and the SHAKE-style fixed point of `shake/` on
/// other elements whose constraints are enforced at the quadrature points or the ends
/// ([`super::shake::ShakeStep::fits`]); `Method::Explicit` takes RATTLE steps; the Newton
/// methods and everything else take dense Newton.
///
/// # Errors
/// `Method::Explicit` or `Method::FixedPoint` where their steps do not fit, naming why.
pub(crate) fn choose<L: Lagrangian>(
    method: Method,
    lag: &L,
    element: &Element,
    layout: &Layout,
    forced: bool,
) -> Result<Path> {
    let rattle = element.degree() == 1 && element.rule.kind == QuadratureKind::Trapezoid && layout.sites == 0;
    let shake = super::shake::ShakeStep::fits(element, layout);
    let model = if lag.mass_matrix().is_none() {
        Some("a mechanical Lagrangian (L = 1/2 v'Mv - V)")
    } else if forced {
        Some("no non-conservative forces")
    } else {
        None
    };
    let refuse = |steps: &str, need: &str| {
        Err(invalid(
            "solver method",
            format!("a constrained run takes {steps} steps only with {need}; use the newton method (or auto) for this problem"),
        ))
    };
    match (method, model) {
        (Method::Newton | Method::FullNewton | Method::SimplifiedNewton, _) => Ok(Path::Newton),
        (Method::Auto, Some(_)) => Ok(Path::Newton),
        (Method::Auto | Method::FixedPoint, None) if rattle => Ok(Path::Rattle),
        (Method::Auto | Method::FixedPoint, None) if shake => Ok(Path::Shake),
        (Method::Auto, None) => Ok(Path::Newton),
        (Method::Explicit, None) if rattle => Ok(Path::Rattle),
        (Method::Explicit, None) => refuse("explicit (RATTLE)", "degree 1 with the trapezoid rule"),
        (Method::Explicit, Some(need)) => refuse("explicit (RATTLE)", need),
        (Method::FixedPoint, None) => refuse(
            "fixed-point",
            "constraints enforced weakly, at the quadrature points or at the ends (not at the nodes)",
        ),
        (Method::FixedPoint, Some(need)) => refuse("fixed-point", need),
    }
}

/// Scratch of the RATTLE step (n coordinates, m constraints).
#[derive(Debug, Clone)]
pub(crate) struct RattleStep {
    n: usize,
    m: usize,
    /// f at the start and at the end of the step.
    pub(super) f0: Vec<f64>,
    pub(super) f1: Vec<f64>,
    /// The unconstrained drift h M⁻¹(p_k + (h/2) f_0).
    drift: Vec<f64>,
    /// q_k + Δq.
    y: Vec<f64>,
    /// W = M⁻¹G(q_k)ᵀ stored by columns: `w[l n + a]`.
    w: Vec<f64>,
    /// M⁻¹ G(q_{k+1})ᵀ by columns, for the projection.
    w1: Vec<f64>,
    /// An m×m matrix, its right-hand side and a row of G.
    mat: Vec<f64>,
    /// The Newton matrix G(y)W of the last iterate, kept for the check of the next
    /// (`RattleStep::solve`).
    last_mat: Vec<f64>,
    rhs: Vec<f64>,
    row: Vec<f64>,
    /// The momentum increment (p̃ − p_k, then p_{k+1} − p_k) and the compensation of the
    /// momentum's running sum.
    pub(super) p_tilde: Vec<f64>,
    pub(super) pcomp: Vec<f64>,
    pub mu: Vec<f64>,
    /// u of the last three steps before the last one (`[u_{k−1}, u_{k−2}, u_{k−3}]`, m
    /// each), how many of them are known and the step they were taken with, for the
    /// extrapolated guess.
    pub(super) hist: Vec<f64>,
    pub(super) known: usize,
    pub(super) h_last: f64,
}

impl RattleStep {
    /// Scratch for n coordinates and m constraints.
    pub fn new(n: usize, m: usize) -> Self {
        Self {
            n,
            m,
            f0: vec![0.0; n],
            f1: vec![0.0; n],
            drift: vec![0.0; n],
            y: vec![0.0; n],
            w: vec![0.0; m * n],
            w1: vec![0.0; m * n],
            mat: vec![0.0; m * m],
            last_mat: vec![0.0; m * m],
            rhs: vec![0.0; m],
            row: vec![0.0; n],
            p_tilde: vec![0.0; n],
            pcomp: vec![0.0; n],
            mu: vec![0.0; m],
            hist: vec![0.0; 3 * m],
            known: 0,
            h_last: f64::NAN,
        }
    }

    /// What the next step reads of the last ones, into a checkpoint: the compensation of the
    /// momentum's running sum and the extrapolation's last u.
    pub fn save(&self, w: &mut crate::step::checkpoint::Words) {
        w.fs(&self.pcomp);
        w.fs(&self.hist);
        w.u(self.known);
        w.f(self.h_last);
    }

    /// Reads what [`RattleStep::save`] wrote.
    ///
    /// # Errors
    /// A damaged checkpoint.
    pub fn load(&mut self, r: &mut crate::step::checkpoint::Reader<'_>) -> crate::error::Result<()> {
        r.fs(&mut self.pcomp)?;
        r.fs(&mut self.hist)?;
        self.known = r.u()?;
        self.h_last = r.f()?;
        Ok(())
    }

    /// Solves the position equations of the step from (t, q_k, p_k), whose constraint jet
    /// (g, G) is `start` (with `reuse_force`, the end force of the last step is the force at
    /// q_k: an autonomous L and the same node), for Δq (into `dq`) and u = hλ̂ (into `u`, which holds the guess);
    /// `end` is left holding the jet at q_{k+1} = q_k + (Δq + `comp`), the node the compensated
    /// summation of the increments will commit (`comp` its running compensation), so that the
    /// constraints and the hidden constraint hold at the stored node itself (the dense path
    /// evaluates them at q_k + Δq, an ulp away). Returns the Newton iterations.
    ///
    /// # Errors
    /// A singular m×m matrix, a non-finite residual or no convergence within `max_iterations`
    /// (increments of u above `tol · scale`).
    #[allow(clippy::too_many_arguments)]
    pub fn solve<L: Lagrangian, C: Constraints>(
        &mut self,
        (lag, mass, con): (&L, &MassMatrix, &C),
        (start, end): (&ConstraintJet, &mut ConstraintJet),
        (t, h, reuse_force): (f64, f64, bool),
        (q, p, comp): (&[f64], &[f64], &[f64]),
        (dq, u): (&mut [f64], &mut [f64]),
        (tol, max_iterations, scale): (f64, usize, f64),
    ) -> std::result::Result<usize, NewtonFailure> {
        let (n, m) = (self.n, self.m);
        let half = h * 0.5;
        if reuse_force {
            // The last end force, evaluated at this node (an autonomous L).
            std::mem::swap(&mut self.f0, &mut self.f1);
        } else {
            lag.force(t, q, &mut self.f0);
        }
        // h M⁻¹(p_k + (c + (h/2) f_0)), c the carried compensation of p_k.
        for ((r, &cc), &fc) in self.row.iter_mut().zip(&self.pcomp).zip(&self.f0) {
            *r = cc + half * fc;
        }
        mass.solve(&self.row, &mut self.y);
        mass.solve(p, &mut self.drift);
        for (d, &s) in self.drift.iter_mut().zip(&self.y) {
            *d = h * (*d + s);
        }
        for l in 0..m {
            mass.solve(&start.jac[l * n..(l + 1) * n], &mut self.w[l * n..(l + 1) * n]);
        }
        extrapolate(u, &mut self.hist, (&mut self.known, &mut self.h_last), h);
        let fail = |failure, residual: f64, iterations| NewtonFailure {
            failure,
            residual,
            iterations,
        };
        let mut iterations = 0;
        let mut converged = false;
        loop {
            self.increment(u, dq);
            // The node the step commits (compensated summation): the constraints hold there.
            for (((y, &qc), &d), &cc) in self.y.iter_mut().zip(q).zip(dq.iter()).zip(comp) {
                *y = qc + (d + cc);
            }
            end.eval(con, &self.y, false);
            let rnorm = end.residual();
            if !rnorm.is_finite() || !end.jac.iter().all(|x| x.is_finite()) {
                return Err(fail(StepFailure::NonFinite, rnorm, iterations));
            }
            if converged || rnorm == 0.0 {
                return Ok(iterations);
            }
            // The check of the iterate: the correction the last matrix gives at it is within
            // the tolerance (after a Newton update from an extrapolated guess it is of the
            // order of the guess's error squared): the iterate is the solution, and its jet is
            // in hand.
            if iterations > 0 {
                self.mat.copy_from_slice(&self.last_mat);
                self.rhs.copy_from_slice(&end.g);
                if solve_small(&mut self.mat, &mut self.rhs, m) && moves_node(&self.rhs, &self.w, n) <= ROUNDOFF * scale
                {
                    return Ok(iterations);
                }
            }
            if iterations == max_iterations {
                return Err(fail(StepFailure::NotConverged, rnorm, iterations));
            }
            // G(y) W δ = g(y), u += δ.
            for i in 0..m {
                let gi = &end.jac[i * n..(i + 1) * n];
                for l in 0..m {
                    self.mat[i * m + l] = dot(gi, &self.w[l * n..(l + 1) * n]);
                }
            }
            self.last_mat.copy_from_slice(&self.mat);
            self.rhs.copy_from_slice(&end.g);
            if !solve_small(&mut self.mat, &mut self.rhs, m) {
                return Err(fail(StepFailure::Singular, rnorm, iterations + 1));
            }
            let dnorm = max_abs(&self.rhs);
            for (ul, dl) in u.iter_mut().zip(&self.rhs) {
                *ul += dl;
            }
            iterations += 1;
            converged = dnorm <= tol * scale;
        }
    }

    /// Δq = drift − W u.
    fn increment(&self, u: &[f64], dq: &mut [f64]) {
        let n = self.n;
        dq.copy_from_slice(&self.drift);
        for (l, &ul) in u.iter().enumerate() {
            for (d, &wa) in dq.iter_mut().zip(&self.w[l * n..(l + 1) * n]) {
                *d -= ul * wa;
            }
        }
    }

    /// The momentum increment after [`RattleStep::solve`] (the end force at the new node
    /// `y`): a = c + h Σ_i b_i f(c_i) − G(q_k)ᵀλ̂ (λ̂ = u/h), so that p̃ = p_k + a, with c the
    /// compensation that the last step's momentum sum left ([`RattleStep::project`]).
    pub fn momentum<L: Lagrangian>(
        &mut self,
        lag: &L,
        element: &Element,
        start: &ConstraintJet,
        (t, h): (f64, f64),
        lambda: &[f64],
    ) {
        lag.force(t + h, &self.y, &mut self.f1);
        let (b0, b1) = (element.rule.weights[0], element.rule.weights[1]);
        for ((d, &a), &b) in self.p_tilde.iter_mut().zip(&self.f0).zip(&self.f1) {
            *d = h * (b0 * a + b1 * b);
        }
        start.add_transpose_times(lambda, -1.0, &mut self.p_tilde);
        for (d, &c) in self.p_tilde.iter_mut().zip(&self.pcomp) {
            *d += c;
        }
    }

    /// The projection of p̃ = p_k + a ([`RattleStep::momentum`]) onto T*N at the node whose jet
    /// is `end`: (G M⁻¹ Gᵀ) μ̂ = G M⁻¹ p̃, p_{k+1} = p_k + (a − Gᵀμ̂) by compensated summation
    /// (into `p1`; the compensation is carried to the next step, as for q), v = M⁻¹p_{k+1}.
    /// Returns μ̂, or None if G M⁻¹ Gᵀ is singular.
    ///
    /// The momentum is summed with compensation because its rounding, ulp(p) per step, is
    /// what made the nodes drift from the RATTLE map evaluated exactly: a random walk of
    /// energy errors that the shear of the flow turns into a phase error growing like t^{3/2}.
    /// With it the nodes follow the double-double RATTLE map more closely than the dense path
    /// and the hand-written loop do (`tests/all/rattle_exact.rs`).
    pub fn project(
        &mut self,
        mass: &MassMatrix,
        end: &ConstraintJet,
        p: &[f64],
        p1: &mut [f64],
        v: &mut [f64],
    ) -> Option<&[f64]> {
        let (n, m) = (self.n, self.m);
        for l in 0..m {
            mass.solve(&end.jac[l * n..(l + 1) * n], &mut self.w1[l * n..(l + 1) * n]);
        }
        for i in 0..m {
            let gi = &end.jac[i * n..(i + 1) * n];
            for l in 0..m {
                self.mat[i * m + l] = dot(gi, &self.w1[l * n..(l + 1) * n]);
            }
            let wi = &self.w1[i * n..(i + 1) * n];
            self.rhs[i] = dot(wi, p) + dot(wi, &self.p_tilde);
        }
        if !solve_small(&mut self.mat, &mut self.rhs, m) {
            return None;
        }
        self.mu.copy_from_slice(&self.rhs);
        end.add_transpose_times(&self.mu, -1.0, &mut self.p_tilde);
        for c in 0..n {
            let y = self.p_tilde[c];
            let sum = p[c] + y;
            self.pcomp[c] = y - (sum - p[c]);
            p1[c] = sum;
        }
        mass.solve(p1, v);
        Some(&self.mu)
    }
}
