//! Events in adaptive runs: one step in fictitious time seen as a [`Piece`] for the event
//! detector of fixed-step runs (`solution/events.rs`), parametrised by the fraction σ ∈ [0, 1]
//! of the step. At σ the state is the element polynomial q_h(σ), the physical velocity
//! v = (dq_h/ds)/g(q_h) and the physical time t(σ) = t_k + σΔs Σ_i b_i g(q_h(σ c_i)) of the
//! clock (`clock.rs`), so events g(t, q, v) are located in σ by the same sampling and regula
//! falsi and reported at t(σ*). Orders as for fixed steps: q_h of order s + 1 between nodes,
//! v and p of order s, t(σ) of the order of the quadrature on [0, σ].

use super::clock::Clock;
use super::monitor::Monitor;
use crate::discrete::Element;
use crate::solution::Piece;
use crate::step::ElementNodes;

/// One step of an adaptive run, from the node at physical time `t_prev`.
pub(crate) struct AdaptivePiece<'a, 'e, G> {
    pub(crate) step: usize,
    pub(crate) element: &'a Element,
    pub(crate) monitor: &'a G,
    pub(crate) el: &'a ElementNodes<'e>,
    pub(crate) clock: &'a mut Clock,
    pub(crate) t_prev: f64,
}

impl<G: Monitor> Piece for AdaptivePiece<'_, '_, G> {
    fn step(&self) -> usize {
        self.step
    }

    fn range(&self) -> (f64, f64) {
        (0.0, 1.0)
    }

    fn at(&mut self, sigma: f64, q: &mut [f64], v: &mut [f64]) -> f64 {
        self.clock.interpolate(self.element, self.el, sigma, q, Some(v));
        let g = self.monitor.value(q);
        v.iter_mut().for_each(|x| *x /= g);
        self.t_prev + self.clock.elapsed(self.element, self.monitor, self.el, sigma)
    }
}
