//! What every node of a `femvi run` needs, inside a chunk of steps too (issue 16: no
//! non-finite value is ever written): its energy, the check that it and the state are
//! finite, and its copy as the last good node, the node a run that meets a non-finite one
//! ends on; the call-free twin of that work for the explicit fast loop; and, with the energy
//! at the kept nodes only (`energy_nodes`), the check of a kept node's energy when its chunk
//! ends, which goes back to the node before if it fails.

use super::Recorders;
use femvi::step::Node;
use femvi::{Integrator, Lagrangian};

/// The last node with a finite state and energy: where a run that met a non-finite one ends.
pub(super) struct Good {
    pub(super) steps: usize,
    pub(super) t: f64,
    pub(super) q: Vec<f64>,
    pub(super) p: Vec<f64>,
    /// Where [`Recorders::each_node_lean`] copies a node while it checks that it is finite
    /// (one pass over q and p, not two); swapped with q and p if it is.
    pub(super) next_q: Vec<f64>,
    pub(super) next_p: Vec<f64>,
    /// Energy at the kept nodes only: the node before the last one shown (steps, t; its q
    /// and p in `next_q`, `next_p`), where the run goes back to if the energy of the last
    /// one, computed when its chunk ends, is not finite.
    pub(super) before: Option<(usize, f64)>,
}

impl Good {
    /// No node yet: `steps` and `t` those of the run's start (a resumed run's checkpoint).
    pub(super) fn new(steps: usize, t: f64) -> Self {
        Good {
            steps,
            t,
            q: vec![],
            p: vec![],
            next_q: vec![],
            next_p: vec![],
            before: None,
        }
    }

    /// Goes back to the node before the last one shown ([`Good::before`]), if kept.
    pub(super) fn back(&mut self) {
        if let Some((steps, t)) = self.before.take() {
            std::mem::swap(&mut self.q, &mut self.next_q);
            std::mem::swap(&mut self.p, &mut self.next_p);
            (self.steps, self.t) = (steps, t);
        }
    }
}

impl Recorders<'_> {
    /// What every node needs, inside a chunk too: its energy, the check that it is finite,
    /// and the copy of the last good node. `discrete` is energy mode's discrete energy (0
    /// otherwise).
    #[inline(always)]
    pub(in crate::record) fn each_node<L: Lagrangian>(
        &mut self,
        lag: &L,
        node: Node<'_>,
        discrete: f64,
    ) -> femvi::Result<()> {
        self.first_k.get_or_insert(node.k);
        let h = if self.restored {
            self.restored = false;
            self.energy.restored_at(node.k);
            self.current.get().h
        } else if self.energy.kept_only() {
            0.0 // the kept nodes' energies are computed and checked in `boundary`
        } else {
            self.energy.at(lag, node)?
        };
        check_finite(&node, h, discrete)?;
        if self.energy.kept_only() && self.good.next_q.len() == node.q.len() && self.good.next_p.len() == node.p.len() {
            // The previous good node stays in the spare buffers: `boundary` goes back to it if
            // this node's energy, computed there, is not finite.
            std::mem::swap(&mut self.good.q, &mut self.good.next_q);
            std::mem::swap(&mut self.good.p, &mut self.good.next_p);
            self.good.before = Some((self.good.steps, self.good.t));
        }
        self.good.steps = self.steps_at(node.k);
        self.good.t = node.t;
        if self.good.q.len() == node.q.len() && self.good.p.len() == node.p.len() {
            // Element by element: a few numbers, not worth a call to memmove at every node.
            self.good.q.iter_mut().zip(node.q).for_each(|(g, x)| *g = *x);
            self.good.p.iter_mut().zip(node.p).for_each(|(g, x)| *g = *x);
        } else {
            self.good.q = node.q.to_vec();
            self.good.p = node.p.to_vec();
            self.good.next_q = node.q.to_vec();
            self.good.next_p = node.p.to_vec();
        }
        Ok(())
    }

    /// Whether the nodes of the next chunk may go through [`Self::each_node_lean`]: an
    /// autonomous mechanical Lagrangian with M = I ([`EnergyError::lean`]), past the first
    /// node and a restored checkpoint's.
    pub(in crate::record) fn lean<L: Lagrangian>(&self, lag: &L) -> bool {
        let dim = lag.dim();
        !self.restored
            && self.first_k.is_some()
            && self.good.q.len() == dim
            && self.good.p.len() == dim
            && self.good.next_q.len() == dim
            && self.good.next_p.len() == dim
            && self.energy.lean(lag)
    }

    /// [`Self::each_node`] in a chunk [`Self::lean`] accepted: the same work and results,
    /// in code without a call or an error path, so that the explicit fast loop it runs in
    /// keeps its carried values in registers (`femvi run` on Kepler: 1.17× → 1.02× the
    /// library's loop). False when the node is not finite or not recorded: the caller
    /// then passes the same node to [`Self::each_node`] for the error.
    #[inline(always)]
    pub(in crate::record) fn each_node_lean<L: Lagrangian>(&mut self, lag: &L, node: Node<'_>) -> bool {
        let Some(h) = self.energy.at_lean(lag, node) else {
            return false;
        };
        // Copies whose length is the node's, a constant in the fast loop: a few moves, where
        // a loop over `good`'s length becomes a call to memcpy (`lean` checked the lengths).
        // The copy and the test that the node is finite (as `check_finite`) in one pass, into
        // the spare buffers, which become the last good node if it is.
        let (Some(gq), Some(gp)) = (
            self.good.next_q.get_mut(..node.q.len()),
            self.good.next_p.get_mut(..node.p.len()),
        ) else {
            return false;
        };
        if !(node.t.is_finite() & h.is_finite() & copy_finite(gq, node.q) & copy_finite(gp, node.p)) {
            return false;
        }
        std::mem::swap(&mut self.good.q, &mut self.good.next_q);
        std::mem::swap(&mut self.good.p, &mut self.good.next_p);
        self.good.steps = self.steps_at(node.k);
        self.good.t = node.t;
        true
    }

    /// Energy at the kept nodes only: the energy of the node `it` is at if the outputs keep
    /// it (`last`: the grid's final node, or the node a stopped run ends on). Not finite, or
    /// not computable: the error, and the last good node is the one before.
    pub(super) fn check_kept_energy<L: Lagrangian>(&mut self, it: &Integrator<'_, L>, last: bool) -> femvi::Result<()> {
        let checked = self
            .energy
            .at_kept(it, last)
            .and_then(|h| h.map_or(Ok(()), |h| check_finite(&it.node(), h, 0.0)));
        if checked.is_err() {
            self.good.back();
        }
        checked
    }
}

/// An error if `node`, its energy `h` or the discrete energy is not finite.
#[inline(always)]
fn check_finite(node: &Node<'_>, h: f64, discrete: f64) -> femvi::Result<()> {
    if all_finite(node, [h, discrete]) {
        return Ok(());
    }
    not_finite(node, h, discrete)
}

/// Copies `x` into `to` (of the same length); whether all of `x` is finite. One pass, which
/// the compiler vectorises.
#[inline(always)]
fn copy_finite(to: &mut [f64], x: &[f64]) -> bool {
    to.iter_mut().zip(x).fold(true, |all, (t, x)| {
        *t = *x;
        all & x.is_finite()
    })
}

/// Whether the node's t, q and p and the two numbers are all finite: an and of the
/// elements' tests, which the compiler vectorises (a sum of x·0, NaN exactly when some x is
/// not finite, is one chain of dependent additions, 2n latencies per node: more than the
/// step itself of a large chain).
#[inline(always)]
fn all_finite(node: &Node<'_>, [a, b]: [f64; 2]) -> bool {
    let each = |v: &[f64]| v.iter().fold(true, |all, x| all & x.is_finite());
    node.t.is_finite() & a.is_finite() & b.is_finite() & each(node.q) & each(node.p)
}

/// The error of [`check_finite`].
#[cold]
#[inline(never)]
fn not_finite(node: &Node<'_>, h: f64, discrete: f64) -> femvi::Result<()> {
    let finite = node.t.is_finite() && node.q.iter().chain(node.p).all(|x| x.is_finite());
    if finite && h.is_finite() && discrete.is_finite() {
        return Ok(());
    }
    let what = if finite { "energy" } else { "state" };
    Err(femvi::Error::Observer(format!(
        "non-finite {what} at step {}, t = {}: the run is unstable (a smaller step may help); the rows before it are written",
        node.k, node.t
    )))
}
