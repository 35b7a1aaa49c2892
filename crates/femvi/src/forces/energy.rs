//! Forces in the energy mode (time steps as variables, paper §3): the discrete
//! Lagrange–d'Alembert principle with the element's time nodes varied, whose energy equation
//! fixes h_k, so that the discrete energy changes by exactly the discrete work of the forces.
//!
//! # Derivation
//!
//! Continuous (Marsden–West 2001, §4.2 and §3.2; Kane–Marsden–Ortiz–West 2000, §2): with
//! the time t(τ) a variable too, a variation (δq, δt) moves the point of the path seen at a
//! fixed physical time by δq − q̇ δt, so the principle in the extended configuration space is
//! δ∫L dt + ∫F·(δq − q̇ δt) dt = 0. The δt-equation is d/dt(q̇·∂L/∂q̇ − L) = F·q̇ − ∂L/∂t,
//! the energy balance dE/dt = F·q̇ (autonomous L).
//!
//! Discrete: element k is [t_k, t_{k+1}], h = t_{k+1} − t_k, path q_h(τ) = Σ_j Q^j ℓ_j(τ)
//! with t = t_k + τ h. Varying (t_k, t_{k+1}) at fixed τ moves the point by
//! δt(τ) = (1 − τ) δt_k + τ δt_{k+1}, and the path seen at fixed t by
//! δq_h(τ) − q̇_h(τ) δt(τ), with q̇_h = (1/h) Σ_j Q^j ℓ_j'. The element's virtual work with its
//! own quadrature (b_i, c_i), F_i = F(t_k + c_i h, q_h(c_i), q̇_h(c_i)), is
//!
//!   h Σ_i b_i F_i·(δq_h(c_i) − q̇_h(c_i) δt(c_i))
//!     = Σ_j F_d^j·δQ^j − W_k⁻ δt_k − W_k⁺ δt_{k+1},
//!
//!   W_k⁻ = h Σ_i b_i (1 − c_i) F_i·q̇_h(c_i),   W_k⁺ = h Σ_i b_i c_i F_i·q̇_h(c_i).
//!
//! The δQ terms are the forced step equations ([`crate::forces`]). With the discrete energies
//! E_k⁻ = ∂L_d/∂t_k and E_{k+1}⁺ = −∂L_d/∂t_{k+1} of each element ([`crate::Element::energies`],
//! DESIGN.md §1), the coefficient of δt_k, shared by elements k − 1 and k, gives
//!
//!   E_k⁻(element k) − W_k⁻ = E_k⁺(element k − 1) + W_{k−1}⁺ =: Ẽ_k,
//!
//! the forced form of (3.3): the equation solved for h_k, and the definition of the node's
//! discrete energy Ẽ_k (its two sides agree at a solved node). Subtracting at nodes k and k + 1,
//!
//!   Ẽ_{k+1} − Ẽ_k = (E_{k+1}⁺ − E_k⁻)(element k) + W_k⁻ + W_k⁺
//!                 = W_k − h Σ_i b_i ∂L/∂t(c_i),   W_k = h Σ_i b_i F_i·q̇_h(c_i),
//!
//! so the discrete energy changes by exactly the element's discrete work (the same W_k that
//! the fixed-step runs accumulate) plus, for a time-dependent L, the discrete −∫∂L/∂t. This
//! is the continuous balance with the integral of F·q̇ over [t_k, t_{k+1}] replaced by the
//! element's quadrature along its own polynomial; without forces it is (3.3), and for
//! autonomous L, E_k⁻ = E_{k+1}⁺ on each element and Ẽ_k = E_k⁻ − W_k⁻.
//!
//! # The run
//!
//! Step 0 is taken with h_0 as a parameter (as in the conservative mode), which fixes
//! Ẽ_0 = E_0⁻ − W_0⁻ and Ẽ_1 = E_1⁺ + W_0⁺. Each later step searches h_k in
//! [min_step, max_step] with g(h) = E_k⁻(h) − W_k⁻(h) − Ẽ_k = 0 (the search of the conservative
//! mode, `step/energy_search.rs`), each trial solving the forced step by Newton
//! (`energy_step.rs`); Ẽ_{k+1} is carried as Ẽ_k + (E⁺ − E⁻) + W_k with compensated sums.
//! Reported: W at the kept nodes, Ẽ at the kept nodes *measured* from the solved elements
//! (E⁺ + W⁺ of the element before the node, not the carried value), the discrete balance
//! max_k |Ẽ_k − Ẽ_0 − Σ_{j<k} W_j| (round-off where every energy equation was solved), and
//! the balance of the nodal H as in fixed-step runs (H_k − H_0 − W_k, small at the method's
//! order, not round-off).

use super::energy_step::{ElementEnergy, EnergyStep};
use super::solve::{Node, Run};
use super::step::Taken;
use super::{EnergyBalance, Force, ForcedSolution};
use crate::discrete::Element;
use crate::error::{invalid, Error, Result, StepFailure};
use crate::lagrangian::Lagrangian;
use crate::solution::SolveOptions;
use crate::step::{search_step, Degenerate, EnergyOptions, EnergyStats, Method, TimeGrid};

/// The start of a forced energy-mode run: (t0, q0, p0, v0).
pub(super) struct Begin<'s> {
    pub(super) t0: f64,
    pub(super) q0: &'s [f64],
    pub(super) p0: &'s [f64],
    pub(super) v0: &'s [f64],
}

/// The carried discrete energy Ẽ_k with the compensation of its sum, and the statistics.
struct Carry {
    started: bool,
    h_prev: f64,
    comp: f64,
    stats: EnergyStats,
    /// Ẽ_0 as measured on the first element (NaN before it).
    e0: f64,
    balance: EnergyBalance,
}

impl Carry {
    fn new(h0: f64) -> Self {
        Self {
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
            e0: f64::NAN,
            balance: EnergyBalance::default(),
        }
    }

    /// Records the measured Ẽ at a node against Ẽ_0 + W (W: the work accumulated to it).
    fn measure(&mut self, e: f64, work: f64) {
        let gap = (e - self.e0 - work).abs();
        let scale = if self.e0 != 0.0 { self.e0.abs() } else { 1.0 };
        self.balance.max_abs = self.balance.max_abs.max(gap);
        self.balance.max_rel = self.balance.max_rel.max(gap / scale);
    }
}

/// Checks the step bounds against the first step, as [`crate::Integrator::with_energy`].
fn check_bounds(h0: f64, energy: &EnergyOptions, method: Method) -> Result<()> {
    let (lo, hi) = (energy.min_step, energy.max_step);
    if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= h0 && h0 <= hi) {
        return Err(invalid(
            "step bounds",
            format!("need 0 < min_step ({lo}) <= step ({h0}) <= max_step ({hi}), all finite"),
        ));
    }
    if matches!(method, Method::FixedPoint | Method::Explicit) {
        return Err(invalid(
            "solver method",
            "the energy mode with forces solves its steps by Newton's method; use method = \"auto\" or \"newton\"",
        ));
    }
    Ok(())
}

/// The forced energy-mode run (module docs) on `grid` (its first step is h_0, its end the
/// time past which the run stops).
pub(super) fn solve_energy<L: Lagrangian, F: Force>(
    lag: &L,
    force: &F,
    element: &Element,
    options: &SolveOptions,
    (grid, energy): (TimeGrid, EnergyOptions),
    begin: Begin<'_>,
) -> Result<ForcedSolution> {
    let n = lag.dim();
    let h0 = grid.nominal(0);
    check_bounds(h0, &energy, options.solver.method)?;
    let mut stepper = EnergyStep::new(lag, force, element, options.solver, begin.t0)?;
    let mut run = Run::new(n, options.every);
    let mut node = Node {
        k: 0,
        t: begin.t0,
        q: begin.q0.to_vec(),
        p: begin.p0.to_vec(),
        cq: vec![0.0; n],
        cp: vec![0.0; n],
        work: 0.0,
    };
    let mut v = begin.v0.to_vec();
    let mut carry = Carry::new(h0);
    // Ẽ at the kept nodes (node 0's is known once element 0 is solved).
    let mut discrete: Vec<f64> = Vec::new();
    let mut node_energy = f64::NAN;
    let (mut error, mut stopped, mut iterations) = (None, false, 0usize);
    let mut taken = Taken {
        dq: vec![0.0; n],
        dp: vec![0.0; n],
        ..Taken::default()
    };
    loop {
        let last = node.t >= grid.end();
        let kept = run.kept();
        if let Err(e) = run.record(lag, &node, &mut v, last) {
            error = Some(e);
            break;
        }
        if run.kept() > kept {
            discrete.push(node_energy);
        }
        if last {
            break;
        }
        if options.max_steps.is_some_and(|m| node.k >= m) {
            stopped = true;
            break;
        }
        let (h, ee) = match step(&mut stepper, &mut carry, &node, begin.v0, energy, &mut iterations) {
            Ok(x) => x,
            Err(e) => {
                error = Some(e);
                break;
            }
        };
        if node.k == 0 {
            carry.e0 = ee.minus - ee.w_minus;
            if let Some(d) = discrete.first_mut() {
                *d = carry.e0;
            }
        }
        if stepper.dq.iter().chain(&stepper.dp).any(|x| !x.is_finite()) {
            error = Some(non_finite(node.k, node.t));
            break;
        }
        stepper.accept(node.t, h, &node.q);
        taken.dq.copy_from_slice(&stepper.dq);
        taken.dp.copy_from_slice(&stepper.dp);
        taken.work = ee.work;
        taken.time_work = ee.plus - ee.minus;
        node.advance(&taken, node.t + h);
        node_energy = ee.plus + ee.w_plus;
        carry.measure(node_energy, node.work);
    }
    if stopped || error.is_some() {
        let kept = run.kept();
        run.keep_last(&node, &v);
        if run.kept() > kept {
            discrete.push(node_energy);
        }
    }
    let mut sol = run.finish(node.k, iterations, stopped, error);
    sol.solution.energy_stats = Some(carry.stats);
    sol.discrete_energy = discrete;
    sol.discrete_balance = Some(carry.balance);
    Ok(sol)
}

/// A non-finite node as the step error of step k at t.
fn non_finite(k: usize, t: f64) -> Error {
    Error::Step(crate::error::StepError {
        step: k,
        t,
        residual: f64::NAN,
        iterations: 0,
        failure: StepFailure::NonFinite,
    })
}

/// One step: h_k from the energy equation (or h_0 as a parameter on the first step), the
/// element solved at it (left in `stepper`), the carried Ẽ moved on. Returns (h, energies).
fn step<L: Lagrangian, F: Force>(
    stepper: &mut EnergyStep<'_, L, F>,
    carry: &mut Carry,
    node: &Node,
    v0: &[f64],
    opts: EnergyOptions,
    iterations: &mut usize,
) -> Result<(f64, ElementEnergy)> {
    let (k, t, q, p) = (node.k, node.t, &node.q[..], &node.p[..]);
    let mut solve_at = |h: f64, iterations: &mut usize| -> Result<ElementEnergy> {
        *iterations += stepper.solve(k, t, h, q, p, v0)?;
        Ok(stepper.energies(t, h, q))
    };
    let target = carry.stats.energy;
    let (h, ee, change, residual, degenerate, fresh) = if !carry.started {
        // The first element with its step as a parameter fixes the discrete energy.
        let h = carry.h_prev;
        let ee = solve_at(h, iterations)?;
        (h, ee, ee.plus + ee.w_plus, 0.0, false, true)
    } else {
        let mut last = ElementEnergy::default();
        let found = search_step(carry.h_prev, target, opts, (k, t), |h| {
            let ee = solve_at(h, iterations).ok()?;
            last = ee;
            let g = (ee.minus - ee.w_minus) - target;
            g.is_finite()
                .then_some((g, (ee.plus - ee.minus) + ee.work, ee.magnitude))
        });
        match found {
            Ok((h, change, rel)) => (h, last, change, rel, false, false),
            Err(fail) if opts.on_degenerate == Degenerate::Fixed && fail.failure == StepFailure::NoAdmissibleStep => {
                // Time as a parameter for this step: Ẽ starts a new level (the balance breaks).
                let h = carry.h_prev.clamp(opts.min_step, opts.max_step);
                let ee = solve_at(h, iterations)?;
                (h, ee, ee.plus + ee.w_plus, 0.0, true, true)
            }
            Err(fail) => return Err(Error::Step(fail)),
        }
    };
    carry.started = true;
    carry.h_prev = h;
    let st = &mut carry.stats;
    if fresh {
        st.energy = change;
        carry.comp = 0.0;
    } else {
        let y = change + carry.comp;
        let e = st.energy + y;
        carry.comp = (st.energy - e) + y;
        st.energy = e;
    }
    st.min_step = st.min_step.min(h);
    st.max_step = st.max_step.max(h);
    st.max_rel_residual = st.max_rel_residual.max(residual);
    if degenerate {
        st.degenerate_steps += 1;
    }
    Ok((h, ee))
}
