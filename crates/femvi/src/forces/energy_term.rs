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
//! [`Integrator::with_force_energy`] is the integrator's energy mode (`step/energy.rs`) with
//! this term: step 0 is taken with h_0 as a parameter (as in the conservative mode), which
//! fixes Ẽ_0 = E_0⁻ − W_0⁻ and Ẽ_1 = E_1⁺ + W_0⁺. Each later step searches h_k in
//! [min_step, max_step] with g(h) = E_k⁻(h) − W_k⁻(h) − Ẽ_k = 0 (`step/energy_search.rs`),
//! each trial solving the forced step by Newton (`energy_step.rs`, [`StepTerm::energies`]);
//! Ẽ_{k+1} is carried as Ẽ_k + (E⁺ − E⁻) + W_k with compensated sums. The term keeps Ẽ at
//! each node *measured* from the solved elements (E⁺ + W⁺ of the element before the node, not
//! the carried value) and the discrete balance max_k |Ẽ_k − Ẽ_0 − Σ_{j<k} W_j| (round-off
//! where every energy equation was solved); the integrator keeps everything else (the node
//! sums, the last element for dense output and events, checkpoints, the observers). The
//! balance of the nodal H is as in fixed-step runs (H_k − H_0 − W_k, small at the method's
//! order, not round-off).
//!
//! [`StepTerm::energies`]: crate::step::term::StepTerm::energies

use super::energy_step::{ElementEnergy, EnergyStep};
use super::solve::start;
use super::{EnergyBalance, Force};
use crate::discrete::Element;
use crate::error::{check_len, invalid, Result};
use crate::lagrangian::Lagrangian;
use crate::step::checkpoint::{Reader, Words};
use crate::step::state::{Increments, LastElement, RunState};
use crate::step::term::{DiscreteEnergy, StepTerm};
use crate::step::{EnergyOptions, Integrator, Method, SolverOptions, Start, TimeGrid};

impl<'a, L: Lagrangian + Sync> Integrator<'a, L> {
    /// Sets up a run of `lag` under the force `force` with time steps as variables: each step
    /// h_k solves the forced energy equation E_k⁻ − W_k⁻ = Ẽ_k (module docs of
    /// `forces/energy_term.rs`), so that the discrete energy Ẽ changes by exactly the discrete work
    /// of the force ([`Integrator::discrete_balance`]). The first step is the grid's, taken
    /// with h as a parameter; the run stops at the first node at or past the grid's end.
    ///
    /// # Errors
    /// As [`Integrator::with_force`]; step bounds that do not hold the first step;
    /// `Method::FixedPoint` or `Explicit` (the steps are solved by Newton's method).
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::forces::LinearForce;
    /// use femvi::{models, Element, EnergyOptions, Integrator, SolverOptions, Start, TimeGrid};
    ///
    /// // The damped oscillator: the discrete energy falls by exactly the discrete work.
    /// let (lag, element) = (models::harmonic(1.0, 1.0)?, Element::with_order(4)?);
    /// let friction = LinearForce::damping(1, 0.2);
    /// let start = Start::Velocity { q: vec![1.0], v: vec![0.0] };
    /// let grid = TimeGrid::uniform(0.0, 0.05, 10.0)?;
    /// let energy = EnergyOptions::from_step(0.05);
    /// let mut it = Integrator::with_force_energy(&lag, &element, grid, start, SolverOptions::default(), &friction, energy)?;
    /// while it.step()? {}
    /// assert!(it.node().t >= 10.0 && it.work() < -0.3);
    /// assert!(it.discrete_balance().unwrap().max_rel < 1e-13);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn with_force_energy<F: Force + Sync>(
        lag: &'a L,
        element: &'a Element,
        grid: TimeGrid,
        start_at: Start,
        opts: SolverOptions,
        force: &'a F,
        energy: EnergyOptions,
    ) -> Result<Self> {
        let n = lag.dim();
        check_len("force", n, force.dim())?;
        opts.validate()?;
        element.check_nondegenerate()?;
        crate::step::energy_bounds(grid.nominal(0), &energy)?;
        if matches!(opts.method, Method::FixedPoint | Method::Explicit) {
            return Err(invalid(
                "solver method",
                "the energy mode with forces solves its steps by Newton's method; use method = \"auto\" or \"newton\"",
            ));
        }
        let t0 = grid.t0();
        let (q0, p0, v0) = start(lag, &start_at, t0)?;
        let term = EnergyTerm {
            stepper: EnergyStep::new(lag, force, element, opts, t0)?,
            v0,
            at: (t0, 0.0),
            base: vec![0.0; n],
            energies: ElementEnergy::default(),
            steps: 0,
            work: 0.0,
            discrete: DiscreteEnergy {
                at_node: f64::NAN,
                first: f64::NAN,
                max_abs: 0.0,
                max_rel: 0.0,
            },
        };
        let start = Start::Momentum { q: q0, p: p0 };
        // The integrator's own solver is never asked: one that fits any Lagrangian.
        let plain = SolverOptions {
            method: Method::Auto,
            ..opts
        };
        let mut me = Integrator::with_term(lag, element, grid, start, plain, Box::new(term))?;
        me.enable_energy(energy)?;
        Ok(me)
    }
}

impl<L: Lagrangian> Integrator<'_, L> {
    /// The discrete energy Ẽ measured at the current node of a run with
    /// [`Integrator::with_force_energy`] (E⁺ + W⁺ of the element before it; NaN at the start
    /// node); None for other runs.
    pub fn discrete_energy(&self) -> Option<f64> {
        self.term_discrete_energy().map(|d| d.at_node)
    }

    /// The discrete energy balance of a run with [`Integrator::with_force_energy`] so far:
    /// the largest |Ẽ_k − Ẽ_0 − W_k| over the nodes (round-off where every energy equation
    /// was solved); None for other runs.
    pub fn discrete_balance(&self) -> Option<EnergyBalance> {
        self.term_discrete_energy().map(|d| EnergyBalance {
            max_abs: d.max_abs,
            max_rel: d.max_rel,
        })
    }
}

/// The forced step by Newton at each trial step of the energy equation (`energy_step.rs`).
struct EnergyTerm<'a, L, F> {
    stepper: EnergyStep<'a, L, F>,
    /// The velocity at the start node: the predictor of the first step.
    v0: Vec<f64>,
    /// (t_k, h) of the last solve, and q_k.
    at: (f64, f64),
    base: Vec<f64>,
    /// The energies of the element solved last.
    energies: ElementEnergy,
    /// Steps accepted, and the work W_k summed as the integrator sums it.
    steps: usize,
    work: f64,
    discrete: DiscreteEnergy,
}

impl<L: Lagrangian, F: Force> StepTerm for EnergyTerm<'_, L, F> {
    fn solve(
        &mut self,
        state: &RunState,
        _last: &mut LastElement,
        (h, _): (f64, f64),
        out: &mut Increments,
    ) -> Result<usize> {
        let iterations = self.stepper.solve(state.k, state.t, h, &state.q, &state.p, &self.v0)?;
        out.incr.copy_from_slice(&self.stepper.incr);
        out.dq.copy_from_slice(&self.stepper.dq);
        out.dp.copy_from_slice(&self.stepper.dp);
        self.at = (state.t, h);
        self.base.copy_from_slice(&state.q);
        Ok(iterations)
    }

    fn energies(&mut self, t: f64, h: f64, q: &[f64]) -> Option<ElementEnergy> {
        self.energies = self.stepper.energies(t, h, q);
        Some(self.energies)
    }

    fn accepted(&mut self, _n: usize) {
        let (t, h) = self.at;
        self.stepper.accept(t, h, &self.base);
        let e = self.energies;
        self.work += self.element_work();
        let d = &mut self.discrete;
        if self.steps == 0 {
            d.first = e.minus - e.w_minus;
        }
        self.steps += 1;
        d.at_node = e.plus + e.w_plus;
        let gap = (d.at_node - d.first - self.work).abs();
        let scale = if d.first != 0.0 { d.first.abs() } else { 1.0 };
        d.max_abs = d.max_abs.max(gap);
        d.max_rel = d.max_rel.max(gap / scale);
    }

    fn element_work(&self) -> f64 {
        self.energies.work + (self.energies.plus - self.energies.minus)
    }

    fn save(&self, w: &mut Words) {
        w.u(self.steps);
        let d = &self.discrete;
        for x in [self.work, d.at_node, d.first, d.max_abs, d.max_rel] {
            w.f(x);
        }
    }

    fn load(&mut self, r: &mut Reader<'_>, last: &LastElement) -> Result<()> {
        self.steps = r.u()?;
        let d = &mut self.discrete;
        for x in [
            &mut self.work,
            &mut d.at_node,
            &mut d.first,
            &mut d.max_abs,
            &mut d.max_rel,
        ] {
            *x = r.f()?;
        }
        // The predictor's source is the last accepted element, which the integrator saved.
        if last.valid {
            self.stepper.last.clone_from(last);
        }
        Ok(())
    }

    fn name(&self) -> &'static str {
        "forces in the energy mode"
    }

    fn discrete_energy(&self) -> Option<DiscreteEnergy> {
        Some(self.discrete)
    }
}
