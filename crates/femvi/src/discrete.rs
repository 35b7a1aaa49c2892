//! Discrete Lagrangians from finite elements (DESIGN.md §1): the element integral
//!
//!   L_d(t_k, t_{k+1}; Q) = h Σ_i b_i L(t_k + c_i h, q_h(c_i), q̇_h(c_i)),
//!   q_h(τ) = Σ_j Q^j ℓ_j(τ),  q̇_h(τ) = (1/h) Σ_j Q^j ℓ_j'(τ),
//!
//! which is h_k times the paper's element average 𝕃 of (2.27) (degree 1) and (2.39b)
//! (degree 2), for any degree s and any quadrature rule. The paper's midpoint Lagrangian
//! (2.19) is degree 1 with the one-point rule ([`Element::midpoint`]).
//!
//! Nodal values are passed as a base point q_k plus increments Q^j − q_k, so that round-off
//! does not grow with |q| (DESIGN.md §2). [`Element`] evaluates L_d, its gradient
//! ∂L_d/∂Q^j (whose end rows are the discrete Legendre transforms p_k⁻ = −∂L_d/∂Q^0 and
//! p_{k+1}⁺ = ∂L_d/∂Q^s, the paper's D_2 and D_4/D_5 terms of (2.3)/(2.40)), its Hessian
//! (for Newton, tangent maps and boundary value problems) and the discrete energies
//! E_k⁻ = ∂L_d/∂t_k, E_{k+1}⁺ = −∂L_d/∂t_{k+1} of §3.
//!
//! The evaluations write into caller-owned buffers and are called in the step loop, so they
//! stay infallible: buffers of the wrong size (checked in O(r), `discrete/checks.rs`) give
//! NaN instead of a panic, and [`Element::check_buffers`] names the wrong one as a typed
//! error, once, before a loop.

mod checks;
mod generic;
mod work;

pub use work::ElementWork;

use crate::error::{invalid, Result};
use crate::fem::{LagrangeBasis, NodeFamily, QuadratureKind, QuadratureRule};
use crate::lagrangian::Lagrangian;

/// A finite element: a Lagrange basis of degree s and a quadrature rule, with the basis
/// values ℓ_j(c_i) and derivatives ℓ_j'(c_i) tabulated once at the quadrature nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Element {
    /// The shape functions.
    pub basis: LagrangeBasis,
    /// The quadrature rule.
    pub rule: QuadratureRule,
    phi: Vec<f64>,
    dphi: Vec<f64>,
}

impl Element {
    /// A Galerkin element of degree `degree` with nodes of `family` and the quadrature `rule`.
    ///
    /// # Errors
    /// Degree 0, or an invalid rule.
    pub fn galerkin(degree: usize, family: NodeFamily, rule: QuadratureKind) -> Result<Self> {
        let basis = LagrangeBasis::new(degree, family)?;
        let rule = QuadratureRule::new(rule)?;
        let (phi, dphi) = basis.tabulate(&rule.nodes);
        Ok(Self { basis, rule, phi, dphi })
    }

    /// The element of order 2s for `order` = 2s: degree s with equispaced nodes and s-point
    /// Gauss–Legendre quadrature (femvi's default choice; the nodal order is 2s).
    ///
    /// # Errors
    /// An order that is zero or odd.
    ///
    /// # Example
    ///
    /// ```
    /// let element = femvi::Element::with_order(8)?;
    /// assert_eq!((element.degree(), element.points()), (4, 4));
    /// assert!(femvi::Element::with_order(7).is_err());
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn with_order(order: usize) -> Result<Self> {
        if order == 0 || order % 2 == 1 {
            return Err(invalid(
                "order",
                format!("{order}: Galerkin elements with Gauss quadrature have even orders 2s, s >= 1"),
            ));
        }
        let s = order / 2;
        Self::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s))
    }

    /// The paper's midpoint discrete Lagrangian (2.19), generalised:
    /// L_d = h L(t_k + h/2, (q_k + q_{k+1})/2, (q_{k+1} − q_k)/h).
    pub fn midpoint() -> Self {
        Self::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Midpoint)
            .unwrap_or_else(|_| unreachable!("degree 1 with one point is valid"))
    }

    /// Degree s.
    pub fn degree(&self) -> usize {
        self.basis.degree
    }

    /// Number of nodes, s + 1.
    pub fn nodes(&self) -> usize {
        self.basis.degree + 1
    }

    /// Number of quadrature points r.
    pub fn points(&self) -> usize {
        self.rule.len()
    }

    /// ℓ_j(c_i) (NaN for i or j out of range).
    #[inline]
    pub fn phi(&self, i: usize, j: usize) -> f64 {
        self.table(&self.phi, i, j)
    }

    /// ℓ_j'(c_i) (NaN for i or j out of range).
    #[inline]
    pub fn dphi(&self, i: usize, j: usize) -> f64 {
        self.table(&self.dphi, i, j)
    }

    #[inline]
    fn table(&self, tab: &[f64], i: usize, j: usize) -> f64 {
        let w = self.nodes();
        if i < self.points() && j < w {
            tab.get(i * w + j).copied().unwrap_or(f64::NAN)
        } else {
            f64::NAN
        }
    }

    /// The element stiffness K_jm = Σ_i b_i ℓ_j'(c_i) ℓ_m'(c_i), row-major (s+1)².
    pub fn stiffness(&self) -> Vec<f64> {
        let w = self.nodes();
        let mut k = vec![0.0; w * w];
        for i in 0..self.points() {
            let b = self.rule.weights[i];
            for j in 0..w {
                for m in 0..w {
                    k[j * w + m] += b * self.dphi[i * w + j] * self.dphi[i * w + m];
                }
            }
        }
        k
    }

    /// Fills the time, position and velocity at each quadrature point of the element
    /// [t0, t0 + h] with nodal values `base` + `incr[j]` (incr has (s+1)·n entries for
    /// n = `base.len()`, and `work` is made for this element and n; otherwise the points are
    /// NaN).
    pub fn points_in_place(&self, t0: f64, h: f64, base: &[f64], incr: &[f64], work: &mut ElementWork) {
        if !self.fits(base.len(), incr, work) {
            work.poison();
            return;
        }
        self.points_unchecked(t0, h, base, incr, work);
    }

    fn points_unchecked(&self, t0: f64, h: f64, base: &[f64], incr: &[f64], work: &mut ElementWork) {
        let n = base.len();
        let w = self.nodes();
        for i in 0..self.points() {
            work.tc[i] = t0 + self.rule.nodes[i] * h;
            let qi = &mut work.qc[i * n..(i + 1) * n];
            qi.copy_from_slice(base);
            let vi = &mut work.vc[i * n..(i + 1) * n];
            vi.iter_mut().for_each(|x| *x = 0.0);
            for j in 0..w {
                let (a, d) = (self.phi[i * w + j], self.dphi[i * w + j] / h);
                let dj = &incr[j * n..(j + 1) * n];
                for c in 0..n {
                    qi[c] += a * dj[c];
                    vi[c] += d * dj[c];
                }
            }
        }
    }

    /// The discrete Lagrangian L_d and its gradient ∂L_d/∂Q^j into `grad` ((s+1)·n entries).
    /// With `with_t`, ∂L/∂t is also evaluated at the points (needed by [`Element::energies`]).
    /// Buffers that do not fit (see [`Element::check_buffers`]) give NaN, and a NaN `grad`.
    #[allow(clippy::too_many_arguments)]
    pub fn gradient_in_place<L: Lagrangian>(
        &self,
        lag: &L,
        t0: f64,
        h: f64,
        base: &[f64],
        incr: &[f64],
        with_t: bool,
        work: &mut ElementWork,
        grad: &mut [f64],
    ) -> f64 {
        let n = base.len();
        if !(self.fits(n, incr, work) && grad.len() == incr.len() && lag.dim() == n) {
            grad.iter_mut().for_each(|g| *g = f64::NAN);
            return f64::NAN;
        }
        let w = self.nodes();
        self.points_unchecked(t0, h, base, incr, work);
        grad.iter_mut().for_each(|g| *g = 0.0);
        let mut ld = 0.0;
        for i in 0..self.points() {
            let pd = &mut work.pts[i];
            lag.first_derivatives(
                work.tc[i],
                &work.qc[i * n..(i + 1) * n],
                &work.vc[i * n..(i + 1) * n],
                with_t,
                pd,
            );
            let b = self.rule.weights[i];
            ld += b * pd.value;
            for (j, gj) in grad.chunks_exact_mut(n).enumerate() {
                let (a, d) = (b * h * self.phi[i * w + j], b * self.dphi[i * w + j]);
                for ((g, lq), lv) in gj.iter_mut().zip(pd.l_q()).zip(pd.l_v()) {
                    *g += a * lq + d * lv;
                }
            }
        }
        h * ld
    }

    /// L_d, its gradient and its Hessian ∂²L_d/∂Q^j∂Q^m (row-major ((s+1)n)², into `hess`).
    /// Buffers that do not fit give NaN, as for [`Element::gradient_in_place`].
    #[allow(clippy::too_many_arguments)]
    pub fn hessian_in_place<L: Lagrangian>(
        &self,
        lag: &L,
        t0: f64,
        h: f64,
        base: &[f64],
        incr: &[f64],
        work: &mut ElementWork,
        grad: &mut [f64],
        hess: &mut [f64],
    ) -> f64 {
        let n = base.len();
        let w = self.nodes();
        let dim = w * n;
        let fits = self.fits(n, incr, work) && grad.len() == dim && lag.dim() == n;
        if !(fits && dim.checked_mul(dim) == Some(hess.len())) {
            grad.iter_mut().chain(hess.iter_mut()).for_each(|g| *g = f64::NAN);
            return f64::NAN;
        }
        self.points_unchecked(t0, h, base, incr, work);
        grad.iter_mut().for_each(|g| *g = 0.0);
        hess.iter_mut().for_each(|g| *g = 0.0);
        let mut ld = 0.0;
        for i in 0..self.points() {
            let pd = &mut work.pts[i];
            lag.second_derivatives(
                work.tc[i],
                &work.qc[i * n..(i + 1) * n],
                &work.vc[i * n..(i + 1) * n],
                false,
                pd,
            );
            let b = self.rule.weights[i];
            ld += b * pd.value;
            for j in 0..w {
                let (aj, dj) = (self.phi[i * w + j], self.dphi[i * w + j]);
                for c in 0..n {
                    grad[j * n + c] += b * (h * aj * pd.l_q()[c] + dj * pd.l_v()[c]);
                }
                for m in 0..w {
                    let (am, dm) = (self.phi[i * w + m], self.dphi[i * w + m]);
                    let (qq, qv, vq, vv) = (b * h * aj * am, b * aj * dm, b * dj * am, b * dj * dm / h);
                    for c in 0..n {
                        let row = &mut hess[(j * n + c) * dim + m * n..(j * n + c) * dim + m * n + n];
                        for (e, r) in row.iter_mut().enumerate() {
                            *r += qq * pd.h(1 + c, 1 + e)
                                + qv * pd.h(1 + c, 1 + n + e)
                                + vq * pd.h(1 + n + c, 1 + e)
                                + vv * pd.h(1 + n + c, 1 + n + e);
                        }
                    }
                }
            }
        }
        h * ld
    }

    /// The discrete energies (E_k⁻, E_{k+1}⁺) = (∂L_d/∂t_k, −∂L_d/∂t_{k+1}) of the element whose
    /// points were last evaluated by [`Element::gradient_in_place`] with `with_t = true`:
    ///   E⁻ = Σ b_i (v_i·∂L/∂v − L)_i + h Σ b_i (1 − c_i) ∂L/∂t_i,
    ///   E⁺ = Σ b_i (v_i·∂L/∂v − L)_i − h Σ b_i c_i ∂L/∂t_i.
    /// For autonomous L both equal the quadrature average of the energy function.
    /// (NaN, NaN) if `work` was not made for this element.
    pub fn energies(&self, h: f64, work: &ElementWork) -> (f64, f64) {
        let n = work.n;
        if !work.fits(self.points(), n) {
            return (f64::NAN, f64::NAN);
        }
        let (mut e, mut lt_minus, mut lt_plus) = (0.0, 0.0, 0.0);
        for i in 0..self.points() {
            let pd = &work.pts[i];
            let b = self.rule.weights[i];
            let c = self.rule.nodes[i];
            let vlv: f64 = work.vc[i * n..(i + 1) * n]
                .iter()
                .zip(pd.l_v())
                .map(|(a, b)| a * b)
                .sum();
            e += b * (vlv - pd.value);
            lt_minus += b * (1.0 - c) * pd.l_t();
            lt_plus += b * c * pd.l_t();
        }
        (e + h * lt_minus, e - h * lt_plus)
    }

    /// Checks that the element is usable for a Lagrangian whose kinetic part is quadratic:
    /// the stiffness K must have rank s (only constants in its kernel), otherwise the
    /// discrete Lagrangian is degenerate (e.g. degree 2 with the one-point midpoint rule).
    ///
    /// # Errors
    /// [`crate::Error::Invalid`] naming the element and rule, or an element whose public
    /// fields were changed after construction so that they disagree.
    pub fn check_nondegenerate(&self) -> Result<()> {
        self.check_consistent()?;
        let w = self.nodes();
        let s = self.degree();
        let k = self.stiffness();
        let a = nalgebra::DMatrix::from_fn(s, s, |j, m| k[j * w + m + 1]);
        let sv = a.singular_values();
        if sv.min() <= 1e-12 * sv.max() {
            return Err(invalid(
                "scheme",
                format!(
                    "degree {s} with the {:?} rule ({} points) gives a degenerate discrete Lagrangian: the quadrature is too weak for the element's kinetic energy; use at least {} Gauss-Legendre points",
                    self.rule.kind,
                    self.points(),
                    s
                ),
            ));
        }
        Ok(())
    }
}
