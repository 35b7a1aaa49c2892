//! The tangent map of a Lie-group step in canonical coordinates, and its symplecticity
//! defect (`femvi check` on T*SO(3)).
//!
//! Near a node, a rotation is R = R_c exp(ψ̂) in the chart centred at the node's R_c; the
//! cotangent lift of that chart gives the conjugate momenta p_ψ = dexp_{−ψ}ᵀ μ = dexp_ψ μ
//! (since δR = R (dexp_{−ψ} δψ)^), and (ψ, p_ψ) are canonical coordinates of T*SO(3). With
//! ordinary coordinates as they are, the step maps (ψ, p_ψ) near (0, μ_k) at node k to
//! (ψ′, p′) in the chart centred at node k + 1; the map is symplectic iff its Jacobian J
//! satisfies JᵀΩJ = Ω. J comes from the implicit function theorem on the step equations
//! F(x; ψ, μ) = 0 of `step.rs` (dx = −F_x⁻¹(F_ψ dψ + F_μ dμ), with μ = dexp_ψ⁻¹ p_ψ, so
//! dμ = dp + ½ hat(μ_k) dψ at ψ = 0), and the outputs
//!
//!   ψ′ = exp(ξ̂^s)ᵀ ψ + dexp_{−ξ^s} dξ^s   (from R_k exp(ψ̂) exp(ξ̂^s + dξ̂^s)),
//!   μ′ = dexp_{ξ^s}⁻¹ g,  p′ = dexp_{ψ′} μ′, so dp′ = dμ′ + ½ dψ′ × μ′,
//!
//! with g = ∂S/∂ξ^s; second derivatives of the action by hyper-dual passes
//! (`action::action_moved` moves the node).

use super::action::{action_moved, StepData};
use super::layout::Rotations;
use super::so3::{cross, dexp, dexp_inv, exp};
use crate::discrete::Element;
use crate::lagrangian::Lagrangian;
use nalgebra::DMatrix;
use num_dual::{Dual64, HyperDual64};

/// The solved step: its start node, the momenta there (slots) and the unknowns x.
pub(crate) struct Solved<'a> {
    pub data: &'a StepData<'a>,
    pub mom: &'a [f64],
    pub x: &'a [f64],
}

/// max |JᵀΩJ − Ω| of the step `step` (2·slots square J, canonical coordinates).
pub(crate) fn defect<L: Lagrangian>(lag: &L, element: &Element, layout: &Rotations, step: &Solved<'_>) -> f64 {
    let j = jacobian(lag, element, layout, step);
    let ne = layout.slots();
    let omega = DMatrix::from_fn(2 * ne, 2 * ne, |a, b| {
        if b == a + ne {
            1.0
        } else if a == b + ne {
            -1.0
        } else {
            0.0
        }
    });
    let d = j.transpose() * &omega * &j - omega;
    d.amax()
}

/// Second derivatives of S at the solution: rows `rows` (indices of z), columns the unknowns
/// x (s·ne) and then the moved node (ne).
fn mixed<L: Lagrangian>(
    lag: &L,
    element: &Element,
    layout: &Rotations,
    step: &Solved<'_>,
    rows: std::ops::Range<usize>,
) -> DMatrix<f64> {
    let ne = layout.slots();
    let m = step.x.len();
    let mut z: Vec<HyperDual64> = (0..ne)
        .map(|_| HyperDual64::from(0.0))
        .chain(step.x.iter().map(|&v| HyperDual64::from(v)))
        .collect();
    let mut moved = vec![HyperDual64::from(0.0); ne];
    let mut out = DMatrix::zeros(rows.len(), m + ne);
    for (i, a) in rows.enumerate() {
        for b in 0..m + ne {
            z[a].eps1 = 1.0;
            if b < m {
                z[ne + b].eps2 = 1.0;
            } else {
                moved[b - m].eps2 = 1.0;
            }
            let r = action_moved(lag, element, layout, step.data, &z, Some(&moved));
            z[a].eps1 = 0.0;
            if b < m {
                z[ne + b].eps2 = 0.0;
            } else {
                moved[b - m].eps2 = 0.0;
            }
            out[(i, b)] = r.eps1eps2;
        }
    }
    out
}

/// ∂S/∂x^s at the solution.
fn end_gradient<L: Lagrangian>(lag: &L, element: &Element, layout: &Rotations, step: &Solved<'_>) -> Vec<f64> {
    let ne = layout.slots();
    let m = step.x.len();
    let mut z: Vec<Dual64> = (0..ne)
        .map(|_| Dual64::from(0.0))
        .chain(step.x.iter().map(|&v| Dual64::from(v)))
        .collect();
    (0..ne)
        .map(|b| {
            z[m + b].eps = 1.0;
            let g = action_moved(lag, element, layout, step.data, &z, None).eps;
            z[m + b].eps = 0.0;
            g
        })
        .collect()
}

/// The Jacobian of the step in canonical coordinates (module docs).
pub(crate) fn jacobian<L: Lagrangian>(
    lag: &L,
    element: &Element,
    layout: &Rotations,
    step: &Solved<'_>,
) -> DMatrix<f64> {
    let ne = layout.slots();
    let m = step.x.len();
    let rot = layout.count();
    // F = ∂S/∂z_a (+ μ_a): rows 0..m of z; dF/d(x, moved).
    let f = mixed(lag, element, layout, step, 0..m);
    let fx = f.columns(0, m).into_owned();
    // dF/du for u = (ψ, p): F_ψ directly, plus μ's dependence on ψ in the first ne rows.
    let mut fu = DMatrix::zeros(m, 2 * ne);
    fu.columns_mut(0, ne).copy_from(&f.columns(m, ne));
    for r in 0..rot {
        let mu = [step.mom[3 * r], step.mom[3 * r + 1], step.mom[3 * r + 2]];
        // dμ = dp + ½ hat(μ) dψ.
        for (c, e) in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]].iter().enumerate() {
            let col = cross(&mu, e);
            for a in 0..3 {
                fu[(3 * r + a, 3 * r + c)] += 0.5 * col[a];
            }
        }
    }
    for a in 0..ne {
        fu[(a, ne + a)] += 1.0;
    }
    let dx = match fx.lu().solve(&(-fu.clone())) {
        Some(dx) => dx,
        None => return DMatrix::from_element(2 * ne, 2 * ne, f64::NAN),
    };
    // dg for g = ∂S/∂x^s: rows of x^s in z.
    let gs = mixed(lag, element, layout, step, m..m + ne);
    let mut dg = gs.columns(0, m) * &dx;
    {
        let mut psi = dg.columns_mut(0, ne);
        psi += gs.columns(m, ne);
    }
    let g0 = end_gradient(lag, element, layout, step);
    let xs = &step.x[m - ne..];
    let mut j = DMatrix::zeros(2 * ne, 2 * ne);
    for col in 0..2 * ne {
        let dpsi_in = |c: usize| if col == c { 1.0 } else { 0.0 };
        for r in 0..rot {
            let xi = [xs[3 * r], xs[3 * r + 1], xs[3 * r + 2]];
            let dxi = [0, 1, 2].map(|c| dx[(m - ne + 3 * r + c, col)]);
            let psi = [0, 1, 2].map(|c| dpsi_in(3 * r + c));
            // ψ′ = exp(ξ̂)ᵀ ψ + dexp_{−ξ} dξ.
            let e = exp(&xi);
            let back = dexp(&xi.map(|v| -v), &dxi);
            let dpsi_out: [f64; 3] =
                std::array::from_fn(|a| e[a] * psi[0] + e[3 + a] * psi[1] + e[6 + a] * psi[2] + back[a]);
            // μ′ = dexp_ξ⁻¹ g: its derivative in g and in ξ (one dual pass).
            let g = [0, 1, 2].map(|c| g0[3 * r + c]);
            let dgr = [0, 1, 2].map(|c| dg[(3 * r + c, col)]);
            let xd: [Dual64; 3] = std::array::from_fn(|c| Dual64::new(xi[c], dxi[c]));
            let gd: [Dual64; 3] = std::array::from_fn(|c| Dual64::new(g[c], dgr[c]));
            let mu = dexp_inv(&xd, &gd);
            let mu0 = mu.map(|v| v.re);
            let tw = cross(&dpsi_out, &mu0);
            for a in 0..3 {
                j[(3 * r + a, col)] = dpsi_out[a];
                j[(ne + 3 * r + a, col)] = mu[a].eps + 0.5 * tw[a];
            }
        }
        for slot in 3 * rot..ne {
            // q′ = q_k + δq + d^s, p′ = g.
            j[(slot, col)] = dpsi_in(slot) + dx[(m - ne + slot, col)];
            j[(ne + slot, col)] = dg[(slot, col)];
        }
    }
    j
}
