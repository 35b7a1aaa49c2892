//! LU factorisation with partial pivoting of a banded matrix (the layout of LAPACK's dgbtrf),
//! for the block-banded Jacobians of boundary value problems: O(M·kl·(kl + ku)) work, so a
//! Newton iteration costs O(N) in the number of elements. Hand-written: nalgebra has no banded
//! solver and faer's sparse LU, which would also do, costs far more to build than these lines.
//!
//! Every entry point checks its arguments: a size whose storage does not fit in memory, an
//! entry outside the band, a right-hand side of the wrong length or a solve before a
//! successful factorisation are typed errors, not panics.

use crate::error::{check_len, invalid, Result};

/// A square banded matrix with lower bandwidth kl and upper bandwidth ku, stored row by row
/// with room for the fill of partial pivoting (upper bandwidth kl + ku after factorisation).
#[derive(Debug, Clone)]
pub struct BandMatrix {
    m: usize,
    kl: usize,
    ku: usize,
    width: usize,
    data: Vec<f64>,
    pivots: Vec<usize>,
    /// Whether `data` holds a successful factorisation (and `pivots` its row swaps).
    factored: bool,
}

impl BandMatrix {
    /// A zero matrix of size m with the given bandwidths: m·(2 kl + ku + 1) numbers.
    ///
    /// # Errors
    /// A size whose storage overflows or cannot be allocated.
    pub fn zeros(m: usize, kl: usize, ku: usize) -> Result<Self> {
        let too_big = || {
            invalid(
                "band matrix",
                format!("size {m} with bandwidths {kl}, {ku} does not fit in memory"),
            )
        };
        let width = kl
            .checked_mul(2)
            .and_then(|w| w.checked_add(ku))
            .and_then(|w| w.checked_add(1))
            .ok_or_else(too_big)?;
        let len = m.checked_mul(width).ok_or_else(too_big)?;
        let mut data = Vec::new();
        data.try_reserve_exact(len).map_err(|_| too_big())?;
        data.resize(len, 0.0);
        let mut pivots = Vec::new();
        pivots.try_reserve_exact(m).map_err(|_| too_big())?;
        pivots.resize(m, 0);
        Ok(Self {
            m,
            kl,
            ku,
            width,
            data,
            pivots,
            factored: false,
        })
    }

    /// The lower and upper bandwidths (kl, ku) it was made with.
    ///
    /// ```
    /// let band = femvi::solve::BandMatrix::zeros(5, 1, 2)?;
    /// assert_eq!((band.size(), band.bandwidths()), (5, (1, 2)));
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn bandwidths(&self) -> (usize, usize) {
        (self.kl, self.ku)
    }

    /// The size m.
    pub fn size(&self) -> usize {
        self.m
    }

    #[inline]
    fn idx(&self, i: usize, j: usize) -> usize {
        i * self.width + (j + self.kl - i)
    }

    /// Whether (i, j) lies in the matrix and in its band (|i − j| within kl, ku).
    #[inline]
    fn in_band(&self, i: usize, j: usize) -> bool {
        i < self.m && j < self.m && j.saturating_add(self.kl) >= i && j <= i.saturating_add(self.ku)
    }

    /// Sets every entry to zero (keeping the allocation).
    pub fn clear(&mut self) {
        self.data.iter_mut().for_each(|x| *x = 0.0);
        self.factored = false;
    }

    /// Entry (i, j) before factorisation (zero outside the band or the matrix).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        if self.in_band(i, j) {
            self.data[self.idx(i, j)]
        } else {
            0.0
        }
    }

    /// Adds `v` to entry (i, j).
    ///
    /// # Errors
    /// (i, j) outside the matrix or outside the band (|i − j| beyond kl below or ku above).
    #[inline]
    pub fn add(&mut self, i: usize, j: usize, v: f64) -> Result<()> {
        if !self.in_band(i, j) {
            return Err(invalid(
                "band matrix entry",
                format!(
                    "({i}, {j}) is outside a matrix of size {} with bandwidths {}, {}",
                    self.m, self.kl, self.ku
                ),
            ));
        }
        let k = self.idx(i, j);
        self.data[k] += v;
        self.factored = false;
        Ok(())
    }

    /// Factorises in place. Returns false if a pivot is zero or not finite (singular matrix).
    pub fn factor(&mut self) -> bool {
        self.factored = self.factor_in_place();
        self.factored
    }

    fn factor_in_place(&mut self) -> bool {
        let (m, kl, ku) = (self.m, self.kl, self.ku);
        for j in 0..m {
            let last = (j + kl).min(m - 1);
            let mut p = j;
            let mut best = self.data[self.idx(j, j)].abs();
            for i in j + 1..=last {
                let v = self.data[self.idx(i, j)].abs();
                if v > best {
                    best = v;
                    p = i;
                }
            }
            if !(best > 0.0 && best.is_finite()) {
                return false;
            }
            self.pivots[j] = p;
            let cols = (j + kl + ku).min(m - 1);
            if p != j {
                for c in j..=cols {
                    let (a, b) = (self.idx(j, c), self.idx(p, c));
                    self.data.swap(a, b);
                }
            }
            let pivot = self.data[self.idx(j, j)];
            for i in j + 1..=last {
                let k = self.idx(i, j);
                let l = self.data[k] / pivot;
                self.data[k] = l;
                if l != 0.0 {
                    for c in j + 1..=cols {
                        let (a, b) = (self.idx(i, c), self.idx(j, c));
                        self.data[a] -= l * self.data[b];
                    }
                }
            }
        }
        true
    }

    /// Solves A x = b in place with the factorisation.
    ///
    /// # Errors
    /// No successful [`BandMatrix::factor`] since the last change, or `b` not of length m.
    pub fn solve(&self, b: &mut [f64]) -> Result<()> {
        if !self.factored {
            return Err(invalid("band matrix", "solve needs a successful factor() first"));
        }
        check_len("right-hand side", self.m, b.len())?;
        let (m, kl, ku) = (self.m, self.kl, self.ku);
        for j in 0..m {
            let p = self.pivots[j];
            if p != j {
                b.swap(j, p);
            }
            let bj = b[j];
            for i in j + 1..=(j + kl).min(m - 1) {
                b[i] -= self.data[self.idx(i, j)] * bj;
            }
        }
        for i in (0..m).rev() {
            let mut acc = b[i];
            for c in i + 1..=(i + kl + ku).min(m - 1) {
                acc -= self.data[self.idx(i, c)] * b[c];
            }
            b[i] = acc / self.data[self.idx(i, i)];
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_a_dense_solve_with_pivoting() {
        // A banded matrix whose leading entries are zero, so pivoting is needed.
        let (m, kl, ku) = (9, 2, 1);
        let mut band = BandMatrix::zeros(m, kl, ku).unwrap();
        let mut dense = nalgebra::DMatrix::<f64>::zeros(m, m);
        for i in 0..m {
            for j in i.saturating_sub(kl)..=(i + ku).min(m - 1) {
                let v = if i == j && i % 3 == 0 {
                    0.0
                } else {
                    ((i * 7 + j * 3) % 11) as f64 - 5.0
                };
                band.add(i, j, v).unwrap();
                dense[(i, j)] = v;
            }
        }
        let b: Vec<f64> = (0..m).map(|i| (i as f64).sin()).collect();
        let mut x = b.clone();
        assert!(band.factor());
        band.solve(&mut x).unwrap();
        let want = dense.lu().solve(&nalgebra::DVector::from_vec(b)).unwrap();
        for i in 0..m {
            assert!(
                (x[i] - want[i]).abs() < 1e-12 * (1.0 + want[i].abs()),
                "{i}: {} vs {}",
                x[i],
                want[i]
            );
        }
    }

    #[test]
    fn singular_is_reported() {
        let mut band = BandMatrix::zeros(3, 1, 1).unwrap();
        band.add(0, 0, 1.0).unwrap();
        band.add(1, 1, 0.0).unwrap();
        band.add(2, 2, 1.0).unwrap();
        assert!(!band.factor());
    }
}
