//! Where a degree-s element enforces the constraints inside the element ([`Enforcement`]), as
//! data: evaluation points y_i = Σ_j a_ij Q^j (nodes or quadrature points) with weights ω_i,
//! and the map Ψ from the element's interior multiplier unknowns Λ̂_c to the multiplier at
//! each point, Λ(y_i) = Σ_c Ψ_ic Λ̂_c. The augmented discrete Lagrangian of the element is
//!
//!   L_d − λ̂·g(Q^0) − Σ_i ω_i Λ(y_i)·g(y_i) − μ̂·g(Q^s),
//!
//! its interior constraint equations are ∂/∂Λ̂_c = 0: Σ_i ω_i Ψ_ic g(y_i) = 0, and the
//! constraint force on node j is Σ_i a_ij ω_i G(y_i)ᵀ Λ(y_i) (module `step`).

use crate::discrete::Element;
use crate::error::{invalid, Result};

/// Where the constraints are enforced inside an element (they always hold at the nodes q_k).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Enforcement {
    /// Only at the element's end nodes: the interior nodes move freely (measured order 2 for
    /// every degree).
    Ends,
    /// At every node, with multipliers at the interior nodes. With Gauss–Lobatto nodes and
    /// quadrature (Lobatto IIIA–IIIB, Jay 1996) the measured order is 2s; with equispaced nodes
    /// and Gauss quadrature lower (measured 2, 4, 4, 6 for s = 1 … 4).
    Nodes,
    /// At every quadrature point (pointwise), plus the end node. Overdetermined for degree 1
    /// with one point (the chord of a curved manifold cannot touch it in its middle) and
    /// repeated for rules with the end points (Lobatto), so refused there; measured order
    /// 2s − 2 on the spherical pendulum, with Newton failures at small steps for degree 2.
    Points,
    /// Weakly: ∫ ψ(τ) g(q_h(τ)) dτ = 0 for every polynomial ψ of degree ≤ s − 2 (by the
    /// element's quadrature), plus the end node; the multiplier inside the element is a
    /// polynomial of degree s − 2 (as in Jay's SPARK methods). Degree 1: the same as `Ends`
    /// (RATTLE with the trapezoid rule). Measured order 2s for s = 1 … 4 with Gauss and with
    /// Lobatto elements. The default.
    #[default]
    Weak,
}

/// Evaluation points of the interior constraints of one element.
#[derive(Debug, Clone)]
pub(crate) struct Layout {
    /// Number of evaluation points P.
    pub points: usize,
    /// a_ij, row-major P × (s+1).
    pub a: Vec<f64>,
    /// ω_i.
    pub omega: Vec<f64>,
    /// Number of interior multiplier blocks I.
    pub sites: usize,
    /// Ψ_ic, row-major P × I.
    pub psi: Vec<f64>,
}

/// Legendre polynomial P_k(x) by the three-term recurrence.
fn legendre(k: usize, x: f64) -> f64 {
    let (mut p0, mut p1) = (1.0, x);
    if k == 0 {
        return p0;
    }
    for j in 1..k {
        let jf = j as f64;
        let p2 = ((2.0 * jf + 1.0) * x * p1 - jf * p0) / (jf + 1.0);
        p0 = p1;
        p1 = p2;
    }
    p1
}

impl Layout {
    /// The layout of `enforcement` for `element`.
    ///
    /// # Errors
    /// `Points` on an element whose pointwise constraints are overdetermined (degree 1), or
    /// `Weak` with fewer quadrature points than s − 1 (the weak equations would be dependent).
    pub fn new(element: &Element, enforcement: Enforcement) -> Result<Self> {
        let s = element.degree();
        let w = s + 1;
        let r = element.points();
        let identity = |k: usize| {
            let mut psi = vec![0.0; k * k];
            (0..k).for_each(|i| psi[i * k + i] = 1.0);
            psi
        };
        Ok(match enforcement {
            Enforcement::Ends => Self::empty(),
            Enforcement::Nodes => {
                let p = s - 1;
                let mut a = vec![0.0; p * w];
                (0..p).for_each(|i| a[i * w + i + 1] = 1.0);
                Self {
                    points: p,
                    a,
                    omega: vec![1.0; p],
                    sites: p,
                    psi: identity(p),
                }
            }
            Enforcement::Points => {
                if s == 1 {
                    return Err(invalid(
                        "constraint enforcement",
                        "pointwise at the quadrature points needs degree >= 2 (degree 1 cannot meet a curved manifold at its ends and inside)",
                    ));
                }
                if element.rule.nodes.iter().any(|&c| c <= 0.0 || c >= 1.0) {
                    return Err(invalid(
                        "constraint enforcement",
                        "pointwise at the quadrature points needs a rule without the end points (the end constraints would repeat)",
                    ));
                }
                Self {
                    points: r,
                    a: quadrature_basis(element),
                    omega: vec![1.0; r],
                    sites: r,
                    psi: identity(r),
                }
            }
            Enforcement::Weak => {
                let k = s - 1;
                if r < k {
                    return Err(invalid(
                        "constraint enforcement",
                        format!("weak constraints of degree {s} need at least {k} quadrature points, the rule has {r}"),
                    ));
                }
                if k == 0 {
                    return Ok(Self::empty());
                }
                let mut psi = vec![0.0; r * k];
                for i in 0..r {
                    let x = 2.0 * element.rule.nodes[i] - 1.0;
                    (0..k).for_each(|c| psi[i * k + c] = legendre(c, x));
                }
                Self {
                    points: r,
                    a: quadrature_basis(element),
                    omega: element.rule.weights.clone(),
                    sites: k,
                    psi,
                }
            }
        })
    }

    fn empty() -> Self {
        Self {
            points: 0,
            a: vec![],
            omega: vec![],
            sites: 0,
            psi: vec![],
        }
    }
}

/// ℓ_j(c_i), row-major r × (s+1).
fn quadrature_basis(element: &Element) -> Vec<f64> {
    let (r, w) = (element.points(), element.nodes());
    let mut a = vec![0.0; r * w];
    for i in 0..r {
        for j in 0..w {
            a[i * w + j] = element.phi(i, j);
        }
    }
    a
}
