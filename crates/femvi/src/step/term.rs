//! Terms of the step equations beside the Lagrangian (issue 33): a term owns the solve of a
//! step whose equations it changes, and the [`Integrator`](super::Integrator) keeps everything
//! else — the grid, the node with its compensated sums (`state.rs`), the last element (dense
//! output, events, starting values), the counters, checkpoints and the driver with its
//! observers ([`super::drive()`]). A run without a term has no term object and takes the
//! solvers of `solver.rs` as before: the plain paths keep their code and bits.
//!
//! The first term is the discrete Lagrange–d'Alembert force of [`crate::forces`]
//! (`forces/term.rs`): its step equations add F_d^j = h Σ_i b_i F(t_i, q_h(c_i), q̇_h(c_i)) ℓ_j(c_i)
//! to R_j, and each element adds its discrete work W to the run's total
//! ([`Integrator::work`](super::Integrator::work)). The second is the holonomic constraints
//! of [`crate::constraints`] (`constraints/term.rs`): the constrained step with its
//! multipliers, whose new momentum is the projection onto T*N (set, not summed:
//! [`StepTerm::momentum`]).

use super::checkpoint::{Reader, Words};
use super::state::{Increments, LastElement, RunState};
use crate::error::Result;
use crate::rotation::BodyState;

/// The solve of a step under a term, and what the term adds to the node.
pub(crate) trait StepTerm {
    /// Solves the step `(h, t_next)` from the node in `state` into `out` (the node increments
    /// Q^j − q_k in `out.incr`, q_{k+1} − q_k in `out.dq`, p_{k+1} − p_k in `out.dp`), with
    /// `last` the previous element (its starting values); returns the iterations.
    ///
    /// # Errors
    /// A failed solve, naming the step and its time.
    fn solve(
        &mut self,
        state: &RunState,
        last: &mut LastElement,
        step: (f64, f64),
        out: &mut Increments,
    ) -> Result<usize>;

    /// The solved step was accepted: the term's carried state moves on.
    fn accepted(&mut self, n: usize);

    /// What the last solved element adds to the run's discrete work.
    fn element_work(&self) -> f64;

    /// Writes the term's carried state (beyond the integrator's) into a checkpoint.
    fn save(&self, w: &mut Words);

    /// Reads what [`StepTerm::save`] wrote; `last` is the restored previous element.
    ///
    /// # Errors
    /// A damaged checkpoint.
    fn load(&mut self, r: &mut Reader<'_>, last: &LastElement) -> Result<()>;

    /// The term's name in a checkpoint's fingerprint.
    fn name(&self) -> &'static str;

    /// Whether the term does work ([`StepTerm::element_work`]): it has forces.
    fn works(&self) -> bool {
        true
    }

    /// The momentum of the new node if the term sets it rather than summing an increment
    /// (the projection onto T*N of a constrained step); read right after the commit.
    fn momentum(&self) -> Option<&[f64]> {
        None
    }

    /// The constraint quantities of a constrained run at the current node; None otherwise.
    fn constraints(&self, _t: f64, _q: &[f64]) -> Option<crate::constraints::NodeConstraints> {
        None
    }

    /// The body angular velocity and momentum of each rotation at the node (t, q, p) of a
    /// run with rotations ([`crate::rotation`]); None otherwise.
    fn rotation_states(&self, _t: f64, _q: &[f64], _p: &[f64]) -> Option<Vec<BodyState>> {
        None
    }

    /// The derivative ∂F_d/∂Q of the term's discrete forces in the nodal values of the element
    /// `el` ((s+1)n square, row-major), for the tangent map of the step
    /// (`term_tangent.rs`); None for a term whose steps are not the forced rows alone (the
    /// constraints, whose map lives on the manifold).
    fn force_jacobian(&mut self, _el: super::ElementNodes<'_>) -> Option<&[f64]> {
        None
    }

    /// The ambient tangent map Φ (2n square) of the last step (t_k, h, t_{k+1}) of a
    /// constrained run, on which the charts of T*N act (`chaos/constrained.rs`); None for a
    /// term without constraints, Some(None) if the linearised step is singular.
    fn ambient_tangent(&mut self, _step: (f64, f64, f64)) -> Option<Option<nalgebra::DMatrix<f64>>> {
        None
    }

    /// The rotation blocks of a run with rotations; None for other terms.
    fn rotations(&self) -> Option<&crate::rotation::Rotations> {
        None
    }

    /// The length of one tangent vector of the run when the term carries them in its own
    /// coordinates (2·slots: the canonical chart coordinates (ψ, p_ψ) of T*SO(3) for each
    /// rotation, (δq, δp) for each ordinary coordinate); None for (δq, δp) of length 2n.
    fn chart_dim(&self) -> Option<usize> {
        None
    }

    /// The tangent map of the last solved step in the term's chart coordinates
    /// ([`StepTerm::chart_dim`] square), for a term that has them; None otherwise.
    fn chart_tangent(&mut self) -> Option<Result<nalgebra::DMatrix<f64>>> {
        None
    }

    /// The largest symplecticity defect of the steps so far, if the term measures it (a
    /// constrained run for `femvi check`, on the manifold).
    fn defect(&self) -> Option<f64> {
        None
    }

    /// The discrete energies of the element solved last from (t, q) with step h, with the
    /// term's shares of them (time steps as variables, `energy.rs`); None if the term has no
    /// energy equation (the integrator then evaluates E⁻, E⁺ of L alone).
    fn energies(&mut self, _t: f64, _h: f64, _q: &[f64]) -> Option<ElementEnergies> {
        None
    }

    /// The discrete energy measured at the current node and its balance so far, if the term
    /// keeps them (forces in the energy mode).
    fn discrete_energy(&self) -> Option<DiscreteEnergy> {
        None
    }

    /// Takes up to `max_steps` steps of the grid in a loop of the term's own, where it has one
    /// for this run (the RATTLE steps of small constrained systems,
    /// `constraints/rattle_loop.rs`), showing every node reached to `at_node` (false stops
    /// after that node): the nodes, bits and carried state of as many
    /// [`StepTerm::solve`]s with the integrator's commits. None if the term has no such loop
    /// here (the integrator then steps one at a time).
    fn advance(
        &mut self,
        _run: TermRun<'_>,
        _max_steps: usize,
        _at_node: &mut dyn FnMut(super::Node<'_>) -> bool,
    ) -> Option<TermAdvance> {
        None
    }
}

/// What a term's own loop ([`StepTerm::advance`]) moves: the integrator's node and last
/// element, along its grid.
pub(crate) struct TermRun<'r> {
    pub(crate) grid: &'r super::TimeGrid,
    pub(crate) state: &'r mut RunState,
    pub(crate) last: &'r mut LastElement,
}

/// How a term's own loop ended: the steps taken, and whether the next step failed (the
/// integrator takes it again by [`StepTerm::solve`], which reports the failure).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct TermAdvance {
    pub(crate) done: usize,
    pub(crate) failed: bool,
}

/// The discrete energy Ẽ of a run in the energy mode with forces, measured on the solved
/// elements (`forces/energy_term.rs`), and its balance Ẽ_k − Ẽ_0 − W_k.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct DiscreteEnergy {
    /// Ẽ_k at the current node: E⁺ + W⁺ of the element before it (NaN at the start node).
    pub(crate) at_node: f64,
    /// Ẽ_0 = E⁻ − W⁻ of the first element (NaN before it).
    pub(crate) first: f64,
    /// The largest |Ẽ_k − Ẽ_0 − W_k| so far.
    pub(crate) max_abs: f64,
    /// The largest |Ẽ_k − Ẽ_0 − W_k| / |Ẽ_0| so far (/ 1 if Ẽ_0 = 0).
    pub(crate) max_rel: f64,
}

/// What an element solved at a trial step gives the energy equation of time steps as
/// variables: g(h) = (E⁻ − W⁻) − Ẽ_k, the carried change (E⁺ − E⁻) + W, and after a step with
/// h as a parameter the new level E⁺ + W⁺ (`forces/energy_term.rs` derives the shares W⁻, W⁺ of
/// the work; without a force they are zero and the equation is the paper's (3.3)).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct ElementEnergies {
    /// E⁻ = ∂L_d/∂t_k.
    pub(crate) minus: f64,
    /// E⁺ = −∂L_d/∂t_{k+1}.
    pub(crate) plus: f64,
    /// W⁻ = h Σ_i b_i (1 − c_i) F_i·q̇_i, the work's share of the element's first node.
    pub(crate) w_minus: f64,
    /// W⁺ = h Σ_i b_i c_i F_i·q̇_i, the share of its last node.
    pub(crate) w_plus: f64,
    /// W = h Σ_i b_i F_i·q̇_i (the reported work).
    pub(crate) work: f64,
    /// Size of the terms of E⁻ − W⁻ (the scale of the search's tolerances).
    pub(crate) magnitude: f64,
}
