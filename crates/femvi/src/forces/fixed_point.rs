//! Forced runs by the mechanical fixed-point solver (`step/fixed_point_step.rs`), for
//! L = ½vᵀMv − V(t, q) with a constant mass matrix and a force F(t, q) that does not depend
//! on v.
//!
//! The forced step equations (module docs of [`crate::forces`]) differ from the conservative
//! ones only by F_d^j = h Σ_i b_i F(t_i, q_h(c_i)) ℓ_j(c_i), and ∂L_d/∂Q^j holds the same sum
//! h Σ_i b_i ∂L/∂q(c_i) ℓ_j(c_i) with ∂L/∂q = −∇V. So with v-independent F the forced
//! equations are the mechanical ones with the force −∇V replaced by −∇V + F(t, q) at the
//! quadrature points, and the fixed point's collocation-like form
//! Y_l = h a_l u + h² Σ_i B_li M⁻¹f_i, Δp = h Σ_i b_i f_i holds with f_i = (−∇V + F)(t_i, q_i).
//! [`WithForce`] is that augmented force, handed to the unchanged fixed-point solver of
//! [`crate::step`] by the force term (`term.rs`); the discrete work W_k is then evaluated on
//! each solved element exactly as the Newton step does ([`ElementWorkOf`]:
//! [`super::element_forces`] on the element's nodes, and −h Σ b_i ∂L/∂t for a time-dependent
//! L), so [`super::solve_forced`] reports the same quantities either way.

use super::element::element_forces;
use super::Force;
use crate::discrete::Element;
use crate::lagrangian::{Lagrangian, MassMatrix, PointDerivatives, Scalar};
use crate::step::ElementNodes;

/// Largest dimension whose force buffers live on the stack (larger ones allocate per call).
const STACK: usize = 16;

/// The mechanical Lagrangian `lag` seen by the fixed-point solver with the generalised force
/// −∇V(t, q) + F(t, q, 0). Only [`Lagrangian::mass_matrix`] and the forces are augmented;
/// value and derivatives are those of `lag` (they give p = Mv at the start). Not a Lagrangian
/// of the forced system: it exists only to drive the fixed-point solver, which reads the mass
/// matrix and the forces and nothing else, and is valid only for F independent of v.
pub(super) struct WithForce<'a, L, F> {
    lag: &'a L,
    force: &'a F,
}

impl<'a, L: Lagrangian, F: Force> WithForce<'a, L, F> {
    pub(super) fn new(lag: &'a L, force: &'a F) -> Self {
        Self { lag, force }
    }

    /// out += F(t, q, 0).
    #[inline]
    fn add_force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        let n = q.len();
        if n <= STACK {
            let mut buf = [0.0; 2 * STACK];
            let (zeros, f) = buf.split_at_mut(STACK);
            self.force.force(t, q, &zeros[..n], &mut f[..n]);
            out.iter_mut().zip(&f[..n]).for_each(|(o, f)| *o += f);
        } else {
            let (zeros, mut f) = (vec![0.0; n], vec![0.0; n]);
            self.force.force(t, q, &zeros, &mut f);
            out.iter_mut().zip(&f).for_each(|(o, f)| *o += f);
        }
    }
}

impl<L: Lagrangian, F: Force> Lagrangian for WithForce<'_, L, F> {
    fn dim(&self) -> usize {
        self.lag.dim()
    }
    fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        self.lag.value(t, q, v)
    }
    fn is_autonomous(&self) -> bool {
        false
    }
    fn mass_matrix(&self) -> Option<&MassMatrix> {
        self.lag.mass_matrix()
    }
    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        self.lag.force(t, q, out);
        self.add_force(t, q, out);
    }
    fn forces(&self, t: &[f64], q: &[f64], out: &mut [f64]) {
        self.lag.forces(t, q, out);
        let n = self.lag.dim();
        if n == 0 {
            return;
        }
        for ((&ti, qi), oi) in t.iter().zip(q.chunks_exact(n)).zip(out.chunks_exact_mut(n)) {
            self.add_force(ti, qi, oi);
        }
    }
    fn first_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        self.lag.first_derivatives(t, q, v, with_t, out)
    }
    fn second_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        self.lag.second_derivatives(t, q, v, with_t, out)
    }
}

/// Buffers for the work of one element.
pub(super) struct ElementWorkOf<'e> {
    element: &'e Element,
    fd: Vec<f64>,
    q: Vec<f64>,
    v: Vec<f64>,
    pd: PointDerivatives,
}

impl<'e> ElementWorkOf<'e> {
    pub(super) fn new(element: &'e Element, n: usize) -> Self {
        Self {
            element,
            fd: vec![0.0; element.nodes() * n],
            q: vec![0.0; n],
            v: vec![0.0; n],
            pd: PointDerivatives::new(n),
        }
    }

    /// The element's work of F, h Σ_i b_i F·q̇_h(c_i), and for a time-dependent L its
    /// −h Σ_i b_i ∂L/∂t(c_i): what the Newton step adds (`step.rs`).
    pub(super) fn of<L: Lagrangian, F: Force>(&mut self, lag: &L, force: &F, el: ElementNodes<'_>) -> f64 {
        let element = self.element;
        let mut w = element_forces(element, force, el.t, el.h, el.base, el.incr, &mut self.fd);
        if lag.is_autonomous() {
            return w;
        }
        let n = el.base.len();
        for i in 0..element.points() {
            self.q.copy_from_slice(el.base);
            self.v.iter_mut().for_each(|x| *x = 0.0);
            for j in 0..element.nodes() {
                let (a, d) = (element.phi(i, j), element.dphi(i, j) / el.h);
                for c in 0..n {
                    self.q[c] += el.incr[j * n + c] * a;
                    self.v[c] += el.incr[j * n + c] * d;
                }
            }
            let t = el.t + element.rule.nodes[i] * el.h;
            lag.first_derivatives(t, &self.q, &self.v, true, &mut self.pd);
            w -= el.h * element.rule.weights[i] * self.pd.l_t();
        }
        w
    }
}
