//! The relative energy error |H - H0| / |H0| (|H - H0| where H0 = 0) at every node of a run,
//! its maximum for summary.json, and the node's energy for the trajectory writers.
//!
//! For a time-dependent Lagrangian H is not conserved; there it also follows the continuous
//! law dH/dt = −∂L/∂t: the work W(t) = −∫∂L/∂t dt by the trapezoid rule over the nodes (so
//! itself only second-order accurate in the step), and the largest |H − H0 − W| relative
//! to |H0| (the balance error).

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
    /// Time-dependent L only: (t, ∂L/∂t) at the last node, the work so far, the largest
    /// balance error.
    balance: Option<Balance>,
}

/// The energy balance of a time-dependent Lagrangian.
#[derive(Debug, Clone, Copy)]
struct Balance {
    last: Option<(f64, f64)>,
    work: f64,
    max_rel: f64,
}

impl EnergyError {
    /// For a system with `dim` coordinates started from `start` (whose velocities, if given,
    /// start the first Legendre inversion).
    pub fn new(dim: usize, start: &Start, autonomous: bool) -> Self {
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
            balance: (!autonomous).then_some(Balance {
                last: None,
                work: 0.0,
                max_rel: 0.0,
            }),
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

    /// Time-dependent L: the largest |H − H0 − W| / |H0| (W the work −∫∂L/∂t dt); None for
    /// an autonomous L.
    pub fn max_rel_balance(&self) -> Option<f64> {
        self.balance.map(|b| b.max_rel)
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
        if let Some(b) = self.balance.as_mut() {
            it.lagrangian()
                .first_derivatives(node.t, node.q, &self.v, true, &mut self.work);
            let lt = self.work.l_t();
            if let Some((t0, lt0)) = b.last {
                b.work -= 0.5 * (node.t - t0) * (lt + lt0);
            }
            b.last = Some((node.t, lt));
            let scale = if self.e0 != 0.0 { self.e0.abs() } else { 1.0 };
            b.max_rel = b.max_rel.max((h - self.e0 - b.work).abs() / scale);
        }
        Ok(())
    }
}
