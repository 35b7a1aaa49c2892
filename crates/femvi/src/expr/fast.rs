//! The compiled derivatives of an expression Lagrangian, built once at load: the symbolic
//! gradient (reverse mode over the expression graph) and Hessian (forward mode over the
//! gradient graph) as flat f64 tapes, and, when the expression is mechanical
//! (L = ½vᵀMv − V(t, q) with constant M, found by [`structure::expand`]), the mass matrix and a
//! tape of the force −∂V/∂q, so that the fixed-point and explicit solvers apply; when it is
//! gyroscopic (L = ½vᵀMv + A(t, q)·v − V(t, q)), M and a tape of A and ∂L/∂q for the
//! gyroscopic fixed point (step/gyroscopic/mod.rs).
//!
//! Every part is optional: an expression whose graph outgrows the node budget, or whose
//! Hessian would cost more than [`HESSIAN_WORK`] node visits to build, keeps automatic
//! differentiation for that part. A quadratic form that is not positive definite gives no
//! mass matrix, so the general path and its regularity check (singular Hessians rejected as
//! today) handle it exactly as before.

use super::dag::{Dag, Id};
use super::program::Program;
use super::structure;
use super::tape::Tape;
use crate::lagrangian::MassMatrix;

/// The most node visits (variables × graph size) spent building a Hessian tape.
pub(super) const HESSIAN_WORK: usize = 20_000_000;

/// Compiled tapes of one expression Lagrangian.
#[derive(Debug, Clone, Default)]
pub(super) struct Fast {
    /// M, when L = ½vᵀMv − V(t, q) with M constant and positive definite.
    pub(super) mass: Option<MassMatrix>,
    /// ∂L/∂q at v = 0 (the force −∂V/∂q), n outputs; only with `mass`.
    pub(super) force: Option<Tape>,
    /// M, when L = ½vᵀMv + A(t, q)·v − V(t, q) with A ≠ 0 and M constant and positive
    /// definite (gyroscopic).
    pub(super) gyro_mass: Option<MassMatrix>,
    /// A (n outputs) then ∂L/∂q (n outputs) over (t, q, v); only with `gyro_mass`.
    pub(super) gyro: Option<Tape>,
    /// L and ∂L/∂z for z = (t, q, v): 1 + (2n + 1) outputs.
    pub(super) first: Option<Tape>,
    /// L, ∂L/∂z and ∂²L/∂z_a∂z_b for a ≤ b (row by row): 1 + m + m(m + 1)/2 outputs.
    pub(super) second: Option<Tape>,
    /// The program's f64 value as machine code (equal to `Program::eval` bit for bit).
    #[cfg(feature = "jit")]
    pub(super) value: Option<std::sync::Arc<super::native::Native>>,
}

impl Fast {
    /// Compiles what fits the budgets for `program` over t, q and v of dimension n.
    pub(super) fn new(program: &Program, n: usize) -> Self {
        let mut fast = Self::default();
        #[cfg(feature = "jit")]
        {
            fast.value = super::native::compile_program(program.ops(), n).map(std::sync::Arc::new);
        }
        let mut dag = Dag::default();
        let Some(root) = dag.add_program(program.ops()) else {
            return fast;
        };
        let m = 2 * n + 1;
        if let Some(exp) = structure::expand(&mut dag, root, n) {
            let mass = exp.mass(n).and_then(|(diag, off)| mass_matrix(n, diag, &off));
            if exp.c1.is_empty() {
                fast.force = mass.as_ref().and_then(|_| force_tape(&mut dag, exp.c0, n));
                fast.mass = mass.filter(|_| fast.force.is_some());
            } else {
                fast.gyro = mass.as_ref().and_then(|_| gyro_tape(&mut dag, root, &exp.c1, n));
                fast.gyro_mass = mass.filter(|_| fast.gyro.is_some());
            }
        }
        let Some(grad) = dag.gradient(root, m) else {
            return fast;
        };
        let mut outs = vec![root];
        outs.extend(&grad);
        fast.first = Some(Tape::new(&dag, &outs, n));
        if m.saturating_mul(dag.reachable(&grad).len()) > HESSIAN_WORK {
            return fast;
        }
        let mut upper = Vec::with_capacity(m * (m + 1) / 2);
        let mut columns = Vec::with_capacity(m);
        for b in 0..m {
            let Some(col) = dag.derivative(&grad, b) else {
                return fast;
            };
            columns.push(col);
        }
        for a in 0..m {
            for col in &columns[a..] {
                upper.push(col[a]);
            }
        }
        outs.extend(upper);
        fast.second = Some(Tape::new(&dag, &outs, n));
        fast
    }
}

/// The mass matrix with diagonal `diag` and upper off-diagonal entries `off`, if positive
/// definite (stored as diagonal when `off` is empty: O(n) for large systems).
fn mass_matrix(n: usize, diag: Vec<f64>, off: &[(usize, usize, f64)]) -> Option<MassMatrix> {
    if off.is_empty() {
        return MassMatrix::diagonal(diag).ok();
    }
    let len = n.checked_mul(n)?;
    let mut m = vec![0.0; len];
    for (i, d) in diag.iter().enumerate() {
        m[i * n + i] = *d;
    }
    for &(i, j, c) in off {
        m[i * n + j] = c;
        m[j * n + i] = c;
    }
    MassMatrix::dense(n, m).ok()
}

/// The tape of the force's derivative along v, (∂f/∂q)·v with f = ∂c0/∂q, over (t, q, v)
/// (n outputs), for a mechanical `program` (built on first use by
/// [`crate::Lagrangian::force_derivative`] of [`super::ExprLagrangian`]); None if the
/// expression is not mechanical or the graph outgrows its budget.
pub(super) fn force_derivative_tape(program: &Program, n: usize) -> Option<Tape> {
    let mut dag = Dag::default();
    let root = dag.add_program(program.ops())?;
    let exp = structure::expand(&mut dag, root, n)?;
    if !exp.c1.is_empty() {
        return None;
    }
    let force = match exp.c0 {
        Some(c0) => dag.gradient(c0, 1 + n)?,
        None => {
            let zero = dag.constant(0.0);
            return Some(Tape::new(&dag, &vec![zero; n], n));
        }
    };
    let dirs: Vec<Id> = (0..n).map(|j| dag.var(1 + n + j)).collect();
    let outs = dag.directional(force.get(1..)?, &|i| (1..=n).contains(&i).then(|| dirs[i - 1]))?;
    Some(Tape::new(&dag, &outs, n))
}

/// The tape of ∂c0/∂q (c0 None means 0).
fn force_tape(dag: &mut Dag, c0: Option<Id>, n: usize) -> Option<Tape> {
    let grad = match c0 {
        Some(c0) => dag.gradient(c0, 1 + n)?,
        None => vec![dag.constant(0.0); 1 + n],
    };
    Some(Tape::new(dag, grad.get(1..)?, n))
}

/// The tape of A (the coefficients `c1` of the velocities, 0 where absent) and ∂L/∂q of the
/// whole Lagrangian `root` (= (∂A/∂q)ᵀv + ∂c0/∂q when the quadratic part is constant).
fn gyro_tape(dag: &mut Dag, root: Id, c1: &std::collections::BTreeMap<usize, Id>, n: usize) -> Option<Tape> {
    let grad = dag.gradient(root, 1 + n)?;
    let zero = dag.constant(0.0);
    let mut outs: Vec<Id> = (0..n).map(|i| c1.get(&i).copied().unwrap_or(zero)).collect();
    outs.extend(grad.get(1..)?);
    Some(Tape::new(dag, &outs, n))
}
