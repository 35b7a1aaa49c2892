//! The integrator with time steps as parameters: state, start-up, and the three solvers of
//! the step equations — Newton (any Lagrangian, derivatives by automatic differentiation),
//! fixed-point iteration on forces (mechanical Lagrangians), and explicit stepping (degree 1
//! with the trapezoid rule, which is Störmer–Verlet). Positions and momenta are advanced by
//! increments with compensated summation, so round-off grows like √steps.

use super::fixed_point::{affine, FixedPointTables, StepTables};
use super::grid::TimeGrid;
use super::start::StageStart;
use crate::discrete::{Element, ElementWork};
use crate::error::{check_len, invalid, Error, Result, StepError, StepFailure};
use crate::fem::QuadratureKind;
use crate::lagrangian::{check_regular, velocity_from_momentum, Lagrangian, PointDerivatives};
use crate::solve::{newton_dense, DenseNewtonWork, NewtonFailure};

#[path = "energy.rs"]
mod energy;
use energy::EnergyState;
pub use energy::{Degenerate, EnergyOptions, EnergyStats};

/// Which solver takes the step equations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Explicit for degree 1 with the trapezoid rule on a mechanical Lagrangian, fixed-point
    /// iteration for other mechanical Lagrangians, Newton otherwise.
    Auto,
    /// Newton's method with a line search.
    Newton,
    /// Fixed-point iteration on the forces (mechanical Lagrangians only).
    FixedPoint,
    /// Explicit stepping (degree 1, trapezoid rule, mechanical Lagrangians only).
    Explicit,
}

/// The fixed-point solver starts from the last step's stage forces, the forces at the last two
/// nodes and one predicted force, interpolated in time (step/start.rs), when the rule has at
/// most this many points and the step changed by at most 2×; otherwise from the last element's
/// polynomial. The interpolation reaches one step ahead, and its Lebesgue constant grows
/// quickly with the number of points: on P3 (pendulum) degrees 9, 10 and 12 still converged
/// in fewer sweeps with it (at h = 1.5: 6.99, 6.85, 6.55 against 8.03, 7.77, 7.49 from the
/// polynomial), beyond that it was not measured. History: extrapolating the r stage forces of
/// the last step alone left a starting error of 2e-4 … 1e-3 on P3 at h = 0.5 (degree 6), the
/// interpolation 1e-7 … 2e-6 there (5e-4 … 3e-3 at h = 1.25); two steps of stage forces (2r
/// points) were no better than one.
const START_MAX_POINTS: usize = 12;

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
const RICH_START_POINTS: usize = 4;

/// The fixed-point polish stops once a sweep changes the stages by at most this many units of
/// round-off (relative to the largest stage or coordinate). Four units were tried: 0.2–0.4
/// fewer sweeps per step on P3 (3–5 % less time), but on P1 the median final error over 21
/// step sizes (degree 8, 100–300 steps per period, with `COEFFICIENT_ROUNDING`) went from
/// 1.0e-10 to 1.8e-10: a start already within a few units stops the iteration after its first
/// sweep, and the start's error, a smooth function of the state, has a sign.
const ROUNDOFF_ULPS: f64 = 1.0;

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
const COEFFICIENT_ROUNDING: bool = true;

/// Tolerance, iteration cap and method of the step solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverOptions {
    /// Relative tolerance on the increments of the unknowns (relative to max |q|).
    pub tolerance: f64,
    /// Iteration cap per step.
    pub max_iterations: usize,
    /// The solver.
    pub method: Method,
    /// Fixed-point iteration only: once the tolerance is met, iterate on while the increments
    /// still decrease (at most three more sweeps) until the stages are correct to round-off.
    /// The error a truncated iteration leaves has the same sign every step, so without the
    /// polish it accumulates like a drift of about h·|∂f/∂q|·tolerance·max|q| per step; with
    /// it, only round-off remains. Off, the solver stops at the tolerance: fewer force
    /// evaluations (P3 with degree 6 at h = 1.25 and tolerance 1e-10: 4.6 sweeps per step
    /// against 7.1) for problems whose accuracy target is far above round-off.
    /// Default: true.
    pub polish: bool,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-14,
            max_iterations: 50,
            method: Method::Auto,
            polish: true,
        }
    }
}

impl SolverOptions {
    /// Checks the options.
    ///
    /// # Errors
    /// A tolerance that is not positive and finite, or a zero iteration cap.
    pub fn validate(&self) -> Result<()> {
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(invalid(
                "solver tolerance",
                format!("{} is not a positive finite number", self.tolerance),
            ));
        }
        if self.max_iterations == 0 {
            return Err(invalid("solver max_iterations", "must be at least 1"));
        }
        Ok(())
    }
}

/// Initial data of a run.
#[derive(Debug, Clone, PartialEq)]
pub enum Start {
    /// q0 and the velocity v0; p0 = ∂L/∂v(t0, q0, v0).
    Velocity {
        /// Position q0.
        q: Vec<f64>,
        /// Velocity v0.
        v: Vec<f64>,
    },
    /// q0 and the momentum p0.
    Momentum {
        /// Position q0.
        q: Vec<f64>,
        /// Momentum p0.
        p: Vec<f64>,
    },
    /// The paper's start from (q0, q1), q1 at the first grid node t1.
    Positions {
        /// Position q0.
        q0: Vec<f64>,
        /// Position q1.
        q1: Vec<f64>,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Resolved {
    Newton,
    FixedPoint,
    Explicit,
}

/// A node of the discrete trajectory.
#[derive(Debug, Clone, Copy)]
pub struct Node<'s> {
    /// Node index k.
    pub k: usize,
    /// Time t_k.
    pub t: f64,
    /// Position q_k.
    pub q: &'s [f64],
    /// Momentum p_k (the discrete Legendre transform).
    pub p: &'s [f64],
}

/// The last element the integrator solved: [t, t + h] with nodal values q + incr_j.
#[derive(Debug, Clone, Copy)]
pub struct ElementNodes<'s> {
    /// Start time t_k.
    pub t: f64,
    /// Step h_k.
    pub h: f64,
    /// q_k.
    pub base: &'s [f64],
    /// Nodal increments Q^j − q_k, j = 0 … s, row-major (s+1)×n.
    pub incr: &'s [f64],
}

/// Integrates the discrete Euler–Lagrange equations of an element over a time grid.
pub struct Integrator<'a, L: Lagrangian> {
    lag: &'a L,
    element: &'a Element,
    grid: TimeGrid,
    opts: SolverOptions,
    method: Resolved,
    n: usize,
    k: usize,
    t: f64,
    q: Vec<f64>,
    p: Vec<f64>,
    comp_q: Vec<f64>,
    comp_p: Vec<f64>,
    /// Velocity at the start, for the first guess.
    v0: Vec<f64>,
    pending: Option<(f64, Vec<f64>, Vec<f64>)>,
    have_last: bool,
    last_t: f64,
    last_h: f64,
    last_base: Vec<f64>,
    last_incr: Vec<f64>,
    // Workspaces.
    x: Vec<f64>,
    incr: Vec<f64>,
    /// The node increments' second, small sum (fixed-point step with exact coefficients).
    incr_lo: Vec<f64>,
    /// The positions q_k + Y_l at the quadrature points (fixed-point sweep).
    stage_q: Vec<f64>,
    grad: Vec<f64>,
    hess: Vec<f64>,
    ework: ElementWork,
    newton: DenseNewtonWork,
    fp: Option<FixedPointTables>,
    y: Vec<f64>,
    force: Vec<f64>,
    wforce: Vec<f64>,
    u: Vec<f64>,
    tmp: Vec<f64>,
    dq: Vec<f64>,
    dp: Vec<f64>,
    force0_valid: bool,
    fsal_slot: usize,
    lazy_valid: bool,
    lazy_p: Vec<f64>,
    lazy_cp: Vec<f64>,
    lazy_pending: Vec<f64>,
    /// The force at the node before the current one and the step that led to the current
    /// node (the explicit fast path's drift formula, with `lazy_valid`).
    lazy_fprev: Vec<f64>,
    lazy_hprev: f64,
    extrap_rho: f64,
    extrap: Vec<f64>,
    /// Starting values of the fixed-point stages from the last accepted step (its stage forces
    /// M⁻¹f live in `stage_start.data`), and whether they are valid.
    stage_start: StageStart,
    have_last_w: bool,
    ftmp: Vec<f64>,
    /// Sweeps of the last fixed-point step (chooses the starting procedure).
    last_sweeps: usize,
    /// The element's tables scaled by the last few distinct steps (a cycle of up to
    /// `CACHED_STEPS` steps builds them once), the entry of the current step and the one to
    /// be replaced next; and the stage times of the current step.
    step_tables: Vec<StepTables>,
    cur_tables: usize,
    next_tables: usize,
    stage_t: Vec<f64>,
    basis_buf: Vec<f64>,
    iterations: usize,
    steps: usize,
    energy: Option<EnergyState>,
}

impl<'a, L: Lagrangian> Integrator<'a, L> {
    /// Sets up a run of `lag` discretised by `element` on `grid` from `start`.
    ///
    /// # Errors
    /// Wrong dimensions, invalid options, a degenerate element or Lagrangian, a method that
    /// does not fit the Lagrangian, or (for the start from (q0, q1)) a failed solve of the
    /// first element.
    pub fn new(lag: &'a L, element: &'a Element, grid: TimeGrid, start: Start, opts: SolverOptions) -> Result<Self> {
        opts.validate()?;
        element.check_nondegenerate()?;
        let n = lag.dim();
        let s = element.degree();
        let r = element.points();
        let mechanical = lag.mass_matrix().is_some();
        let explicit_fits = s == 1 && element.rule.kind == QuadratureKind::Trapezoid;
        let method = match opts.method {
            Method::Auto if mechanical && explicit_fits => Resolved::Explicit,
            Method::Auto if mechanical => Resolved::FixedPoint,
            Method::Auto | Method::Newton => Resolved::Newton,
            Method::FixedPoint if mechanical => Resolved::FixedPoint,
            Method::Explicit if mechanical && explicit_fits => Resolved::Explicit,
            Method::FixedPoint => {
                return Err(invalid(
                    "solver method",
                    "fixed-point iteration needs a mechanical Lagrangian (L = 1/2 v'Mv - V)",
                ))
            }
            Method::Explicit => {
                return Err(invalid(
                    "solver method",
                    "explicit stepping needs degree 1 with the trapezoid rule and a mechanical Lagrangian",
                ))
            }
        };
        let fp = if method == Resolved::FixedPoint {
            Some(FixedPointTables::new(element)?)
        } else {
            None
        };
        let t0 = grid.t0();
        let mut me = Self {
            lag,
            element,
            opts,
            method,
            n,
            k: 0,
            t: t0,
            q: vec![0.0; n],
            p: vec![0.0; n],
            comp_q: vec![0.0; n],
            comp_p: vec![0.0; n],
            v0: vec![0.0; n],
            pending: None,
            have_last: false,
            last_t: t0,
            last_h: 0.0,
            last_base: vec![0.0; n],
            last_incr: vec![0.0; (s + 1) * n],
            x: vec![0.0; s * n],
            incr: vec![0.0; (s + 1) * n],
            incr_lo: vec![0.0; s * n],
            stage_q: vec![0.0; element.points() * n],
            grad: vec![0.0; (s + 1) * n],
            hess: vec![0.0; ((s + 1) * n).pow(2)],
            ework: ElementWork::new(element, n),
            newton: DenseNewtonWork::new(s * n),
            fp,
            y: vec![0.0; r * n],
            force: vec![0.0; r * n],
            wforce: vec![0.0; r * n],
            u: vec![0.0; n],
            tmp: vec![0.0; n],
            dq: vec![0.0; n],
            dp: vec![0.0; n],
            force0_valid: false,
            fsal_slot: 0,
            lazy_valid: false,
            lazy_p: vec![0.0; n],
            lazy_cp: vec![0.0; n],
            lazy_pending: vec![0.0; n],
            lazy_fprev: vec![0.0; n],
            lazy_hprev: 0.0,
            extrap_rho: f64::NAN,
            extrap: vec![0.0; s * (s + 1)],
            stage_start: StageStart::new(element, n),
            have_last_w: false,
            ftmp: vec![0.0; n],
            last_sweeps: usize::MAX,
            step_tables: if method == Resolved::FixedPoint {
                (0..CACHED_STEPS).map(|_| StepTables::new(s, r)).collect()
            } else {
                Vec::new()
            },
            cur_tables: 0,
            next_tables: 0,
            stage_t: vec![0.0; r],
            basis_buf: vec![0.0; s + 1],
            iterations: 0,
            steps: 0,
            energy: None,
            grid,
        };
        me.start(start)?;
        Ok(me)
    }

    fn start(&mut self, start: Start) -> Result<()> {
        let n = self.n;
        let t0 = self.t;
        let mut work = PointDerivatives::new(n);
        let finite = |what: &str, x: &[f64]| {
            if x.iter().all(|v| v.is_finite()) {
                Ok(())
            } else {
                Err(invalid(what, "contains a non-finite number"))
            }
        };
        match start {
            Start::Velocity { q, v } => {
                check_len("initial q", n, q.len())?;
                check_len("initial v", n, v.len())?;
                finite("initial q", &q)?;
                finite("initial v", &v)?;
                check_regular(self.lag, t0, &q, &v)?;
                self.lag.first_derivatives(t0, &q, &v, false, &mut work);
                self.p.copy_from_slice(work.l_v());
                self.q = q;
                self.v0 = v;
            }
            Start::Momentum { q, p } => {
                check_len("initial q", n, q.len())?;
                check_len("initial p", n, p.len())?;
                finite("initial q", &q)?;
                finite("initial p", &p)?;
                let mut v = vec![0.0; n];
                velocity_from_momentum(self.lag, t0, &q, &p, &mut v, &mut work)?;
                check_regular(self.lag, t0, &q, &v)?;
                self.q = q;
                self.p = p;
                self.v0 = v;
            }
            Start::Positions { q0, q1 } => {
                check_len("initial q", n, q0.len())?;
                check_len("initial q1", n, q1.len())?;
                finite("initial q", &q0)?;
                finite("initial q1", &q1)?;
                let (h, t1) = self
                    .grid
                    .next(0, t0)
                    .ok_or_else(|| invalid("time span", "no first step"))?;
                let v: Vec<f64> = q0.iter().zip(&q1).map(|(a, b)| (b - a) / h).collect();
                check_regular(self.lag, t0, &q0, &v)?;
                let (p0, p1) = self.solve_first_element(h, &q0, &q1)?;
                self.q = q0;
                self.p = p0;
                self.v0 = v;
                self.pending = Some((t1, q1, p1));
            }
        }
        Ok(())
    }

    /// Solves element 0's internal equations with both ends fixed; returns (p0, p1).
    fn solve_first_element(&mut self, h: f64, q0: &[f64], q1: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
        let n = self.n;
        let s = self.element.degree();
        let t0 = self.t;
        self.incr.iter_mut().for_each(|x| *x = 0.0);
        for m in 1..=s {
            let tau = self.element.basis.nodes[m];
            for c in 0..n {
                self.incr[m * n + c] = tau * (q1[c] - q0[c]);
            }
        }
        let dim = (s - 1) * n;
        let mut x: Vec<f64> = self.incr[n..s * n].to_vec();
        let mut work = DenseNewtonWork::new(dim);
        let (lag, element, tol) = (self.lag, self.element, self.opts.tolerance);
        let (incr, ework, grad, hess) = (&mut self.incr, &mut self.ework, &mut self.grad, &mut self.hess);
        let scale = q0.iter().chain(q1).fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
        let w = (s + 1) * n;
        newton_dense(
            &mut x,
            tol,
            self.opts.max_iterations,
            |_| scale,
            &mut work,
            |x, r, jac| {
                incr[n..s * n].copy_from_slice(x);
                match jac {
                    Some(jac) => {
                        element.hessian_in_place(lag, t0, h, q0, incr, ework, grad, hess);
                        for a in 0..dim {
                            for b in 0..dim {
                                jac[a * dim + b] = hess[(n + a) * w + n + b];
                            }
                        }
                    }
                    None => {
                        element.gradient_in_place(lag, t0, h, q0, incr, false, ework, grad);
                    }
                }
                r.copy_from_slice(&grad[n..s * n]);
            },
        )
        .map_err(|f| self.step_error(f))?;
        self.incr[n..s * n].copy_from_slice(&x);
        self.element
            .gradient_in_place(self.lag, t0, h, q0, &self.incr, false, &mut self.ework, &mut self.grad);
        let p0: Vec<f64> = self.grad[..n].iter().map(|g| -g).collect();
        let p1 = self.grad[s * n..].to_vec();
        self.remember(t0, h, q0);
        Ok((p0, p1))
    }

    fn step_error(&self, f: NewtonFailure) -> Error {
        Error::Step(StepError {
            step: self.k,
            t: self.t,
            residual: f.residual,
            iterations: f.iterations,
            failure: f.failure,
        })
    }

    fn remember(&mut self, t: f64, h: f64, base: &[f64]) {
        self.have_last = true;
        self.last_t = t;
        self.last_h = h;
        self.last_base.copy_from_slice(base);
        self.last_incr.copy_from_slice(&self.incr);
    }

    /// The current node.
    pub fn node(&self) -> Node<'_> {
        Node {
            k: self.k,
            t: self.t,
            q: &self.q,
            p: &self.p,
        }
    }

    /// The element solved by the last step, if any.
    pub fn last_element(&self) -> Option<ElementNodes<'_>> {
        self.have_last.then_some(ElementNodes {
            t: self.last_t,
            h: self.last_h,
            base: &self.last_base,
            incr: &self.last_incr,
        })
    }

    /// The grid.
    pub fn grid(&self) -> &TimeGrid {
        &self.grid
    }

    /// The Lagrangian.
    pub fn lagrangian(&self) -> &L {
        self.lag
    }

    /// Mean solver iterations per step so far (0 for explicit steps).
    pub fn mean_iterations(&self) -> f64 {
        if self.steps == 0 {
            0.0
        } else {
            self.iterations as f64 / self.steps as f64
        }
    }

    /// Whether the run has reached the end of its grid.
    pub fn finished(&self) -> bool {
        if self.energy.is_some() {
            return self.pending.is_none() && self.t >= self.grid.end();
        }
        self.pending.is_none() && self.grid.next(self.k, self.t).is_none()
    }

    /// Advances one step. Returns `Ok(false)` at the end of the grid.
    ///
    /// # Errors
    /// [`Error::Step`] with the step index, time and residual if the step equations cannot be
    /// solved; the integrator then stays at the last good node.
    pub fn step(&mut self) -> Result<bool> {
        if let Some((t1, q1, p1)) = self.pending.take() {
            self.q = q1;
            self.p = p1;
            self.t = t1;
            self.k = 1;
            self.steps += 1;
            return Ok(true);
        }
        if self.energy.is_some() {
            return self.step_energy();
        }
        if let Some(done) = self.fast_explicit(1) {
            return done.map(|d| d > 0);
        }
        let Some((h, t_next)) = self.grid.next(self.k, self.t) else {
            return Ok(false);
        };
        self.solve_at(h)?;
        self.commit(h, t_next)?;
        Ok(true)
    }

    /// Solves the step equations from the current node with step h into `dq`, `dp` and
    /// `incr`, without moving the state.
    fn solve_at(&mut self, h: f64) -> Result<()> {
        match self.method {
            Resolved::Explicit => self.step_explicit(h),
            Resolved::FixedPoint => self.step_fixed_point(h)?,
            Resolved::Newton => {
                self.guess(h);
                self.step_newton(h)?
            }
        }
        Ok(())
    }

    /// Moves the state to the node solved by [`Self::solve_at`] with step h.
    fn commit(&mut self, h: f64, t_next: f64) -> Result<()> {
        // The node becomes the last element's base; buffers are swapped, not copied (copies
        // of a few numbers cost more than the Verlet step itself).
        self.have_last = true;
        self.last_t = self.t;
        self.last_h = h;
        std::mem::swap(&mut self.q, &mut self.last_base);
        if self.method != Resolved::Explicit {
            std::mem::swap(&mut self.incr, &mut self.last_incr);
        }
        if self.method == Resolved::FixedPoint {
            // The stage forces (M⁻¹f) of the accepted step, for the next step's guess.
            let identity = self.lag.mass_matrix().is_some_and(|m| m.is_identity());
            let r = self.element.points();
            let w = if identity { &self.force } else { &self.wforce };
            self.stage_start.data[..r * self.n].copy_from_slice(&w[..r * self.n]);
            self.have_last_w = true;
        }
        let mut finite = true;
        for c in 0..self.n {
            let base = self.last_base[c];
            let y = self.dq[c] + self.comp_q[c];
            let t = base + y;
            self.comp_q[c] = (base - t) + y;
            self.q[c] = t;
            let y = self.dp[c] + self.comp_p[c];
            let t = self.p[c] + y;
            self.comp_p[c] = (self.p[c] - t) + y;
            self.p[c] = t;
            finite &= t.is_finite() && self.q[c].is_finite();
        }
        if !finite {
            return Err(Error::Step(StepError {
                step: self.k,
                t: self.t,
                residual: f64::NAN,
                iterations: 0,
                failure: StepFailure::NonFinite,
            }));
        }
        self.k += 1;
        self.t = t_next;
        self.steps += 1;
        Ok(())
    }

    /// Advances up to `max_steps` steps and returns how many were taken (0 at the end of the
    /// grid). Results are identical to calling [`Integrator::step`] that many times; for
    /// explicit stepping of small systems the steps run in a tight loop over fixed-size arrays.
    ///
    /// # Errors
    /// As [`Integrator::step`]; the steps before the failure are kept.
    pub fn advance(&mut self, max_steps: usize) -> Result<usize> {
        if let Some(done) = self.fast_explicit(max_steps) {
            return done;
        }
        self.advance_generic(max_steps)
    }

    /// The fixed-size explicit path for the sizes it is compiled for (None otherwise).
    fn fast_explicit(&mut self, max_steps: usize) -> Option<Result<usize>> {
        if self.method != Resolved::Explicit || self.pending.is_some() || self.energy.is_some() {
            return None;
        }
        let identity = self.lag.mass_matrix().is_some_and(|m| m.is_identity());
        // The dimension and whether M = I fixed at compile time: the loop has no branch on the
        // mass and its arrays live in registers.
        Some(match (self.n, identity) {
            (1, true) => self.advance_explicit::<1, true>(max_steps),
            (1, false) => self.advance_explicit::<1, false>(max_steps),
            (2, true) => self.advance_explicit::<2, true>(max_steps),
            (2, false) => self.advance_explicit::<2, false>(max_steps),
            (3, true) => self.advance_explicit::<3, true>(max_steps),
            (3, false) => self.advance_explicit::<3, false>(max_steps),
            (4, true) => self.advance_explicit::<4, true>(max_steps),
            (4, false) => self.advance_explicit::<4, false>(max_steps),
            (6, true) => self.advance_explicit::<6, true>(max_steps),
            (6, false) => self.advance_explicit::<6, false>(max_steps),
            _ => return None,
        })
    }

    fn advance_generic(&mut self, max_steps: usize) -> Result<usize> {
        let mut done = 0;
        while done < max_steps && self.step()? {
            done += 1;
        }
        Ok(done)
    }

    /// Störmer–Verlet over `[f64; N]` locals: the step of `step_explicit` (the same
    /// increments up to rounding: the drift is summed in another order, below) and the
    /// compensated update of `commit`. Any split of a run into calls gives the same numbers
    /// (the lazy state persists); tests compare it with a hand-written variable-step Verlet
    /// loop and with Newton's method on the element equations.
    fn advance_explicit<const N: usize, const IDENTITY: bool>(&mut self, max_steps: usize) -> Result<usize> {
        let Some(mass) = self.lag.mass_matrix() else {
            unreachable!("checked in new")
        };
        let identity = IDENTITY;
        let load = |v: &[f64]| -> [f64; N] {
            let mut a = [0.0; N];
            a.copy_from_slice(&v[..N]);
            a
        };
        // The momentum is kept lazily: the compensated sum (p, cp) without the last increment,
        // which is added off the critical path of the next step (the drift uses
        // (p + cp) + pending directly). This state persists between calls, so that any split
        // of a run into `advance` calls gives the same numbers.
        let (mut q, mut cq) = (load(&self.q), load(&self.comp_q));
        let (mut p, mut cp, mut pending) = if self.lazy_valid {
            (load(&self.lazy_p), load(&self.lazy_cp), load(&self.lazy_pending))
        } else {
            (load(&self.p), load(&self.comp_p), [0.0; N])
        };
        // The drift from node k is h_k P_k + ½h_k² f_k with P_k = P_{k−1} + ½h_{k−1}(f_{k−1} + f_k),
        // evaluated as (h_k P_{k−1} + ½h_k h_{k−1} f_{k−1}) + ½h_k(h_{k−1} + h_k) f_k: the first
        // part is known before f_k is, so the chain from one force to the next position is one
        // product and two sums (against three products and four sums through P_k), which put
        // this loop within the hand-written loop's time. Without the lazy state, P_k itself is
        // (p, cp) and h_{k−1} = 0 reduces the formula to h_k P_k + ½h_k² f_k.
        let (mut fprev, mut hprev) = if self.lazy_valid {
            (load(&self.lazy_fprev), self.lazy_hprev)
        } else {
            ([0.0; N], 0.0)
        };
        let (mut f0, mut f1, mut y, mut dq, mut dp) = ([0.0; N], [0.0; N], [0.0; N], [0.0; N], [0.0; N]);
        // M⁻¹ f_{k−1}, carried from step to step like f_{k−1} itself.
        let (mut u, mut w, mut wprev) = ([0.0; N], [0.0; N], [0.0; N]);
        if !IDENTITY {
            mass.solve(&fprev, &mut wprev);
        }
        if self.force0_valid {
            let off = self.fsal_slot * N;
            f0 = load(&self.force[off..off + N]);
        } else {
            self.lag.force(self.t, &q, &mut f0);
        }
        let (mut k, mut t) = (self.k, self.t);
        let (mut last_t, mut last_h, mut last_q, mut last_dq) = (self.last_t, self.last_h, q, dq);
        let mut done = 0;
        let mut failed = false;
        let uniform = self.grid.uniform_rule();
        let mut k1 = (k + 1) as i64 as f64;
        while done < max_steps {
            let next = match &uniform {
                Some(u) => u.next(k1, t),
                None => self.grid.next(k, t),
            };
            let Some((h, t_next)) = next else { break };
            let half_h = 0.5 * h;
            let (a, b) = (half_h * hprev, half_h * (hprev + h));
            let prev = (q, p, cq, cp, pending);
            if identity {
                for c in 0..N {
                    dq[c] = (h * (p[c] + cp[c]) + a * fprev[c]) + b * f0[c];
                    y[c] = q[c] + dq[c];
                }
            } else {
                let mut pk = [0.0; N];
                for c in 0..N {
                    pk[c] = p[c] + cp[c];
                }
                mass.solve(&pk, &mut u);
                mass.solve(&f0, &mut w);
                for c in 0..N {
                    dq[c] = (h * u[c] + a * wprev[c]) + b * w[c];
                    y[c] = q[c] + dq[c];
                }
            }
            // The pending increment joins the compensated sum off the critical path.
            for c in 0..N {
                let yp = pending[c] + cp[c];
                let tp = p[c] + yp;
                cp[c] = (p[c] - tp) + yp;
                p[c] = tp;
            }
            self.lag.force(t + h, &y, &mut f1);
            // x·0 is NaN exactly when x is not finite: one sum tells whether all are.
            let mut probe = 0.0;
            for c in 0..N {
                dp[c] = half_h * (f0[c] + f1[c]);
                let yq = dq[c] + cq[c];
                let tq = q[c] + yq;
                cq[c] = (q[c] - tq) + yq;
                q[c] = tq;
                pending[c] = dp[c];
                probe += dp[c] * 0.0 + tq * 0.0;
            }
            if probe.is_nan() {
                (q, p, cq, cp, pending) = prev;
                failed = true;
                break;
            }
            last_q = prev.0;
            last_dq = dq;
            fprev = f0;
            wprev = w;
            hprev = h;
            f0 = f1;
            last_t = t;
            last_h = h;
            k += 1;
            k1 += 1.0;
            t = t_next;
            done += 1;
        }
        // Write the state back: the lazy momentum, and the node's momentum materialised.
        self.lazy_p.copy_from_slice(&p);
        self.lazy_cp.copy_from_slice(&cp);
        self.lazy_pending.copy_from_slice(&pending);
        self.lazy_fprev.copy_from_slice(&fprev);
        self.lazy_hprev = hprev;
        self.lazy_valid = true;
        for c in 0..N {
            let yp = pending[c] + cp[c];
            let tp = p[c] + yp;
            cp[c] = (p[c] - tp) + yp;
            p[c] = tp;
        }
        self.q.copy_from_slice(&q);
        self.p.copy_from_slice(&p);
        self.comp_q.copy_from_slice(&cq);
        self.comp_p.copy_from_slice(&cp);
        self.force[..N].copy_from_slice(&f0);
        self.fsal_slot = 0;
        self.force0_valid = true;
        self.steps += done;
        if done > 0 {
            self.have_last = true;
            self.last_t = last_t;
            self.last_h = last_h;
            self.last_base.copy_from_slice(&last_q);
            self.last_incr[N..2 * N].copy_from_slice(&last_dq);
        }
        self.k = k;
        self.t = t;
        if failed {
            // The state is at the last good node; report like `step` does.
            self.force0_valid = false;
            return Err(Error::Step(StepError {
                step: k,
                t,
                residual: f64::NAN,
                iterations: 0,
                failure: StepFailure::NonFinite,
            }));
        }
        Ok(done)
    }

    /// The tangent map ∂(q_{k+1}, p_{k+1})/∂(q_k, p_k) of the last step (row-major 2n×2n),
    /// by implicit differentiation of its equations p_k = −∂L_d/∂Q^0, ∂L_d/∂Q^j = 0 at the
    /// solved element: with dQ^0 = dq, dQ^m = dq + dX^m,
    ///   Σ_{m≥1} H_jm dX^m = −δ_j0 dp − (Σ_m H_jm) dq  (j < s),
    ///   dq' = dq + dX^s,  dp' = Σ_m H_sm dQ^m,
    /// where H is the element Hessian ∂²L_d/∂Q∂Q. Exact up to the solver's tolerance.
    ///
    /// # Errors
    /// No step taken yet, or a singular step Jacobian.
    pub fn tangent_map(&mut self) -> Result<Vec<f64>> {
        if !self.have_last {
            return Err(invalid("tangent map", "no step has been taken"));
        }
        let n = self.n;
        let s = self.element.degree();
        let w = (s + 1) * n;
        let (t, h) = (self.last_t, self.last_h);
        let base = self.last_base.clone();
        self.element.hessian_in_place(
            self.lag,
            t,
            h,
            &base,
            &self.last_incr,
            &mut self.ework,
            &mut self.grad,
            &mut self.hess,
        );
        let hess = &self.hess;
        let dim = s * n;
        let jac = nalgebra::DMatrix::from_fn(dim, dim, |a, b| hess[a * w + n + b]);
        let lu = jac.lu();
        // Row sums over node blocks: (Σ_m H_jm) for rows a, component c.
        let sum_cols = |a: usize, c: usize| (0..=s).map(|m| hess[a * w + m * n + c]).sum::<f64>();
        let mut out = vec![0.0; 4 * n * n];
        for col in 0..2 * n {
            // Direction: dq = e_col (col < n) or dp = e_{col-n}.
            let mut rhs = nalgebra::DVector::zeros(dim);
            for a in 0..dim {
                rhs[a] = if col < n {
                    -sum_cols(a, col)
                } else if a == col - n {
                    -1.0
                } else {
                    0.0
                };
            }
            let dx = lu.solve(&rhs).ok_or_else(|| {
                Error::Step(StepError {
                    step: self.k.saturating_sub(1),
                    t,
                    residual: f64::NAN,
                    iterations: 0,
                    failure: StepFailure::Singular,
                })
            })?;
            for c in 0..n {
                let dq0 = if col < n && c == col { 1.0 } else { 0.0 };
                // dq' = dq + dX^s.
                out[c * 2 * n + col] = dq0 + dx[(s - 1) * n + c];
                // dp' = Σ_m H_sm dQ^m, dQ^0 = dq, dQ^m = dq + dX^m.
                let row = (s * n + c) * w;
                let mut acc = 0.0;
                for m in 0..=s {
                    for e in 0..n {
                        let dq = if col < n && e == col { 1.0 } else { 0.0 };
                        let dqm = if m == 0 { dq } else { dq + dx[(m - 1) * n + e] };
                        acc += hess[row + m * n + e] * dqm;
                    }
                }
                out[(n + c) * 2 * n + col] = acc;
            }
        }
        Ok(out)
    }

    /// Starting values of the node increments x (nodes 1 … s): the previous element's
    /// polynomial extrapolated, or the initial velocity on the first step.
    fn guess(&mut self, h: f64) {
        let n = self.n;
        let s = self.element.degree();
        let nodes = &self.element.basis.nodes;
        if !self.have_last {
            for m in 1..=s {
                for c in 0..n {
                    self.x[(m - 1) * n + c] = nodes[m] * h * self.v0[c];
                }
            }
            return;
        }
        let rho = h / self.last_h;
        if rho != self.extrap_rho {
            self.extrap_rho = rho;
            for m in 1..=s {
                self.element
                    .basis
                    .values_in_place(1.0 + nodes[m] * rho, &mut self.basis_buf);
                self.extrap[(m - 1) * (s + 1)..m * (s + 1)].copy_from_slice(&self.basis_buf);
            }
        }
        let end = &self.last_incr[s * n..];
        for m in 1..=s {
            let row = &self.extrap[(m - 1) * (s + 1)..m * (s + 1)];
            for c in 0..n {
                let mut acc = 0.0;
                for (j, l) in row.iter().enumerate() {
                    acc += l * (self.last_incr[j * n + c] - end[c]);
                }
                self.x[(m - 1) * n + c] = acc;
            }
        }
    }

    #[inline]
    fn step_explicit(&mut self, h: f64) {
        // Störmer–Verlet: degree 1, trapezoid. The force at the end of a step is the force at
        // the start of the next (kept in the other half of `force`, which alternates).
        let n = self.n;
        let Some(mass) = self.lag.mass_matrix() else {
            unreachable!("checked in new")
        };
        let (lo, hi) = self.force.split_at_mut(n);
        let (f0, f1) = if self.fsal_slot == 0 {
            (lo, &mut hi[..n])
        } else {
            (&mut hi[..n], lo)
        };
        if !self.force0_valid {
            self.lag.force(self.t, &self.q, f0);
        }
        let half_h2 = 0.5 * h * h;
        if mass.is_identity() {
            for c in 0..n {
                self.dq[c] = h * self.p[c] + half_h2 * f0[c];
                self.y[c] = self.q[c] + self.dq[c];
            }
        } else {
            mass.solve(&self.p, &mut self.u);
            mass.solve(f0, &mut self.tmp);
            for c in 0..n {
                self.dq[c] = h * self.u[c] + half_h2 * self.tmp[c];
                self.y[c] = self.q[c] + self.dq[c];
            }
        }
        self.lag.force(self.t + h, &self.y[..n], f1);
        for c in 0..n {
            self.dp[c] = 0.5 * h * (f0[c] + f1[c]);
            self.last_incr[n + c] = self.dq[c];
        }
        self.fsal_slot ^= 1;
        self.force0_valid = true;
    }

    fn step_fixed_point(&mut self, h: f64) -> Result<()> {
        let n = self.n;
        let s = self.element.degree();
        let r = self.element.points();
        let rho = if self.have_last_w { h / self.last_h } else { f64::NAN };
        let force_guess = r <= START_MAX_POINTS && (0.5..=2.0).contains(&rho);
        if !force_guess {
            self.guess(h);
        }
        let Some(mass) = self.lag.mass_matrix() else {
            unreachable!("checked in new")
        };
        let Some(tab) = self.fp.as_ref() else {
            unreachable!("built in new")
        };
        let identity = mass.is_identity();
        let exact = self.opts.polish && COEFFICIENT_ROUNDING;
        mass.solve(&self.p, &mut self.u);
        if self.step_tables[self.cur_tables].h_bits != h.to_bits() {
            match self.step_tables.iter().position(|t| t.h_bits == h.to_bits()) {
                Some(i) => self.cur_tables = i,
                None => {
                    let i = self.next_tables;
                    self.next_tables = (i + 1) % CACHED_STEPS;
                    self.step_tables[i].build(tab, &self.element.rule.weights, h);
                    self.cur_tables = i;
                }
            }
        }
        let st = &self.step_tables[self.cur_tables];
        for (st, c) in self.stage_t.iter_mut().zip(&self.element.rule.nodes) {
            *st = self.t + c * h;
        }
        // Starting stage values: from the last step's stage forces and two more forces
        // (step/start.rs), or from the node guess.
        if force_guess {
            let (lag, q, t, ftmp, tmp) = (self.lag, &self.q, self.t, &mut self.ftmp, &mut self.tmp);
            self.stage_start.start(
                self.element,
                tab,
                self.k,
                h,
                self.last_h,
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
        } else {
            for l in 0..r {
                for c in 0..n {
                    self.y[l * n + c] = (1..=s).map(|m| self.element.phi(l, m) * self.x[(m - 1) * n + c]).sum();
                }
            }
        }
        let qscale = self.q.iter().fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
        let tol = self.opts.tolerance;
        let mut prev = f64::INFINITY;
        let mut non_decreasing = 0;
        let mut iterations = 0;
        let mut polish = 0;
        loop {
            iterations += 1;
            // The sweep with the dimension fixed at compile time for n ≤ 3 (inlined: through a
            // function pointer it measured 1.4× slower on the pendulum).
            macro_rules! sweep {
                ($N:literal) => {
                    fixed_point_sweep::<L, $N>(
                        self.lag,
                        mass,
                        n,
                        &self.stage_t[..r],
                        &self.q,
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
            let scale = qscale.max(ymax);
            let fail = |failure| {
                Error::Step(StepError {
                    step: self.k,
                    t: self.t,
                    residual: delta,
                    iterations,
                    failure,
                })
            };
            if !delta.is_finite() {
                return Err(fail(StepFailure::NonFinite));
            }
            if delta <= tol * scale {
                // Polish: the error left by a truncated iteration has the same sign every
                // step and would drift conserved quantities linearly, so iterate on while the
                // increments still decrease (as GNI_IRK2 does), at most three more times.
                // Stopping earlier on the estimate δ²/δ_prev is wrong: the momentum update
                // h Σ b_i f_i carries the stages' error δ times h|∂f/∂q|, not times the
                // contraction (measured: P3's energy error, degree 6, h = 0.5, doubled from
                // 9.3e-12 to 2.0e-11).
                if !self.opts.polish
                    || delta == 0.0
                    || delta >= prev
                    || polish >= 3
                    || delta <= ROUNDOFF_ULPS * f64::EPSILON * scale
                {
                    break;
                }
                polish += 1;
            } else if delta >= prev {
                if delta <= 64.0 * f64::EPSILON * scale {
                    break; // Round-off level: it cannot get any better.
                }
                non_decreasing += 1;
                if non_decreasing >= 3 {
                    return Err(fail(StepFailure::Stalled));
                }
            }
            if iterations >= self.opts.max_iterations && delta > tol * scale {
                return Err(fail(StepFailure::NotConverged));
            }
            if iterations >= self.opts.max_iterations {
                break;
            }
            prev = delta;
        }
        self.iterations += iterations;
        self.last_sweeps = iterations;
        // Node increments, end increment and momentum increment from the last forces.
        self.incr[..n].iter_mut().for_each(|x| *x = 0.0);
        let w: &[f64] = if identity {
            &self.force[..r * n]
        } else {
            &self.wforce[..r * n]
        };
        // Node increments ΔQ^m = h α_m u + h² Σ_i β_mi w_i and the momentum increment
        // h Σ_i b_i f_i from the last forces, with the coefficients' rounding errors as a
        // second, small sum when polishing.
        affine(
            s,
            n,
            &st.h_alpha,
            &self.u,
            &st.h2_beta,
            r,
            w,
            &mut self.incr[n..],
            false,
        );
        if exact {
            let lo = &mut self.incr_lo[..s * n];
            affine(s, n, &st.h_alpha_lo, &self.u, &st.h2_beta_lo, r, w, lo, false);
            for (hi, lo) in self.incr[n..].iter_mut().zip(lo.iter()) {
                *hi += lo;
            }
        }
        self.dq.copy_from_slice(&self.incr[s * n..]);
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
            self.dp[c] = hi;
        }
        Ok(())
    }

    fn step_newton(&mut self, h: f64) -> Result<()> {
        let n = self.n;
        let s = self.element.degree();
        let dim = s * n;
        let w = (s + 1) * n;
        let (lag, element, t0) = (self.lag, self.element, self.t);
        let (q, p) = (&self.q, &self.p);
        let (incr, ework, grad, hess) = (&mut self.incr, &mut self.ework, &mut self.grad, &mut self.hess);
        incr[..n].iter_mut().for_each(|x| *x = 0.0);
        let qscale = q.iter().fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
        let scale = |x: &[f64]| x.iter().fold(qscale, |m, v| m.max(v.abs()));
        let report = newton_dense(
            &mut self.x,
            self.opts.tolerance,
            self.opts.max_iterations,
            scale,
            &mut self.newton,
            |x, r, jac| {
                incr[n..].copy_from_slice(x);
                match jac {
                    Some(jac) => {
                        element.hessian_in_place(lag, t0, h, q, incr, ework, grad, hess);
                        for a in 0..dim {
                            jac[a * dim..(a + 1) * dim].copy_from_slice(&hess[a * w + n..a * w + w]);
                        }
                    }
                    None => {
                        element.gradient_in_place(lag, t0, h, q, incr, false, ework, grad);
                    }
                }
                r.copy_from_slice(&grad[..dim]);
                for c in 0..n {
                    r[c] += p[c];
                }
            },
        );
        let report = match report {
            Ok(r) => r,
            Err(f) => return Err(self.step_error(f)),
        };
        self.iterations += report.iterations;
        // The last evaluation (residual only) was at the converged x: the points hold ∂L/∂q.
        self.incr[n..].copy_from_slice(&self.x);
        self.dq.copy_from_slice(&self.x[(s - 1) * n..]);
        for c in 0..n {
            self.dp[c] = h
                * (0..element.points())
                    .map(|i| element.rule.weights[i] * self.ework.pts[i].l_q()[c])
                    .sum::<f64>();
        }
        Ok(())
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
