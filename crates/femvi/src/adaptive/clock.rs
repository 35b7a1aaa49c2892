//! Physical time along the fictitious time s: dt/ds = g(q(s)) integrated over each element
//! by the element's own quadrature rule (issue 21; DESIGN.md §4),
//!
//!   t_{k+1} = t_k + Δs Σ_i b_i g(q_h(c_i)),
//!
//! with q_h the element's interpolant (DESIGN.md §1). Inside the element the same rule on
//! [0, σ] gives t(σ) = t_k + σΔs Σ_i b_i g(q_h(σ c_i)), which equals t_{k+1} at σ = 1 bit for
//! bit and is what a requested physical time is solved for ([`Clock::locate`]): Newton's
//! method in σ with dt/dσ ≈ Δs g(q_h(σ)), kept inside a bisection bracket.

use super::monitor::Monitor;
use crate::discrete::Element;
use crate::step::ElementNodes;

/// Scratch for evaluating an element's interpolant and its clock.
#[derive(Debug, Clone)]
pub(crate) struct Clock {
    l: Vec<f64>,
    dl: Vec<f64>,
    q: Vec<f64>,
    /// The basis at the rule's points (row i: ℓ_j(c_i)), for the whole element's step (the
    /// same numbers `values_in_place` gives, computed once).
    at_points: Vec<f64>,
}

impl Clock {
    pub(crate) fn new(element: &Element, n: usize) -> Self {
        let w = element.nodes();
        let mut at_points = vec![0.0; element.points() * w];
        for (row, &c) in at_points.chunks_exact_mut(w.max(1)).zip(&element.rule.nodes) {
            element.basis.values_in_place(c, row);
        }
        Self {
            l: vec![0.0; w],
            dl: vec![0.0; w],
            q: vec![0.0; n],
            at_points,
        }
    }

    /// q_h(τ) and, if asked, dq_h/ds = Σ_j ℓ_j'(τ) X^j / Δs into `q` and `qs`.
    pub(crate) fn interpolate(
        &mut self,
        element: &Element,
        el: &ElementNodes<'_>,
        tau: f64,
        q: &mut [f64],
        qs: Option<&mut [f64]>,
    ) {
        let n = el.base.len();
        element.basis.values_in_place(tau, &mut self.l);
        combine(el, &self.l, q);
        if let Some(qs) = qs {
            element.basis.derivatives_in_place(tau, &mut self.dl);
            qs.iter_mut().for_each(|x| *x = 0.0);
            for (j, &dj) in self.dl.iter().enumerate() {
                for (c, x) in qs.iter_mut().enumerate() {
                    *x += dj * el.incr[j * n + c] / el.h;
                }
            }
        }
    }

    /// g(q_h(τ)).
    fn g_at<G: Monitor>(&mut self, element: &Element, monitor: &G, el: &ElementNodes<'_>, tau: f64) -> f64 {
        let mut q = std::mem::take(&mut self.q);
        self.interpolate(element, el, tau, &mut q, None);
        let g = monitor.value(&q);
        self.q = q;
        g
    }

    /// t(σ) − t_k = σΔs Σ_i b_i g(q_h(σ c_i)); at σ = 1 the element's physical step.
    pub(crate) fn elapsed<G: Monitor>(
        &mut self,
        element: &Element,
        monitor: &G,
        el: &ElementNodes<'_>,
        sigma: f64,
    ) -> f64 {
        let mut sum = 0.0;
        if sigma == 1.0 {
            let w = element.nodes().max(1);
            let mut q = std::mem::take(&mut self.q);
            for (l, &b) in self.at_points.chunks_exact(w).zip(&element.rule.weights) {
                combine(el, l, &mut q);
                sum += b * monitor.value(&q);
            }
            self.q = q;
        } else {
            for (&c, &b) in element.rule.nodes.iter().zip(&element.rule.weights) {
                sum += b * self.g_at(element, monitor, el, sigma * c);
            }
        }
        sigma * el.h * sum
    }

    /// The σ ∈ [0, 1] with t(σ) − t_k = `target`, for 0 < target ≤ `total` = t(1) − t_k.
    pub(crate) fn locate<G: Monitor>(
        &mut self,
        element: &Element,
        monitor: &G,
        el: &ElementNodes<'_>,
        target: f64,
        total: f64,
    ) -> f64 {
        if target >= total {
            return 1.0;
        }
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        let mut sigma = target / total;
        for _ in 0..100 {
            let f = self.elapsed(element, monitor, el, sigma) - target;
            if f == 0.0 {
                return sigma;
            }
            if f < 0.0 {
                lo = sigma;
            } else {
                hi = sigma;
            }
            let slope = el.h * self.g_at(element, monitor, el, sigma);
            let mut next = sigma - f / slope;
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            if (next - sigma).abs() <= 4.0 * f64::EPSILON || hi - lo <= 4.0 * f64::EPSILON {
                return next;
            }
            sigma = next;
        }
        sigma
    }
}

/// q = base + Σ_j l_j X^j: the element's interpolant from basis values `l`.
fn combine(el: &ElementNodes<'_>, l: &[f64], q: &mut [f64]) {
    let n = el.base.len();
    q.copy_from_slice(el.base);
    for (j, &lj) in l.iter().enumerate() {
        for (c, qc) in q.iter_mut().enumerate() {
            *qc += lj * el.incr[j * n + c];
        }
    }
}
