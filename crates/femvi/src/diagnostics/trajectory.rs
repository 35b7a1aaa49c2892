//! The piecewise-polynomial trajectory q_h(t) of a run (the paper's (2.26)/(2.38b) interpolant),
//! recorded element by element, evaluated anywhere, and its L² distance to a reference — the
//! norm of the paper's error estimates (2.33) and (2.56).

use crate::error::{check_len, Result};
use crate::fem::{LagrangeBasis, QuadratureKind, QuadratureRule, MAX_POINTS};
use crate::lagrangian::Lagrangian;
use crate::step::Integrator;

/// The elements of a run: start times, steps and nodal values.
#[derive(Debug, Clone, PartialEq)]
pub struct PiecewiseTrajectory {
    n: usize,
    basis: LagrangeBasis,
    t: Vec<f64>,
    h: Vec<f64>,
    /// Nodal values, (s+1)·n per element.
    nodes: Vec<f64>,
}

impl PiecewiseTrajectory {
    /// Runs `it` to its end, recording every element; `basis` is its element's basis and n
    /// its dimension.
    ///
    /// # Errors
    /// [`crate::Error::Dimension`] if n is not the integrator's dimension or the basis not its
    /// element's; any step error.
    pub fn record<L: Lagrangian>(it: &mut Integrator<L>, basis: &LagrangeBasis, n: usize) -> Result<Self> {
        check_len("trajectory dimension", it.node().q.len(), n)?;
        let mut me = Self {
            n,
            basis: basis.clone(),
            t: vec![],
            h: vec![],
            nodes: vec![],
        };
        while it.step()? {
            if let Some(e) = it.last_element() {
                check_len(
                    "nodal values of the element (basis nodes x n)",
                    e.incr.len(),
                    basis.len() * n,
                )?;
                me.t.push(e.t);
                me.h.push(e.h);
                for j in 0..basis.len() {
                    for c in 0..n {
                        me.nodes.push(e.base[c] + e.incr[j * n + c]);
                    }
                }
            }
        }
        Ok(me)
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether no element was recorded.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// q_h(t) into `out` (t is clamped to the recorded span); NaN if nothing was recorded or
    /// `out` does not have the trajectory's dimension.
    pub fn eval(&self, t: f64, out: &mut [f64]) {
        if self.t.is_empty() || out.len() != self.n {
            out.iter_mut().for_each(|x| *x = f64::NAN);
            return;
        }
        let k = self.t.partition_point(|&tk| tk <= t).saturating_sub(1);
        let tau = ((t - self.t[k]) / self.h[k]).clamp(0.0, 1.0);
        let w = self.basis.len();
        let mut l = vec![0.0; w];
        self.basis.values_in_place(tau, &mut l);
        let nodes = &self.nodes[k * w * self.n..(k + 1) * w * self.n];
        for (c, o) in out.iter_mut().enumerate() {
            *o = (0..w).map(|j| l[j] * nodes[j * self.n + c]).sum();
        }
    }

    /// (∫ |q_h(t) − q_ref(t)|² dt)^½ over the recorded span, by a Gauss rule of `points` points
    /// per element (clamped to 1 ..= [`MAX_POINTS`]); `reference(t, out)` writes q_ref(t).
    pub fn l2_distance(&self, points: usize, mut reference: impl FnMut(f64, &mut [f64])) -> f64 {
        let rule = QuadratureRule::new(QuadratureKind::GaussLegendre(points.clamp(1, MAX_POINTS)))
            .unwrap_or_else(|_| unreachable!("1 ..= MAX_POINTS points"));
        let (mut qh, mut qr) = (vec![0.0; self.n], vec![0.0; self.n]);
        let mut sum = 0.0;
        for k in 0..self.t.len() {
            for (c, b) in rule.nodes.iter().zip(&rule.weights) {
                let t = self.t[k] + c * self.h[k];
                self.eval(t, &mut qh);
                reference(t, &mut qr);
                sum += self.h[k] * b * qh.iter().zip(&qr).map(|(a, r)| (a - r).powi(2)).sum::<f64>();
            }
        }
        sum.sqrt()
    }
}
