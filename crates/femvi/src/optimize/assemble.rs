//! The KKT Lagrangian of the discretised problem summed over elements: its value parts (the
//! objective and the constraint residuals, for the line search) and its gradient and banded
//! Hessian (for the Newton step). Each quadrature point contributes Ψ (`point.rs`), carried to
//! the unknowns by the element's basis values ℓ_a(c_j) and derivatives ℓ_a'(c_j); the ends add
//! Λ_0·p_0 and the end term Φ(t1, q_N, v_N) − Λ_N·p(t1, q_N, v_N): the terminal cost and the
//! boundary momentum (DESIGN §5), p = ∂L/∂v. Free components of q_N and of the end velocity
//! v_N are unknowns (`layout.rs`); the given ones are constants.

use super::layout::Layout;
use super::point::{point_hessian, point_residual, PointMap, PointScratch, PointTime};
use super::system::Controls;
use crate::discrete::Element;
use crate::error::Result;
use crate::lagrangian::Lagrangian;
use crate::lagrangian::Scalar;
use crate::solve::BandMatrix;
use num_dual::{Dual, Dual64, HyperDual64};

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
    /// The end position's given components (the free ones are placeholders).
    pub(super) q1: Vec<f64>,
    /// The end velocity's given components (the free ones are placeholders).
    pub(super) v1: Vec<f64>,
    /// Banded index of each free component of the end position.
    pub(super) end_q: Vec<Option<usize>>,
    /// Banded index of each free component of the end velocity.
    pub(super) end_v: Vec<Option<usize>>,
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

    /// Component i of node g's position, and where its share goes.
    pub(super) fn node_q(&self, x: &[f64], g: usize, i: usize) -> (f64, Target) {
        match (self.layout.q(g), g) {
            (Some(b), _) => (x[b + i], Target::Band(b + i)),
            (None, 0) => (self.q0[i], Target::Fixed),
            (None, _) => self.end_q[i].map_or((self.q1[i], Target::Fixed), |b| (x[b], Target::Band(b))),
        }
    }

    /// Component i of the end velocity, and where its share goes.
    pub(super) fn end_velocity(&self, x: &[f64], i: usize) -> (f64, Target) {
        self.end_v[i].map_or((self.v1[i], Target::Fixed), |b| (x[b], Target::Band(b)))
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
            let lam = &x[l.lambda(g)..l.lambda(g) + n];
            for i in 0..n {
                let (q, qt) = self.node_q(x, g, i);
                let lt = Target::Band(l.lambda(g) + i);
                y[i] += phi * q;
                y[n + i] += dphi * q;
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
        self.boundary(x, t1, band, grad, border)?;
        if self.layout.mc > 0 {
            self.constraint_terms(x, band, grad, border)?;
        }
        Ok(())
    }

    /// The ends' terms in the gradient and Hessian: Λ_0·p_0, and the end term
    /// Φ(t1, q_N, v_N) − Λ_N·p(t1, q_N, v_N) by hyper-dual passes over its variables
    /// z = (t1, q_N, v_N, Λ_N), the given ones skipped.
    fn boundary(&self, x: &[f64], t1: f64, band: &mut BandMatrix, grad: &mut [f64], border: &mut Border) -> Result<()> {
        let (l, n) = (self.layout, self.layout.n);
        let first = l.lambda(0);
        for i in 0..n {
            grad[first + i] += self.p0[i];
        }
        let (z, links) = self.end_variables(x, t1);
        let z: Vec<(f64, Target)> = z.into_iter().zip(links).map(|(v, l)| (v, l[0].0)).collect();
        hyper_term(&z, |zd| self.end_term(zd), band, grad, border)
    }

    /// The end term's variables z = (t1, q_N, v_N, Λ_N) and where each one's share goes.
    fn end_variables(&self, x: &[f64], t1: f64) -> (Vec<f64>, Vec<Vec<(Target, f64)>>) {
        let (l, n) = (self.layout, self.layout.n);
        let last = l.lambda(l.nodes() - 1);
        let time = if self.free { Target::Time } else { Target::Fixed };
        let mut z = vec![(t1, time)];
        z.extend((0..n).map(|i| self.node_q(x, l.nodes() - 1, i)));
        z.extend((0..n).map(|i| self.end_velocity(x, i)));
        z.extend((0..n).map(|i| (x[last + i], Target::Band(last + i))));
        z.into_iter().map(|(v, t)| (v, vec![(t, 1.0)])).unzip()
    }

    /// Φ(t, q, v) − Λ·∂L/∂v(t, q, v) at z = (t, q, v, Λ), generic so that hyper-dual z give
    /// its derivatives.
    fn end_term<D: Scalar>(&self, z: &[D]) -> D
    where
        Dual<D>: Scalar,
    {
        let n = self.layout.n;
        let (t, q, v, lam) = (z[0], &z[1..=n], &z[1 + n..=2 * n], &z[1 + 2 * n..=3 * n]);
        let qd: Vec<Dual<D>> = q.iter().map(|&a| Dual::from_re(a)).collect();
        let vd: Vec<Dual<D>> = v.iter().zip(lam).map(|(&a, &b)| Dual::new(a, b)).collect();
        let along = self.lag.value(Dual::from_re(t), &qd, &vd).eps;
        self.ctl.terminal_cost(t, q, v) - along
    }

    /// The terminal cost Φ(t1, q_N, v_N) and the end momentum p(t1, q_N, v_N) at an iterate.
    pub(super) fn end_state(&self, x: &[f64], t1: f64) -> (f64, Vec<f64>) {
        let n = self.layout.n;
        let (z, _) = self.end_variables(x, t1);
        let (t, q, v) = (Dual64::from(z[0]), &z[1..=n], &z[1 + n..=2 * n]);
        let qd: Vec<Dual64> = q.iter().map(|&a| Dual64::from(a)).collect();
        let mut vd: Vec<Dual64> = v.iter().map(|&a| Dual64::from(a)).collect();
        let p = (0..n)
            .map(|i| {
                vd[i].eps = 1.0;
                let r = self.lag.value(t, &qd, &vd).eps;
                vd[i].eps = 0.0;
                r
            })
            .collect();
        (self.ctl.terminal_cost(z[0], q, v), p)
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
        let (terminal, p1) = self.end_state(x, t1);
        objective += terminal;
        for i in 0..n {
            c[first + i] += self.p0[i];
            c[last + i] -= p1[i];
        }
        if l.mc > 0 {
            self.constraint_values(x, &mut c);
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
            .flat_map(|g| (0..self.layout.n).map(move |i| self.node_q(x, g, i).0))
            .collect()
    }
}

/// The gradient and Hessian of a small term f(z) by hyper-dual passes over its variables
/// that are unknowns (the given ones skipped), added to the global arrays.
pub(super) fn hyper_term(
    z: &[(f64, Target)],
    f: impl Fn(&[HyperDual64]) -> HyperDual64,
    band: &mut BandMatrix,
    grad: &mut [f64],
    border: &mut Border,
) -> Result<()> {
    let nz = z.len();
    let active: Vec<usize> = (0..nz).filter(|&a| z[a].1 != Target::Fixed).collect();
    let (mut gz, mut hz) = (vec![0.0; nz], vec![0.0; nz * nz]);
    let mut zd: Vec<HyperDual64> = z.iter().map(|&(v, _)| HyperDual64::from(v)).collect();
    for (ia, &a) in active.iter().enumerate() {
        for &b in &active[ia..] {
            zd[a].eps1 = 1.0;
            zd[b].eps2 = 1.0;
            let r = f(&zd);
            zd[a].eps1 = 0.0;
            zd[b].eps2 = 0.0;
            (hz[a * nz + b], hz[b * nz + a]) = (r.eps1eps2, r.eps1eps2);
            if b == a {
                gz[a] = r.eps1;
            }
        }
    }
    let links: Vec<Vec<(Target, f64)>> = z.iter().map(|&(_, t)| vec![(t, 1.0)]).collect();
    scatter(&links, &gz, &hz, band, grad, border)
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
