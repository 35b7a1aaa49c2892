//! The holonomic constraints' share of the optimiser's KKT Lagrangian (module docs of
//! `optimize`, DESIGN §4): at every node g the term κ_g·g(Q_g) − ν_g·G(Q_g)Λ_g, i.e. the
//! constraint impulse −G(Q_g)ᵀν_g in node g's equation and g(Q_g) = 0 where Q_g has unknowns,
//! and at the end the hidden constraints κ'·G(q_N)v_N. Each term is local to a node, so the
//! banded structure holds; its derivatives come from hyper-dual passes (`hyper_term`).

use super::assemble::{hyper_term, Border, Model, Target};
use super::system::Controls;
use crate::error::Result;
use crate::lagrangian::{Lagrangian, Scalar};
use crate::solve::BandMatrix;
use num_dual::{Dual, Dual64};

impl<L: Lagrangian + ?Sized, C: Controls> Model<'_, L, C> {
    /// The holonomic constraints' terms, node by node: κ_g·g(Q_g) − ν_g·G(Q_g)Λ_g (the
    /// constraint impulse −G(Q_g)ᵀν_g in node g's equation, and g(Q_g) = 0 where Q_g has
    /// unknowns), and with a free end velocity the hidden constraints κ'·G(q_N)v_N.
    pub(super) fn constraint_terms(
        &self,
        x: &[f64],
        band: &mut BandMatrix,
        grad: &mut [f64],
        border: &mut Border,
    ) -> Result<()> {
        let (l, n, mc) = (self.layout, self.layout.n, self.layout.mc);
        let fixed = |_| (0.0, Target::Fixed);
        let band_at = |i: usize| (x[i], Target::Band(i));
        for g in 0..l.nodes() {
            let mut z: Vec<(f64, Target)> = (0..n).map(|i| self.node_q(x, g, i)).collect();
            z.extend((l.lambda(g)..l.lambda(g) + n).map(band_at));
            z.extend((l.nu(g)..l.nu(g) + mc).map(band_at));
            match l.kappa(g) {
                Some(k) => z.extend((k..k + mc).map(band_at)),
                None => z.extend((0..mc).map(fixed)),
            }
            hyper_term(&z, |zd| self.node_term(zd), band, grad, border)?;
        }
        if let Some(h) = l.hidden() {
            let mut z: Vec<(f64, Target)> = (0..n).map(|i| self.node_q(x, l.nodes() - 1, i)).collect();
            z.extend((0..n).map(|i| self.end_velocity(x, i)));
            z.extend((h..h + mc).map(band_at));
            hyper_term(&z, |zd| self.hidden_term(zd), band, grad, border)?;
        }
        Ok(())
    }

    /// κ·g(Q) − ν·G(Q)Λ at z = (Q, Λ, ν, κ), G(Q)Λ as the derivative of g along Λ.
    fn node_term<D: Scalar>(&self, z: &[D]) -> D
    where
        Dual<D>: Scalar,
    {
        let (n, mc) = (self.layout.n, self.layout.mc);
        let (nu, kappa) = (&z[2 * n..2 * n + mc], &z[2 * n + mc..]);
        self.along(&z[..n], &z[n..2 * n], |g| {
            g.iter()
                .zip(nu.iter().zip(kappa))
                .fold(D::from(0.0), |s, (gl, (&v, &k))| s + k * gl.re - v * gl.eps)
        })
    }

    /// κ'·G(q)v at z = (q, v, κ').
    fn hidden_term<D: Scalar>(&self, z: &[D]) -> D
    where
        Dual<D>: Scalar,
    {
        let n = self.layout.n;
        self.along(&z[..n], &z[n..2 * n], |g| {
            g.iter()
                .zip(&z[2 * n..])
                .fold(D::from(0.0), |s, (gl, &k)| s + k * gl.eps)
        })
    }

    /// `f` of g(q + ε·dir) as dual numbers (g(q) and G(q)·dir), evaluated in stack buffers
    /// when n and the number of constraints are at most 16 (no allocation in the node loop's
    /// hyper-dual passes), else in allocated ones.
    fn along<D: Scalar>(&self, q: &[D], dir: &[D], f: impl FnOnce(&[Dual<D>]) -> D) -> D
    where
        Dual<D>: Scalar,
    {
        const STACK: usize = 16;
        let (n, mc) = (self.layout.n, self.layout.mc);
        let zero = Dual::from_re(D::from(0.0));
        let fill = |qd: &mut [Dual<D>]| {
            qd.iter_mut()
                .zip(q.iter().zip(dir))
                .for_each(|(d, (&a, &b))| *d = Dual::new(a, b));
        };
        if n <= STACK && mc <= STACK {
            let (mut qd, mut g) = ([zero; STACK], [zero; STACK]);
            fill(&mut qd[..n]);
            self.ctl.constraints(&qd[..n], &mut g[..mc]);
            f(&g[..mc])
        } else {
            let (mut qd, mut g) = (vec![zero; n], vec![zero; mc]);
            fill(&mut qd);
            self.ctl.constraints(&qd, &mut g);
            f(&g)
        }
    }

    /// The constraints' shares of c: −G(Q_g)ᵀν_g in node g's equation, g(Q_g) at κ_g and
    /// G(q_N)v_N at the hidden constraints' multipliers.
    pub(super) fn constraint_values(&self, x: &[f64], c: &mut [f64]) {
        let (l, n, mc) = (self.layout, self.layout.n, self.layout.mc);
        let mut qd = vec![Dual64::from(0.0); n];
        let mut g = vec![Dual64::from(0.0); mc];
        for node in 0..l.nodes() {
            qd.iter_mut()
                .enumerate()
                .for_each(|(i, d)| *d = Dual64::from(self.node_q(x, node, i).0));
            for i in 0..n {
                qd[i].eps = 1.0;
                self.ctl.constraints(&qd, &mut g);
                qd[i].eps = 0.0;
                c[l.lambda(node) + i] -= (0..mc).map(|k| g[k].eps * x[l.nu(node) + k]).sum::<f64>();
            }
            if let Some(k) = l.kappa(node) {
                (0..mc).for_each(|j| c[k + j] = g[j].re);
            }
        }
        if let Some(h) = l.hidden() {
            let last = l.nodes() - 1;
            for (i, d) in qd.iter_mut().enumerate() {
                *d = Dual64::new(self.node_q(x, last, i).0, self.end_velocity(x, i).0);
            }
            self.ctl.constraints(&qd, &mut g);
            (0..mc).for_each(|j| c[h + j] = g[j].eps);
        }
    }
}
