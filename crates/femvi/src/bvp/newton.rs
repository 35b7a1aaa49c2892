//! Newton's method on ∂S = 0 for the unknowns of a boundary value problem: each iteration
//! assembles the residual and the banded Jacobian, factorises it (banded LU, O(N) for N
//! elements) and takes the correction with a backtracking line search on |∂S|² (the Armijo
//! condition with 10⁻⁴, halving the step down to 1/1024). Failures are typed
//! [`StepError`]s: a singular Jacobian, non-finite values, a stalled line search, a folded
//! mesh, or the iteration cap.
//!
//! **Convergence.** The iteration stops when a correction is at most `tolerance` relative to
//! the largest |Q| (the correction is taken). With N elements the residual cannot fall below
//! its round-off floor, which grows like N: the gradient terms ∂L/∂v·φ'/h of an element are
//! differences of nodal values divided by h, so their rounding is about ε·|Q|·‖J‖ with
//! ‖J‖ ~ 1/h (pendulum, degree 2: a floor of 2.3e-13 at 10⁴ elements, 2.8e-12 at 10⁵,
//! 2.8e-11 at 10⁶), and the corrections computed from that noise stop shrinking before they
//! reach the tolerance. So the iteration also stops, at the iterate where it stands, when the
//! **scaled residual** η = ‖∂S‖∞ / (‖J‖∞ · max|Q|) is at most `tolerance` — the residual is
//! no larger than a relative change `tolerance` of the unknowns would make it, a test that
//! does not depend on N (measured η ≈ 1e-16 from 10³ to 10⁷ elements) — and either the
//! correction did not shrink to half of the previous one or the line search fails. Above
//! 10³·tolerance (a correction a failed search would not take) the search does not backtrack
//! at that point: at round-off shorter steps do not decrease the residual either. While
//! Newton still converges quadratically none of this happens, so problems that converged
//! before take the same iterations and end bit for bit where they did (golden test).
//! The moving mesh does not use this test: its time equations depend on the steps only at
//! O(h^(2s)), so their rows are far smaller than ‖J‖∞ and a normwise η would call a nearly
//! singular, unsolved problem converged (degree 2 stalls, as before, with a typed error).

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

/// max_i Σ_j |J_ij| of a banded matrix before factorisation, NaN if an entry is NaN.
pub(crate) fn band_inf_norm(band: &BandMatrix, bw: usize) -> f64 {
    (0..band.size())
        .map(|i| {
            let j1 = (i + bw).min(band.size() - 1);
            (i.saturating_sub(bw)..=j1).map(|j| band.get(i, j).abs()).sum::<f64>()
        })
        .fold(0.0f64, |m, v| if v.is_nan() { f64::NAN } else { m.max(v) })
}

/// How a Newton iteration ended.
#[derive(Debug, Clone, Copy)]
pub(super) struct Converged {
    /// Iterations (Jacobian factorisations) taken.
    pub(super) iterations: usize,
    /// ‖J‖∞ of the last Jacobian assembled (1 if there were no unknowns), for the scaled
    /// residual ‖∂S‖∞ / (‖J‖∞ · scale) at the solution.
    pub(super) jacobian_norm: f64,
}

/// Newton's method with a backtracking line search on ∂S = 0 over the unknowns `x`, with the
/// banded Jacobian. `rel(x, dx)` is the size of a correction relative to the unknowns and
/// `scale(x)` the size of the unknowns for the scaled residual; see the module doc for the
/// stopping rules (with `round_off_stop` false, the corrections' rule alone).
pub(super) fn newton<L: Lagrangian>(
    asm: &mut Assembly<'_, L>,
    x: &mut Vec<f64>,
    options: BvpOptions,
    rel: impl Fn(&[f64], &[f64]) -> f64,
    scale: impl Fn(&[f64]) -> f64,
    round_off_stop: bool,
) -> Result<Converged> {
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
        jacobian_norm: 1.0,
    };
    let mut iterations = 0;
    let mut last_size = f64::INFINITY;
    loop {
        if unknowns == 0 {
            return Ok(it.converged(iterations));
        }
        iterations += 1;
        let Some(rnorm) = it.direction(x, iterations)? else {
            return Ok(it.converged(iterations));
        };
        let size = rel(x, &it.dx);
        let small = size <= options.tolerance;
        // At round-off: the residual is no larger than a relative change `tolerance` of the
        // unknowns would make it.
        let floor = round_off_stop && rnorm <= options.tolerance * it.jacobian_norm * scale(x);
        if !small && floor && size > 0.5 * last_size {
            return Ok(it.converged(iterations));
        }
        last_size = size;
        let lambda = match it.line_search(x, size, rnorm, iterations, floor) {
            Ok(lambda) => lambda,
            Err(_) if floor => return Ok(it.converged(iterations)),
            Err(e) => return Err(e),
        };
        std::mem::swap(x, &mut it.trial);
        if small || lambda * size <= options.tolerance {
            return Ok(it.converged(iterations));
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
    /// ‖J‖∞ of the last Jacobian assembled.
    jacobian_norm: f64,
}

impl<L: Lagrangian> Newton<'_, '_, L> {
    /// The outcome after `iterations` iterations.
    fn converged(&self, iterations: usize) -> Converged {
        Converged {
            iterations,
            jacobian_norm: self.jacobian_norm,
        }
    }

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
        self.jacobian_norm = band_inf_norm(&self.band, self.asm.layout.bandwidth());
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
    /// folded mesh never is); leaves x + λ dx in `trial` and returns λ. `at_floor`: the
    /// residual is at round-off (see the module doc), so a full step that does not decrease
    /// it ends the search at once (the stalled error, which the caller takes as converged).
    fn line_search(&mut self, x: &[f64], size: f64, rnorm: f64, iterations: usize, at_floor: bool) -> Result<f64> {
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
            if at_floor && last_fold.is_none() && size > 1e3 * self.options.tolerance {
                // The residual is at round-off: shorter steps would not decrease it either
                // (and a correction this large is not taken below).
                return Err(self.fail(StepFailure::Stalled, rnorm, iterations, 0));
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
