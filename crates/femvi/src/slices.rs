//! Copies of slices of a few numbers without a call to memmove: the node and multiplier
//! vectors of the constrained steps (`constraints/small.rs`, `shake/`) and the node velocity
//! of the energy check (`solution/energy.rs`). Where a slice's length is not a constant,
//! `copy_from_slice` is a call to memcpy, which on vectors of two to four entries costs more
//! than the copy itself (6 % of a RATTLE run of the spherical pendulum). A leaf module: it
//! imports nothing of the crate.

/// `dst = src` element by element (the shorter length if they differ).
#[inline(always)]
pub(crate) fn copy(dst: &mut [f64], src: &[f64]) {
    dst.iter_mut().zip(src).for_each(|(d, s)| *d = *s);
}

/// As [`copy`], by moves for up to four entries (where the length is known only at run time,
/// as in a loop calling its observer per node through a pointer), by [`copy`] beyond.
#[inline(always)]
pub(crate) fn copy_short(dst: &mut [f64], src: &[f64]) {
    match (dst, src) {
        ([a], [x]) => *a = *x,
        ([a, b], [x, y]) => (*a, *b) = (*x, *y),
        ([a, b, c], [x, y, z]) => (*a, *b, *c) = (*x, *y, *z),
        ([a, b, c, d], [x, y, z, w]) => (*a, *b, *c, *d) = (*x, *y, *z, *w),
        (dst, src) => copy(dst, src),
    }
}

#[cfg(test)]
mod tests {
    use super::{copy, copy_short};

    /// Every length, the unrolled ones and beyond: `dst` becomes `src` entry for entry, by
    /// both copies; with lengths that differ, the shorter prefix is copied and the rest kept.
    #[test]
    fn copies_every_length() {
        for n in 0..7 {
            let src: Vec<f64> = (0..n).map(|i| 1.5 + i as f64).collect();
            for f in [copy, copy_short] {
                let mut dst = vec![f64::NAN; n];
                f(&mut dst, &src);
                assert_eq!(dst, src, "length {n}");
                let mut longer = vec![-1.0; n + 2];
                f(&mut longer, &src);
                assert_eq!(&longer[..n], &src[..], "length {n} into {}", n + 2);
                assert_eq!(&longer[n..], &[-1.0, -1.0], "length {n}: the tail is kept");
            }
        }
    }
}
