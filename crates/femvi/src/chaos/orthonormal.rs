//! Modified Gram–Schmidt for the Lyapunov spectrum (Benettin et al. 1980): the tangent
//! vectors re-orthonormalised in order, a QR factorisation W = QR of which the spectrum
//! keeps ln R_ii.
//!
//! The loop is right-looking: once vector i is normalised, its projection is taken out of
//! every later vector. Each later vector then undergoes the same operations in the same
//! order as in the textbook (left-looking) form — the projections of vectors 0, 1, …, i − 1
//! in turn, each dot product summed in index order from −0 (the bits of
//! `Iterator::sum`) — so the result is bit for bit the same. What changes is that the dot
//! products of eight later vectors against one normalised vector are independent chains of
//! additions, which the processor overlaps: on the FPU chain with n = 64 (129 vectors of 128
//! numbers), the left-looking loop was half of a tangent run's time (one chain of 128
//! dependent additions per dot product).

use super::accumulate::norm;

/// Later vectors whose projections are taken together (independent chains).
const BLOCK: usize = 8;

/// Modified Gram–Schmidt on the d-vectors of `w` (column-major): orthonormalises them in
/// order and writes ln R_ii, the logarithms of the lengths removed, to `logs` (one per
/// vector; extra vectors without a slot are orthonormalised all the same).
pub(crate) fn orthonormalise(w: &mut [f64], d: usize, logs: &mut [f64]) {
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
        let mut later = rest[..(k - i - 1) * d].chunks_exact_mut(BLOCK * d);
        for block in later.by_ref() {
            project::<BLOCK>(q, block);
        }
        for v in later.into_remainder().chunks_exact_mut(d) {
            project::<1>(q, v);
        }
    }
}

/// Takes the projection on the unit vector `q` out of each of the `B` vectors of `block`
/// (one after another, each q.len() long): r = q·v summed in order from −0, then v −= r q.
#[inline(always)]
fn project<const B: usize>(q: &[f64], block: &mut [f64]) {
    let d = q.len();
    let mut r = [-0.0f64; B];
    for (e, qe) in q.iter().enumerate() {
        for (b, rb) in r.iter_mut().enumerate() {
            *rb += qe * block[b * d + e];
        }
    }
    for (v, rb) in block.chunks_exact_mut(d).zip(r) {
        for (x, qe) in v.iter_mut().zip(q) {
            *x -= rb * qe;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::orthonormalise;

    /// The textbook (left-looking) modified Gram–Schmidt, as this module had it before.
    fn left_looking(w: &mut [f64], d: usize, logs: &mut [f64]) {
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

    /// The blocked right-looking loop has the textbook loop's bits, for every count of
    /// vectors around the block size and with signed zeros among the entries.
    #[test]
    fn right_looking_blocks_have_the_textbook_bits() {
        let mut rand = crate::testing::uniform(0x6a5d_39e1_0f2b_c417);
        for d in [1usize, 2, 3, 7, 16, 21] {
            for k in [1usize, 2, 7, 8, 9, 17, 25] {
                let k = k.min(d.max(2) * 2);
                let mut w: Vec<f64> = (0..k * d)
                    .map(|i| if i % 5 == 3 { -0.0 } else { rand() - 0.5 })
                    .collect();
                let mut want = w.clone();
                let (mut logs, mut want_logs) = (vec![0.0; k], vec![0.0; k]);
                orthonormalise(&mut w, d, &mut logs);
                left_looking(&mut want, d, &mut want_logs);
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&w), bits(&want), "d = {d}, k = {k}");
                assert_eq!(bits(&logs), bits(&want_logs), "d = {d}, k = {k}");
            }
        }
    }
}
