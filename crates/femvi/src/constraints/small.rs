//! Small dense linear algebra of the RATTLE and fixed-point steps (`rattle.rs`, `shake/`)
//! without allocation: the m×m solves of the Newton iteration on the multipliers and of the
//! projection (Hairer–Lubich–Wanner VII.1.4: G(q_k + Δq) M⁻¹ G(q_k)ᵀ δ = g,
//! G M⁻¹ Gᵀ μ̂ = G M⁻¹ p̃, [`project_linear`]), copies and M⁻¹ of a few numbers, and the
//! conditioning of the constraint Jacobian G checked at every node (the ratio of its extreme
//! singular values, by one-sided Jacobi rotations of its rows, Hestenes 1958).

pub(crate) use crate::slices::copy;

/// out = M⁻¹x, the identity by [`copy`] (slices of a few numbers: no call to memmove).
#[inline]
pub(crate) fn mass_solve(mass: &crate::lagrangian::MassMatrix, x: &[f64], out: &mut [f64]) {
    if mass.is_identity() {
        copy(out, x);
    } else {
        mass.solve(x, out);
    }
}

#[inline]
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Solves the row-major m×m system `a` x = `b` in place (x into `b`) by Gaussian elimination
/// with partial pivoting; false if a pivot is zero or not finite.
#[inline]
pub(super) fn solve_small(a: &mut [f64], b: &mut [f64], m: usize) -> bool {
    if m == 1 {
        let x = b[0] / a[0];
        b[0] = x;
        return a[0] != 0.0 && x.is_finite();
    }
    if let ([a00, a01, a10, a11], [b0, b1]) = (&mut *a, &mut *b) {
        // The same elimination with partial pivoting, unrolled.
        if a10.abs() > a00.abs() {
            std::mem::swap(a00, a10);
            std::mem::swap(a01, a11);
            std::mem::swap(b0, b1);
        }
        let d = *a00;
        if d == 0.0 || !d.is_finite() {
            return false;
        }
        let f = *a10 / d;
        *a11 -= f * *a01;
        *b1 -= f * *b0;
        *b1 /= *a11;
        *b0 = (*b0 - *a01 * *b1) / d;
        return b0.is_finite() && b1.is_finite();
    }
    solve_general(a, b, m)
}

/// [`solve_small`] for any m: the elimination loops.
fn solve_general(a: &mut [f64], b: &mut [f64], m: usize) -> bool {
    for k in 0..m {
        let piv = (k..m).fold(k, |best, i| {
            if a[i * m + k].abs() > a[best * m + k].abs() {
                i
            } else {
                best
            }
        });
        let d = a[piv * m + k];
        if d == 0.0 || !d.is_finite() {
            return false;
        }
        if piv != k {
            for j in 0..m {
                a.swap(k * m + j, piv * m + j);
            }
            b.swap(k, piv);
        }
        for i in k + 1..m {
            let f = a[i * m + k] / d;
            for j in k..m {
                a[i * m + j] -= f * a[k * m + j];
            }
            b[i] -= f * b[k];
        }
    }
    for k in (0..m).rev() {
        let s: f64 = (k + 1..m).map(|j| a[k * m + j] * b[j]).sum();
        b[k] = (b[k] - s) / a[k * m + k];
    }
    b.iter().all(|x| x.is_finite())
}

/// Ratio of the smallest to the largest singular value of the row-major m×n matrix `g`
/// without allocating (one-sided Jacobi on the rows, in `scratch`, m n entries): the
/// [`ConstraintJet::conditioning`] of a step's end node, checked every step.
#[inline]
pub(crate) fn conditioning(g: &[f64], m: usize, n: usize, scratch: &mut [f64]) -> f64 {
    if m == 0 {
        return 1.0;
    }
    if n < m || !g.iter().all(|x| x.is_finite()) {
        return 0.0;
    }
    if m == 1 {
        // One row: no rotation, the ratio of its norm to itself (what the sweeps below give,
        // without copying the row).
        let s = dot(&g[..n], &g[..n]).sqrt();
        return if s > 0.0 && s.is_finite() { 1.0 } else { 0.0 };
    }
    rows_conditioning(g, m, n, scratch)
}

/// [`conditioning`] of m ≥ 2 rows: the Jacobi sweeps.
fn rows_conditioning(g: &[f64], m: usize, n: usize, scratch: &mut [f64]) -> f64 {
    let a = &mut scratch[..m * n];
    a.copy_from_slice(&g[..m * n]);
    for _sweep in 0..30 {
        let mut rotated = false;
        for i in 0..m {
            for j in i + 1..m {
                let (ri, rj) = (&a[i * n..(i + 1) * n], &a[j * n..(j + 1) * n]);
                let (aii, ajj, aij) = (dot(ri, ri), dot(rj, rj), dot(ri, rj));
                if aij == 0.0 || aij.abs() <= 1e-15 * (aii * ajj).sqrt() {
                    continue;
                }
                rotated = true;
                let zeta = (ajj - aii) / (2.0 * aij);
                let t = zeta.signum() / (zeta.abs() + (1.0 + zeta * zeta).sqrt());
                let c = 1.0 / (1.0 + t * t).sqrt();
                let s = c * t;
                for k in 0..n {
                    let (x, y) = (a[i * n + k], a[j * n + k]);
                    a[i * n + k] = c * x - s * y;
                    a[j * n + k] = s * x + c * y;
                }
            }
        }
        if !rotated {
            break;
        }
    }
    let norms = (0..m).map(|i| dot(&a[i * n..(i + 1) * n], &a[i * n..(i + 1) * n]).sqrt());
    let (lo, hi) = norms.fold((f64::INFINITY, 0.0f64), |(lo, hi), s| (lo.min(s), hi.max(s)));
    if hi > 0.0 && hi.is_finite() {
        lo / hi
    } else {
        0.0
    }
}

/// The projection of `ptilde` onto T*N at a node whose jet is `jet`, for a constant mass matrix:
/// (G M⁻¹ Gᵀ) μ̂ = G M⁻¹ p̃, p = p̃ − Gᵀμ̂ (into `p`), v = M⁻¹p (into `v`), μ̂ into `mu`.
/// `scratch` holds m n + m² + m entries. False if G M⁻¹ Gᵀ is singular.
pub(crate) fn project_linear(
    mass: &crate::lagrangian::MassMatrix,
    jet: &super::jet::ConstraintJet,
    ptilde: &[f64],
    scratch: &mut [f64],
    p: &mut [f64],
    v: &mut [f64],
    mu: &mut [f64],
) -> bool {
    let (m, n) = (jet.m, jet.n);
    let (w, rest) = scratch.split_at_mut(m * n);
    let (mat, rhs) = rest.split_at_mut(m * m);
    for l in 0..m {
        mass_solve(mass, &jet.jac[l * n..(l + 1) * n], &mut w[l * n..(l + 1) * n]);
    }
    for i in 0..m {
        let gi = &jet.jac[i * n..(i + 1) * n];
        for l in 0..m {
            mat[i * m + l] = dot(gi, &w[l * n..(l + 1) * n]);
        }
        rhs[i] = dot(&w[i * n..(i + 1) * n], ptilde);
    }
    if !solve_small(mat, &mut rhs[..m], m) {
        return false;
    }
    copy(mu, &rhs[..m]);
    copy(p, ptilde);
    jet.add_transpose_times(mu, -1.0, p);
    mass_solve(mass, p, v);
    true
}

#[cfg(test)]
mod tests {
    use super::{conditioning, solve_small};

    /// The one-sided Jacobi ratio against nalgebra's SVD, on full-rank and nearly dependent rows.
    #[test]
    fn conditioning_matches_the_svd() {
        let cases: [(usize, usize, Vec<f64>); 4] = [
            (1, 3, vec![0.3, -1.2, 2.0]),
            (2, 4, vec![1.0, 2.0, -0.5, 0.3, 0.7, -1.1, 2.2, 0.9]),
            (3, 5, (0..15).map(|i| ((i * 7 + 3) % 11) as f64 - 5.0).collect()),
            (2, 3, vec![1.0, 2.0, 3.0, 1.0, 2.0, 3.0 + 1e-9]),
        ];
        for (m, n, g) in cases {
            let sv = nalgebra::DMatrix::from_row_slice(m, n, &g).singular_values();
            let svd = sv.min() / sv.max();
            let jacobi = conditioning(&g, m, n, &mut vec![0.0; m * n]);
            assert!(
                (jacobi - svd).abs() <= 1e-6 * svd,
                "{m}x{n}: {jacobi:e} against {svd:e}"
            );
        }
        assert_eq!(conditioning(&[1.0, 2.0, 2.0, 4.0], 2, 2, &mut [0.0; 4]), 0.0);
        assert_eq!(conditioning(&[f64::NAN, 1.0], 1, 2, &mut [0.0; 2]), 0.0);
    }

    #[test]
    fn small_solves_pivot_and_refuse_singular_systems() {
        let (mut a, mut b) = (vec![0.0, 2.0, 1.0, 1.0], vec![4.0, 3.0]);
        assert!(solve_small(&mut a, &mut b, 2));
        assert_eq!(b, [1.0, 2.0]);
        assert!(!solve_small(&mut [1.0, 2.0, 2.0, 4.0], &mut [1.0, 1.0], 2));
        assert!(!solve_small(&mut [0.0], &mut [1.0], 1));
    }

    /// The unrolled 2×2 elimination makes the loops' operations: the same bits (the RATTLE
    /// steps of two constraints kept theirs, `golden/terms.txt`).
    #[test]
    fn the_two_by_two_solve_is_the_general_elimination() {
        let mut x = 0.37f64;
        let mut next = || {
            x = (x * 7.31 + 0.113).fract();
            x - 0.5
        };
        for _ in 0..1000 {
            let a: Vec<f64> = (0..4).map(|_| next()).collect();
            let b: Vec<f64> = (0..2).map(|_| next()).collect();
            let (mut a1, mut b1, mut a2, mut b2) = (a.clone(), b.clone(), a, b);
            assert_eq!(
                solve_small(&mut a1, &mut b1, 2),
                super::solve_general(&mut a2, &mut b2, 2)
            );
            assert_eq!(
                b1.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                b2.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
            );
        }
    }
}
