//! The relative energy error |H - H0| / |H0| (|H - H0| where H0 = 0) at every node of a run,
//! its maximum for summary.json, and the node's energy for the trajectory writers.

use femvi::lagrangian::{hamiltonian, PointDerivatives};
use femvi::step::Observer;
use femvi::{Integrator, Lagrangian, Start};
use std::cell::Cell;
use std::rc::Rc;

/// The energy of the node being recorded, as [`EnergyError`] computed it.
#[derive(Debug, Clone, Copy, Default)]
pub struct NodeEnergy {
    /// The Hamiltonian H(t, q, p).
    pub h: f64,
    /// Its relative error against the first node's.
    pub rel: f64,
}

/// Computes the energy at every node (it must run before the observers that read
/// [`EnergyError::current`]) and keeps the largest relative error.
pub struct EnergyError {
    /// Velocities of the last Legendre inversion: the next one starts from them.
    v: Vec<f64>,
    work: PointDerivatives,
    e0: f64,
    max_rel: f64,
    current: Rc<Cell<NodeEnergy>>,
}

impl EnergyError {
    /// For a system with `dim` coordinates started from `start` (whose velocities, if given,
    /// start the first Legendre inversion).
    pub fn new(dim: usize, start: &Start) -> Self {
        let v = match start {
            Start::Velocity { v, .. } => v.clone(),
            _ => vec![0.0; dim],
        };
        EnergyError {
            v,
            work: PointDerivatives::new(dim),
            e0: f64::NAN,
            max_rel: 0.0,
            current: Rc::default(),
        }
    }

    /// The energy of the node being recorded, updated at each node.
    pub fn current(&self) -> Rc<Cell<NodeEnergy>> {
        Rc::clone(&self.current)
    }

    /// The largest relative energy error so far (0 before the first node).
    pub fn max_rel(&self) -> f64 {
        self.max_rel
    }
}

impl<L: Lagrangian> Observer<L> for EnergyError {
    fn node(&mut self, it: &Integrator<'_, L>, _last: bool) -> femvi::Result<()> {
        let node = it.node();
        let h = hamiltonian(it.lagrangian(), node.t, node.q, node.p, &mut self.v, &mut self.work)?;
        if self.e0.is_nan() {
            self.e0 = h;
        }
        let rel = if self.e0 != 0.0 {
            ((h - self.e0) / self.e0).abs()
        } else {
            (h - self.e0).abs()
        };
        self.max_rel = self.max_rel.max(rel);
        self.current.set(NodeEnergy { h, rel });
        Ok(())
    }
}
