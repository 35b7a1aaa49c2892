//! Scratch space for element evaluations: the times, positions and velocities at the
//! quadrature points and the Lagrangian's derivatives there.

use super::Element;
use crate::lagrangian::PointDerivatives;

/// Scratch space for element evaluations: quadrature-point values and derivatives.
#[derive(Debug, Clone)]
pub struct ElementWork {
    pub(super) n: usize,
    /// Times t_k + c_i h.
    pub tc: Vec<f64>,
    /// Positions at the points, row-major r×n.
    pub qc: Vec<f64>,
    /// Velocities at the points, row-major r×n.
    pub vc: Vec<f64>,
    /// Lagrangian derivatives at the points.
    pub pts: Vec<PointDerivatives>,
}

impl ElementWork {
    /// Scratch for `element` and configuration dimension `n`.
    pub fn new(element: &Element, n: usize) -> Self {
        let r = element.points();
        Self {
            n,
            tc: vec![0.0; r],
            qc: vec![0.0; r * n],
            vc: vec![0.0; r * n],
            pts: (0..r).map(|_| PointDerivatives::new(n)).collect(),
        }
    }
}
