//! One Newton step of the interior-point iteration: the KKT matrix, banded over the elements'
//! unknowns and bordered by the free final time, factorised once and solved by block
//! elimination (two banded solves), so a step costs O(N).
//!
//! [A b; bᵀ d] (x, τ) = (r, ρ): A y = b and A x₁ = r, then τ = (ρ − bᵀx₁)/(d − bᵀy) and
//! x = x₁ − τ y.

use crate::error::Result;
use crate::solve::BandMatrix;

/// Solves the bordered system with `band` factorised; `col`, `diag` the border (ignored when
/// `free` is false). Returns τ (0 without a border); `rhs` becomes x. `None` if the Schur
/// complement of the border vanishes.
pub(super) fn bordered_solve(
    band: &BandMatrix,
    free: bool,
    col: &[f64],
    diag: f64,
    rhs: &mut [f64],
    rho: f64,
) -> Result<Option<f64>> {
    band.solve(rhs)?;
    if !free {
        return Ok(Some(0.0));
    }
    let mut y = col.to_vec();
    band.solve(&mut y)?;
    let schur = diag - dot(col, &y);
    if schur == 0.0 || !schur.is_finite() {
        return Ok(None);
    }
    let tau = (rho - dot(col, rhs)) / schur;
    rhs.iter_mut().zip(&y).for_each(|(x, y)| *x -= tau * y);
    Ok(Some(tau))
}

/// Σ a_i b_i.
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
