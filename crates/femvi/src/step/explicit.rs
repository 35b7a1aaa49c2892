//! Explicit stepping: degree 1 with the trapezoid rule on a mechanical Lagrangian is
//! Störmer–Verlet (the paper's linear element, §2.3), Δq = h M⁻¹p + ½h² M⁻¹f_k,
//! Δp = ½h (f_k + f_{k+1}). Two paths with the same increments up to rounding: a step at a
//! time over the run's buffers ([`ExplicitStep::step`]), and a tight loop over `[f64; N]`
//! locals for small fixed sizes ([`ExplicitStep::advance`]) that keeps the compensated
//! momentum lazily between calls; and for other sizes with M = I, a loop that fuses the
//! commit of a step with the drift of the next (`explicit_wide.rs`, same bits as `step`),
//! which for a local force takes long chains in blocks of space and time
//! (`explicit_blocked.rs`, same bits).

#[path = "explicit_blocked.rs"]
mod blocked;
#[path = "explicit_wide.rs"]
mod wide;

pub(crate) use blocked::block_radius;

use super::checkpoint::{Reader, Words};
use super::grid::TimeGrid;
use super::state::{Increments, LastElement, Node, RunState};
use crate::error::{Error, Result, StepError, StepFailure};
use crate::lagrangian::{Lagrangian, MassMatrix};

/// The explicit solver's force buffers and the fast path's lazy state.
#[derive(Debug, Clone)]
pub(crate) struct ExplicitStep {
    /// Forces at the two ends of a step, alternating halves (the end force of one step is the
    /// start force of the next).
    force: Vec<f64>,
    fsal_slot: usize,
    force0_valid: bool,
    y: Vec<f64>,
    u: Vec<f64>,
    tmp: Vec<f64>,
    /// The fast path's momentum: the compensated sum (p, cp) without the last increment
    /// `pending`, the force at the node before the current one and the step that led to the
    /// current node (the drift formula), valid once the fast path ran.
    lazy_valid: bool,
    lazy_p: Vec<f64>,
    lazy_cp: Vec<f64>,
    lazy_pending: Vec<f64>,
    lazy_fprev: Vec<f64>,
    lazy_hprev: f64,
    /// The start of a call of the wide loop (`explicit_wide.rs`): compensation of q, p,
    /// compensation of p, carried force, q; empty until that loop needs it.
    start: Vec<f64>,
}

/// The fast path's carried values in fixed-size arrays.
#[derive(Clone, Copy)]
struct Carry<const N: usize> {
    q: [f64; N],
    cq: [f64; N],
    p: [f64; N],
    cp: [f64; N],
    pending: [f64; N],
    fprev: [f64; N],
    hprev: f64,
    f0: [f64; N],
}

fn load<const N: usize>(v: &[f64]) -> [f64; N] {
    let mut a = [0.0; N];
    a.copy_from_slice(&v[..N]);
    a
}

impl ExplicitStep {
    pub(crate) fn new(n: usize) -> Self {
        Self {
            force: vec![0.0; 2 * n],
            fsal_slot: 0,
            force0_valid: false,
            y: vec![0.0; n],
            u: vec![0.0; n],
            tmp: vec![0.0; n],
            lazy_valid: false,
            lazy_p: vec![0.0; n],
            lazy_cp: vec![0.0; n],
            lazy_pending: vec![0.0; n],
            lazy_fprev: vec![0.0; n],
            lazy_hprev: 0.0,
            start: Vec::new(),
        }
    }

    /// The carried forces and lazy momentum (checkpoints).
    pub(crate) fn save_state(&self, w: &mut Words) {
        w.fs(&self.force);
        w.u(self.fsal_slot);
        w.b(self.force0_valid);
        w.b(self.lazy_valid);
        for v in [&self.lazy_p, &self.lazy_cp, &self.lazy_pending, &self.lazy_fprev] {
            w.fs(v);
        }
        w.f(self.lazy_hprev);
    }

    pub(crate) fn load_state(&mut self, r: &mut Reader<'_>) -> Result<()> {
        r.fs(&mut self.force)?;
        self.fsal_slot = r.u()? & 1;
        self.force0_valid = r.b()?;
        self.lazy_valid = r.b()?;
        for v in [
            &mut self.lazy_p,
            &mut self.lazy_cp,
            &mut self.lazy_pending,
            &mut self.lazy_fprev,
        ] {
            r.fs(v)?;
        }
        self.lazy_hprev = r.f()?;
        Ok(())
    }

    /// One Verlet step of size h from the current node into `out` (`RunState::commit` makes
    /// its dq the last element's end increment: explicit steps do not swap increments).
    #[inline]
    pub(crate) fn step<L: Lagrangian>(
        &mut self,
        lag: &L,
        mass: &MassMatrix,
        state: &RunState,
        h: f64,
        out: &mut Increments,
    ) {
        let n = state.n;
        let (lo, hi) = self.force.split_at_mut(n);
        let (f0, f1) = if self.fsal_slot == 0 {
            (lo, &mut hi[..n])
        } else {
            (&mut hi[..n], lo)
        };
        if !self.force0_valid {
            lag.force(state.t, &state.q, f0);
        }
        let half_h2 = 0.5 * h * h;
        if mass.is_identity() {
            for c in 0..n {
                out.dq[c] = h * state.p[c] + half_h2 * f0[c];
                self.y[c] = state.q[c] + out.dq[c];
            }
        } else {
            mass.solve(&state.p, &mut self.u);
            mass.solve(f0, &mut self.tmp);
            for c in 0..n {
                out.dq[c] = h * self.u[c] + half_h2 * self.tmp[c];
                self.y[c] = state.q[c] + out.dq[c];
            }
        }
        lag.force(state.t + h, &self.y[..n], f1);
        for c in 0..n {
            out.dp[c] = 0.5 * h * (f0[c] + f1[c]);
        }
        self.fsal_slot ^= 1;
        self.force0_valid = true;
    }

    /// The last step was rejected: the force it carried (at the failed point) is not the
    /// force at the node the run stays at, so the next step evaluates it again.
    pub(crate) fn rejected(&mut self) {
        self.force0_valid = false;
    }

    /// Störmer–Verlet over `[f64; N]` locals for up to `max_steps` steps: the increments of
    /// [`Self::step`] (up to rounding: the drift is summed in another order, below) and the
    /// compensated update of `RunState::commit`. Any split of a run into calls gives the same
    /// numbers (the lazy state persists); tests compare it with a hand-written variable-step
    /// Verlet loop and with Newton's method on the element equations.
    ///
    /// `at_node` sees every node reached, (k, t, q, p) with p materialised exactly as the
    /// state would hold it; returning false stops the loop after that node. Its work does not
    /// feed the step's dependency chain, so the processor overlaps the two.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn advance<L: Lagrangian, F: FnMut(Node<'_>) -> bool, const N: usize, const IDENTITY: bool>(
        &mut self,
        lag: &L,
        mass: &MassMatrix,
        grid: &TimeGrid,
        state: &mut RunState,
        last: &mut LastElement,
        max_steps: usize,
        at_node: &mut F,
    ) -> Result<usize> {
        let mut c = self.load::<L, N>(lag, state);
        let (k0, t0) = (state.k, state.t);
        let run = verlet_loop::<L, F, N, IDENTITY>(lag, mass, grid, &mut c, (k0, t0), max_steps, at_node);
        self.store(&mut c, state);
        state.steps += run.done;
        if run.done > 0 {
            last.valid = true;
            last.t = run.last_t;
            last.h = run.last_h;
            last.base.copy_from_slice(&run.last_q);
            last.incr[N..2 * N].copy_from_slice(&run.last_dq);
        }
        state.k = run.k;
        state.t = run.t;
        if run.failed {
            // The state is at the last good node; report like `step` does.
            self.force0_valid = false;
            return Err(Error::Step(StepError {
                step: run.k,
                t: run.t,
                residual: f64::NAN,
                iterations: 0,
                failure: StepFailure::NonFinite,
            }));
        }
        Ok(run.done)
    }

    /// The carried values from the state, or from the lazy state of the last call. The
    /// momentum is kept lazily: the compensated sum (p, cp) without the last increment, which
    /// is added off the critical path of the next step (the drift uses (p + cp) + pending
    /// directly). Without the lazy state, P_k itself is (p, cp) and h_{k−1} = 0.
    fn load<L: Lagrangian, const N: usize>(&self, lag: &L, state: &RunState) -> Carry<N> {
        let q = load(&state.q);
        let (p, cp, pending, fprev, hprev) = if self.lazy_valid {
            (
                load(&self.lazy_p),
                load(&self.lazy_cp),
                load(&self.lazy_pending),
                load(&self.lazy_fprev),
                self.lazy_hprev,
            )
        } else {
            (load(&state.p), load(&state.comp_p), [0.0; N], [0.0; N], 0.0)
        };
        let mut f0 = [0.0; N];
        if self.force0_valid {
            let off = self.fsal_slot * N;
            f0 = load(&self.force[off..off + N]);
        } else {
            lag.force(state.t, &q, &mut f0);
        }
        Carry {
            q,
            cq: load(&state.comp_q),
            p,
            cp,
            pending,
            fprev,
            hprev,
            f0,
        }
    }

    /// Writes the state back: the lazy momentum, and the node's momentum materialised.
    fn store<const N: usize>(&mut self, c: &mut Carry<N>, state: &mut RunState) {
        self.lazy_p.copy_from_slice(&c.p);
        self.lazy_cp.copy_from_slice(&c.cp);
        self.lazy_pending.copy_from_slice(&c.pending);
        self.lazy_fprev.copy_from_slice(&c.fprev);
        self.lazy_hprev = c.hprev;
        self.lazy_valid = true;
        for i in 0..N {
            let yp = c.pending[i] + c.cp[i];
            let tp = c.p[i] + yp;
            c.cp[i] = (c.p[i] - tp) + yp;
            c.p[i] = tp;
        }
        state.q.copy_from_slice(&c.q);
        state.p.copy_from_slice(&c.p);
        state.comp_q.copy_from_slice(&c.cq);
        state.comp_p.copy_from_slice(&c.cp);
        self.force[..N].copy_from_slice(&c.f0);
        self.fsal_slot = 0;
        self.force0_valid = true;
    }
}

/// Where the fast loop stopped.
struct LoopEnd<const N: usize> {
    done: usize,
    failed: bool,
    k: usize,
    t: f64,
    last_t: f64,
    last_h: f64,
    last_q: [f64; N],
    last_dq: [f64; N],
}

/// The fast loop. The drift from node k is h_k P_k + ½h_k² f_k with
/// P_k = P_{k−1} + ½h_{k−1}(f_{k−1} + f_k), evaluated as
/// (h_k P_{k−1} + ½h_k h_{k−1} f_{k−1}) + ½h_k(h_{k−1} + h_k) f_k: the first part is known
/// before f_k is, so the chain from one force to the next position is one product and two
/// sums (against three products and four sums through P_k), which put this loop within the
/// hand-written loop's time.
#[inline(always)]
fn verlet_loop<L: Lagrangian, F: FnMut(Node<'_>) -> bool, const N: usize, const IDENTITY: bool>(
    lag: &L,
    mass: &MassMatrix,
    grid: &TimeGrid,
    cr: &mut Carry<N>,
    (k0, t0): (usize, f64),
    max_steps: usize,
    at_node: &mut F,
) -> LoopEnd<N> {
    let mut c = *cr;
    let (mut f1, mut y, mut dq, mut dp) = ([0.0; N], [0.0; N], [0.0; N], [0.0; N]);
    // M⁻¹ f_{k−1}, carried from step to step like f_{k−1} itself.
    let (mut u, mut w, mut wprev) = ([0.0; N], [0.0; N], [0.0; N]);
    if !IDENTITY {
        mass.solve(&c.fprev, &mut wprev);
    }
    let (mut k, mut t) = (k0, t0);
    let mut end = LoopEnd {
        done: 0,
        failed: false,
        k,
        t,
        last_t: 0.0,
        last_h: 0.0,
        last_q: c.q,
        last_dq: dq,
    };
    let uniform = grid.uniform_rule();
    let mut k1 = (k + 1) as i64 as f64;
    while end.done < max_steps {
        let next = match &uniform {
            Some(u) => u.next(k1, t),
            None => grid.next(k, t),
        };
        let Some((h, t_next)) = next else { break };
        let half_h = 0.5 * h;
        let (a, b) = (half_h * c.hprev, half_h * (c.hprev + h));
        drift::<N, IDENTITY>(
            mass,
            [h, a, b],
            [&c.p, &c.cp, &c.fprev, &wprev, &c.f0, &c.q],
            &mut u,
            &mut w,
            &mut dq,
            &mut y,
        );
        // The new carried values go to locals and are committed once the step is known to be
        // finite (no copy of the old ones to roll back to). The pending increment joins the
        // compensated sum off the critical path.
        let (mut p, mut cp, mut q, mut cq) = ([0.0; N], [0.0; N], [0.0; N], [0.0; N]);
        for i in 0..N {
            let yp = c.pending[i] + c.cp[i];
            p[i] = c.p[i] + yp;
            cp[i] = (c.p[i] - p[i]) + yp;
        }
        lag.force(t + h, &y, &mut f1);
        // x·0 is NaN exactly when x is not finite: one sum tells whether all are.
        let mut probe = 0.0;
        for i in 0..N {
            dp[i] = half_h * (c.f0[i] + f1[i]);
            let yq = dq[i] + c.cq[i];
            q[i] = c.q[i] + yq;
            cq[i] = (c.q[i] - q[i]) + yq;
            probe += dp[i] * 0.0 + q[i] * 0.0;
        }
        if probe.is_nan() {
            end.failed = true;
            break;
        }
        end.last_q = c.q;
        end.last_dq = dq;
        (c.p, c.cp, c.q, c.cq, c.pending) = (p, cp, q, cq, dp);
        c.fprev = c.f0;
        wprev = w;
        c.hprev = h;
        c.f0 = f1;
        end.last_t = t;
        end.last_h = h;
        k += 1;
        k1 += 1.0;
        t = t_next;
        end.done += 1;
        // The node's momentum as `store` materialises it (dead code when `at_node` ignores it),
        // and a copy of q: `at_node` borrows copies, so that the carried values never have
        // their address taken and stay in registers (f_k through memory would add a store and
        // a load to the step's dependency chain).
        let mut p = [0.0; N];
        for i in 0..N {
            p[i] = c.p[i] + (c.pending[i] + c.cp[i]);
        }
        let q = c.q;
        let node = Node { k, t, q: &q, p: &p };
        if !at_node(node) {
            break;
        }
    }
    *cr = c;
    end.k = k;
    end.t = t;
    end
}

/// The drift of one step, dq = (h P + a f_{k−1}) + b f_k with P = p + cp (M⁻¹ applied to
/// P and the forces unless M = I), and the new position y = q + dq. `v` holds
/// (p, cp, f_{k−1}, M⁻¹f_{k−1}, f_k, q); `u` and `w` receive M⁻¹P and M⁻¹f_k.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn drift<const N: usize, const IDENTITY: bool>(
    mass: &MassMatrix,
    [h, a, b]: [f64; 3],
    [p, cp, fprev, wprev, f0, q]: [&[f64; N]; 6],
    u: &mut [f64; N],
    w: &mut [f64; N],
    dq: &mut [f64; N],
    y: &mut [f64; N],
) {
    if IDENTITY {
        for c in 0..N {
            dq[c] = (h * (p[c] + cp[c]) + a * fprev[c]) + b * f0[c];
            y[c] = q[c] + dq[c];
        }
    } else {
        let mut pk = [0.0; N];
        for c in 0..N {
            pk[c] = p[c] + cp[c];
        }
        mass.solve(&pk, u);
        mass.solve(f0, w);
        for c in 0..N {
            dq[c] = (h * u[c] + a * wprev[c]) + b * w[c];
            y[c] = q[c] + dq[c];
        }
    }
}
