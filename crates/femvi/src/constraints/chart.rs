//! Symplectic coordinates on the tangent space of T*N at a node, for tangent vectors carried
//! along a constrained run ([`crate::chaos::constrained_indicators`]).
//!
//! T_x(T*N) at x = (q, p) is the set of (δq, δp) ∈ R²ⁿ with G δq = 0 and
//! δ(G ∂H/∂p) = ∇²g(v)·δq + G A⁻¹(δp − ∂²L/∂v∂q δq) = 0 (A = ∂²L/∂v²): 2m rows
//! ([`tangent_rows`]), dimension 2(n − m). With U an orthonormal basis of ker G (n × (n − m)),
//! the coordinates (α, β) = (Uᵀδq, Uᵀδp) are symplectic: for tangent vectors δq = Uα, so
//! δq₁·δp₂ − δp₁·δq₂ = α₁·β₂ − β₁·α₂, the canonical form of R^{2(n−m)}. They are one-to-one
//! on T_x(T*N): α = β = 0 gives δq = 0 and δp = Gᵀμ with G A⁻¹ Gᵀ μ = 0, so δp = 0. The
//! inverse ([`Chart::lift`]) adds to (Uα, Uβ) the Gᵀμ that satisfies the hidden constraint;
//! lift ∘ reduce is a projection of R²ⁿ onto T_x(T*N) along {δq, δp ∈ range Gᵀ}.
//!
//! The Euclidean norm of (α, β) does not depend on which U is taken (it is
//! |δq|² + |P δp|², P = UUᵀ the orthogonal projector onto ker G), so norms, Gram–Schmidt and
//! hence MEGNO and the Lyapunov exponents do not either; and since the metric and the
//! symplectic form are the canonical pair of R^{2(n−m)} in these coordinates, a conservative
//! spectrum comes in ± pairs as for an unconstrained run.

use super::jet::ConstraintJet;
use super::Constraints;
use crate::lagrangian::{Lagrangian, PointDerivatives};
use nalgebra::DMatrix;

/// The 2m rows (2m × 2n) whose null space is T_x(T*N) at (t, q, p) (module doc); None if
/// the velocity cannot be recovered or A is singular.
pub(crate) fn tangent_rows<L: Lagrangian, C: Constraints>(
    lag: &L,
    con: &C,
    t: f64,
    q: &[f64],
    p: &[f64],
) -> Option<DMatrix<f64>> {
    let (n, m) = (q.len(), con.count());
    let mut v = vec![0.0; n];
    let mut pd = PointDerivatives::new(n);
    crate::lagrangian::velocity_from_momentum(lag, t, q, p, &mut v, &mut pd).ok()?;
    lag.second_derivatives(t, q, &v, false, &mut pd);
    let mut jet = ConstraintJet::new(m, n);
    jet.eval(con, q, true);
    let g = DMatrix::from_row_slice(m, n, &jet.jac);
    let a = DMatrix::from_fn(n, n, |i, j| pd.h(1 + n + i, 1 + n + j));
    let lvq = DMatrix::from_fn(n, n, |i, j| pd.h(1 + n + i, 1 + j));
    let gv = DMatrix::from_fn(m, n, |l, i| (0..n).map(|j| jet.hess[(l * n + i) * n + j] * v[j]).sum());
    let g_ainv = a.lu().solve(&g.transpose())?.transpose();
    let mut c = DMatrix::zeros(2 * m, 2 * n);
    c.view_mut((0, 0), (m, n)).copy_from(&g);
    c.view_mut((m, 0), (m, n)).copy_from(&(gv - &g_ainv * lvq));
    c.view_mut((m, n), (m, n)).copy_from(&g_ainv);
    Some(c)
}

/// The symplectic coordinates of T_x(T*N) at one node (module doc).
pub(crate) struct Chart {
    /// (δq, δp) ↦ (Uᵀδq, Uᵀδp): 2(n − m) × 2n.
    pub reduce: DMatrix<f64>,
    /// Its inverse on T_x(T*N): 2n × 2(n − m).
    pub lift: DMatrix<f64>,
}

/// The chart at (t, q, p); None if a system is singular.
pub(crate) fn chart<L: Lagrangian, C: Constraints>(lag: &L, con: &C, t: f64, q: &[f64], p: &[f64]) -> Option<Chart> {
    let (n, m) = (q.len(), con.count());
    let d = n - m.min(n);
    let c = tangent_rows(lag, con, t, q, p)?;
    // Finite entries only: nalgebra's eigen-decomposition does not end on NaN.
    if !c.iter().all(|x| x.is_finite()) {
        return None;
    }
    // ker G: the eigenvectors of GᵀG for its n − m smallest eigenvalues.
    let g = c.view((0, 0), (m, n));
    let eig = (g.transpose() * g).symmetric_eigen();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let u = DMatrix::from_fn(n, d, |r, col| eig.eigenvectors[(r, order[col])]);
    let mut reduce = DMatrix::zeros(2 * d, 2 * n);
    reduce.view_mut((0, 0), (d, n)).copy_from(&u.transpose());
    reduce.view_mut((d, n), (d, n)).copy_from(&u.transpose());
    // lift = [[C], [reduce]]⁻¹ [[0], [I]]: the vector of the tangent space with those
    // coordinates.
    let mut stacked = DMatrix::zeros(2 * n, 2 * n);
    stacked.view_mut((0, 0), (2 * m, 2 * n)).copy_from(&c);
    stacked.view_mut((2 * m, 0), (2 * d, 2 * n)).copy_from(&reduce);
    let mut rhs = DMatrix::zeros(2 * n, 2 * d);
    rhs.view_mut((2 * m, 0), (2 * d, 2 * d)).fill_with_identity();
    let lift = stacked.lu().solve(&rhs)?;
    Some(Chart { reduce, lift })
}
