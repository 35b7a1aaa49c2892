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
//! ([`Integrator::work`](super::Integrator::work)).

use super::checkpoint::{Reader, Words};
use super::state::{Increments, LastElement, RunState};
use crate::error::Result;

/// The solve of a step under a term, and what the term adds to the node.
pub(crate) trait StepTerm {
    /// Solves the step of size `h` from the node in `state` into `out` (the node increments
    /// Q^j − q_k in `out.incr`, q_{k+1} − q_k in `out.dq`, p_{k+1} − p_k in `out.dp`), with
    /// `last` the previous element (its starting values); returns the iterations.
    ///
    /// # Errors
    /// A failed solve, naming the step and its time.
    fn solve(&mut self, state: &RunState, last: &mut LastElement, h: f64, out: &mut Increments) -> Result<usize>;

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
}
