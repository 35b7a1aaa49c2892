//! The discrete Lagrangian over any scalar type, and its derivatives with respect to the
//! element's times and nodal values together by hyper-dual numbers (for the energy equations,
//! the extended tangent map and the moving mesh).

use super::Element;
use crate::lagrangian::{Lagrangian, Scalar};

impl Element {
    /// L_d(t_k, t_k + h; Q) evaluated for any scalar type (for derivatives with respect to the
    /// times and nodal values together, e.g. by hyper-dual numbers). `nodes` holds Q^0 … Q^s.
    /// The step is passed itself, not as a difference of times, so that it keeps its digits.
    /// NaN unless `nodes` has (s+1)·n entries for the Lagrangian's n.
    pub fn action_generic<D: Scalar, L: Lagrangian>(&self, lag: &L, t0: D, h: D, nodes: &[D]) -> D {
        let (n, w) = (lag.dim(), self.nodes());
        if n.checked_mul(w) != Some(nodes.len()) {
            return D::from(f64::NAN);
        }
        let mut q = vec![D::from(0.0); n];
        let mut v = vec![D::from(0.0); n];
        let mut sum = D::from(0.0);
        for i in 0..self.points() {
            q.iter_mut().for_each(|x| *x = D::from(0.0));
            v.iter_mut().for_each(|x| *x = D::from(0.0));
            for j in 0..self.nodes() {
                let (a, d) = (self.phi[i * w + j], self.dphi[i * w + j]);
                for c in 0..n {
                    q[c] += nodes[j * n + c] * a;
                    v[c] += nodes[j * n + c] * d;
                }
            }
            for x in v.iter_mut() {
                *x /= h;
            }
            sum += lag.value(t0 + h * self.rule.nodes[i], &q, &v) * self.rule.weights[i];
        }
        sum * h
    }

    /// Value, gradient and Hessian of L_d with respect to z = (t_k, t_{k+1}, Q^0 … Q^s), by
    /// hyper-dual numbers (one pass per pair of variables): the derivatives that the energy
    /// equations, the extended tangent map and the moving mesh need. Row-major, m = 2 + (s+1)n.
    /// NaN (at the size for the Lagrangian's n) unless `base` has n entries and `incr` (s+1)·n.
    pub fn full_hessian<L: Lagrangian>(
        &self,
        lag: &L,
        t0: f64,
        h: f64,
        base: &[f64],
        incr: &[f64],
    ) -> (f64, Vec<f64>, Vec<f64>) {
        let t1 = t0 + h;
        use num_dual::HyperDual64;
        let n = base.len();
        if n != lag.dim() || n.checked_mul(self.nodes()) != Some(incr.len()) {
            let m = 2 + self.nodes() * lag.dim();
            return (f64::NAN, vec![f64::NAN; m], vec![f64::NAN; m * m]);
        }
        let m = 2 + incr.len();
        let mut z: Vec<HyperDual64> = Vec::with_capacity(m);
        z.push(HyperDual64::from(t0));
        z.push(HyperDual64::from(t1));
        for j in 0..self.nodes() {
            for c in 0..n {
                z.push(HyperDual64::from(base[c] + incr[j * n + c]));
            }
        }
        let mut grad = vec![0.0; m];
        let mut hess = vec![0.0; m * m];
        let mut value = 0.0;
        for a in 0..m {
            for b in a..m {
                z[a].eps1 = 1.0;
                z[b].eps2 = 1.0;
                // h = t_{k+1} − t_k: its real part exact, its dual parts the difference.
                let hd = HyperDual64::new(h, z[1].eps1 - z[0].eps1, z[1].eps2 - z[0].eps2, 0.0);
                let r = self.action_generic(lag, z[0], hd, &z[2..]);
                z[a].eps1 = 0.0;
                z[b].eps2 = 0.0;
                if a == b {
                    grad[a] = r.eps1;
                    value = r.re;
                }
                hess[a * m + b] = r.eps1eps2;
                hess[b * m + a] = r.eps1eps2;
            }
        }
        (value, grad, hess)
    }
}
