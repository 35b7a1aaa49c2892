//! The discrete action of a Lie-group Galerkin element (module docs of [`super`]): on
//! [t_k, t_k + h] each rotation is R(τ) = R_k exp(η̂) exp(ζ̂(τ)) with ζ(τ) = Σ_j ζ^j ℓ_j(τ),
//! ζ^0 = 0, and each ordinary coordinate q(τ) = q_k + Σ_j d^j ℓ_j(τ); the body angular velocity
//! is w(τ) = (1/h) dexp_{−ζ(τ)} ζ′(τ), and the action h Σ_i b_i L(t_i, R(c_i), R ŵ(c_i), …) is
//! the Lagrangian on the embedding (the entries of R and Ṙ = R ŵ) at the quadrature points.
//!
//! The variables are z = (e, x^1, …, x^s), each a vector of the layout's slots: e holds the
//! variation η of the chart's centre R_k (and d^0 for the ordinary coordinates), x^j the node
//! ξ^j (and d^j). The last node is ζ^s = ξ^s − dexp_{ξ^s}⁻¹ η, which keeps
//! R_{k+1} = R_k exp(ξ̂^s) fixed to first order in η, so ∂S/∂η at η = 0 is the derivative of
//! the discrete Lagrangian L_d(R_k, R_{k+1}) in its first argument (left-trivialised), chart
//! and all; only first derivatives in e are ever taken.

use super::layout::Rotations;
use super::so3::{dexp, dexp_inv, exp, hat, mul, Mat3};
use crate::discrete::Element;
use crate::forces::Force;
use crate::lagrangian::{Lagrangian, Scalar};

/// A generalized force on the embedded coordinates (the nine entries of each rotation, then
/// the ordinary coordinates), evaluated at plain values: the torques and forces of a run with
/// rotations ([`crate::Integrator::with_rotations_and_force`]).
pub(crate) trait EmbeddedForce {
    /// F(t, q, v) into `out` (the embedded dimension n).
    fn eval(&self, t: f64, q: &[f64], v: &[f64], out: &mut [f64]);
}

impl<F: Force> EmbeddedForce for F {
    fn eval(&self, t: f64, q: &[f64], v: &[f64], out: &mut [f64]) {
        self.force(t, q, v, out);
    }
}

/// What the action of a step needs besides its variables.
pub(crate) struct StepData<'a> {
    /// t_k and h.
    pub t0: f64,
    pub h: f64,
    /// The node q_k (rotation blocks and ordinary coordinates).
    pub q: &'a [f64],
    /// The force of a forced run: the action then gains its virtual work with the force
    /// frozen at the iterate (module docs of [`super`]).
    pub force: Option<&'a (dyn EmbeddedForce + Sync)>,
}

/// The action S(z) of the element from the node in `data` (module docs).
pub(crate) fn action<D: Scalar, L: Lagrangian>(
    lag: &L,
    element: &Element,
    layout: &Rotations,
    data: &StepData<'_>,
    z: &[D],
) -> D {
    action_moved(lag, element, layout, data, z, None)
}

/// [`action`] from the node moved by `moved` (slots: R_k exp(ψ̂) for a rotation, q_k + δq for
/// an ordinary coordinate), for the derivatives of the step in its start (`tangent.rs`).
///
/// With a force F (`data.force`), each point adds F·q(c_i) with F evaluated at the plain
/// values of the point (not differentiated): the derivative of the sum in z is then
/// h Σ_i b_i F_i·∂q(c_i)/∂z, the discrete Lagrange–d'Alembert forces of the element.
pub(crate) fn action_moved<D: Scalar, L: Lagrangian>(
    lag: &L,
    element: &Element,
    layout: &Rotations,
    data: &StepData<'_>,
    z: &[D],
    moved: Option<&[D]>,
) -> D {
    let mut sum = D::from(0.0);
    let mut frozen = data.force.map(|_| {
        (
            vec![0.0; data.q.len()],
            vec![0.0; data.q.len()],
            vec![0.0; data.q.len()],
        )
    });
    let traced = path_points(element, layout, data, (z, moved), |i, t, q, v| {
        let mut l = lag.value(t, q, v);
        if let (Some(f), Some((qr, vr, fr))) = (data.force, frozen.as_mut()) {
            qr.iter_mut().zip(q).for_each(|(a, b)| *a = b.re());
            vr.iter_mut().zip(v).for_each(|(a, b)| *a = b.re());
            f.eval(t.re(), qr, vr, fr);
            for (x, fc) in q.iter().zip(fr.iter()) {
                l += *x * *fc;
            }
        }
        sum += l * element.rule.weights[i];
    });
    if traced {
        sum * data.h
    } else {
        D::from(f64::NAN)
    }
}

/// The discrete work h Σ_i b_i F(c_i)·q̇(c_i) of `data.force` along the element with nodes
/// `x` (the solved unknowns, centre not moved); 0 without a force.
pub(crate) fn element_work(element: &Element, layout: &Rotations, data: &StepData<'_>, x: &[f64]) -> f64 {
    let Some(f) = data.force else {
        return 0.0;
    };
    let ne = layout.slots();
    let z: Vec<f64> = std::iter::repeat_n(0.0, ne).chain(x.iter().copied()).collect();
    let mut out = vec![0.0; data.q.len()];
    let mut sum = 0.0;
    let traced = path_points(element, layout, data, (&z, None), |i, t, q, v| {
        f.eval(t, q, v, &mut out);
        let power: f64 = out.iter().zip(v).map(|(a, b)| a * b).sum();
        sum += power * element.rule.weights[i];
    });
    if traced {
        sum * data.h
    } else {
        f64::NAN
    }
}

/// Calls `at(i, t_i, q(c_i), v(c_i))` at each quadrature point of the element with variables
/// `z` from the node in `data` moved by `moved` (module docs); false (and no call) if the
/// sizes do not fit.
fn path_points<D: Scalar>(
    element: &Element,
    layout: &Rotations,
    data: &StepData<'_>,
    (z, moved): (&[D], Option<&[D]>),
    mut at: impl FnMut(usize, D, &[D], &[D]),
) -> bool {
    let (s, ne, n) = (element.degree(), layout.slots(), layout.dim());
    if z.len() != ne * (s + 1) || data.q.len() != n || moved.is_some_and(|m| m.len() != ne) {
        return false;
    }
    let zero = D::from(0.0);
    // Each rotation's centre R_k exp(η̂) and its nodes ζ^0 = 0, ζ^1 … ζ^s.
    let mut centres: Vec<Mat3<D>> = Vec::with_capacity(layout.count());
    let mut nodes: Vec<[D; 3]> = Vec::with_capacity(layout.count() * (s + 1));
    for (r, &o) in layout.offsets().iter().enumerate() {
        let mut rk: Mat3<D> = std::array::from_fn(|k| D::from(data.q[o + k]));
        if let Some(m) = moved {
            rk = mul(&rk, &exp(&[m[3 * r], m[3 * r + 1], m[3 * r + 2]]));
        }
        let eta: [D; 3] = std::array::from_fn(|c| z[3 * r + c]);
        centres.push(mul(&rk, &exp(&eta)));
        nodes.push([zero; 3]);
        for j in 1..=s {
            let xi: [D; 3] = std::array::from_fn(|c| z[j * ne + 3 * r + c]);
            if j < s {
                nodes.push(xi);
            } else {
                let back = dexp_inv(&xi, &eta);
                nodes.push(std::array::from_fn(|c| xi[c] - back[c]));
            }
        }
    }
    let mut q = vec![zero; n];
    let mut v = vec![zero; n];
    let inv_h = 1.0 / data.h;
    for i in 0..element.points() {
        for (slot, &c) in layout.ordinary().iter().enumerate() {
            let base = moved.map_or(zero, |m| m[3 * layout.count() + slot]);
            let (mut y, mut dy) = (D::from(data.q[c]) + base, zero);
            for j in 0..=s {
                let d = z[j * ne + 3 * layout.count() + slot];
                y += d * element.phi(i, j);
                dy += d * element.dphi(i, j);
            }
            q[c] = y;
            v[c] = dy * inv_h;
        }
        for (r, &o) in layout.offsets().iter().enumerate() {
            let (mut zeta, mut dzeta) = ([zero; 3], [zero; 3]);
            for (j, node) in nodes[r * (s + 1)..(r + 1) * (s + 1)].iter().enumerate().skip(1) {
                let (a, d) = (element.phi(i, j), element.dphi(i, j));
                for c in 0..3 {
                    zeta[c] += node[c] * a;
                    dzeta[c] += node[c] * d;
                }
            }
            let rot = mul(&centres[r], &exp(&zeta));
            let minus = zeta.map(|x| -x);
            let w = dexp(&minus, &dzeta).map(|x| x * inv_h);
            let rdot = mul(&rot, &hat(&w));
            q[o..o + 9].copy_from_slice(&rot);
            v[o..o + 9].copy_from_slice(&rdot);
        }
        let t = D::from(data.t0 + data.h * element.rule.nodes[i]);
        at(i, t, &q, &v);
    }
    true
}
