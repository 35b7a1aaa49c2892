//! Newton's method on the equations of a constrained boundary value problem
//! (`bvp_assembly.rs`) with the exact banded Jacobian, factorised by [`BandMatrix`]'s banded
//! LU (O(N) per iteration), and a backtracking line search on the squared residual (the
//! Armijo condition with 10⁻⁴, halving down to 1/1024), as [`crate::bvp`] does for the
//! unconstrained problem. The iteration stops when a correction is below the tolerance
//! relative to the size of the unknowns and the boundary values.

use super::bvp_assembly::Assembly;
use super::Constraints;
use crate::error::StepFailure;
use crate::lagrangian::Lagrangian;
use crate::solve::{BandMatrix, NewtonFailure};

/// max |x_i|, NaN if any entry is NaN.
pub(super) fn inf_norm(x: &[f64]) -> f64 {
    x.iter()
        .fold(0.0f64, |m, v| if v.is_nan() { f64::NAN } else { m.max(v.abs()) })
}

/// Solves the equations for the unknowns `x` (from their value on entry), with tolerance
/// `tol` on the relative correction and at most `max_iterations` iterations; `floor` is the
/// smallest scale of the unknowns (the size of the boundary values). Returns the iterations.
pub(super) fn newton<L: Lagrangian, C: Constraints>(
    asm: &mut Assembly<'_, L, C>,
    band: &mut BandMatrix,
    x: &mut [f64],
    tol: f64,
    max_iterations: usize,
    floor: f64,
    jacobian_norm: &mut f64,
) -> Result<usize, NewtonFailure> {
    let len = x.len();
    if len == 0 {
        return Ok(0);
    }
    let fail = |failure, residual, iterations| NewtonFailure {
        failure,
        residual,
        iterations,
    };
    let (mut r, mut r_trial, mut dx, mut trial) = (vec![0.0; len], vec![0.0; len], vec![0.0; len], vec![0.0; len]);
    for it in 1..=max_iterations {
        asm.eval(x, &mut r, Some(band));
        // ‖J‖∞ before the factorisation, for the scaled residual the solution reports.
        *jacobian_norm = crate::bvp::band_inf_norm(band, band.bandwidths().0.max(band.bandwidths().1));
        let rnorm = inf_norm(&r);
        if !rnorm.is_finite() {
            return Err(fail(StepFailure::NonFinite, rnorm, it));
        }
        if rnorm == 0.0 {
            return Ok(it);
        }
        if !band.factor() {
            return Err(fail(StepFailure::Singular, rnorm, it));
        }
        dx.iter_mut().zip(&r).for_each(|(d, v)| *d = -v);
        if band.solve(&mut dx).is_err() || !inf_norm(&dx).is_finite() {
            return Err(fail(StepFailure::NonFinite, rnorm, it));
        }
        let size = inf_norm(&dx) / inf_norm(x).max(floor).max(f64::MIN_POSITIVE);
        let small = size <= tol;
        let r2: f64 = r.iter().map(|v| v * v).sum();
        let mut lambda = 1.0;
        loop {
            trial
                .iter_mut()
                .zip(x.iter().zip(&dx))
                .for_each(|(t, (a, d))| *t = a + lambda * d);
            asm.eval(&trial, &mut r_trial, None);
            let t2: f64 = r_trial.iter().map(|v| v * v).sum();
            if small || (t2.is_finite() && t2 <= (1.0 - 1e-4 * lambda) * r2) {
                break;
            }
            lambda *= 0.5;
            if lambda < 1.0 / 1024.0 {
                if size > 1e3 * tol {
                    return Err(fail(StepFailure::Stalled, rnorm, it));
                }
                // Near convergence round-off may keep the residual from decreasing.
                lambda = 1.0;
                trial
                    .iter_mut()
                    .zip(x.iter().zip(&dx))
                    .for_each(|(t, (a, d))| *t = a + d);
                break;
            }
        }
        x.copy_from_slice(&trial);
        if small || lambda * size <= tol {
            return Ok(it);
        }
    }
    asm.eval(x, &mut r, None);
    Err(fail(StepFailure::NotConverged, inf_norm(&r), max_iterations))
}
