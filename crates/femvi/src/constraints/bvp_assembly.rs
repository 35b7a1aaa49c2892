//! The equations of a constrained two-point boundary value problem and their banded Jacobian
//! (the derivation is in `bvp.rs`): per element the node rows and interior constraint rows of
//! the constrained step (`step.rs`, with p_k = 0 and no start multiplier), plus per interior
//! element end node q_k the node multiplier ν_k: −G(q_k)ᵀν_k in its node rows and the row
//! g(q_k) = 0.
//!
//! Unknowns, in order of time so that the Jacobian is banded: per element k the block
//! (h·Λ̂_k, Q^1 … Q^{s−1} of element k, q_{k+1}, h·ν_{k+1}), the last block without q_N and
//! ν_N. Element k touches its own block and the end (q_k, h·ν_k) of the one before, so the
//! bandwidth is I m + (s+1) n + m − 1 and a Newton iteration costs O(N).

use super::forcing::NodeForce;
use super::layout::Layout as Sites;
use super::step::StepSystem;
use super::Constraints;
use crate::bvp::BoundaryValues;
use crate::discrete::Element;
use crate::lagrangian::Lagrangian;
use crate::solve::BandMatrix;

/// The numbering of the unknowns.
#[derive(Debug, Clone, Copy)]
pub(super) struct Numbering {
    pub n: usize,
    pub m: usize,
    pub s: usize,
    /// Interior multiplier blocks per element, I.
    pub sites: usize,
    pub elements: usize,
}

impl Numbering {
    /// Unknowns per element block: I m + s n + m.
    fn block(&self) -> usize {
        self.sites * self.m + self.s * self.n + self.m
    }

    /// Number of unknowns and the bandwidth, or None if they overflow.
    pub fn checked_size(&self) -> Option<(usize, usize)> {
        let (n, m, s) = (self.n, self.m, self.s);
        let block = self
            .sites
            .checked_mul(m)?
            .checked_add(s.checked_mul(n)?)?
            .checked_add(m)?;
        let len = self.elements.checked_mul(block)?.checked_sub(n + m)?;
        let bw = block.checked_add(n)?.checked_sub(1)?;
        Some((len, bw))
    }

    /// Component `a` of local node j (0 … s) of element k, if it is an unknown.
    pub fn node(&self, k: usize, j: usize, a: usize) -> Option<usize> {
        let (b, first) = (self.block(), self.sites * self.m);
        if j == 0 {
            return (k > 0).then(|| (k - 1) * b + first + (self.s - 1) * self.n + a);
        }
        if j == self.s && k + 1 == self.elements {
            return None;
        }
        Some(k * b + first + (j - 1) * self.n + a)
    }

    /// Interior multiplier (h·Λ̂) c, component l, of element k.
    pub fn site(&self, k: usize, c: usize, l: usize) -> usize {
        k * self.block() + c * self.m + l
    }

    /// Node multiplier h·ν_k, component l, of element end node k (1 … N−1).
    pub fn nu(&self, k: usize, l: usize) -> usize {
        (k - 1) * self.block() + self.sites * self.m + self.s * self.n + l
    }
}

/// The problem and the work space of its assembly.
pub(super) struct Assembly<'a, L, C> {
    pub lag: &'a L,
    pub con: &'a C,
    pub element: &'a Element,
    pub bv: &'a BoundaryValues,
    pub num: Numbering,
    /// The element equations (reused for every element).
    pub sys: StepSystem,
    /// All global nodal values, row-major (N s + 1) × n, unpacked from the unknowns.
    pub nodes: Vec<f64>,
    /// Unknowns of one element's step system: increments Q^j − Q^0, h·λ̂ (zero), h·Λ̂.
    xs: Vec<f64>,
    zero_p: Vec<f64>,
    /// ν at a node.
    nu: Vec<f64>,
    /// Σ_l ν_l ∇²g_l at a node, n × n.
    nu_hess: Vec<f64>,
    /// The force whose discrete forces are added to each element's node rows
    /// ([`StepSystem::add_term`]).
    pub force: Option<&'a dyn NodeForce>,
}

impl<'a, L: Lagrangian, C: Constraints> Assembly<'a, L, C> {
    pub fn new(
        lag: &'a L,
        con: &'a C,
        element: &'a Element,
        bv: &'a BoundaryValues,
        sites: Sites,
        nodes: Vec<f64>,
    ) -> Self {
        let (n, m, s) = (lag.dim(), con.count(), element.degree());
        let num = Numbering {
            n,
            m,
            s,
            sites: sites.sites,
            elements: bv.elements,
        };
        let sys = StepSystem::new(element, sites, n, m);
        let xs = vec![0.0; sys.unknowns()];
        Self {
            lag,
            con,
            element,
            bv,
            num,
            sys,
            nodes,
            xs,
            zero_p: vec![0.0; n],
            nu: vec![0.0; m],
            nu_hess: vec![0.0; n * n],
            force: None,
        }
    }

    /// Writes the unknowns `x` into `nodes`.
    pub fn unpack(&mut self, x: &[f64]) {
        let (n, s) = (self.num.n, self.num.s);
        for k in 0..self.num.elements {
            for j in 1..=s {
                for a in 0..n {
                    if let Some(i) = self.num.node(k, j, a) {
                        self.nodes[(k * s + j) * n + a] = x[i];
                    }
                }
            }
        }
    }

    /// Evaluates the step system of element k at the unknowns `x` (nodes unpacked): its
    /// residual and, if `with_jac`, its Jacobian, in `sys`.
    pub fn eval_element(&mut self, k: usize, x: &[f64], with_jac: bool) {
        let (n, m, s) = (self.num.n, self.num.m, self.num.s);
        let g0 = k * s;
        let base = &self.nodes[g0 * n..(g0 + 1) * n];
        for j in 1..=s {
            for a in 0..n {
                self.xs[(j - 1) * n + a] = self.nodes[(g0 + j) * n + a] - base[a];
            }
        }
        self.xs[s * n..s * n + m].iter_mut().for_each(|v| *v = 0.0);
        for c in 0..self.num.sites {
            for l in 0..m {
                self.xs[s * n + m + c * m + l] = x[self.num.site(k, c, l)];
            }
        }
        let (t0, h) = (self.bv.t0 + k as f64 * self.bv.step(), self.bv.step());
        self.sys.eval(
            self.element,
            self.lag,
            self.con,
            t0,
            h,
            base,
            &self.zero_p,
            &self.xs,
            with_jac,
        );
        if let Some(force) = self.force {
            self.sys.add_term(force.term(), t0, h, base, with_jac);
        }
    }

    /// The residual at the unknowns `x` into `r` and, if given, the Jacobian into `band`.
    pub fn eval(&mut self, x: &[f64], r: &mut [f64], mut band: Option<&mut BandMatrix>) {
        self.unpack(x);
        r.iter_mut().for_each(|v| *v = 0.0);
        if let Some(b) = band.as_deref_mut() {
            b.clear();
        }
        for k in 0..self.num.elements {
            self.eval_element(k, x, band.is_some());
            self.scatter_element(k, r, band.as_deref_mut());
            if k + 1 < self.num.elements {
                self.add_node(k + 1, x, r, band.as_deref_mut());
            }
        }
    }

    /// The full row or column of `sys` behind unknown-space index: local node rows/columns
    /// (j n + a) and interior multiplier rows/columns, with their unknowns.
    fn locals(&self, k: usize) -> impl Iterator<Item = (usize, Option<usize>)> + '_ {
        let (n, m, s) = (self.num.n, self.num.m, self.num.s);
        let wn = (s + 1) * n;
        let nodes = (0..wn).map(move |i| (i, self.num.node(k, i / n, i % n)));
        let sites = (0..self.num.sites * m).map(move |i| (wn + m + i, Some(self.num.site(k, i / m, i % m))));
        nodes.chain(sites)
    }

    /// Adds element k's node rows and interior constraint rows (and their derivatives in the
    /// element's nodes and interior multipliers) at the unknowns.
    fn scatter_element(&self, k: usize, r: &mut [f64], mut band: Option<&mut BandMatrix>) {
        let f = self.sys.full;
        for (fr, row) in self.locals(k) {
            let Some(row) = row else { continue };
            r[row] += self.sys.res[fr];
            if let Some(b) = band.as_deref_mut() {
                for (fc, col) in self.locals(k) {
                    if let Some(col) = col {
                        let added = b.add(row, col, self.sys.jac[fr * f + fc]);
                        debug_assert!(added.is_ok(), "the numbering keeps an element's entries in the band");
                    }
                }
            }
        }
    }

    /// The node multiplier terms of element end node k (1 … N−1), whose jet is the end jet of
    /// the element just evaluated (element k − 1).
    fn add_node(&mut self, k: usize, x: &[f64], r: &mut [f64], band: Option<&mut BandMatrix>) {
        let (n, m, s) = (self.num.n, self.num.m, self.num.s);
        let h = self.bv.step();
        let jet = &self.sys.end;
        let row = |a: usize| self.num.node(k - 1, s, a).unwrap_or(usize::MAX);
        for l in 0..m {
            self.nu[l] = x[self.num.nu(k, l)] / h;
        }
        let nu = &self.nu;
        for l in 0..m {
            r[self.num.nu(k, l)] = jet.g[l];
            for a in 0..n {
                r[row(a)] -= jet.jac[l * n + a] * nu[l];
            }
        }
        let Some(b) = band else { return };
        self.nu_hess.iter_mut().for_each(|v| *v = 0.0);
        jet.add_contracted_hessian(nu, -1.0, &mut self.nu_hess, n, 0, 0);
        let mut put = |i: usize, j: usize, v: f64| {
            let added = b.add(i, j, v);
            debug_assert!(added.is_ok(), "the numbering keeps a node's entries in the band");
        };
        for a in 0..n {
            for c in 0..n {
                put(row(a), row(c), self.nu_hess[a * n + c]);
            }
            for l in 0..m {
                let g = jet.jac[l * n + a];
                put(row(a), self.num.nu(k, l), -g / h);
                put(self.num.nu(k, l), row(a), g);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvp::line_guess;
    use crate::constraints::Enforcement;
    use crate::fem::{NodeFamily, QuadratureKind};

    /// The assembled Jacobian is the derivative of the residual (central differences), off
    /// the solution and with nonzero multipliers, for degree 1 and for each enforcement with
    /// interior multipliers (the spherical pendulum: the sphere's Hessian enters through the
    /// multipliers).
    #[test]
    fn jacobian_is_the_derivative_of_the_residual() {
        let (lag, sphere) = crate::models::chain(3, 1, 1.0, 9.81, 1.0).unwrap();
        let cases = [
            (Element::with_order(2).unwrap(), Enforcement::Weak),
            (Element::with_order(6).unwrap(), Enforcement::Weak),
            (
                Element::galerkin(2, NodeFamily::Lobatto, QuadratureKind::GaussLobatto(3)).unwrap(),
                Enforcement::Nodes,
            ),
            (Element::with_order(4).unwrap(), Enforcement::Points),
        ];
        for (element, enforcement) in &cases {
            let bv = BoundaryValues {
                t0: 0.0,
                q0: vec![0.6, 0.0, -0.8],
                t1: 1.0,
                q1: vec![0.0, 0.8, -0.6],
                elements: 3,
            };
            let sites = Sites::new(element, *enforcement).unwrap();
            let mut asm = Assembly::new(&lag, &sphere, element, &bv, sites, line_guess(&bv, element));
            let (len, bw) = asm.num.checked_size().unwrap();
            let x: Vec<f64> = (0..len).map(|i| 0.3 * (i as f64 * 1.3).sin()).collect();
            let mut band = BandMatrix::zeros(len, bw, bw).unwrap();
            let mut r = vec![0.0; len];
            asm.eval(&x, &mut r, Some(&mut band));
            let (mut rp, mut rm) = (vec![0.0; len], vec![0.0; len]);
            let d = 1e-6;
            for i in 0..len {
                let mut xp = x.clone();
                xp[i] += d;
                asm.eval(&xp, &mut rp, None);
                let mut xm = x.clone();
                xm[i] -= d;
                asm.eval(&xm, &mut rm, None);
                for row in 0..len {
                    let fd = (rp[row] - rm[row]) / (2.0 * d);
                    let jac = band.get(row, i);
                    assert!(
                        (fd - jac).abs() < 1e-6 * (1.0 + jac.abs()),
                        "{enforcement:?}, degree {}: J[{row}][{i}] = {jac}, difference quotient {fd}",
                        element.degree()
                    );
                }
            }
        }
    }
}
