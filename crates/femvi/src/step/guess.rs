//! Starting values of the implicit solvers' unknowns, the node increments X^m = Q^m − q_k
//! (m = 1 … s): the last element's polynomial extrapolated over the new step, or the initial
//! velocity on the first step.

use super::state::LastElement;
use crate::discrete::Element;

/// The unknowns x (nodes 1 … s, row-major s×n) and the extrapolation table for the last step
/// ratio.
#[derive(Debug, Clone)]
pub(crate) struct Guess {
    pub(crate) x: Vec<f64>,
    rho: f64,
    extrap: Vec<f64>,
    basis_buf: Vec<f64>,
}

impl Guess {
    pub(crate) fn new(s: usize, n: usize) -> Self {
        Self {
            x: vec![0.0; s * n],
            rho: f64::NAN,
            extrap: vec![0.0; s * (s + 1)],
            basis_buf: vec![0.0; s + 1],
        }
    }

    /// Sets `x` for the step h: the previous element's polynomial extrapolated, or the
    /// initial velocity `v0` on the first step.
    #[inline]
    pub(crate) fn predict(&mut self, element: &Element, last: &LastElement, v0: &[f64], h: f64) {
        let n = v0.len();
        let s = element.degree();
        let nodes = &element.basis.nodes;
        if !last.valid {
            for m in 1..=s {
                for c in 0..n {
                    self.x[(m - 1) * n + c] = nodes[m] * h * v0[c];
                }
            }
            return;
        }
        let rho = h / last.h;
        if rho != self.rho {
            self.rho = rho;
            for m in 1..=s {
                element.basis.values_in_place(1.0 + nodes[m] * rho, &mut self.basis_buf);
                self.extrap[(m - 1) * (s + 1)..m * (s + 1)].copy_from_slice(&self.basis_buf);
            }
        }
        let end = &last.incr[s * n..];
        for m in 1..=s {
            let row = &self.extrap[(m - 1) * (s + 1)..m * (s + 1)];
            for c in 0..n {
                let mut acc = 0.0;
                for (j, l) in row.iter().enumerate() {
                    acc += l * (last.incr[j * n + c] - end[c]);
                }
                self.x[(m - 1) * n + c] = acc;
            }
        }
    }
}
