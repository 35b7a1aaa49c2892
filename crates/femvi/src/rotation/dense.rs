//! Dense output of a Lie-group element (module docs of [`super`]): between its nodes a
//! rotation follows the element's own path R(τ) = R_k exp(ζ̂(τ)), ζ(τ) = Σ_j ℓ_j(τ) ξ^j, with
//! the nodal ξ^j = log(R_kᵀ R^j) read back from the element's nodes, and Ṙ(τ) = R(τ) ŵ(τ),
//! w = dexp_{−ζ} ζ′ / h (as `action.rs` evaluates it). It is on SO(3) at every τ; the
//! polynomial through the nine entries, which the other coordinates take, would leave it by
//! O(h^{s+1}) between nodes.

use super::so3::{dexp, exp, hat, log, mul, mul_tn, Mat3};

/// Overwrites the rotation block at `o` of `q` and `v` with the element's path at the point
/// whose basis values are `l` and derivatives `dl`, from the element's left node `base` and
/// nodal increments `incr` (row-major (s+1)×n), step `h`.
pub(crate) fn eval_block(
    (l, dl): (&[f64], &[f64]),
    (h, base, incr): (f64, &[f64], &[f64]),
    o: usize,
    q: &mut [f64],
    v: &mut [f64],
) {
    let n = base.len();
    let block = |row: usize| -> Option<Mat3<f64>> {
        let mut m = [0.0; 9];
        for (k, x) in m.iter_mut().enumerate() {
            *x = base.get(o + k)? + incr.get(row * n + o + k)?;
        }
        Some(m)
    };
    let Some(rk) = block(0) else { return };
    let (mut zeta, mut dzeta) = ([0.0; 3], [0.0; 3]);
    for (j, (a, d)) in l.iter().zip(dl).enumerate().skip(1) {
        let Some(rj) = block(j) else { return };
        let xi = log(&mul_tn(&rk, &rj));
        for c in 0..3 {
            zeta[c] += a * xi[c];
            dzeta[c] += d * xi[c];
        }
    }
    let r = mul(&rk, &exp(&zeta));
    let w = dexp(&zeta.map(|x| -x), &dzeta).map(|x| x / h);
    let rdot = mul(&r, &hat(&w));
    if let (Some(qo), Some(vo)) = (q.get_mut(o..o + 9), v.get_mut(o..o + 9)) {
        qo.copy_from_slice(&r);
        vo.copy_from_slice(&rdot);
    }
}

/// The rotation block at `o` of `q` on the element's path at the point whose basis values
/// are `l`, from the element's nodal values `nodes` (row-major (s+1)×n, n = `q.len()`):
/// R_0 exp(Σ_j ℓ_j log(R_0ᵀ R_j)), as [`eval_block`] (positions only, for the L² sums of
/// `diagnostics/trajectory.rs`). Left as it is if a block does not fit.
pub(crate) fn path_block(l: &[f64], nodes: &[f64], o: usize, q: &mut [f64]) {
    let n = q.len();
    let block = |row: usize| -> Option<Mat3<f64>> { nodes.get(row * n + o..row * n + o + 9)?.try_into().ok() };
    let Some(r0) = block(0) else { return };
    let mut zeta = [0.0; 3];
    for (j, a) in l.iter().enumerate().skip(1) {
        let Some(rj) = block(j) else { return };
        let xi = log(&mul_tn(&r0, &rj));
        for c in 0..3 {
            zeta[c] += a * xi[c];
        }
    }
    if let Some(qo) = q.get_mut(o..o + 9) {
        qo.copy_from_slice(&mul(&r0, &exp(&zeta)));
    }
}
