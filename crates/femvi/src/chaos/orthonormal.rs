//! Modified Gram–Schmidt for the Lyapunov spectrum (Benettin et al. 1980): the tangent
//! vectors re-orthonormalised in order, a QR factorisation W = QR of which the spectrum
//! keeps ln R_ii.
//!
//! The loop is right-looking: once vector i is normalised, its projection is taken out of
//! every later vector, which undergoes the projections of vectors 0, 1, …, i − 1 in turn as
//! in the textbook (left-looking) form. Each projection's dot product is summed in
//! [`LANES`] partial sums (component e into sum e mod 8, in order, then the sums added in a
//! fixed tree): the chains of additions overlap and the loop vectorises, with the same bits
//! on every instruction set (no fused multiply-add; the loop is compiled for AVX-512, AVX2
//! and the baseline and the processor's best taken at run time). On the FPU chain with
//! n = 64 (129 vectors of 128 numbers, re-orthonormalised every 10 steps) the textbook loop,
//! one chain of 128 dependent additions per dot product, was half of a tangent run's time.
//! The lengths R_ii are summed in order, one chain per vector.

use super::accumulate::norm;

/// Partial sums of a dot product.
const LANES: usize = 8;

/// Modified Gram–Schmidt on the d-vectors of `w` (column-major): orthonormalises them in
/// order and writes ln R_ii, the logarithms of the lengths removed, to `logs` (one per
/// vector; vectors without a slot are orthonormalised all the same).
pub(crate) fn orthonormalise(w: &mut [f64], d: usize, logs: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the processor has the instruction set the variant is compiled for.
            return unsafe { x86::avx512(w, d, logs) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: as above.
            return unsafe { x86::avx2(w, d, logs) };
        }
    }
    gram_schmidt(w, d, logs);
}

/// The loop of [`orthonormalise`], inlined into each instruction-set variant.
#[inline(always)]
fn gram_schmidt(w: &mut [f64], d: usize, logs: &mut [f64]) {
    if d == 0 {
        return;
    }
    let k = w.len() / d;
    for i in 0..k {
        let (done, rest) = w.split_at_mut((i + 1) * d);
        let q = &mut done[i * d..];
        let len = norm(q);
        if let Some(l) = logs.get_mut(i) {
            *l = len.ln();
        }
        q.iter_mut().for_each(|x| *x /= len);
        let q = &*q;
        for v in rest[..(k - i - 1) * d].chunks_exact_mut(d) {
            let r = dot(q, v);
            v.iter_mut().zip(q).for_each(|(x, qe)| *x -= r * qe);
        }
    }
}

/// a·b in [`LANES`] partial sums (component e into sum e mod LANES, in order), added as
/// ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7)).
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut s = [0.0f64; LANES];
    let (ac, bc) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let (at, bt) = (ac.remainder(), bc.remainder());
    for (x, y) in ac.zip(bc) {
        for l in 0..LANES {
            s[l] += x[l] * y[l];
        }
    }
    for (l, (x, y)) in at.iter().zip(bt).enumerate() {
        s[l] += x * y;
    }
    ((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]))
}

/// The loop compiled with wider vector instructions (the same operations).
#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::gram_schmidt;

    /// With AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(super) fn avx512(w: &mut [f64], d: usize, logs: &mut [f64]) {
        gram_schmidt(w, d, logs);
    }

    /// With AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) fn avx2(w: &mut [f64], d: usize, logs: &mut [f64]) {
        gram_schmidt(w, d, logs);
    }
}

#[cfg(test)]
mod tests {
    use super::{gram_schmidt, orthonormalise};

    /// The textbook (left-looking) modified Gram–Schmidt, each dot product one sum in order.
    fn textbook(w: &mut [f64], d: usize, logs: &mut [f64]) {
        let k = w.len() / d;
        for i in 0..k {
            for j in 0..i {
                let (done, rest) = w.split_at_mut(i * d);
                let qj = &done[j * d..(j + 1) * d];
                let vi = &mut rest[..d];
                let r: f64 = qj.iter().zip(vi.iter()).map(|(a, b)| a * b).sum();
                for (x, q) in vi.iter_mut().zip(qj) {
                    *x -= r * q;
                }
            }
            let v = &mut w[i * d..(i + 1) * d];
            let len = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            logs[i] = len.ln();
            for x in v.iter_mut() {
                *x /= len;
            }
        }
    }

    #[test]
    fn gram_schmidt_gives_orthonormal_vectors_and_the_r_diagonal() {
        // Columns (3, 4) and (1, 0): R = [[5, 3/5], [0, 4/5]].
        let mut w = vec![3.0, 4.0, 1.0, 0.0];
        let mut logs = [0.0; 2];
        orthonormalise(&mut w, 2, &mut logs);
        assert!((logs[0] - 5f64.ln()).abs() < 1e-15 && (logs[1] - 0.8f64.ln()).abs() < 1e-15);
        assert!((w[0] * w[2] + w[1] * w[3]).abs() < 1e-15);
    }

    /// On random vectors of several sizes around the partial sums' count: Q orthonormal to
    /// 1e-14, ln R_ii and Q within 1e-12 of the textbook loop's, and every instruction-set
    /// variant with the bits of the baseline loop.
    #[test]
    fn partial_sums_keep_the_factorisation_and_every_variant_has_the_same_bits() {
        let mut rand = crate::testing::uniform(0x6a5d_39e1_0f2b_c417);
        for d in [1usize, 2, 3, 7, 8, 9, 16, 21, 64] {
            for k in [1usize, 2, 7, 9, 17] {
                let k = k.min(d);
                let w0: Vec<f64> = (0..k * d)
                    .map(|i| if i % 5 == 3 { -0.0 } else { rand() - 0.5 })
                    .collect();
                let (mut w, mut want, mut base) = (w0.clone(), w0.clone(), w0.clone());
                let (mut logs, mut want_logs, mut base_logs) = (vec![0.0; k], vec![0.0; k], vec![0.0; k]);
                orthonormalise(&mut w, d, &mut logs);
                textbook(&mut want, d, &mut want_logs);
                gram_schmidt(&mut base, d, &mut base_logs);
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&w), bits(&base), "d = {d}, k = {k}");
                assert_eq!(bits(&logs), bits(&base_logs), "d = {d}, k = {k}");
                #[cfg(target_arch = "x86_64")]
                if std::arch::is_x86_feature_detected!("avx2") {
                    let (mut w2, mut logs2) = (w0.clone(), vec![0.0; k]);
                    // SAFETY: the processor has AVX2.
                    unsafe { super::x86::avx2(&mut w2, d, &mut logs2) };
                    assert_eq!(bits(&w2), bits(&base), "AVX2, d = {d}, k = {k}");
                    assert_eq!(bits(&logs2), bits(&base_logs), "AVX2, d = {d}, k = {k}");
                }
                for (a, b) in logs.iter().zip(&want_logs) {
                    assert!(
                        (a - b).abs() <= 1e-12 * b.abs().max(1.0),
                        "d = {d}, k = {k}: {a} against {b}"
                    );
                }
                for (a, b) in w.iter().zip(&want) {
                    assert!((a - b).abs() <= 1e-12, "d = {d}, k = {k}: {a} against {b}");
                }
                for i in 0..k {
                    for j in 0..k {
                        let g: f64 = (0..d).map(|e| w[i * d + e] * w[j * d + e]).sum();
                        let id = if i == j { 1.0 } else { 0.0 };
                        assert!((g - id).abs() <= 1e-14, "d = {d}, k = {k}: Q^T Q ({i}, {j}) = {g}");
                    }
                }
            }
        }
    }
}
