//! Time steps as variables (paper §3): each step solves the fixed-step equations of
//! (3.2)/(2.40)–(2.42) together with the discrete energy equation (3.3),
//! E_k⁻(w_k) = E_k, where E_k = E_k⁺(w_{k−1}) is carried from the previous element
//! (DESIGN.md §1 signs). For autonomous L, E_k⁻ = E_{k+1}⁺ and the discrete energy is conserved
//! to solver precision; otherwise it evolves by (3.3), the discrete (1.9).
//!
//! The step h_k is found by a one-dimensional search on g(h) = E_k⁻(w_k(h)) − E_k, where
//! w_k(h) solves the ordinary step equations at that h (the same solvers as fixed steps):
//! secant iterations from h_{k−1}, switching to regula falsi (Illinois) once a sign change
//! brackets the root, with h kept in [min_step, max_step]. Positivity by construction
//! excludes the spurious time-reversed root h_k = −h_{k−1} (ERRATA.md). Where the discrete
//! energy is insensitive to h (c₂ ≈ 0) or has no root in the bounds, the step is degenerate:
//! a typed error, or (on request) one step with h as a parameter, counted.

use super::{Integrator, Resolved};
use crate::error::{invalid, Error, Result, StepError, StepFailure};
use crate::lagrangian::Lagrangian;

/// What to do at a step whose energy equation has no admissible root.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Degenerate {
    /// Stop with [`StepFailure::NoAdmissibleStep`].
    Error,
    /// Take that step with the previous step size as a parameter, and count it.
    Fixed,
}

/// Bounds and policy of the energy-preserving mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyOptions {
    /// Smallest admissible step.
    pub min_step: f64,
    /// Largest admissible step.
    pub max_step: f64,
    /// Degeneracy policy.
    pub on_degenerate: Degenerate,
}

impl EnergyOptions {
    /// Defaults derived from the first step h: steps in [h/1000, 10 h], degenerate steps are errors.
    pub fn from_step(h: f64) -> Self {
        Self {
            min_step: h * 1e-3,
            max_step: h * 10.0,
            on_degenerate: Degenerate::Error,
        }
    }
}

/// Statistics of a run in energy mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyStats {
    /// The discrete energy E_k carried at the current node.
    pub energy: f64,
    /// Smallest step taken so far.
    pub min_step: f64,
    /// Largest step taken so far.
    pub max_step: f64,
    /// Steps taken with h as a parameter because the energy equation was degenerate.
    pub degenerate_steps: usize,
    /// Largest |E_k⁻(w_k) − E_k| / |E_k| of the energy equations solved (the (3.3) residual).
    pub max_rel_residual: f64,
}

#[derive(Debug, Clone)]
pub(super) struct EnergyState {
    opts: EnergyOptions,
    started: bool,
    h_prev: f64,
    /// Compensation of the carried energy's sum of increments.
    comp: f64,
    stats: EnergyStats,
}

/// Relative size of |g| at which the search stops; the residual left is at round-off level.
const ACCEPT: f64 = 0.25 * f64::EPSILON;
/// Relative size of |g| above which a step counts as having no admissible root. For degree
/// s the discrete energy depends on h only at O(h^{2s}), so for s ≥ 3 g is nearly flat and
/// its round-off noise hides the root: such steps are degenerate, not accepted loosely.
const REJECT: f64 = 64.0 * f64::EPSILON;

impl<'a, L: Lagrangian> Integrator<'a, L> {
    /// Sets up a run with time steps as variables. The grid gives t0, the first step (taken
    /// with h as a parameter, which fixes the discrete energy, unless the start is from
    /// (q0, q1), whose first element fixes it) and the end: the run stops at the first node
    /// at or past it.
    ///
    /// # Errors
    /// As [`Integrator::new`], and invalid step bounds.
    pub fn with_energy(
        lag: &'a L,
        element: &'a crate::Element,
        grid: crate::TimeGrid,
        start: super::Start,
        options: super::SolverOptions,
        energy: EnergyOptions,
    ) -> Result<Self> {
        let h0 = grid.nominal(0);
        let (lo, hi) = (energy.min_step, energy.max_step);
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= h0 && h0 <= hi) {
            return Err(invalid(
                "step bounds",
                format!("need 0 < min_step ({lo}) <= step ({h0}) <= max_step ({hi}), all finite"),
            ));
        }
        let mut me = Self::new(lag, element, grid, start, options)?;
        if me.method == Resolved::Explicit {
            // Explicit stepping keeps state between steps; the search solves a step repeatedly.
            me.method = Resolved::FixedPoint;
            me.fp = Some(super::FixedPointTables::new(element)?);
        }
        let mut state = EnergyState {
            opts: energy,
            started: false,
            h_prev: h0,
            comp: 0.0,
            stats: EnergyStats {
                energy: f64::NAN,
                min_step: f64::INFINITY,
                max_step: 0.0,
                degenerate_steps: 0,
                max_rel_residual: 0.0,
            },
        };
        if me.pending.is_some() {
            // Start from (q0, q1): element 0 was solved in `new`; its E⁺ at t1 is the energy.
            let (t, h) = (me.last_t, me.last_h);
            let base = me.last_base.clone();
            me.incr.copy_from_slice(&me.last_incr);
            let (_, e_plus, _) = me.element_energies(t, h, &base);
            state.started = true;
            state.stats.energy = e_plus;
            state.stats.min_step = h;
            state.stats.max_step = h;
        }
        me.energy = Some(state);
        Ok(me)
    }

    /// The tangent map of the last energy-mode step on extended phase space, in the canonical
    /// variables (q, t; p, −E) (row-major, 2(n+1) square, ordered q_1 … q_n, t, p_1 … p_n, −E).
    /// The step equations R_j = δ_j0 p_k + ∂L_d/∂Q^j (j < s) and R_E = ∂L_d/∂t_k − E_k are
    /// differentiated implicitly for (dX, dt_{k+1}), with the full Hessian F of L_d in
    /// (t_k, t_{k+1}, Q); then q' = q_k + X^s, t' = t_{k+1}, p' = ∂L_d/∂Q^s, E' = −∂L_d/∂t_{k+1}.
    /// The paper's (3.6) says this map preserves dq∧dp − dt∧dE.
    ///
    /// # Errors
    /// Not in energy mode, no variable step taken yet, or a singular system.
    pub fn extended_tangent_map(&mut self) -> Result<Vec<f64>> {
        if self.energy.is_none() || !self.have_last {
            return Err(invalid("extended tangent map", "needs a step taken in energy mode"));
        }
        let n = self.n;
        let s = self.element.degree();
        let (t0, h) = (self.last_t, self.last_h);
        let (_, _, f) = self
            .element
            .full_hessian(self.lag, t0, h, &self.last_base, &self.last_incr);
        let m = 2 + (s + 1) * n;
        let fz = |a: usize, b: usize| f[a * m + b];
        // Indices into z: τ0 = 0, τ1 = 1, Q^j component c = 2 + j n + c.
        let qi = |j: usize, c: usize| 2 + j * n + c;
        let dim = s * n + 1;
        // Unknowns: dX^m (m = 1..=s), then dt_{k+1}. Rows: R_j (j < s), then R_E.
        let jac = nalgebra::DMatrix::from_fn(dim, dim, |row, col| {
            let rz = if row < s * n { qi(row / n, row % n) } else { 0 };
            if col < s * n {
                fz(rz, qi(col / n + 1, col % n))
            } else {
                fz(rz, 1)
            }
        });
        let lu = jac.lu();
        let d = 2 * (n + 1);
        let mut out = vec![0.0; d * d];
        // Inputs in the order (q_1..q_n, t, p_1..p_n, −E).
        for col in 0..d {
            let dq = |c: usize| if col < n && c == col { 1.0 } else { 0.0 };
            let dt0 = if col == n { 1.0 } else { 0.0 };
            let dp = |c: usize| {
                if col > n && col < 2 * n + 1 && c == col - n - 1 {
                    1.0
                } else {
                    0.0
                }
            };
            let de = if col == 2 * n + 1 { -1.0 } else { 0.0 }; // the variable is −E
                                                                // dQ^j = dq + dX^j contributes Σ_m F_{r,Q^m} dq through all nodes (translation).
            let translation = |rz: usize| {
                (0..=s)
                    .map(|j| (0..n).map(|c| fz(rz, qi(j, c)) * dq(c)).sum::<f64>())
                    .sum::<f64>()
            };
            let mut rhs = nalgebra::DVector::zeros(dim);
            for row in 0..dim {
                let rz = if row < s * n { qi(row / n, row % n) } else { 0 };
                let mut r = translation(rz) + fz(rz, 0) * dt0;
                if row < n {
                    r += dp(row);
                }
                if row == s * n {
                    r -= de;
                }
                rhs[row] = -r;
            }
            let sol = lu.solve(&rhs).ok_or_else(|| {
                Error::Step(StepError {
                    step: self.k.saturating_sub(1),
                    t: t0,
                    residual: f64::NAN,
                    iterations: 0,
                    failure: StepFailure::Singular,
                })
            })?;
            let dx = |j: usize, c: usize| if j == 0 { 0.0 } else { sol[(j - 1) * n + c] };
            let dt1 = sol[s * n];
            // Differential of ∂L_d/∂z_r along the solution.
            let along = |rz: usize| {
                let mut acc = fz(rz, 0) * dt0 + fz(rz, 1) * dt1;
                for j in 0..=s {
                    for c in 0..n {
                        acc += fz(rz, qi(j, c)) * (dq(c) + dx(j, c));
                    }
                }
                acc
            };
            for c in 0..n {
                out[c * d + col] = dq(c) + dx(s, c);
                out[(n + 1 + c) * d + col] = along(qi(s, c));
            }
            out[n * d + col] = dt1;
            // E' = −∂L_d/∂t_{k+1}; the variable is −E' = ∂L_d/∂t_{k+1}.
            out[(2 * n + 1) * d + col] = along(1);
        }
        Ok(out)
    }

    /// Statistics of the energy mode (None with steps as parameters).
    pub fn energy_stats(&self) -> Option<EnergyStats> {
        self.energy.as_ref().map(|e| e.stats)
    }

    /// (E⁻, E⁺, magnitude of the energy terms) of the element [t, t + h] whose increments are
    /// in `incr` (as left by a solve).
    fn element_energies(&mut self, t: f64, h: f64, base: &[f64]) -> (f64, f64, f64) {
        let autonomous = self.lag.is_autonomous();
        self.element.gradient_in_place(
            self.lag,
            t,
            h,
            base,
            &self.incr,
            !autonomous,
            &mut self.ework,
            &mut self.grad,
        );
        let (em, ep) = self.element.energies(h, &self.ework);
        let n = self.n;
        let mut mag = 0.0;
        for (i, pd) in self.ework.pts.iter().enumerate() {
            let vlv: f64 = self.ework.vc[i * n..(i + 1) * n]
                .iter()
                .zip(pd.l_v())
                .map(|(a, b)| (a * b).abs())
                .sum();
            mag += self.element.rule.weights[i] * (vlv + pd.value.abs());
        }
        (em, ep, mag.max(em.abs()).max(f64::MIN_POSITIVE))
    }

    /// (g, E⁺ − E⁻, magnitude) with g(h) = E⁻ − target after solving at h; None if the solve
    /// fails at that trial step.
    fn energy_gap(&mut self, h: f64, target: f64) -> Option<(f64, f64, f64)> {
        self.solve_at(h).ok()?;
        let base = std::mem::take(&mut self.tmp);
        let mut base = base;
        base.copy_from_slice(&self.q);
        let (em, ep, mag) = self.element_energies(self.t, h, &base);
        self.tmp = base;
        let g = em - target;
        g.is_finite().then_some((g, ep - em, mag))
    }

    pub(super) fn step_energy(&mut self) -> Result<bool> {
        if self.t >= self.grid.end() {
            return Ok(false);
        }
        let Some(state) = self.energy.as_ref() else {
            unreachable!("energy mode")
        };
        let (started, h_prev, opts, target) = (state.started, state.h_prev, state.opts, state.stats.energy);
        // The carried energy changes only by the element's physical change E⁺ − E⁻ (zero for
        // autonomous L, the discrete (1.9) otherwise), summed with compensation, so that the
        // solver residuals of the energy equations do not accumulate.
        let (h, change, residual, degenerate, fresh) = if !started {
            // The first element with its step as a parameter fixes the discrete energy.
            self.solve_at(h_prev)?;
            let base = self.q.clone();
            let (_, ep, _) = self.element_energies(self.t, h_prev, &base);
            (h_prev, ep, 0.0, false, true)
        } else {
            match self.search_step(h_prev, target, opts) {
                Ok((h, change, rel)) => (h, change, rel, false, false),
                Err(fail)
                    if opts.on_degenerate == Degenerate::Fixed && fail.failure == StepFailure::NoAdmissibleStep =>
                {
                    // Time as a parameter for this step: the element's E⁺ starts a new level.
                    let h = h_prev.clamp(opts.min_step, opts.max_step);
                    self.solve_at(h)?;
                    let base = self.q.clone();
                    let (_, ep, _) = self.element_energies(self.t, h, &base);
                    (h, ep, 0.0, true, true)
                }
                Err(fail) => return Err(Error::Step(fail)),
            }
        };
        let t_next = self.t + h;
        self.commit(h, t_next)?;
        let Some(state) = self.energy.as_mut() else {
            unreachable!("energy mode")
        };
        state.started = true;
        state.h_prev = h;
        if fresh {
            state.stats.energy = change;
            state.comp = 0.0;
        } else {
            let y = change + state.comp;
            let e = state.stats.energy + y;
            state.comp = (state.stats.energy - e) + y;
            state.stats.energy = e;
        }
        state.stats.min_step = state.stats.min_step.min(h);
        state.stats.max_step = state.stats.max_step.max(h);
        state.stats.max_rel_residual = state.stats.max_rel_residual.max(residual);
        if degenerate {
            state.stats.degenerate_steps += 1;
        }
        Ok(true)
    }

    /// Finds h in the bounds with E⁻(w_k(h)) = target; leaves the solve at that h in place.
    /// Returns (h, E⁺ − E⁻ of the element, relative residual).
    fn search_step(
        &mut self,
        h_prev: f64,
        target: f64,
        opts: EnergyOptions,
    ) -> std::result::Result<(f64, f64, f64), StepError> {
        let (lo, hi) = (opts.min_step, opts.max_step);
        let fail = |me: &Self, residual: f64, iterations: usize| StepError {
            step: me.k,
            t: me.t,
            residual,
            iterations,
            failure: StepFailure::NoAdmissibleStep,
        };
        let mut evals = 0;
        // First point: the previous step.
        let mut h0 = h_prev.clamp(lo, hi);
        let Some((mut g0, e0, mag)) = self.energy_gap(h0, target) else {
            return Err(fail(self, f64::NAN, 1));
        };
        evals += 1;
        let tol = ACCEPT * mag;
        let scale = target.abs().max(f64::MIN_POSITIVE);
        if g0.abs() <= tol {
            return Ok((h0, e0, g0.abs() / scale));
        }
        let mut h1 = if h0 * 1.001 <= hi { h0 * 1.001 } else { h0 * 0.999 };
        let (mut g1, mut e1) = match self.energy_gap(h1, target) {
            Some((g, e, _)) => (g, e),
            None => return Err(fail(self, g0.abs() / scale, 2)),
        };
        evals += 1;
        // Secant phase, trust region [h/2, 2h], until a sign change or convergence.
        while g0.signum() == g1.signum() {
            if g1.abs() <= tol {
                return Ok((h1, e1, g1.abs() / scale));
            }
            let slope = (g1 - g0) / (h1 - h0);
            let mut h2 = if slope != 0.0 && slope.is_finite() {
                h1 - g1 / slope
            } else {
                f64::NAN
            };
            if !h2.is_finite() {
                // Flat: the energy does not depend on h here (c₂ ≈ 0).
                h2 = if g1.abs() < g0.abs() {
                    2.0 * h1 - h0
                } else {
                    2.0 * h0 - h1
                };
            }
            h2 = h2.clamp(0.5 * h1, 2.0 * h1).clamp(lo, hi);
            if (h2 - h1).abs() <= 4.0 * f64::EPSILON * h1 || evals >= 60 {
                // Stuck at a bound or no progress: accept only a round-off-level residual.
                return if g1.abs() <= REJECT * mag {
                    Ok((h1, e1, g1.abs() / scale))
                } else {
                    Err(fail(self, g1.abs() / scale, evals))
                };
            }
            let Some((g2, e2, _)) = self.energy_gap(h2, target) else {
                return Err(fail(self, g1.abs() / scale, evals));
            };
            evals += 1;
            (h0, g0) = (h1, g1);
            (h1, g1, e1) = (h2, g2, e2);
        }
        // Bracketed between h0 and h1: Illinois regula falsi.
        let (mut ha, mut ga, mut hb, mut gb) = (h0, g0, h1, g1);
        let (mut best_h, mut best_g) = if g0.abs() < g1.abs() { (h0, g0) } else { (h1, g1) };
        while evals < 100 && (hb - ha).abs() > 4.0 * f64::EPSILON * hb.abs().max(ha.abs()) {
            let mut hc = (ha * gb - hb * ga) / (gb - ga);
            if !hc.is_finite() || hc <= ha.min(hb) || hc >= ha.max(hb) {
                hc = 0.5 * (ha + hb);
            }
            let Some((gc, _, _)) = self.energy_gap(hc, target) else {
                return Err(fail(self, best_g.abs() / scale, evals));
            };
            evals += 1;
            if gc.abs() < best_g.abs() {
                (best_h, best_g) = (hc, gc);
            }
            if gc.abs() <= tol {
                break;
            }
            if gc.signum() != gb.signum() {
                (ha, ga) = (hb, gb);
            } else {
                ga *= 0.5;
            }
            (hb, gb) = (hc, gc);
        }
        if best_g.abs() > REJECT * mag {
            return Err(fail(self, best_g.abs() / scale, evals));
        }
        // Leave the state solved at the chosen step.
        let Some((g, e, _)) = self.energy_gap(best_h, target) else {
            return Err(fail(self, best_g.abs() / scale, evals));
        };
        Ok((best_h, e, g.abs() / scale))
    }
}
