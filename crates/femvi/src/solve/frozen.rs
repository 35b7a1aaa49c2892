//! The kept Jacobian of the simplified Newton iteration ([`super::simplified_newton`]): its
//! explicit inverse, by Gauss–Jordan elimination with partial pivoting, and the correction
//! −J⁻¹r as one matrix-vector product, unrolled for the sizes of small elements (dim ≤ 16)
//! with the same sums in the same order as the loop, so the same bits.

/// A factorised Jacobian and the buffers of the iteration. The factorisation is kept as the
/// explicit inverse: each iteration is then one matrix-vector product,
/// which for the small systems of an element (dim = s·n) costs a fraction of the triangular
/// solves (measured: those took a tenth of a relativistic Kepler step). Its rounding only
/// changes the rate of convergence, not the solution, which is set by the residual.
#[derive(Debug, Clone)]
pub struct FrozenJacobian {
    /// Residual at the last iterate evaluated (after convergence, the one before the last
    /// correction when that correction was below round-off: see [`super::simplified_newton`]).
    pub r: Vec<f64>,
    /// Jacobian to factorise, row-major (filled by the caller before [`FrozenJacobian::factor`]).
    pub jac: Vec<f64>,
    /// J⁻¹, row-major (empty: nothing factorised).
    inv: Vec<f64>,
    pub(super) rhs: Vec<f64>,
    work: Vec<f64>,
}

/// Reduces `a` (row-major dim × dim) to the identity by row operations with partial
/// pivoting, applying them to `b`: b becomes a⁻¹b. False if a pivot is zero.
fn gauss_jordan(a: &mut [f64], b: &mut [f64], dim: usize) -> bool {
    for col in 0..dim {
        let Some(piv) = (col..dim).max_by(|&i, &j| a[i * dim + col].abs().total_cmp(&a[j * dim + col].abs())) else {
            return false;
        };
        let p = a[piv * dim + col];
        if p == 0.0 || !p.is_finite() {
            return false;
        }
        if piv != col {
            for k in 0..dim {
                a.swap(piv * dim + k, col * dim + k);
                b.swap(piv * dim + k, col * dim + k);
            }
        }
        for k in 0..dim {
            a[col * dim + k] /= p;
            b[col * dim + k] /= p;
        }
        for i in (0..dim).filter(|&i| i != col) {
            let f = a[i * dim + col];
            if f != 0.0 {
                for k in 0..dim {
                    a[i * dim + k] -= f * a[col * dim + k];
                    b[i * dim + k] -= f * b[col * dim + k];
                }
            }
        }
    }
    true
}

/// [`gauss_jordan`] for dim = D on rows of fixed size: the same pivots and the same
/// operations in the same order (same bits), unrolled by the compiler (with a run-time dim,
/// inverting an 8 × 8 Jacobian took ~20 000 instructions). False if a or b is not D × D.
fn gauss_jordan_fixed<const D: usize>(a: &mut [f64], b: &mut [f64]) -> bool {
    let (Ok(a), Ok(b)) = (
        <&mut [[f64; D]; D]>::try_from(a.as_chunks_mut::<D>().0),
        <&mut [[f64; D]; D]>::try_from(b.as_chunks_mut::<D>().0),
    ) else {
        return false;
    };
    for col in 0..D {
        let Some(piv) = (col..D).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs())) else {
            return false;
        };
        let p = a[piv][col];
        if p == 0.0 || !p.is_finite() {
            return false;
        }
        if piv != col {
            a.swap(piv, col);
            b.swap(piv, col);
        }
        for k in 0..D {
            a[col][k] /= p;
            b[col][k] /= p;
        }
        let (ac, bc) = (a[col], b[col]);
        for i in (0..D).filter(|&i| i != col) {
            let f = a[i][col];
            if f != 0.0 {
                for k in 0..D {
                    a[i][k] -= f * ac[k];
                    b[i][k] -= f * bc[k];
                }
            }
        }
    }
    true
}

impl FrozenJacobian {
    /// Buffers for `dim` unknowns, nothing factorised (the caller bounds dim: like any
    /// allocation, dim² numbers that do not fit in memory abort).
    pub fn new(dim: usize) -> Self {
        Self {
            r: vec![0.0; dim],
            jac: vec![0.0; dim * dim],
            inv: Vec::new(),
            rhs: vec![0.0; dim],
            work: Vec::new(),
        }
    }

    /// Number of unknowns.
    pub fn dim(&self) -> usize {
        self.r.len()
    }

    /// Whether a factorisation is held.
    pub fn is_factored(&self) -> bool {
        !self.inv.is_empty()
    }

    /// Drops the factorisation.
    pub fn clear(&mut self) {
        self.inv.clear();
    }

    /// Inverts `jac` by Gauss–Jordan elimination with partial pivoting; false, holding
    /// nothing, if it is not finite or singular. (By hand rather than nalgebra's LU and
    /// inverse: those allocate four matrices, and a refresh of an 8 × 8 Jacobian spent more
    /// time there than in the Hessian.)
    pub fn factor(&mut self) -> bool {
        let dim = self.dim();
        self.inv.clear();
        if !self.jac.iter().all(|v| v.is_finite()) {
            return false;
        }
        let mut a = std::mem::take(&mut self.work);
        a.clear();
        a.extend_from_slice(&self.jac);
        // The inverse's buffer is reused (a refresh happens inside a run of steps).
        let mut inv = std::mem::take(&mut self.inv);
        inv.clear();
        inv.resize(dim * dim, 0.0);
        for i in 0..dim {
            inv[i * dim + i] = 1.0;
        }
        macro_rules! fixed {
            ($($d:literal)*) => {
                match dim {
                    $($d => gauss_jordan_fixed::<$d>(&mut a, &mut inv),)*
                    _ => gauss_jordan(&mut a, &mut inv, dim),
                }
            };
        }
        let ok = fixed!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16);
        self.work = a;
        if !(ok && inv.iter().all(|v| v.is_finite())) {
            // Nothing factorised: empty, its capacity kept.
            inv.clear();
        }
        self.inv = inv;
        self.is_factored()
    }

    /// The correction −J⁻¹r into `rhs`; false without a factorisation or if not finite.
    #[inline]
    pub(super) fn correction(&mut self) -> bool {
        let dim = self.dim();
        if self.inv.len() != dim * dim {
            return false;
        }
        macro_rules! fixed {
            ($($d:literal)*) => {
                match dim {
                    $($d => product::<$d>(&self.inv, &self.r, &mut self.rhs),)*
                    _ => product_any(&self.inv, &self.r, &mut self.rhs),
                }
            };
        }
        fixed!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16);
        self.rhs.iter().all(|v| v.is_finite())
    }
}

/// rhs = −A r for A row-major dim × dim, dim = r's length (the caller's check).
fn product_any(a: &[f64], r: &[f64], rhs: &mut [f64]) {
    for (d, row) in rhs.iter_mut().zip(a.chunks_exact(r.len())) {
        *d = -row.iter().zip(r).map(|(a, b)| a * b).sum::<f64>();
    }
}

/// [`product_any`] for dim = D (nothing done if r or rhs is not of length D: the caller
/// checks): the same sums in the same order, unrolled by the compiler
/// (with a run-time dim the loop overhead was twice the flops of an 8 × 8 product).
#[inline]
fn product<const D: usize>(a: &[f64], r: &[f64], rhs: &mut [f64]) {
    let (rows, _) = a.as_chunks::<D>();
    let (Ok(r), Some(rhs)) = (<&[f64; D]>::try_from(r), rhs.first_chunk_mut::<D>()) else {
        return;
    };
    for (d, row) in rhs.iter_mut().zip(rows) {
        *d = -row.iter().zip(r).map(|(a, b)| a * b).sum::<f64>();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pseudo-random numbers in [−½, ½) (a linear congruential generator: reproducible).
    fn uniform(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        }
    }

    /// The unrolled inversion against the loop, bit for bit, for every unrolled size (with
    /// pivoting: the matrices are far from diagonally dominant).
    #[test]
    fn fixed_size_inverse_equals_the_loop_bit_for_bit() {
        let mut rand = uniform(11);
        for dim in 1..=17 {
            let jac: Vec<f64> = (0..dim * dim).map(|_| rand()).collect();
            let mut frozen = FrozenJacobian::new(dim);
            frozen.jac = jac.clone();
            assert!(frozen.factor(), "dim {dim}");
            let (mut a, mut want) = (jac, vec![0.0; dim * dim]);
            (0..dim).for_each(|i| want[i * dim + i] = 1.0);
            assert!(gauss_jordan(&mut a, &mut want, dim));
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&frozen.inv), bits(&want), "dim {dim}");
        }
    }

    /// The unrolled product against the loop, bit for bit, for every unrolled size.
    #[test]
    fn fixed_size_product_equals_the_loop_bit_for_bit() {
        let mut rand = uniform(7);
        for dim in 1..=17 {
            let a: Vec<f64> = (0..dim * dim).map(|_| rand() * 1e3).collect();
            let r: Vec<f64> = (0..dim).map(|_| rand() * 1e-3).collect();
            let mut frozen = FrozenJacobian::new(dim);
            frozen.inv = a.clone();
            frozen.r = r.clone();
            assert!(frozen.correction());
            let mut want = vec![0.0; dim];
            product_any(&a, &r, &mut want);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&frozen.rhs), bits(&want), "dim {dim}");
        }
    }
}
