//! Newton's method on ∂S = 0 for the unknowns of a boundary value problem: each iteration
//! assembles the residual and the banded Jacobian, factorises it (banded LU, O(N) for N
//! elements) and takes the correction with a backtracking line search on |∂S|² (the Armijo
//! condition with 10⁻⁴, halving the step down to 1/1024). Failures are typed
//! [`StepError`]s: a singular Jacobian, non-finite values, a stalled line search, a folded
//! mesh, or the iteration cap.

use super::eval::Assembly;
use super::BvpOptions;
use crate::error::{Error, Result, StepError, StepFailure};
use crate::lagrangian::Lagrangian;
use crate::solve::BandMatrix;

/// max |x_i|, NaN if any entry is NaN.
pub(super) fn inf_norm(x: &[f64]) -> f64 {
    x.iter()
        .fold(0.0f64, |m, v| if v.is_nan() { f64::NAN } else { m.max(v.abs()) })
}

/// Newton's method with a backtracking line search on ∂S = 0 over the unknowns `x`, with the
/// banded Jacobian. `rel(x, dx)` is the size of a correction relative to the unknowns. Returns
/// the iterations taken.
pub(super) fn newton<L: Lagrangian>(
    asm: &mut Assembly<'_, L>,
    x: &mut Vec<f64>,
    options: BvpOptions,
    rel: impl Fn(&[f64], &[f64]) -> f64,
) -> Result<usize> {
    let unknowns = x.len();
    let bw = asm.layout.bandwidth();
    let mut it = Newton {
        asm,
        options,
        r: vec![0.0; unknowns],
        r_trial: vec![0.0; unknowns],
        trial: x.clone(),
        dx: vec![0.0; unknowns],
        band: BandMatrix::zeros(unknowns.max(1), bw, bw)?,
    };
    let mut iterations = 0;
    if unknowns == 0 {
        return Ok(0);
    }
    loop {
        iterations += 1;
        let Some(rnorm) = it.direction(x, iterations)? else {
            return Ok(iterations);
        };
        let size = rel(x, &it.dx);
        let small = size <= options.tolerance;
        let lambda = it.line_search(x, size, rnorm, iterations)?;
        std::mem::swap(x, &mut it.trial);
        if small || lambda * size <= options.tolerance {
            return Ok(iterations);
        }
        if iterations >= options.max_iterations {
            let residual = match it.asm.eval(x, &mut it.r, None) {
                Ok(_) => inf_norm(&it.r),
                Err(_) => f64::NAN,
            };
            return Err(it.fail(StepFailure::NotConverged, residual, iterations, 0));
        }
    }
}

/// The state of one Newton iteration: the residual at the iterate and at a trial point, the
/// correction and the Jacobian.
struct Newton<'s, 'a, L: Lagrangian> {
    asm: &'s mut Assembly<'a, L>,
    options: BvpOptions,
    r: Vec<f64>,
    r_trial: Vec<f64>,
    trial: Vec<f64>,
    dx: Vec<f64>,
    band: BandMatrix,
}

impl<L: Lagrangian> Newton<'_, '_, L> {
    /// The typed error, reported at element `step`'s start on the uniform mesh.
    fn fail(&self, failure: StepFailure, residual: f64, iterations: usize, step: usize) -> Error {
        let (t0, h) = (self.asm.bv.t0, self.asm.bv.step());
        Error::Step(StepError {
            step,
            t: t0 + step as f64 * h,
            residual,
            iterations,
            failure,
        })
    }

    /// Assembles the residual and the Jacobian at `x` and solves for the Newton correction
    /// `dx`. Returns the residual's norm, or None if the residual is exactly zero.
    fn direction(&mut self, x: &[f64], iterations: usize) -> Result<Option<f64>> {
        if let Err(k) = self.asm.eval(x, &mut self.r, Some(&mut self.band)) {
            return Err(self.fail(StepFailure::MeshFolded, f64::NAN, iterations, k));
        }
        let rnorm = inf_norm(&self.r);
        if !rnorm.is_finite() {
            return Err(self.fail(StepFailure::NonFinite, rnorm, iterations, 0));
        }
        if rnorm == 0.0 {
            return Ok(None);
        }
        if !self.band.factor() {
            return Err(self.fail(StepFailure::Singular, rnorm, iterations, 0));
        }
        self.dx.iter_mut().zip(&self.r).for_each(|(d, v)| *d = -v);
        self.band.solve(&mut self.dx)?;
        if !inf_norm(&self.dx).is_finite() {
            return Err(self.fail(StepFailure::NonFinite, rnorm, iterations, 0));
        }
        Ok(Some(rnorm))
    }

    /// Backtracks from the full correction `dx` (of relative size `size`) until |∂S|²
    /// decreases enough (any step is taken once the correction is below the tolerance, but a
    /// folded mesh never is); leaves x + λ dx in `trial` and returns λ.
    fn line_search(&mut self, x: &[f64], size: f64, rnorm: f64, iterations: usize) -> Result<f64> {
        let small = size <= self.options.tolerance;
        let r2: f64 = self.r.iter().map(|v| v * v).sum();
        let mut lambda = 1.0;
        let mut last_fold = None;
        loop {
            self.trial
                .iter_mut()
                .zip(x.iter().zip(&self.dx))
                .for_each(|(t, (a, d))| *t = a + lambda * d);
            let ok = match self.asm.eval(&self.trial, &mut self.r_trial, None) {
                Ok(_) => {
                    let t2: f64 = self.r_trial.iter().map(|v| v * v).sum();
                    small || (t2.is_finite() && t2 <= (1.0 - 1e-4 * lambda) * r2)
                }
                Err(k) => {
                    last_fold = Some(k);
                    false
                }
            };
            if ok {
                return Ok(lambda);
            }
            lambda *= 0.5;
            if lambda < 1.0 / 1024.0 {
                if size <= 1e3 * self.options.tolerance && last_fold.is_none() {
                    self.trial
                        .iter_mut()
                        .zip(x.iter().zip(&self.dx))
                        .for_each(|(t, (a, d))| *t = a + d);
                    return Ok(1.0);
                }
                return Err(match last_fold {
                    Some(k) => self.fail(StepFailure::MeshFolded, rnorm, iterations, k),
                    None => self.fail(StepFailure::Stalled, rnorm, iterations, 0),
                });
            }
        }
    }
}
