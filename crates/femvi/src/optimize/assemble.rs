//! The KKT Lagrangian of the discretised problem summed over elements: its value parts (the
//! objective and the constraint residuals, for the line search) and its gradient and banded
//! Hessian (for the Newton step). Each quadrature point contributes Ψ (`point.rs`), carried to
//! the unknowns by the element's basis values ℓ_a(c_j) and derivatives ℓ_a'(c_j); the ends add
//! Λ_0·p_0 − Λ_N·p_N(t1), the boundary momenta (DESIGN §5).

use super::layout::Layout;
use super::point::{point_hessian, point_residual, PointMap, PointScratch, PointTime};
use super::system::Controls;
use crate::discrete::Element;
use crate::error::Result;
use crate::lagrangian::Lagrangian;
use crate::solve::BandMatrix;
use num_dual::{Dual, HyperDual64};

/// Where a point variable's share goes: a banded unknown, the final time, or nowhere (a
/// given end position).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Target {
    Band(usize),
    Time,
    Fixed,
}

/// The discretised problem: what stays fixed while the iterate changes.
pub(super) struct Model<'a, L: ?Sized, C> {
    pub(super) lag: &'a L,
    pub(super) ctl: &'a C,
    pub(super) element: &'a Element,
    pub(super) layout: Layout,
    pub(super) t0: f64,
    pub(super) free: bool,
    pub(super) q0: Vec<f64>,
    pub(super) q1: Vec<f64>,
    pub(super) v1: Vec<f64>,
    /// p_0 = ∂L/∂v(t0, q0, v0).
    pub(super) p0: Vec<f64>,
    /// The weight w of w·t1 in the objective.
    pub(super) time_weight: f64,
}

/// The final time's row and column of the KKT matrix, outside the band.
#[derive(Debug, Clone)]
pub(super) struct Border {
    /// ∂²/∂t1∂x for the banded unknowns x.
    pub(super) col: Vec<f64>,
    /// ∂²/∂t1².
    pub(super) diag: f64,
    /// ∂/∂t1.
    pub(super) grad: f64,
}

/// The objective and constraint residuals at an iterate.
pub(super) struct Values {
    pub(super) objective: f64,
    /// c at each banded index (zero but at the Λ entries).
    pub(super) c: Vec<f64>,
}

impl<L: Lagrangian + ?Sized, C: Controls> Model<'_, L, C> {
    pub(super) fn map(&self) -> PointMap {
        PointMap {
            n: self.layout.n,
            m: self.layout.m,
            free: self.free,
        }
    }

    pub(super) fn step(&self, t1: f64) -> f64 {
        (t1 - self.t0) / self.layout.elements as f64
    }

    fn time(&self, k: usize, j: usize, t1: f64) -> PointTime {
        let e = self.element;
        PointTime {
            t0: self.t0,
            sigma: k as f64 + e.rule.nodes[j],
            weight: e.rule.weights[j],
            h: self.step(t1),
        }
    }

    /// Position of node g: the given ends, else the unknowns.
    fn node_q<'x>(&'x self, x: &'x [f64], g: usize) -> &'x [f64] {
        let n = self.layout.n;
        match self.layout.q(g) {
            Some(i) => &x[i..i + n],
            None if g == 0 => &self.q0,
            None => &self.q1,
        }
    }

    /// Point variables y at point j of element k, and where each one's share goes.
    fn point(&self, x: &[f64], t1: f64, k: usize, j: usize, y: &mut [f64], links: &mut [Vec<(Target, f64)>]) {
        let (l, e, map) = (self.layout, self.element, self.map());
        let n = l.n;
        y.iter_mut().for_each(|v| *v = 0.0);
        links.iter_mut().for_each(|l| l.clear());
        for a in 0..=l.s {
            let g = k * l.s + a;
            let (phi, dphi) = (e.phi(j, a), e.dphi(j, a));
            let q = self.node_q(x, g);
            let lam = &x[l.lambda(g)..l.lambda(g) + n];
            for i in 0..n {
                let qt = l.q(g).map_or(Target::Fixed, |b| Target::Band(b + i));
                let lt = Target::Band(l.lambda(g) + i);
                y[i] += phi * q[i];
                y[n + i] += dphi * q[i];
                y[map.lambda() + i] += phi * lam[i];
                y[map.lambda() + n + i] += dphi * lam[i];
                links[i].push((qt, phi));
                links[n + i].push((qt, dphi));
                links[map.lambda() + i].push((lt, phi));
                links[map.lambda() + n + i].push((lt, dphi));
            }
        }
        for c in 0..l.m {
            y[2 * n + c] = x[l.u(k, j) + c];
            links[2 * n + c].push((Target::Band(l.u(k, j) + c), 1.0));
        }
        if self.free {
            y[map.h_index()] = self.step(t1);
            links[map.h_index()].push((Target::Time, 1.0 / l.elements as f64));
        }
    }

    /// Gradient of the KKT Lagrangian into `grad` (banded unknowns) and `border.grad`, its
    /// Hessian into `band` (cleared first) and the border.
    pub(super) fn assemble(
        &self,
        x: &[f64],
        t1: f64,
        band: &mut BandMatrix,
        grad: &mut [f64],
        border: &mut Border,
    ) -> Result<()> {
        let map = self.map();
        let ny = map.len();
        band.clear();
        grad.iter_mut().for_each(|g| *g = 0.0);
        border.col.iter_mut().for_each(|g| *g = 0.0);
        (border.diag, border.grad) = (0.0, self.time_weight);
        let (mut y, mut gy, mut hy) = (vec![0.0; ny], vec![0.0; ny], vec![0.0; ny * ny]);
        let mut links = vec![Vec::new(); ny];
        let mut scratch = PointScratch::new(map);
        for k in 0..self.layout.elements {
            for j in 0..self.layout.r {
                self.point(x, t1, k, j, &mut y, &mut links);
                point_hessian(
                    self.lag,
                    self.ctl,
                    map,
                    self.time(k, j, t1),
                    &y,
                    &mut scratch,
                    &mut gy,
                    &mut hy,
                );
                scatter(&links, &gy, &hy, band, grad, border)?;
            }
        }
        self.boundary(x, t1, grad, border);
        Ok(())
    }

    /// The ends' terms Λ_0·p_0 − Λ_N·p_N(t1) in the gradient and Hessian.
    fn boundary(&self, x: &[f64], t1: f64, grad: &mut [f64], border: &mut Border) {
        let (l, n) = (self.layout, self.layout.n);
        let (first, last) = (l.lambda(0), l.lambda(l.nodes() - 1));
        for i in 0..n {
            grad[first + i] += self.p0[i];
        }
        let (p1, dp1, ddp1) = self.end_momentum(t1);
        for i in 0..n {
            grad[last + i] -= p1[i];
            if self.free {
                border.grad -= x[last + i] * dp1[i];
                border.col[last + i] -= dp1[i];
                border.diag -= x[last + i] * ddp1[i];
            }
        }
    }

    /// p_N = ∂L/∂v(t1, q1, v1) and its first and second derivatives in t1.
    pub(super) fn end_momentum(&self, t1: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let n = self.layout.n;
        let (mut p, mut dp, mut ddp) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let t = Dual::new(HyperDual64::new(t1, 1.0, 1.0, 0.0), HyperDual64::from(0.0));
        let q: Vec<Dual<HyperDual64>> = self.q1.iter().map(|&a| Dual::from_re(HyperDual64::from(a))).collect();
        let mut v: Vec<Dual<HyperDual64>> = self.v1.iter().map(|&a| Dual::from_re(HyperDual64::from(a))).collect();
        for i in 0..n {
            v[i].eps = HyperDual64::from(1.0);
            let r = self.lag.value(t, &q, &v).eps;
            v[i].eps = HyperDual64::from(0.0);
            (p[i], dp[i], ddp[i]) = (r.re, r.eps1, r.eps1eps2);
        }
        (p, dp, ddp)
    }

    /// The objective (with w·t1) and the constraint residuals c at an iterate.
    pub(super) fn values(&self, x: &[f64], t1: f64) -> Values {
        let (l, map) = (self.layout, self.map());
        let n = l.n;
        let mut c = vec![0.0; x.len()];
        let mut objective = self.time_weight * t1;
        let (mut y, mut links) = (vec![0.0; map.len()], vec![Vec::new(); map.len()]);
        let (mut dl, mut dm) = (vec![0.0; n], vec![0.0; n]);
        for k in 0..l.elements {
            for j in 0..l.r {
                self.point(x, t1, k, j, &mut y, &mut links);
                objective += point_residual(self.lag, self.ctl, map, self.time(k, j, t1), &y, &mut dl, &mut dm);
                for a in 0..=l.s {
                    let g = l.lambda(k * l.s + a);
                    let (phi, dphi) = (self.element.phi(j, a), self.element.dphi(j, a));
                    for i in 0..n {
                        c[g + i] += phi * dl[i] + dphi * dm[i];
                    }
                }
            }
        }
        let (first, last) = (l.lambda(0), l.lambda(l.nodes() - 1));
        let p1 = self.end_momentum(t1).0;
        for i in 0..n {
            c[first + i] += self.p0[i];
            c[last + i] -= p1[i];
        }
        Values { objective, c }
    }

    /// The discrete momenta at the element end nodes, p_k = −∂L_d/∂Q^0 − f^0 of element k
    /// and p_N = ∂L_d/∂Q^s + f^s of the last (N + 1 rows of n).
    pub(super) fn momenta(&self, x: &[f64], t1: f64) -> Vec<f64> {
        let (l, map) = (self.layout, self.map());
        let n = l.n;
        let mut p = vec![0.0; (l.elements + 1) * n];
        let (mut y, mut links) = (vec![0.0; map.len()], vec![Vec::new(); map.len()]);
        let (mut dl, mut dm) = (vec![0.0; n], vec![0.0; n]);
        for k in 0..l.elements {
            for j in 0..l.r {
                self.point(x, t1, k, j, &mut y, &mut links);
                point_residual(self.lag, self.ctl, map, self.time(k, j, t1), &y, &mut dl, &mut dm);
                let (e, s) = (self.element, l.s);
                for i in 0..n {
                    p[k * n + i] -= e.phi(j, 0) * dl[i] + e.dphi(j, 0) * dm[i];
                    if k + 1 == l.elements {
                        p[(k + 1) * n + i] += e.phi(j, s) * dl[i] + e.dphi(j, s) * dm[i];
                    }
                }
            }
        }
        p
    }

    /// Positions at every node (N·s + 1 rows of n).
    pub(super) fn positions(&self, x: &[f64]) -> Vec<f64> {
        (0..self.layout.nodes())
            .flat_map(|g| self.node_q(x, g).to_vec())
            .collect()
    }
}

/// Adds one point's gradient and Hessian, carried by its links, to the global arrays.
fn scatter(
    links: &[Vec<(Target, f64)>],
    gy: &[f64],
    hy: &[f64],
    band: &mut BandMatrix,
    grad: &mut [f64],
    border: &mut Border,
) -> Result<()> {
    let ny = gy.len();
    for (a, la) in links.iter().enumerate() {
        for &(ta, ca) in la {
            match ta {
                Target::Band(i) => grad[i] += ca * gy[a],
                Target::Time => border.grad += ca * gy[a],
                Target::Fixed => continue,
            }
            for (b, lb) in links.iter().enumerate() {
                let h = hy[a * ny + b];
                if h == 0.0 {
                    continue;
                }
                for &(tb, cb) in lb {
                    let v = ca * cb * h;
                    match (ta, tb) {
                        (Target::Band(i), Target::Band(j)) => band.add(i, j, v)?,
                        (Target::Band(i), Target::Time) => border.col[i] += v,
                        (Target::Time, Target::Time) => border.diag += v,
                        _ => {}
                    }
                }
            }
        }
    }
    Ok(())
}
