//! The fixed-point form of the step equations for mechanical Lagrangians
//! L = ½vᵀMv − V(t, q) (DESIGN.md §2). With increments ΔQ^m = Q^m − q_k the kinetic part of
//! p_k = −∂L_d/∂Q^0, ∂L_d/∂Q^j = 0 is linear, (1/h) Σ_m K_jm M ΔQ^m with the element
//! stiffness K, and does not depend on h in the reference element. Solving it once gives
//!
//!   ΔQ^m = h α_m u + h² Σ_i β_mi M⁻¹ f_i,    u = M⁻¹ p_k,  f_i = −∇V(t_k + c_i h, q(c_i)),
//!
//! and at the quadrature points Y_l = q(c_l) − q_k = h a_l u + h² Σ_i B_li M⁻¹ f_i, an
//! iteration on force evaluations only (no Hessians), as GNI_IRK2 does for Gauss methods.
//! The momentum update is p_{k+1} = p_k + h Σ_i b_i f_i (the sum of all element equations).

use crate::discrete::Element;
use crate::error::{invalid, Result};

/// The h-independent tables of the fixed-point iteration of one element.
#[derive(Debug, Clone, PartialEq)]
pub struct FixedPointTables {
    /// α_m, m = 1 … s.
    pub alpha: Vec<f64>,
    /// β_mi, row-major s×r.
    pub beta: Vec<f64>,
    /// a_l, l = 1 … r.
    pub a: Vec<f64>,
    /// B_li, row-major r×r.
    pub b: Vec<f64>,
}

impl FixedPointTables {
    /// Tables of `element`.
    ///
    /// # Errors
    /// The stiffness block K[0..s, 1..=s] is singular (a degenerate element).
    pub fn new(element: &Element) -> Result<Self> {
        element.check_nondegenerate()?;
        let s = element.degree();
        let r = element.points();
        let w = s + 1;
        let k = element.stiffness();
        let a_mat = nalgebra::DMatrix::from_fn(s, s, |j, m| k[j * w + m + 1]);
        let inv = a_mat
            .try_inverse()
            .ok_or_else(|| invalid("scheme", "the element stiffness is singular"))?;
        // Unknown m (1..=s) is row m−1 of inv; equation j (0..s) is column j.
        let alpha: Vec<f64> = (0..s).map(|m| -inv[(m, 0)]).collect();
        let mut beta = vec![0.0; s * r];
        for m in 0..s {
            for i in 0..r {
                let bw = element.rule.weights[i];
                beta[m * r + i] = -(0..s).map(|j| inv[(m, j)] * bw * element.phi(i, j)).sum::<f64>();
            }
        }
        let mut a = vec![0.0; r];
        let mut b = vec![0.0; r * r];
        for l in 0..r {
            for m in 0..s {
                let pl = element.phi(l, m + 1);
                a[l] += pl * alpha[m];
                for i in 0..r {
                    b[l * r + i] += pl * beta[m * r + i];
                }
            }
        }
        Ok(Self { alpha, beta, a, b })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::{NodeFamily, QuadratureKind};

    #[test]
    fn end_node_moves_with_the_initial_velocity() {
        // Free particle: ΔQ^s = h u exactly, so α_s = 1; and Y_l = c_l h u, so a_l = c_l.
        for s in 1..=6 {
            let e = Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap();
            let t = FixedPointTables::new(&e).unwrap();
            assert!((t.alpha[s - 1] - 1.0).abs() < 1e-12, "s={s}: {}", t.alpha[s - 1]);
            for (l, c) in e.rule.nodes.iter().enumerate() {
                assert!((t.a[l] - c).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn gauss_tables_are_the_gauss_collocation_coefficients() {
        // s = 1 with the midpoint rule is the implicit midpoint rule: Y = h/2 u + h²/4 f.
        let e = Element::midpoint();
        let t = FixedPointTables::new(&e).unwrap();
        assert!((t.b[0] - 0.25).abs() < 1e-15 && (t.a[0] - 0.5).abs() < 1e-15);
        // Degree 2 with the one-point rule is degenerate.
        let e = Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::Midpoint).unwrap();
        assert!(FixedPointTables::new(&e).is_err());
    }
}
