//! The value and Jacobian of several expressions in the coordinates q alone (holonomic
//! constraints g(q), `constraints/expr.rs`), compiled once: each expression's symbolic
//! gradient (`dag.rs`, reverse mode) on one flat tape of m + m·n outputs (`tape.rs`), which
//! with the `jit` feature runs as machine code. The RATTLE step evaluates g and G = ∂g/∂q
//! at every Newton iterate; forward-mode dual numbers through the interpreted program took n
//! passes for G. Equal to automatic differentiation up to rounding.

use super::dag::Dag;
use super::program::Program;
use super::tape::Tape;

/// g and G of m expressions over n coordinates on one tape.
#[derive(Debug, Clone)]
pub(crate) struct JacobianTape {
    tape: Tape,
    m: usize,
    n: usize,
}

impl JacobianTape {
    /// The tape of `programs` (each compiled over the n coordinates, variable i = q_i); None
    /// for n = 0 or an expression beyond the graph's node budget (which then keeps automatic
    /// differentiation).
    pub(crate) fn new(programs: &[Program], n: usize) -> Option<Self> {
        if n == 0 {
            return None;
        }
        let mut dag = Dag::default();
        let roots = programs
            .iter()
            .map(|p| dag.add_program(p.ops()))
            .collect::<Option<Vec<_>>>()?;
        let mut outputs = roots.clone();
        for &root in &roots {
            outputs.extend(dag.gradient(root, n)?);
        }
        // The tape reads variable 0 as t and variable i ≥ 1 as q_{i-1} of its q slice (the
        // layout of Lagrangians over (t, q, v)): [`JacobianTape::eval`] hands it q_0 as t and
        // q_1.. as q, over n − 1 "coordinates" and no velocities.
        let tape = Tape::new(&dag, &outputs, n - 1);
        Some(Self {
            tape,
            m: programs.len(),
            n,
        })
    }

    /// g(q) into `g` (m entries) and G(q) row by row into `jac` (m n entries); false (nothing
    /// written) for slices of other lengths.
    pub(crate) fn eval(&self, q: &[f64], g: &mut [f64], jac: &mut [f64]) -> bool {
        let (m, n) = (self.m, self.n);
        if q.len() != n || g.len() != m || jac.len() != m * n {
            return false;
        }
        let (first, rest) = q.split_at(1);
        self.tape.eval(first[0], rest, &[], |j, x| {
            if j < m {
                g[j] = x;
            } else {
                jac[j - m] = x;
            }
        });
        true
    }
}
