//! The step equations of a mechanical Lagrangian L = ½vᵀMv − V(t, q) by fixed-point iteration
//! on the forces: with Y_l = q(c_l) − q_k at the quadrature points and u = M⁻¹p_k, the
//! element's equations are the collocation-like system
//!   Y_l = h a_l u + h² Σ_i B_li M⁻¹f(t_k + c_i h, q_k + Y_i),
//! iterated until the stages stop changing (and polished to round-off), then
//! ΔQ^m = h α_m u + h² Σ_i β_mi M⁻¹f_i and Δp = h Σ_i b_i f_i. The tables a, B, α, β are the
//! element's, exact in double-double (step/fixed_point.rs); the start interpolates the last
//! step's forces (step/start.rs).

use super::checkpoint::{Reader, Words};
use super::fixed_point::{affine, FixedPointTables, StepTables};
use super::fixed_point_judge::{Judge, Verdict};
use super::guess::Guess;
use super::solver::StepContext;
use super::start::StageStart;
use super::state::{Increments, LastElement, RunState};
use crate::discrete::Element;
use crate::error::{Error, Result, StepError};
use crate::lagrangian::{Lagrangian, MassMatrix};

/// nodes and one predicted force, interpolated in time (step/start.rs), when the rule has at
/// most this many points and the step changed by at most 2×; otherwise from the last element's
/// polynomial. The interpolation reaches one step ahead, and its Lebesgue constant grows
/// quickly with the number of points: on P3 (pendulum) degrees 9, 10 and 12 still converged
/// in fewer sweeps with it (at h = 1.5: 6.99, 6.85, 6.55 against 8.03, 7.77, 7.49 from the
/// polynomial), beyond that it was not measured. History: extrapolating the r stage forces of
/// the last step alone left a starting error of 2e-4 … 1e-3 on P3 at h = 0.5 (degree 6), the
/// interpolation 1e-7 … 2e-6 there (5e-4 … 3e-3 at h = 1.25); two steps of stage forces (2r
/// points) were no better than one.
pub(crate) const START_MAX_POINTS: usize = 12;

/// Step-scaled tables kept by the fixed-point solver (see `Integrator::step_tables`).
/// Measured on P3 (degree 8) with steps cycling through 0.45/0.55: 1.35 µs per step when they
/// were rebuilt every step, against 0.61 µs on the uniform grid.
const CACHED_STEPS: usize = 4;

/// The fixed-point start uses the extra force evaluations (step/start.rs) only for rules of at
/// least `RICH_START_POINTS` points and after a step that needed more than
/// `RICH_START_SWEEPS` sweeps: they cost one or two evaluations where a sweep costs r, and
/// where the stage forces alone already start near round-off (small steps of smooth problems)
/// they save little. Measured on Kepler at 1000 steps per period (10⁶ steps): degrees 2 and 3
/// took 0.185 and 0.190 s with them in every step against 0.150 and 0.170 s without; degree 4
/// 0.186 s against 0.203 s.
const RICH_START_SWEEPS: usize = 2;
/// See [`RICH_START_SWEEPS`].
pub(crate) const RICH_START_POINTS: usize = 4;

/// The fixed-point polish stops once a sweep changes the stages by at most this many units of
/// round-off (relative to the largest stage or coordinate). Four units were tried: 0.2–0.4
/// fewer sweeps per step on P3 (3–5 % less time), but on P1 the median final error over 21
/// step sizes (degree 8, 100–300 steps per period, with `COEFFICIENT_ROUNDING`) went from
/// 1.0e-10 to 1.8e-10: a start already within a few units stops the iteration after its first
/// sweep, and the start's error, a smooth function of the state, has a sign.
pub(crate) const ROUNDOFF_ULPS: f64 = 1.0;

/// With the polish on, the update's h-scaled coefficients (h α, h² β, h b: ΔQ and Δp from the
/// stage forces) enter as f64 value plus rounding error, the errors applied as a second, small
/// sum. Their plain rounding perturbs the method by a fixed relative ε for the whole run: the
/// perturbed method is not symplectic, and the energy drifts linearly. Measured on P1 (Kepler,
/// degree 8, 21 step sizes from 100 to 300 per period, 1000 periods): median final position
/// error 3.5e-10 without, 0.9e-10 with; median |ΔE/E| at the end 3.8e-14 against 1.5e-14;
/// 3 against 11 of the 21 runs below 1e-10. The same for the stage coefficients (h a, h² B,
/// in every sweep) changed nothing measurable (median 1.0e-10) and cost 20–30 % of P3's time;
/// they are correctly rounded from their exact products instead (rounding h² first and then
/// h²·B, as before, gave a median of 2.5e-10). (A correctly rounded Kepler force changed
/// nothing either: the force's own rounding is not what drifts.)
pub(crate) const COEFFICIENT_ROUNDING: bool = true;

/// The fixed-point solver's tables, caches and workspace.
#[derive(Debug, Clone)]
pub(crate) struct FixedPointStep {
    tab: FixedPointTables,
    guess: Guess,
    /// u = M⁻¹p_k.
    u: Vec<f64>,
    tmp: Vec<f64>,
    ftmp: Vec<f64>,
    /// Stage displacements Y_l, row-major r×n.
    y: Vec<f64>,
    /// Stage forces f_l and M⁻¹f_l, row-major r×n.
    force: Vec<f64>,
    wforce: Vec<f64>,
    /// The positions q_k + Y_l at the quadrature points.
    stage_q: Vec<f64>,
    /// The node increments' second, small sum (exact coefficients).
    incr_lo: Vec<f64>,
    /// Starting values of the stages from the last accepted step (its stage forces M⁻¹f
    /// live in `stage_start.data`), and whether they are valid.
    stage_start: StageStart,
    have_last_w: bool,
    /// Sweeps of the last step (chooses the starting procedure).
    last_sweeps: usize,
    /// The element's tables scaled by the last few distinct steps (a cycle of up to
    /// `CACHED_STEPS` steps builds them once), the entry of the current step and the one to
    /// be replaced next; and the stage times of the current step.
    step_tables: Vec<StepTables>,
    cur_tables: usize,
    next_tables: usize,
    stage_t: Vec<f64>,
}

impl FixedPointStep {
    /// Tables and workspace for `element` in dimension n.
    ///
    /// Errors: an element whose fixed-point tables do not exist (singular node matrix).
    pub(crate) fn new(element: &Element, n: usize) -> Result<Self> {
        let (s, r) = (element.degree(), element.points());
        Ok(Self {
            tab: FixedPointTables::new(element)?,
            guess: Guess::new(s, n),
            u: vec![0.0; n],
            tmp: vec![0.0; n],
            ftmp: vec![0.0; n],
            y: vec![0.0; r * n],
            force: vec![0.0; r * n],
            wforce: vec![0.0; r * n],
            stage_q: vec![0.0; r * n],
            incr_lo: vec![0.0; s * n],
            stage_start: StageStart::new(element, n),
            have_last_w: false,
            last_sweeps: usize::MAX,
            step_tables: (0..CACHED_STEPS).map(|_| StepTables::new(s, r)).collect(),
            cur_tables: 0,
            next_tables: 0,
            stage_t: vec![0.0; r],
        })
    }

    /// Solves the step from the current node with step h into `out`; returns the sweeps.
    pub(crate) fn solve<L: Lagrangian>(
        &mut self,
        cx: &StepContext<'_, L>,
        state: &RunState,
        last: &LastElement,
        h: f64,
        out: &mut Increments,
    ) -> Result<usize> {
        let element = cx.element;
        let r = element.points();
        let rho = if self.have_last_w { h / last.h } else { f64::NAN };
        let force_guess = r <= START_MAX_POINTS && (0.5..=2.0).contains(&rho);
        if !force_guess {
            self.guess.predict(element, last, &state.v0, h);
        }
        let Some(mass) = cx.lag.mass_matrix() else {
            unreachable!("the solver is chosen for mechanical Lagrangians only")
        };
        mass.solve(&state.p, &mut self.u);
        self.select_tables(element, h);
        for (st, c) in self.stage_t.iter_mut().zip(&element.rule.nodes) {
            *st = state.t + c * h;
        }
        if force_guess {
            self.start_from_forces(cx, mass, state, last.h, h);
        } else {
            self.start_from_guess(element, state.n);
        }
        let iterations = self.iterate(cx, mass, state)?;
        self.last_sweeps = iterations;
        self.update(cx, mass.is_identity(), state.n, out);
        Ok(iterations)
    }

    /// Makes the tables for step h current: from the cache, or built into the oldest entry.
    #[inline]
    fn select_tables(&mut self, element: &Element, h: f64) {
        if self.step_tables[self.cur_tables].h_bits != h.to_bits() {
            match self.step_tables.iter().position(|t| t.h_bits == h.to_bits()) {
                Some(i) => self.cur_tables = i,
                None => {
                    let i = self.next_tables;
                    self.next_tables = (i + 1) % CACHED_STEPS;
                    self.step_tables[i].build(&self.tab, &element.rule.weights, h);
                    self.cur_tables = i;
                }
            }
        }
    }

    /// Starting stage values from the last step's stage forces and up to two more forces
    /// (step/start.rs).
    fn start_from_forces<L: Lagrangian>(
        &mut self,
        cx: &StepContext<'_, L>,
        mass: &MassMatrix,
        state: &RunState,
        last_h: f64,
        h: f64,
    ) {
        let (lag, element, n) = (cx.lag, cx.element, state.n);
        let identity = mass.is_identity();
        let r = element.points();
        let st = &self.step_tables[self.cur_tables];
        let (q, t, ftmp, tmp) = (&state.q, state.t, &mut self.ftmp, &mut self.tmp);
        self.stage_start.start(
            element,
            &self.tab,
            state.k,
            h,
            last_h,
            r >= RICH_START_POINTS && self.last_sweeps > RICH_START_SWEEPS,
            &st.ha,
            &self.u,
            &mut self.y,
            |theta, y, w| {
                for c in 0..n {
                    tmp[c] = q[c] + y[c];
                }
                if identity {
                    lag.force(t + theta * h, tmp, w);
                } else {
                    lag.force(t + theta * h, tmp, ftmp);
                    mass.solve(ftmp, w);
                }
            },
        );
    }

    /// Starting stage values from the predicted node increments.
    #[inline]
    fn start_from_guess(&mut self, element: &Element, n: usize) {
        let s = element.degree();
        for l in 0..element.points() {
            for c in 0..n {
                self.y[l * n + c] = (1..=s).map(|m| element.phi(l, m) * self.guess.x[(m - 1) * n + c]).sum();
            }
        }
    }

    /// Sweeps until the stages stop changing; returns the number of sweeps.
    fn iterate<L: Lagrangian>(
        &mut self,
        cx: &StepContext<'_, L>,
        mass: &MassMatrix,
        state: &RunState,
    ) -> Result<usize> {
        let (n, r) = (state.n, cx.element.points());
        let st = &self.step_tables[self.cur_tables];
        let qscale = state.qscale();
        let mut judge = Judge::new(&cx.opts);
        let mut iterations = 0;
        loop {
            iterations += 1;
            // The sweep with the dimension fixed at compile time for n ≤ 3 (inlined: through a
            // function pointer it measured 1.4× slower on the pendulum).
            macro_rules! sweep {
                ($N:literal) => {
                    fixed_point_sweep::<L, $N>(
                        cx.lag,
                        mass,
                        n,
                        &self.stage_t[..r],
                        &state.q,
                        &self.u,
                        &st.ha,
                        &st.h2b,
                        &mut self.y,
                        &mut self.force,
                        &mut self.wforce,
                        &mut self.stage_q,
                    )
                };
            }
            let (delta, ymax) = match n {
                1 => sweep!(1),
                2 => sweep!(2),
                3 => sweep!(3),
                _ => sweep!(0),
            };
            match judge.sweep(delta, ymax, qscale, iterations) {
                Verdict::Continue => {}
                Verdict::Converged => break,
                Verdict::Failed(failure) => {
                    return Err(Error::Step(StepError {
                        step: state.k,
                        t: state.t,
                        residual: delta,
                        iterations,
                        failure,
                    }))
                }
            }
        }
        Ok(iterations)
    }

    /// Node increments ΔQ^m = h α_m u + h² Σ_i β_mi w_i and the momentum increment
    /// h Σ_i b_i f_i from the last forces, with the coefficients' rounding errors as a second,
    /// small sum when polishing.
    fn update<L: Lagrangian>(&mut self, cx: &StepContext<'_, L>, identity: bool, n: usize, out: &mut Increments) {
        let (s, r) = (cx.element.degree(), cx.element.points());
        let exact = cx.opts.polish && COEFFICIENT_ROUNDING;
        let st = &self.step_tables[self.cur_tables];
        out.incr[..n].iter_mut().for_each(|x| *x = 0.0);
        let w: &[f64] = if identity {
            &self.force[..r * n]
        } else {
            &self.wforce[..r * n]
        };
        affine(s, n, &st.h_alpha, &self.u, &st.h2_beta, r, w, &mut out.incr[n..], false);
        if exact {
            let lo = &mut self.incr_lo[..s * n];
            affine(s, n, &st.h_alpha_lo, &self.u, &st.h2_beta_lo, r, w, lo, false);
            for (hi, lo) in out.incr[n..].iter_mut().zip(lo.iter()) {
                *hi += lo;
            }
        }
        out.dq.copy_from_slice(&out.incr[s * n..]);
        for c in 0..n {
            let mut hi = 0.0;
            for i in 0..r {
                hi += st.hw[i] * self.force[i * n + c];
            }
            if exact {
                let mut lo = 0.0;
                for i in 0..r {
                    lo += st.hw_lo[i] * self.force[i * n + c];
                }
                hi += lo;
            }
            out.dp[c] = hi;
        }
    }

    /// The data the next step's start depends on (checkpoints); tables and workspaces are
    /// recomputed from the step.
    pub(crate) fn save(&self, w: &mut Words) {
        w.b(self.have_last_w);
        w.u(self.last_sweeps);
        self.stage_start.save(w);
    }

    pub(crate) fn load(&mut self, r: &mut Reader<'_>) -> Result<()> {
        self.have_last_w = r.b()?;
        self.last_sweeps = r.u()?;
        self.stage_start.load(r)
    }

    /// The step was accepted: its stage forces (M⁻¹f) start the next step.
    #[inline]
    pub(crate) fn accepted(&mut self, identity: bool, r: usize, n: usize) {
        let w = if identity { &self.force } else { &self.wforce };
        self.stage_start.data[..r * n].copy_from_slice(&w[..r * n]);
        self.have_last_w = true;
    }
}

/// One sweep of the fixed-point map of the stage values: the forces at q + Y_l for all l in
/// one [`Lagrangian::forces`] call, then Y_l ← h a_l u + h² Σ_i B_li M⁻¹f_i in place by
/// [`affine`] (`h2b` column-major). Returns (max |ΔY|, max |Y|), NaN if a value is not
/// finite. `N` is the dimension when known at compile time (0: use `n`), which lets the
/// compiler unroll the component loops. (Measured and not kept: a Gauss–Seidel order, each
/// stage updated with the newest forces — no fewer sweeps on the pendulum, and slower. Kept:
/// the column-major sum with the stage count fixed at compile time, which vectorises — P3,
/// degree 8, h = 1: 11 500 → 9 800 instructions and 675 → 612 ns per step, best of 15
/// against the row-by-row sum with runtime sizes.)
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn fixed_point_sweep<L: Lagrangian, const N: usize>(
    lag: &L,
    mass: &crate::lagrangian::MassMatrix,
    n: usize,
    stage_t: &[f64],
    q: &[f64],
    u: &[f64],
    ha: &[f64],
    h2b: &[f64],
    y: &mut [f64],
    force: &mut [f64],
    wforce: &mut [f64],
    pos: &mut [f64],
) -> (f64, f64) {
    let n = if N > 0 { N } else { n };
    let r = stage_t.len();
    let rn = r * n;
    let (q, u) = (&q[..n], &u[..n]);
    let identity = mass.is_identity();
    for (pl, yl) in pos[..rn].chunks_exact_mut(n).zip(y.chunks_exact(n)) {
        for c in 0..n {
            pl[c] = q[c] + yl[c];
        }
    }
    lag.forces(stage_t, &pos[..rn], &mut force[..rn]);
    // M⁻¹ f: the forces themselves for unit masses (no copy).
    let w: &[f64] = if identity {
        &force[..rn]
    } else {
        for (fl, wl) in force.chunks_exact(n).zip(wforce.chunks_exact_mut(n)).take(r) {
            mass.solve(fl, wl);
        }
        &wforce[..rn]
    };
    let (delta, ymax, probe) = affine(r, n, ha, u, h2b, r, w, &mut y[..rn], true);
    if probe.is_nan() {
        return (f64::NAN, f64::NAN);
    }
    (delta, ymax)
}
