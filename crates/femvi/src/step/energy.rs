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

use super::checkpoint::{Reader, Words};
use super::element_work::buffers;
use super::energy_search::search_step;
use super::integrator::Integrator;
use super::solver::{Kind, Solver};
use super::term::ElementEnergies;
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
    /// The last step was taken with h as a parameter (tangent maps; not checkpointed: a
    /// restored run's last step counts as one that kept the energy).
    pub(super) last_fresh: bool,
    h_prev: f64,
    /// Compensation of the carried energy's sum of increments.
    comp: f64,
    stats: EnergyStats,
    /// The node's positions during a search (the element's base; no allocation per trial).
    scratch: Vec<f64>,
}

impl EnergyState {
    pub(super) fn options(&self) -> EnergyOptions {
        self.opts
    }

    /// The carried energy and the statistics (checkpoints).
    pub(super) fn save(&self, w: &mut Words) {
        w.b(self.started);
        w.f(self.h_prev);
        w.f(self.comp);
        let st = &self.stats;
        for x in [st.energy, st.min_step, st.max_step, st.max_rel_residual] {
            w.f(x);
        }
        w.u(st.degenerate_steps);
    }

    pub(super) fn load(&mut self, r: &mut Reader<'_>) -> Result<()> {
        self.started = r.b()?;
        self.h_prev = r.f()?;
        self.comp = r.f()?;
        let st = &mut self.stats;
        for x in [
            &mut st.energy,
            &mut st.min_step,
            &mut st.max_step,
            &mut st.max_rel_residual,
        ] {
            *x = r.f()?;
        }
        st.degenerate_steps = r.u()?;
        Ok(())
    }
}

/// Checks the step bounds of the energy mode against the first step h0.
///
/// # Errors
/// Bounds that are not finite and positive, or that do not hold h0.
pub(crate) fn check_bounds(h0: f64, energy: &EnergyOptions) -> Result<()> {
    let (lo, hi) = (energy.min_step, energy.max_step);
    if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= h0 && h0 <= hi) {
        return Err(invalid(
            "step bounds",
            format!("need 0 < min_step ({lo}) <= step ({h0}) <= max_step ({hi}), all finite"),
        ));
    }
    Ok(())
}

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
        check_bounds(grid.nominal(0), &energy)?;
        let mut me = Self::new(lag, element, grid, start, options)?;
        me.enable_energy(energy)?;
        Ok(me)
    }

    /// Turns the steps of a new run into variables of the energy equation (bounds checked by
    /// the caller with [`check_bounds`]): with a term, the term solves each trial step and
    /// gives the energies with its shares ([`StepTerm::energies`](super::term::StepTerm)).
    pub(crate) fn enable_energy(&mut self, energy: EnergyOptions) -> Result<()> {
        if self.term.is_none() && self.solver.kind() == Kind::Explicit {
            // Explicit stepping keeps state between steps; the search solves a step repeatedly.
            self.solver = Solver::new(Kind::FixedPoint, &self.element, self.state.n)?;
        }
        let mut state = EnergyState {
            opts: energy,
            started: false,
            last_fresh: false,
            h_prev: self.grid.nominal(0),
            comp: 0.0,
            scratch: Vec::new(),
            stats: EnergyStats {
                energy: f64::NAN,
                min_step: f64::INFINITY,
                max_step: 0.0,
                degenerate_steps: 0,
                max_rel_residual: 0.0,
            },
        };
        if self.pending.is_some() {
            // Start from (q0, q1): element 0 was solved in `new`; its E⁺ at t1 is the energy.
            let (t, h) = (self.last.t, self.last.h);
            let base = self.last.base.clone();
            self.inc.incr.copy_from_slice(&self.last.incr);
            let e = self.element_energies(t, h, &base);
            state.started = true;
            state.stats.energy = e.plus;
            state.stats.min_step = h;
            state.stats.max_step = h;
        }
        self.energy = Some(state);
        Ok(())
    }

    /// Statistics of the energy mode (None with steps as parameters).
    pub fn energy_stats(&self) -> Option<EnergyStats> {
        self.energy.as_ref().map(|e| e.stats)
    }

    /// E⁻, E⁺ (with the term's shares of the work, if any) and the magnitude of the energy
    /// terms of the element [t, t + h] whose increments are in `incr` (as left by a solve).
    fn element_energies(&mut self, t: f64, h: f64, base: &[f64]) -> ElementEnergies {
        if let Some(e) = self.term.as_mut().and_then(|term| term.energies(t, h, base)) {
            return e;
        }
        let autonomous = self.lag.is_autonomous();
        let n = self.state.n;
        let b = buffers(&mut self.bufs, &self.element, n);
        let (ework, grad) = (&mut b.ework, &mut b.grad);
        self.element
            .gradient_in_place(&*self.lag, t, h, base, &self.inc.incr, !autonomous, ework, grad);
        let (em, ep) = self.element.energies(h, ework);
        let mut mag = 0.0;
        for (i, pd) in ework.pts.iter().enumerate() {
            let vlv: f64 = ework.vc[i * n..(i + 1) * n]
                .iter()
                .zip(pd.l_v())
                .map(|(a, b)| (a * b).abs())
                .sum();
            mag += self.element.rule.weights[i] * (vlv + pd.value.abs());
        }
        ElementEnergies {
            minus: em,
            plus: ep,
            magnitude: mag.max(em.abs()).max(f64::MIN_POSITIVE),
            ..ElementEnergies::default()
        }
    }

    /// (g, E⁺ − E⁻, magnitude) with g(h) = E⁻ − target after solving at h; None if the solve
    /// fails at that trial step.
    fn energy_gap(&mut self, h: f64, target: f64) -> Option<(f64, f64, f64)> {
        self.solve_at(h).ok()?;
        let mut base = self
            .energy
            .as_mut()
            .map(|e| std::mem::take(&mut e.scratch))
            .unwrap_or_default();
        base.clear();
        base.extend_from_slice(&self.state.q);
        let e = self.element_energies(self.state.t, h, &base);
        if let Some(state) = self.energy.as_mut() {
            state.scratch = base;
        }
        // Without a term the shares are zero and these are E⁻ − E_k and E⁺ − E⁻ exactly.
        let g = (e.minus - e.w_minus) - target;
        g.is_finite().then_some((g, (e.plus - e.minus) + e.work, e.magnitude))
    }

    pub(super) fn step_energy(&mut self) -> Result<bool> {
        if self.state.t >= self.grid.end() {
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
            let base = self.state.q.clone();
            let e = self.element_energies(self.state.t, h_prev, &base);
            (h_prev, e.plus + e.w_plus, 0.0, false, true)
        } else {
            match self.search_step(h_prev, target, opts) {
                Ok((h, change, rel)) => (h, change, rel, false, false),
                Err(fail)
                    if opts.on_degenerate == Degenerate::Fixed && fail.failure == StepFailure::NoAdmissibleStep =>
                {
                    // Time as a parameter for this step: the element's E⁺ starts a new level.
                    let h = h_prev.clamp(opts.min_step, opts.max_step);
                    self.solve_at(h)?;
                    let base = self.state.q.clone();
                    let e = self.element_energies(self.state.t, h, &base);
                    (h, e.plus + e.w_plus, 0.0, true, true)
                }
                Err(fail) => return Err(Error::Step(fail)),
            }
        };
        let t_next = self.state.t + h;
        self.commit(h, t_next)?;
        let Some(state) = self.energy.as_mut() else {
            unreachable!("energy mode")
        };
        state.started = true;
        state.h_prev = h;
        state.last_fresh = fresh;
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

    /// Finds h in the bounds with E⁻(w_k(h)) = target ([`search_step`]); leaves the solve at
    /// that h in place. Returns (h, E⁺ − E⁻ of the element, relative residual).
    fn search_step(
        &mut self,
        h_prev: f64,
        target: f64,
        opts: EnergyOptions,
    ) -> std::result::Result<(f64, f64, f64), StepError> {
        let (k, t) = (self.state.k, self.state.t);
        search_step(h_prev, target, opts, (k, t), |h| self.energy_gap(h, target))
    }
}
