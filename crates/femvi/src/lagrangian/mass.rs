//! The constant mass matrix M of a mechanical Lagrangian L = ½vᵀMv − V(t, q), stored by its
//! structure: a diagonal M (the identity and every built-in model among them) by its diagonal
//! and the reciprocals, O(n) memory and work, so that systems of 10⁵–10⁶ coordinates set up in
//! linear time; a dense M by its entries and its inverse (from a Cholesky factorisation),
//! O(n²). Symmetry and positive definiteness are checked at construction, so a Lagrangian
//! with a constant M is regular everywhere.

use crate::error::{check_len, invalid, Error, Result};

/// A constant symmetric positive definite mass matrix, with its inverse.
#[derive(Debug, Clone, PartialEq)]
pub struct MassMatrix {
    n: usize,
    storage: Storage,
}

#[derive(Debug, Clone, PartialEq)]
enum Storage {
    /// Diagonal entries and their reciprocals (solves multiply instead of dividing).
    Diagonal { d: Vec<f64>, inv: Vec<f64>, identity: bool },
    /// Row-major entries and inverse.
    Dense { m: Vec<f64>, inv: Vec<f64> },
}

impl MassMatrix {
    /// The n×n identity (O(n) memory).
    pub fn identity(n: usize) -> Self {
        Self {
            n,
            storage: Storage::Diagonal {
                d: vec![1.0; n],
                inv: vec![1.0; n],
                identity: true,
            },
        }
    }

    /// A diagonal mass matrix (O(n) memory).
    ///
    /// # Errors
    /// A diagonal entry that is not positive and finite.
    pub fn diagonal(d: Vec<f64>) -> Result<Self> {
        if d.iter().any(|&x| !(x > 0.0 && x.is_finite())) {
            return Err(Error::MassNotPositiveDefinite);
        }
        let identity = d.iter().all(|&x| x == 1.0);
        let inv = d.iter().map(|x| 1.0 / x).collect();
        Ok(Self {
            n: d.len(),
            storage: Storage::Diagonal { d, inv, identity },
        })
    }

    /// A dense mass matrix from its row-major entries (stored as diagonal if it is one).
    ///
    /// # Errors
    /// Wrong length, not symmetric, or not positive definite (Cholesky fails).
    pub fn dense(n: usize, m: Vec<f64>) -> Result<Self> {
        let len = n
            .checked_mul(n)
            .ok_or_else(|| invalid("mass matrix", format!("{n} x {n} entries do not fit in memory")))?;
        check_len("mass matrix", len, m.len())?;
        let mat = nalgebra::DMatrix::from_row_slice(n, n, &m);
        if (&mat - mat.transpose()).amax() > 1e-14 * mat.amax() || m.iter().any(|x| !x.is_finite()) {
            return Err(Error::MassNotPositiveDefinite);
        }
        let chol = nalgebra::Cholesky::new(mat).ok_or(Error::MassNotPositiveDefinite)?;
        let inv = chol.inverse();
        let is_diag = (0..n).all(|i| (0..n).all(|j| i == j || m[i * n + j] == 0.0));
        if is_diag {
            return Self::diagonal((0..n).map(|i| m[i * n + i]).collect());
        }
        Ok(Self {
            n,
            storage: Storage::Dense {
                inv: inv.transpose().as_slice().to_vec(),
                m,
            },
        })
    }

    /// Dimension.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Entry (i, j), or None outside the matrix.
    pub fn get(&self, i: usize, j: usize) -> Option<f64> {
        if i >= self.n || j >= self.n {
            return None;
        }
        Some(match &self.storage {
            Storage::Diagonal { d, .. } => {
                if i == j {
                    d[i]
                } else {
                    0.0
                }
            }
            Storage::Dense { m, .. } => m[i * self.n + j],
        })
    }

    /// The diagonal, if M is diagonal.
    pub fn diagonal_entries(&self) -> Option<&[f64]> {
        match &self.storage {
            Storage::Diagonal { d, .. } => Some(d),
            Storage::Dense { .. } => None,
        }
    }

    /// The row-major entries of a dense (not diagonal) M.
    pub(crate) fn dense_entries(&self) -> Option<&[f64]> {
        match &self.storage {
            Storage::Diagonal { .. } => None,
            Storage::Dense { m, .. } => Some(m),
        }
    }

    /// out = M x. `x` and `out` have length [`MassMatrix::dim`]; with other lengths only the
    /// leading entries that fit are computed (no panic).
    pub fn apply(&self, x: &[f64], out: &mut [f64]) {
        match &self.storage {
            Storage::Diagonal { d, .. } => out.iter_mut().zip(x).zip(d).for_each(|((o, x), d)| *o = d * x),
            Storage::Dense { m, .. } => matvec(m, self.n, x, out),
        }
    }

    /// out = M⁻¹ x. Lengths as for [`MassMatrix::apply`].
    #[inline]
    pub fn solve(&self, x: &[f64], out: &mut [f64]) {
        match &self.storage {
            Storage::Diagonal { identity: true, .. } if x.len() == out.len() => out.copy_from_slice(x),
            Storage::Diagonal { identity: true, .. } => out.iter_mut().zip(x).for_each(|(o, x)| *o = *x),
            Storage::Diagonal { inv, .. } => out.iter_mut().zip(x).zip(inv).for_each(|((o, x), d)| *o = x * d),
            Storage::Dense { inv, .. } => matvec(inv, self.n, x, out),
        }
    }

    /// Whether M is the identity.
    pub fn is_identity(&self) -> bool {
        matches!(self.storage, Storage::Diagonal { identity: true, .. })
    }
}

/// out = A x for the row-major n×n matrix `a`.
fn matvec(a: &[f64], n: usize, x: &[f64], out: &mut [f64]) {
    if n == 0 {
        return;
    }
    for (o, row) in out.iter_mut().zip(a.chunks_exact(n)) {
        *o = row.iter().zip(x).map(|(a, x)| a * x).sum();
    }
}
