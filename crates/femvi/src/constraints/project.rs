//! The cotangent space of the constraint manifold at a node, and the constraint force there.
//!
//! Projection (the end multiplier μ̂ of the step, and the start): given q on the manifold and a
//! momentum p̃, find p = p̃ − G(q)ᵀμ̂ with the hidden constraint G(q) ∂H/∂p = 0, i.e. solve
//!
//!   ∂L/∂v(t, q, v) + G(q)ᵀμ̂ = p̃,   G(q) v = 0
//!
//! for (v, μ̂) by Newton (Jacobian [[∂²L/∂v², Gᵀ], [G, 0]]); for L = ½vᵀMv − V it is linear,
//! G M⁻¹ Gᵀ μ̂ = G M⁻¹ p̃, and Newton takes one step.
//!
//! Constraint force: along the exact flow d/dt ∂L/∂v = ∂L/∂q − Gᵀλ and G q̈ + ∇²g(q̇, q̇) = 0, so
//! with A = ∂²L/∂v², r = ∂L/∂q − ∂²L/∂v∂q v − ∂²L/∂v∂t,
//!
//!   (G A⁻¹ Gᵀ) λ = G A⁻¹ r + ∇²g(v, v),
//!
//! which [`state_multiplier`] evaluates at a node's (q, v): the multiplier reported per node
//! (−Gᵀλ is the constraint force). It is a function of the node state, so it converges with
//! the nodes' order.

use super::jet::ConstraintJet;
use crate::lagrangian::{Lagrangian, PointDerivatives};
use crate::solve::{newton_dense, DenseNewtonWork, NewtonFailure};
use nalgebra::{DMatrix, DVector};

/// Scratch of the projection.
#[derive(Debug, Clone)]
pub(crate) struct Projector {
    n: usize,
    m: usize,
    pd: PointDerivatives,
    newton: DenseNewtonWork,
    x: Vec<f64>,
    /// Iterations of the last projection.
    pub iterations: usize,
}

impl Projector {
    pub fn new(n: usize, m: usize) -> Self {
        Self {
            n,
            m,
            pd: PointDerivatives::new(n),
            newton: DenseNewtonWork::new(n + m),
            x: vec![0.0; n + m],
            iterations: 0,
        }
    }

    /// Projects p̃ at (t, q), whose jet (G) is `jet`, from the velocity guess `v`: writes v,
    /// p = p̃ − Gᵀμ̂ and returns μ̂.
    #[allow(clippy::too_many_arguments)]
    pub fn project<L: Lagrangian + ?Sized>(
        &mut self,
        lag: &L,
        jet: &ConstraintJet,
        t: f64,
        q: &[f64],
        p_tilde: &[f64],
        v: &mut [f64],
        p: &mut [f64],
        tol: f64,
        max_iterations: usize,
    ) -> Result<&[f64], NewtonFailure> {
        let (n, m) = (self.n, self.m);
        self.x[..n].copy_from_slice(v);
        self.x[n..].iter_mut().for_each(|x| *x = 0.0);
        let pd = &mut self.pd;
        let k = n + m;
        let scale = |x: &[f64]| x.iter().fold(1.0f64, |a, &b| a.max(b.abs()));
        let report = newton_dense(
            &mut self.x,
            tol,
            max_iterations,
            scale,
            &mut self.newton,
            |x, r, jac| {
                let (vv, mu) = x.split_at(n);
                lag.second_derivatives(t, q, vv, false, pd);
                for a in 0..n {
                    let mut ra = pd.l_v()[a] - p_tilde[a];
                    for l in 0..m {
                        ra += jet.jac[l * n + a] * mu[l];
                    }
                    r[a] = ra;
                }
                for l in 0..m {
                    r[n + l] = (0..n).map(|a| jet.jac[l * n + a] * vv[a]).sum();
                }
                if let Some(jac) = jac {
                    jac.iter_mut().for_each(|x| *x = 0.0);
                    for a in 0..n {
                        for b in 0..n {
                            jac[a * k + b] = pd.h(1 + n + a, 1 + n + b);
                        }
                        for l in 0..m {
                            jac[a * k + n + l] = jet.jac[l * n + a];
                            jac[(n + l) * k + a] = jet.jac[l * n + a];
                        }
                    }
                }
            },
        )?;
        self.iterations = report.iterations;
        v.copy_from_slice(&self.x[..n]);
        p.copy_from_slice(p_tilde);
        jet.add_transpose_times(&self.x[n..], -1.0, p);
        Ok(&self.x[n..])
    }
}

/// The multiplier λ of the exact flow at the state (t, q, v) (see the module doc), from the
/// jet of g at q with second derivatives; NaN if the system is singular. With `force` (the
/// non-conservative force F(t, q, v) there) r gains F: d/dt ∂L/∂v = ∂L/∂q + F − Gᵀλ.
pub(crate) fn state_multiplier<L: Lagrangian>(
    lag: &L,
    jet: &ConstraintJet,
    (t, q, v): (f64, &[f64], &[f64]),
    force: Option<&[f64]>,
) -> Vec<f64> {
    let (n, m) = (jet.n, jet.m);
    if m == 0 {
        return vec![];
    }
    let mut pd = PointDerivatives::new(n);
    lag.second_derivatives(t, q, v, true, &mut pd);
    let a = DMatrix::from_fn(n, n, |i, j| pd.h(1 + n + i, 1 + n + j));
    let r = DVector::from_fn(n, |i, _| {
        let mut ri = pd.l_q()[i] - pd.h(1 + n + i, 0);
        for b in 0..n {
            ri -= pd.h(1 + n + i, 1 + b) * v[b];
        }
        if let Some(f) = force {
            ri += f.get(i).copied().unwrap_or(f64::NAN);
        }
        ri
    });
    let g = DMatrix::from_row_slice(m, n, &jet.jac);
    let lu = a.lu();
    let (Some(ainv_gt), Some(ainv_r)) = (lu.solve(&g.transpose()), lu.solve(&r)) else {
        return vec![f64::NAN; m];
    };
    let lhs = &g * ainv_gt;
    let mut rhs = &g * ainv_r;
    for l in 0..m {
        let mut c = 0.0;
        for i in 0..n {
            for j in 0..n {
                c += jet.hess[(l * n + i) * n + j] * v[i] * v[j];
            }
        }
        rhs[l] += c;
    }
    match lhs.lu().solve(&rhs) {
        Some(x) => x.iter().copied().collect(),
        None => vec![f64::NAN; m],
    }
}
