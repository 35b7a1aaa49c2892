//! Symplecticity on the constraint manifold: the tangent map Φ of one constrained step,
//! (δq_k, δp_k) ↦ (δq_{k+1}, δp_{k+1}), by implicit differentiation of the step equations
//! (the full Jacobian of `step.rs`) and of the projection (module `project`):
//!
//!   J_U δU = −(J_{Q^0} δq_k + E δp_k),   δp̃ = (node-s rows)·δZ,
//!   [[A, Gᵀ], [G, 0]] (δv, δμ̂) = (δp̃ − (∂²L/∂v∂q + μ̂·∇²g) δq_{k+1}, −∇²g(v)·δq_{k+1}),
//!   δp_{k+1} = δp̃ − Gᵀδμ̂ − (μ̂·∇²g) δq_{k+1},
//!
//! restricted to the tangent space of T*N at (q_k, p_k): the vectors with G δq = 0 and
//! δ(G ∂H/∂p) = ∇²g(v)·δq + G A⁻¹(δp − ∂²L/∂v∂q δq) = 0 (an orthonormal basis B from the
//! null space of those 2m rows). The defect is max |(ΦB)ᵀJ(ΦB) − BᵀJB| with
//! ω(a, b) = a_q·b_p − a_p·b_q, the canonical form restricted to T*N.

use super::chart::tangent_rows;
use super::jet::ConstraintJet;
use super::step::StepSystem;
use super::Constraints;
use crate::lagrangian::{Lagrangian, PointDerivatives};
use nalgebra::DMatrix;

/// What the tangent map of one step needs besides the step system (evaluated with its
/// Jacobian at the converged unknowns).
pub(crate) struct StepEnds<'a> {
    pub t1: f64,
    pub q1: &'a [f64],
    pub v1: &'a [f64],
    pub mu: &'a [f64],
}

/// The tangent map Φ of one step in ambient coordinates (row-major 2n square acting on
/// (δq_k, δp_k); module doc), from the step system evaluated with its Jacobian at the
/// converged unknowns; None if a linear system is singular. On the tangent space of T*N it is
/// the derivative of the step; it maps every vector into the tangent space at the new node.
pub(crate) fn step_map<L: Lagrangian, C: Constraints>(
    lag: &L,
    con: &C,
    sys: &StepSystem,
    ends: &StepEnds<'_>,
) -> Option<DMatrix<f64>> {
    let (n, m, s, f) = (sys.n, sys.m, sys.s, sys.full);
    let k = sys.unknowns();
    let ju = DMatrix::from_fn(k, k, |i, j| sys.jac[sys.newton_row(i) * f + j + n]);
    // Right-hand sides for the 2n input directions (δq_k, then δp_k).
    let rhs = DMatrix::from_fn(k, 2 * n, |i, c| {
        let row = sys.newton_row(i);
        if c < n {
            -sys.jac[row * f + c]
        } else if row < n && row == c - n {
            -1.0
        } else {
            0.0
        }
    });
    let du = ju.lu().solve(&rhs)?;
    // δZ = (δq_k, δU); δq_{k+1} = δQ^s; δp̃ = node-s rows · δZ.
    let dz = |r: usize, c: usize| {
        if r < n {
            if c < n && r == c {
                1.0
            } else {
                0.0
            }
        } else {
            du[(r - n, c)]
        }
    };
    let dq1 = DMatrix::from_fn(n, 2 * n, |a, c| dz(s * n + a, c));
    let dpt = DMatrix::from_fn(n, 2 * n, |a, c| {
        (0..f).map(|z| sys.jac[(s * n + a) * f + z] * dz(z, c)).sum()
    });
    // The projection.
    let mut jet1 = ConstraintJet::new(m, n);
    jet1.eval(con, ends.q1, true);
    let mut pd = PointDerivatives::new(n);
    lag.second_derivatives(ends.t1, ends.q1, ends.v1, false, &mut pd);
    let g1 = DMatrix::from_row_slice(m, n, &jet1.jac);
    let mu_hess = DMatrix::from_fn(n, n, |a, b| {
        (0..m).map(|l| ends.mu[l] * jet1.hess[(l * n + a) * n + b]).sum()
    });
    let lvq = DMatrix::from_fn(n, n, |a, b| pd.h(1 + n + a, 1 + b));
    let gv = DMatrix::from_fn(m, n, |l, a| {
        (0..n).map(|b| jet1.hess[(l * n + a) * n + b] * ends.v1[b]).sum()
    });
    let mut kkt = DMatrix::zeros(n + m, n + m);
    for a in 0..n {
        for b in 0..n {
            kkt[(a, b)] = pd.h(1 + n + a, 1 + n + b);
        }
        for l in 0..m {
            kkt[(a, n + l)] = g1[(l, a)];
            kkt[(n + l, a)] = g1[(l, a)];
        }
    }
    let top = &dpt - (&lvq + &mu_hess) * &dq1;
    let bottom = -(&gv * &dq1);
    let mut prhs = DMatrix::zeros(n + m, 2 * n);
    prhs.view_mut((0, 0), (n, 2 * n)).copy_from(&top);
    prhs.view_mut((n, 0), (m, 2 * n)).copy_from(&bottom);
    let sol = kkt.lu().solve(&prhs)?;
    let dmu = sol.rows(n, m).into_owned();
    let dp1 = &dpt - g1.transpose() * dmu - &mu_hess * &dq1;
    let mut phi = DMatrix::zeros(2 * n, 2 * n);
    phi.view_mut((0, 0), (n, 2 * n)).copy_from(&dq1);
    phi.view_mut((n, 0), (n, 2 * n)).copy_from(&dp1);
    Some(phi)
}

/// The defect of one step with tangent map `phi` from (t0, q0, p0) (module doc).
pub(crate) fn step_defect<L: Lagrangian, C: Constraints>(
    lag: &L,
    con: &C,
    phi: Option<DMatrix<f64>>,
    (t0, q0, p0): (f64, &[f64], &[f64]),
) -> f64 {
    let n = q0.len();
    let (Some(phi), Some(basis)) = (phi, tangent_basis(lag, con, t0, q0, p0)) else {
        return f64::NAN;
    };
    let image = &phi * &basis;
    let before = omega(&basis, n);
    let after = omega(&image, n);
    (after - before).amax()
}

/// BᵀJB with ω(a, b) = a_q·b_p − a_p·b_q.
fn omega(b: &DMatrix<f64>, n: usize) -> DMatrix<f64> {
    let q = b.rows(0, n);
    let p = b.rows(n, n);
    q.transpose() * p - p.transpose() * q
}

/// An orthonormal basis (columns) of the tangent space of T*N at (q, p).
fn tangent_basis<L: Lagrangian, C: Constraints>(
    lag: &L,
    con: &C,
    t: f64,
    q: &[f64],
    p: &[f64],
) -> Option<DMatrix<f64>> {
    let (n, m) = (q.len(), con.count());
    let c = tangent_rows(lag, con, t, q, p)?;
    // Finite entries only: nalgebra's eigen-decomposition does not end on NaN.
    if !c.iter().all(|x| x.is_finite()) {
        return None;
    }
    let eig = (c.transpose() * &c).symmetric_eigen();
    let mut order: Vec<usize> = (0..2 * n).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let dim = 2 * (n - m.min(n));
    Some(DMatrix::from_fn(2 * n, dim, |r, col| eig.eigenvectors[(r, order[col])]))
}
