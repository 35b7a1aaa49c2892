//! The first multipliers, by least squares (as IPOPT starts them: Wächter and Biegler, Math.
//! Program. 106, 2006, §3.6): with the multiplier rows (Λ, and with constraints κ and the
//! hidden constraint's) at zero, the Lagrangian's gradient in the primal unknowns is that of
//! the objective, ∇J − z_l + z_u; the multipliers that cancel it best,
//! Λ = argmin ‖∇J − z_l + z_u + AᵀΛ‖₂ with A the Jacobian of the discrete equations, solve
//! the augmented system [I Aᵀ; A 0] [w; Λ] = [−(∇J − z_l + z_u); 0]. It is the KKT matrix
//! with its primal block replaced by the identity, so it is banded like it and costs one
//! banded factorisation. The final time is held (its row and column left out).
//!
//! Zero multipliers tell the first Newton steps that the discrete equations cost nothing to
//! violate, and the merit function's penalty ν starts from them; least-squares multipliers
//! start both from the adjoint's scale. Multipliers larger than 10³ are not used (IPOPT's
//! `constr_mult_init_max`): the least-squares fit of a poor guess can be far from the optimum's.

use super::assemble::{Border, Model};
use super::iterate::{Bound, Iterate};
use super::system::Controls;
use crate::error::Result;
use crate::lagrangian::Lagrangian;
use crate::solve::BandMatrix;

/// The largest least-squares multiplier that is used.
const LARGEST: f64 = 1e3;

/// Sets the multiplier rows `lambda_rows` of `it` to their least-squares values, or leaves
/// them as they are where the augmented system is singular or its solution is not finite or
/// too large. Returns whether they were set.
/// `band`, `grad` and `border` are the solver's, used as work space (their contents are
/// overwritten).
pub(super) fn least_squares<L: Lagrangian + ?Sized, C: Controls>(
    model: &Model<'_, L, C>,
    band: &mut BandMatrix,
    grad: &mut [f64],
    border: &mut Border,
    it: &mut Iterate,
    bounds: &[Bound],
    lambda_rows: &[usize],
) -> Result<bool> {
    let size = model.layout.size();
    let bw = model.layout.bandwidth();
    let mut x = it.x.clone();
    lambda_rows.iter().for_each(|&i| x[i] = 0.0);
    model.assemble(&x, it.t1, band, grad, border)?;
    let mut is_lambda = vec![false; size];
    lambda_rows.iter().for_each(|&i| is_lambda[i] = true);
    for i in (0..size).filter(|&i| !is_lambda[i]) {
        for j in i.saturating_sub(bw)..(i + bw + 1).min(size) {
            if !is_lambda[j] {
                let target = if i == j { 1.0 } else { 0.0 };
                band.add(i, j, target - band.get(i, j))?;
            }
        }
    }
    let mut d: Vec<f64> = (0..size).map(|i| if is_lambda[i] { 0.0 } else { -grad[i] }).collect();
    for (k, b) in bounds.iter().enumerate() {
        if let Some(i) = b.var {
            d[i] += it.zl[k] - it.zu[k];
        }
    }
    if !band.factor() {
        return Ok(false);
    }
    band.solve(&mut d)?;
    // A NaN anywhere makes the fit unusable (f64::max would skip it).
    let usable = lambda_rows.iter().all(|&i| d[i].abs() <= LARGEST);
    if !usable {
        return Ok(false);
    }
    lambda_rows.iter().for_each(|&i| it.x[i] = d[i]);
    Ok(true)
}
