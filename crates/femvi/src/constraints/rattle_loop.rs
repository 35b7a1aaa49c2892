//! The RATTLE steps of `rattle.rs` in a loop of their own over `[f64; N]` locals, for small
//! constrained systems (N coordinates, M constraints fixed at compile time): the path of
//! [`Integrator::advance`](crate::Integrator::advance) and of `femvi run` for such runs
//! (issue 33: RATTLE through `femvi run` at the cost of a hand-written loop).
//!
//! A step here is the step of [`Stepper::step`] with its commits, operation for operation:
//! the same drift, the same Newton iteration on u = hλ̂ from the same extrapolated guess, the
//! same momentum and projection with their compensated sums, the same helpers for the dot
//! products, the m×m solves and the conditioning check; so the nodes, the multipliers and the
//! carried state are those of the step-at-a-time path bit for bit
//! (`tests/all/constraints_rattle_loop.rs`). What it saves is the layers around the step: the
//! slices of run-time length, the copies between the stepper, the term and the integrator,
//! and the jets' buffers; the carried state is read from the stepper at the start of a call
//! and written back at its end. A step that fails is not taken here: the loop stops at the
//! node before it, and the integrator takes the step again through [`Stepper::step`], which
//! reports the failure as it always does.

use super::super::jet::{residual as jet_residual, ConstraintJet};
use super::super::limits::RANK_TOLERANCE;
use super::super::rattle::{extrapolate, max_abs, moves_node, ROUNDOFF};
use super::super::small::{conditioning, dot, mass_solve, solve_small};
use super::super::Constraints;
use super::Stepper;
use crate::discrete::Element;
use crate::lagrangian::{Lagrangian, MassMatrix};
use crate::step::state::Node;
use crate::step::term::{TermAdvance, TermRun};
use std::cell::Cell;

#[cfg(test)]
#[path = "rattle_loop_tests.rs"]
mod tests;

#[cfg(test)]
thread_local! {
    /// Steps this thread took in the loop (for the tests: that it ran).
    static LOOP_STEPS: Cell<usize> = const { Cell::new(0) };
}

/// The node as the stepper and the term keep it: q_k, p_k and the projection's velocity.
pub(crate) struct TermNode<'n> {
    pub(crate) q: &'n mut [f64],
    pub(crate) p: &'n mut [f64],
    pub(crate) v: &'n mut [f64],
}

/// What one step carries to the next.
#[derive(Clone, Copy)]
struct Carry<const N: usize, const M: usize> {
    q: [f64; N],
    p: [f64; N],
    /// Compensations of the sums of q and p.
    comp: [f64; N],
    pcomp: [f64; N],
    /// u = hλ̂ of the last step and the history of the extrapolated guess
    /// (`rattle::extrapolate`).
    u: [f64; M],
    hist: [[f64; M]; 3],
    known: usize,
    h_last: f64,
    /// Whether the end jet and force below are those of the node q (after a step here).
    reuse: bool,
    f1: [f64; N],
    g1: [f64; M],
    jac1: [[f64; N]; M],
}

/// Everything a step computed that the stepper keeps after it (written back at the end).
#[derive(Clone, Copy)]
struct Taken<const N: usize, const M: usize> {
    q0: [f64; N],
    p0: [f64; N],
    dq: [f64; N],
    f0: [f64; N],
    p_tilde: [f64; N],
    v: [f64; N],
    g0: [f64; M],
    jac0: [[f64; N]; M],
    lambda: [f64; M],
    mu: [f64; M],
    iterations: usize,
    t: f64,
    h: f64,
}

impl<const N: usize, const M: usize> Taken<N, M> {
    fn zero() -> Self {
        let (x, y) = ([0.0; N], [0.0; M]);
        Self {
            q0: x,
            p0: x,
            dq: x,
            f0: x,
            p_tilde: x,
            v: x,
            g0: y,
            jac0: [x; M],
            lambda: y,
            mu: y,
            iterations: 0,
            t: 0.0,
            h: 0.0,
        }
    }
}

/// The fixed parts of the run: the model, the element's weights and the solver's settings.
struct Setting<'s, L, C> {
    lag: &'s L,
    con: &'s C,
    /// Whether the constraints have compiled g and G ([`Constraints::value_and_jacobian`]);
    /// else the jets differentiate [`Constraints::value`].
    compiled: bool,
    mass: &'s MassMatrix,
    weights: (f64, f64),
    tol: f64,
    max_iterations: usize,
    autonomous: bool,
}

impl Stepper {
    /// Up to `max_steps` RATTLE steps of the run `run` in the loop of this module, for N
    /// coordinates and M constraints; None where the loop does not apply (not a RATTLE run,
    /// no mass matrix). The term's node is `node`, its largest end residual `max_residual`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn rattle_loop<L: Lagrangian, C: Constraints, const N: usize, const M: usize>(
        &mut self,
        (lag, con, element): (&L, &C, &Element),
        node: TermNode<'_>,
        max_residual: &Cell<f64>,
        run: TermRun<'_>,
        max_steps: usize,
        at_node: &mut dyn FnMut(Node<'_>) -> bool,
    ) -> Option<TermAdvance> {
        let mass = lag.mass_matrix()?;
        let weights = (*element.rule.weights.first()?, *element.rule.weights.get(1)?);
        let (mut c, compiled) = self.load_carry::<N, M>(con, &node)?;
        let set = Setting {
            lag,
            con,
            compiled,
            mass,
            weights,
            tol: self.tol,
            max_iterations: self.max_iterations,
            autonomous: lag.is_autonomous(),
        };
        let TermRun { grid, state, last } = run;
        let (mut k, mut t) = (state.k, state.t);
        let (mut done, mut failed, mut iterations) = (0, false, 0);
        let mut taken = Taken::<N, M>::zero();
        let mut residual = max_residual.get();
        while done < max_steps {
            let Some((h, t_next)) = grid.next(k, t) else { break };
            let scratch = (&mut self.scratch[..], &mut self.jet);
            if !step(&set, &mut c, (t, h), scratch, &mut taken) {
                failed = true;
                break;
            }
            residual = residual.max(jet_residual(&c.g1));
            iterations += taken.iterations;
            (k, t) = (k + 1, t_next);
            done += 1;
            if !at_node(Node { k, t, q: &c.q, p: &c.p }) {
                break;
            }
        }
        #[cfg(test)]
        LOOP_STEPS.with(|s| s.set(s.get() + done));
        if done > 0 {
            max_residual.set(residual);
            self.store_carry(&c, &taken, node);
            state.q.copy_from_slice(&c.q);
            state.p.copy_from_slice(&c.p);
            state.comp_q.copy_from_slice(&c.comp);
            state.comp_p.iter_mut().for_each(|x| *x = 0.0);
            (state.k, state.t) = (k, t);
            state.steps += done;
            state.iterations += iterations;
            last.valid = true;
            (last.t, last.h) = (taken.t, taken.h);
            last.base.copy_from_slice(&taken.q0);
            last.incr[..N].iter_mut().for_each(|x| *x = 0.0);
            last.incr[N..2 * N].copy_from_slice(&taken.dq);
        }
        Some(TermAdvance { done, failed })
    }

    /// The carried state from the stepper and the term's node, and whether the constraints
    /// have compiled g and G; None if the sizes differ.
    fn load_carry<const N: usize, const M: usize>(
        &self,
        con: &impl Constraints,
        node: &TermNode<'_>,
    ) -> Option<(Carry<N, M>, bool)> {
        let rattle = self.rattle.as_ref()?;
        let (q, p) = (array::<N>(node.q)?, array::<N>(node.p)?);
        let (mut g, mut jac) = ([0.0; M], [[0.0; N]; M]);
        // The probe: whether g and G are compiled, which `ConstraintJet::eval` asks first.
        let compiled = con.value_and_jacobian(&q, &mut g, jac.as_flattened_mut());
        let reuse = self.end_at_node;
        if reuse {
            g = array::<M>(&self.sys.end.g)?;
            jac.as_flattened_mut().copy_from_slice(self.sys.end.jac.get(..N * M)?);
        }
        let carry = Carry {
            q,
            p,
            comp: array::<N>(&self.comp)?,
            pcomp: array::<N>(&rattle.pcomp)?,
            u: array::<M>(self.x.get(N..N + M)?)?,
            hist: [
                array::<M>(rattle.hist.get(..M)?)?,
                array::<M>(rattle.hist.get(M..2 * M)?)?,
                array::<M>(rattle.hist.get(2 * M..)?)?,
            ],
            known: rattle.known,
            h_last: rattle.h_last,
            reuse,
            f1: array::<N>(&rattle.f1)?,
            g1: g,
            jac1: jac,
        };
        Some((carry, compiled))
    }

    /// Writes back what the step-at-a-time path would hold after the last step taken.
    fn store_carry<const N: usize, const M: usize>(
        &mut self,
        c: &Carry<N, M>,
        taken: &Taken<N, M>,
        node: TermNode<'_>,
    ) {
        node.q.copy_from_slice(&c.q);
        node.p.copy_from_slice(&c.p);
        node.v.copy_from_slice(&taken.v);
        self.x[..N].copy_from_slice(&taken.dq);
        self.x[N..N + M].copy_from_slice(&c.u);
        self.comp.copy_from_slice(&c.comp);
        self.q_prev.copy_from_slice(&taken.q0);
        self.p_prev.copy_from_slice(&taken.p0);
        self.mu.copy_from_slice(&taken.mu);
        self.iterations = taken.iterations;
        self.sys.start.g.copy_from_slice(&taken.g0);
        self.sys.start.jac.copy_from_slice(taken.jac0.as_flattened());
        self.sys.end.g.copy_from_slice(&c.g1);
        self.sys.end.jac.copy_from_slice(c.jac1.as_flattened());
        self.sys.mult[..M].copy_from_slice(&taken.lambda);
        self.end_at_node = true;
        if let Some(rattle) = self.rattle.as_mut() {
            rattle.f0.copy_from_slice(&taken.f0);
            rattle.f1.copy_from_slice(&c.f1);
            rattle.p_tilde.copy_from_slice(&taken.p_tilde);
            rattle.pcomp.copy_from_slice(&c.pcomp);
            rattle.mu.copy_from_slice(&taken.mu);
            rattle.hist.copy_from_slice(c.hist.as_flattened());
            (rattle.known, rattle.h_last) = (c.known, c.h_last);
        }
    }
}

impl<L, C: Constraints> Setting<'_, L, C> {
    /// g and G at `q` as [`ConstraintJet::eval`] gives them (without second derivatives).
    #[inline(always)]
    fn jet<const N: usize, const M: usize>(
        &self,
        scratch: &mut ConstraintJet,
        q: &[f64; N],
        g: &mut [f64; M],
        jac: &mut [[f64; N]; M],
    ) {
        if self.compiled {
            self.con.value_and_jacobian(q, g, jac.as_flattened_mut());
        } else {
            scratch.eval(self.con, q, false);
            g.copy_from_slice(&scratch.g);
            jac.as_flattened_mut().copy_from_slice(&scratch.jac);
        }
    }
}

/// A slice of length K as an array.
fn array<const K: usize>(x: &[f64]) -> Option<[f64; K]> {
    x.get(..K)?.try_into().ok()
}

/// One RATTLE step from the node in `c` at (t, h) (`RattleStep::solve`, `momentum` and
/// `project` with the stepper's and the integrator's commits): `c` moves to the new node and
/// the step's values go to `taken`; false, with `c` unchanged, if the step fails anywhere.
#[inline(always)]
fn step<L: Lagrangian, C: Constraints, const N: usize, const M: usize>(
    set: &Setting<'_, L, C>,
    c: &mut Carry<N, M>,
    (t, h): (f64, f64),
    (scratch, jet): (&mut [f64], &mut ConstraintJet),
    taken: &mut Taken<N, M>,
) -> bool {
    let (mass, half) = (set.mass, h * 0.5);
    // The start jet and force: the last step's end ones at this very node, or evaluated.
    let (mut g0, mut jac0, mut f0) = (c.g1, c.jac1, c.f1);
    if !c.reuse {
        set.jet(jet, &c.q, &mut g0, &mut jac0);
    }
    if !(c.reuse && set.autonomous) {
        set.lag.force(t, &c.q, &mut f0);
    }
    let scale = c.q.iter().fold(1.0f64, |a, &b| a.max(b.abs()));
    let (mut row, mut y, mut drift) = ([0.0; N], [0.0; N], [0.0; N]);
    for i in 0..N {
        row[i] = c.pcomp[i] + half * f0[i];
    }
    mass_solve(mass, &row, &mut y);
    mass_solve(mass, &c.p, &mut drift);
    for i in 0..N {
        drift[i] = h * (drift[i] + y[i]);
    }
    let mut w = [[0.0; N]; M];
    for l in 0..M {
        mass_solve(mass, &jac0[l], &mut w[l]);
    }
    let (mut u, mut hist, mut known, mut h_last) = (c.u, c.hist, c.known, c.h_last);
    extrapolate(&mut u, hist.as_flattened_mut(), (&mut known, &mut h_last), h);
    let (mut g1, mut jac1) = ([0.0; M], [[0.0; N]; M]);
    let (mut iterations, mut converged) = (0, false);
    let mut last_mat = [[0.0; M]; M];
    let mut dq: [f64; N];
    loop {
        dq = drift;
        for l in 0..M {
            for a in 0..N {
                dq[a] -= u[l] * w[l][a];
            }
        }
        for a in 0..N {
            y[a] = c.q[a] + (dq[a] + c.comp[a]);
        }
        set.jet(jet, &y, &mut g1, &mut jac1);
        let rnorm = jet_residual(&g1);
        if !rnorm.is_finite() || !jac1.as_flattened().iter().all(|x| x.is_finite()) {
            return false;
        }
        if converged || rnorm == 0.0 {
            break;
        }
        // The check of the iterate with the last matrix (`RattleStep::solve`).
        if iterations > 0 {
            let (mut mat, mut rhs) = (last_mat, g1);
            if solve_small(mat.as_flattened_mut(), &mut rhs, M)
                && moves_node(&rhs, w.as_flattened(), N) <= ROUNDOFF * scale
            {
                break;
            }
        }
        if iterations == set.max_iterations {
            return false;
        }
        let (mut mat, mut rhs) = ([[0.0; M]; M], g1);
        for i in 0..M {
            for l in 0..M {
                mat[i][l] = dot(&jac1[i], &w[l]);
            }
        }
        last_mat = mat;
        if !solve_small(mat.as_flattened_mut(), &mut rhs, M) {
            return false;
        }
        let dnorm = max_abs(&rhs);
        for l in 0..M {
            u[l] += rhs[l];
        }
        iterations += 1;
        converged = dnorm <= set.tol * scale;
    }
    let mut lambda = [0.0; M];
    for l in 0..M {
        lambda[l] = u[l] / h;
    }
    // The momentum before the projection (`RattleStep::momentum`).
    let mut f1 = [0.0; N];
    set.lag.force(t + h, &y, &mut f1);
    let (b0, b1) = set.weights;
    let mut pt = [0.0; N];
    for i in 0..N {
        pt[i] = h * (b0 * f0[i] + b1 * f1[i]);
    }
    for l in 0..M {
        for a in 0..N {
            pt[a] += -lambda[l] * jac0[l][a];
        }
    }
    for i in 0..N {
        pt[i] += c.pcomp[i];
    }
    // q_{k+1} by compensated summation (`stepper.rs`, `commit`).
    let (mut q1, mut comp) = ([0.0; N], c.comp);
    for a in 0..N {
        let yv = dq[a] + comp[a];
        let sum = c.q[a] + yv;
        comp[a] = yv - (sum - c.q[a]);
        q1[a] = sum;
    }
    // G at the new node of full rank (`conditioning`; one row: nonzero, without the root).
    let full_rank = if M == 1 {
        let norm2 = dot(&jac1[0], &jac1[0]);
        norm2 > 0.0 && norm2.is_finite()
    } else {
        conditioning(jac1.as_flattened(), M, N, scratch) > RANK_TOLERANCE
    };
    if !full_rank {
        return false;
    }
    // The projection onto T*N (`RattleStep::project`).
    let mut w1 = [[0.0; N]; M];
    for l in 0..M {
        mass_solve(mass, &jac1[l], &mut w1[l]);
    }
    let (mut mat, mut rhs) = ([[0.0; M]; M], [0.0; M]);
    for i in 0..M {
        for l in 0..M {
            mat[i][l] = dot(&jac1[i], &w1[l]);
        }
        rhs[i] = dot(&w1[i], &c.p) + dot(&w1[i], &pt);
    }
    if !solve_small(mat.as_flattened_mut(), &mut rhs, M) {
        return false;
    }
    let mu = rhs;
    for l in 0..M {
        for a in 0..N {
            pt[a] += -mu[l] * jac1[l][a];
        }
    }
    let (mut p1, mut pcomp) = ([0.0; N], [0.0; N]);
    for a in 0..N {
        let yv = pt[a];
        let sum = c.p[a] + yv;
        pcomp[a] = yv - (sum - c.p[a]);
        p1[a] = sum;
    }
    // The integrator's commit checks the new node is finite (x·0 is NaN exactly when x is
    // not finite: one sum tells whether all are).
    let mut probe = 0.0;
    for a in 0..N {
        probe += q1[a] * 0.0 + p1[a] * 0.0;
    }
    if probe.is_nan() {
        return false;
    }
    let mut v = [0.0; N];
    mass_solve(mass, &p1, &mut v);
    (taken.q0, taken.p0, taken.dq, taken.f0, taken.p_tilde, taken.v) = (c.q, c.p, dq, f0, pt, v);
    (taken.g0, taken.jac0, taken.lambda, taken.mu) = (g0, jac0, lambda, mu);
    (taken.iterations, taken.t, taken.h) = (iterations, t, h);
    (c.q, c.p, c.comp, c.pcomp, c.f1, c.g1, c.jac1) = (q1, p1, comp, pcomp, f1, g1, jac1);
    (c.u, c.hist, c.known, c.h_last, c.reuse) = (u, hist, known, h_last, true);
    true
}
