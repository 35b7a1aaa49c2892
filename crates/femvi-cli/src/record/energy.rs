//! The energy at every node for `femvi run`'s outputs and summary.json: the library's
//! [`EnergyTracker`] (H by the Legendre transform, its largest relative error, and for a
//! time-dependent Lagrangian the balance with the work −∫∂L/∂t dt) as an observer, sharing the
//! node's energy with the trajectory writers. `femvi::solve` and the Python package use the
//! same tracker, so their energies are the command's bit for bit. With
//! [`EnergyNodes::Kept`] (`[output] energy_nodes`; by default for Lagrangians without a
//! constant mass matrix) only the nodes the outputs keep get an energy, each Legendre
//! inversion started from the velocity of the element ending on the node, as
//! `femvi::solve` does.

use femvi::fem::LagrangeBasis;
pub use femvi::solution::NodeEnergy;
use femvi::solution::{EnergyNodes, EnergyTracker};
use femvi::step::{Node, Observer};
use femvi::{Integrator, Lagrangian, Start};
use std::cell::Cell;
use std::rc::Rc;

/// Computes the energy at every node (it must run before the observers that read
/// [`EnergyError::current`]) and keeps the largest relative error.
pub struct EnergyError {
    tracker: EnergyTracker,
    current: Rc<Cell<NodeEnergy>>,
    /// [`EnergyNodes::Kept`]: `every`.
    kept: Option<usize>,
    /// With `kept`: the node whose energy the tracker holds.
    tracked: Option<usize>,
}

impl EnergyError {
    /// For a system with `dim` coordinates started from `start` (whose velocities, if given,
    /// start the first Legendre inversion).
    pub fn new(dim: usize, start: &Start, autonomous: bool) -> Self {
        EnergyError {
            tracker: EnergyTracker::new(dim, start, autonomous),
            current: Rc::default(),
            kept: None,
            tracked: None,
        }
    }

    /// The nodes the tracker is shown: `nodes` as [`EnergyNodes::resolve`] gave it; for
    /// [`EnergyNodes::Kept`], the nodes every `every`-th and the last, with `basis` the
    /// element's (for the end velocities).
    pub fn with_nodes(mut self, nodes: EnergyNodes, basis: &LagrangeBasis, every: usize) -> Self {
        self.tracker = self.tracker.with_nodes(nodes, basis);
        self.kept = (nodes == EnergyNodes::Kept).then(|| every.max(1));
        self
    }

    /// Whether only the kept nodes get an energy ([`EnergyError::at_kept`]).
    pub fn kept_only(&self) -> bool {
        self.kept.is_some()
    }

    /// The nodes the largest error is over.
    pub fn nodes(&self) -> EnergyNodes {
        self.tracker.report().nodes
    }

    /// The node the run shows first after a restored checkpoint: its energy is the
    /// tracker's already.
    pub fn restored_at(&mut self, k: usize) {
        self.tracked = Some(k);
    }

    /// [`EnergyNodes::Kept`]: the energy at the node `it` is at if the outputs keep it (node
    /// `every`-th, or `last`) and it has not got one yet, from the end velocity of the element
    /// ending there; None otherwise.
    ///
    /// # Errors
    /// As [`EnergyTracker::node`].
    pub fn at_kept<L: Lagrangian>(&mut self, it: &Integrator<'_, L>, last: bool) -> femvi::Result<Option<f64>> {
        let Some(every) = self.kept else {
            return Ok(None);
        };
        let node = it.node();
        if !(last || node.k.is_multiple_of(every)) || self.tracked == Some(node.k) {
            return Ok(None);
        }
        let h = self
            .tracker
            .node_after(it.lagrangian(), it.last_element(), node.t, node.q, node.p)?
            .h;
        self.tracked = Some(node.k);
        Ok(Some(h))
    }

    /// The energy of the node being recorded, updated at each node.
    pub fn current(&self) -> Rc<Cell<NodeEnergy>> {
        Rc::clone(&self.current)
    }

    /// The largest relative energy error so far (0 before the first node).
    pub fn max_rel(&self) -> f64 {
        self.tracker.report().max_rel_error
    }

    /// Time-dependent L: the largest |H − H0 − W| / |H0| (W the work −∫∂L/∂t dt); None for
    /// an autonomous L.
    pub fn max_rel_balance(&self) -> Option<f64> {
        self.tracker.report().max_rel_balance
    }

    /// The tracker's state for a checkpoint ([`EnergyTracker::words`]).
    pub fn words(&self) -> Vec<u64> {
        self.tracker.words()
    }

    /// Restores a checkpoint's state ([`EnergyTracker::restore_words`]); the node's energy
    /// becomes the current one.
    ///
    /// # Errors
    /// The words do not fit this tracker.
    pub fn restore(&mut self, words: &[u64]) -> femvi::Result<()> {
        self.tracker.restore_words(words)?;
        self.current.set(self.tracker.current());
        Ok(())
    }
}

impl EnergyError {
    /// The energy H at `node` of a run of `lag`, which becomes the tracker's current one;
    /// [`EnergyError::current`] shows it after [`EnergyError::publish`].
    ///
    /// # Errors
    /// As [`EnergyTracker::node`].
    #[inline(always)]
    pub fn at<L: Lagrangian>(&mut self, lag: &L, node: Node<'_>) -> femvi::Result<f64> {
        Ok(self.tracker.node(lag, node.t, node.q, node.p)?.h)
    }

    /// Whether [`EnergyError::at_lean`] applies to `lag` ([`EnergyTracker::lean`]: M = I,
    /// autonomous).
    pub fn lean<L: Lagrangian>(&self, lag: &L) -> bool {
        self.kept.is_none() && self.tracker.lean(lag)
    }

    /// [`EnergyError::at`] for a Lagrangian [`EnergyError::lean`] accepted, without a call
    /// or an error path ([`EnergyTracker::node_lean`]): the same energy, bit for bit; None
    /// (nothing recorded) if the node is not of the tracker's dimension.
    #[inline(always)]
    pub fn at_lean<L: Lagrangian>(&mut self, lag: &L, node: Node<'_>) -> Option<f64> {
        self.tracker.node_lean(lag, node.t, node.q, node.p)
    }

    /// Shows the last node's energy and relative error to the writers ([`EnergyError::current`]).
    pub fn publish(&self) {
        self.current.set(self.tracker.current());
    }
}

impl<L: Lagrangian> Observer<L> for EnergyError {
    fn node(&mut self, it: &Integrator<'_, L>, _last: bool) -> femvi::Result<()> {
        self.at(it.lagrangian(), it.node())?;
        self.publish();
        Ok(())
    }
}
