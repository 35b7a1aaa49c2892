//! The state of a run apart from any solver: the current node (k, t_k, q_k, p_k) with the
//! compensation terms of its sums, the counters, and the last solved element (what dense
//! output, tangent maps and the solvers' starting values read). A solved step is moved into
//! the state by [`RunState::commit`]: positions and momenta advance by increments with
//! compensated (Kahan) summation, so round-off grows like √steps.

use super::checkpoint::{Reader, Words};
use crate::error::{Error, Result, StepError, StepFailure};

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

/// The node a run is at, with the compensation terms of q and p, and the counters.
#[derive(Debug, Clone)]
pub(crate) struct RunState {
    pub(crate) n: usize,
    pub(crate) k: usize,
    pub(crate) t: f64,
    pub(crate) q: Vec<f64>,
    pub(crate) p: Vec<f64>,
    pub(crate) comp_q: Vec<f64>,
    pub(crate) comp_p: Vec<f64>,
    /// Velocity at the start, for the first guess of the implicit solvers.
    pub(crate) v0: Vec<f64>,
    /// Solver iterations and steps so far (for the mean).
    pub(crate) iterations: usize,
    pub(crate) steps: usize,
}

/// The element of the last accepted step (or of the start from (q0, q1)).
#[derive(Debug, Clone)]
pub(crate) struct LastElement {
    pub(crate) valid: bool,
    pub(crate) t: f64,
    pub(crate) h: f64,
    pub(crate) base: Vec<f64>,
    /// Nodal increments, row-major (s+1)×n.
    pub(crate) incr: Vec<f64>,
}

/// What a solver leaves for [`RunState::commit`]: the nodal increments of the solved element
/// (row 0 zero) and the increments of q and p over the step.
#[derive(Debug, Clone)]
pub(crate) struct Increments {
    pub(crate) incr: Vec<f64>,
    pub(crate) dq: Vec<f64>,
    pub(crate) dp: Vec<f64>,
}

impl Increments {
    pub(crate) fn new(s: usize, n: usize) -> Self {
        Self {
            incr: vec![0.0; (s + 1) * n],
            dq: vec![0.0; n],
            dp: vec![0.0; n],
        }
    }
}

impl RunState {
    pub(crate) fn new(n: usize, t0: f64) -> Self {
        Self {
            n,
            k: 0,
            t: t0,
            q: vec![0.0; n],
            p: vec![0.0; n],
            comp_q: vec![0.0; n],
            comp_p: vec![0.0; n],
            v0: vec![0.0; n],
            iterations: 0,
            steps: 0,
        }
    }

    /// The current node.
    #[inline]
    pub(crate) fn node(&self) -> Node<'_> {
        Node {
            k: self.k,
            t: self.t,
            q: &self.q,
            p: &self.p,
        }
    }

    /// Largest |q_k| (at least the smallest positive number): the scale of tolerances.
    #[inline]
    pub(crate) fn qscale(&self) -> f64 {
        self.q.iter().fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()))
    }

    /// Moves the state to the node solved with step h (increments in `inc`) and makes the
    /// element the last one. Buffers are swapped, not copied (copies of a few numbers cost
    /// more than the Verlet step itself); `swap_incr` is false for explicit steps, whose
    /// element is the end increment dq alone (copied here into the last element).
    ///
    /// Errors: [`StepFailure::NonFinite`] if the new node is not finite; nothing is moved then.
    #[inline]
    pub(crate) fn commit(
        &mut self,
        last: &mut LastElement,
        inc: &mut Increments,
        swap_incr: bool,
        h: f64,
        t_next: f64,
    ) -> Result<()> {
        // The new node's finiteness first, from the same sums as below, so that a step that
        // fails leaves the run at its last good node (the promise of `Integrator::step`).
        let mut finite = true;
        for c in 0..self.n {
            let q = self.q[c] + (inc.dq[c] + self.comp_q[c]);
            let p = self.p[c] + (inc.dp[c] + self.comp_p[c]);
            finite &= p.is_finite() && q.is_finite();
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
        last.valid = true;
        last.t = self.t;
        last.h = h;
        std::mem::swap(&mut self.q, &mut last.base);
        if swap_incr {
            std::mem::swap(&mut inc.incr, &mut last.incr);
        } else {
            // An explicit step: its element is q_k + τ dq (the end increment only).
            last.incr[self.n..2 * self.n].copy_from_slice(&inc.dq[..self.n]);
        }
        for c in 0..self.n {
            let base = last.base[c];
            let y = inc.dq[c] + self.comp_q[c];
            let t = base + y;
            self.comp_q[c] = (base - t) + y;
            self.q[c] = t;
            let y = inc.dp[c] + self.comp_p[c];
            let t = self.p[c] + y;
            self.comp_p[c] = (self.p[c] - t) + y;
            self.p[c] = t;
        }
        self.k += 1;
        self.t = t_next;
        self.steps += 1;
        Ok(())
    }
}

impl RunState {
    pub(crate) fn save(&self, w: &mut Words) {
        w.u(self.k);
        w.f(self.t);
        for v in [&self.q, &self.p, &self.comp_q, &self.comp_p, &self.v0] {
            w.fs(v);
        }
        w.u(self.iterations);
        w.u(self.steps);
    }

    pub(crate) fn load(&mut self, r: &mut Reader<'_>) -> Result<()> {
        self.k = r.u()?;
        self.t = r.f()?;
        for v in [
            &mut self.q,
            &mut self.p,
            &mut self.comp_q,
            &mut self.comp_p,
            &mut self.v0,
        ] {
            r.fs(v)?;
        }
        self.iterations = r.u()?;
        self.steps = r.u()?;
        Ok(())
    }
}

impl LastElement {
    pub(crate) fn save(&self, w: &mut Words) {
        w.b(self.valid);
        w.f(self.t);
        w.f(self.h);
        w.fs(&self.base);
        w.fs(&self.incr);
    }

    pub(crate) fn load(&mut self, r: &mut Reader<'_>) -> Result<()> {
        self.valid = r.b()?;
        self.t = r.f()?;
        self.h = r.f()?;
        r.fs(&mut self.base)?;
        r.fs(&mut self.incr)
    }

    pub(crate) fn new(s: usize, n: usize, t0: f64) -> Self {
        Self {
            valid: false,
            t: t0,
            h: 0.0,
            base: vec![0.0; n],
            incr: vec![0.0; (s + 1) * n],
        }
    }

    /// The element as a public view, if there is one.
    #[inline]
    pub(crate) fn view(&self) -> Option<ElementNodes<'_>> {
        self.valid.then_some(ElementNodes {
            t: self.t,
            h: self.h,
            base: &self.base,
            incr: &self.incr,
        })
    }

    /// Records the element [t, t + h] from `base` with the increments `incr`.
    pub(crate) fn remember(&mut self, t: f64, h: f64, base: &[f64], incr: &[f64]) {
        self.valid = true;
        self.t = t;
        self.h = h;
        self.base.copy_from_slice(base);
        self.incr.copy_from_slice(incr);
    }
}
