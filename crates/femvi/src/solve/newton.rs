//! Dense Newton's method with a backtracking (Armijo) line search on ½‖r‖², used for the
//! step equations (2.40)–(2.42) of general Lagrangians and for the start from (q0, q1).
//! The caller evaluates the residual and Jacobian into buffers owned by [`DenseNewtonWork`].

use crate::error::{invalid, StepFailure};
use nalgebra::{DMatrix, DVector};

/// Buffers of a dense Newton iteration of a fixed size.
#[derive(Debug, Clone)]
pub struct DenseNewtonWork {
    /// Residual at the current iterate.
    pub r: Vec<f64>,
    /// Jacobian, row-major.
    pub jac: Vec<f64>,
    trial: Vec<f64>,
    r_trial: Vec<f64>,
    mat: DMatrix<f64>,
    rhs: DVector<f64>,
}

impl DenseNewtonWork {
    /// Buffers for `dim` unknowns (dim² numbers for the Jacobian, twice: like any allocation,
    /// this aborts if they do not fit in memory; [`DenseNewtonWork::try_new`] checks first).
    pub fn new(dim: usize) -> Self {
        Self {
            r: vec![0.0; dim],
            jac: vec![0.0; dim * dim],
            trial: vec![0.0; dim],
            r_trial: vec![0.0; dim],
            mat: DMatrix::zeros(dim, dim),
            rhs: DVector::zeros(dim),
        }
    }

    /// Buffers for `dim` unknowns, if the two dim × dim matrices can be allocated.
    ///
    /// # Errors
    /// dim² overflows or cannot be reserved.
    pub fn try_new(dim: usize) -> crate::Result<Self> {
        let too_big = || {
            invalid(
                "Newton unknowns",
                format!("{dim} x {dim} Jacobians do not fit in memory"),
            )
        };
        let entries = dim.checked_mul(dim).ok_or_else(too_big)?;
        let mut probe: Vec<f64> = Vec::new();
        probe
            .try_reserve_exact(entries.checked_mul(2).ok_or_else(too_big)?)
            .map_err(|_| too_big())?;
        drop(probe);
        Ok(Self::new(dim))
    }

    /// The Newton correction −J⁻¹ r into `rhs`; false if J is singular or the correction is
    /// not finite.
    fn correction(&mut self, dim: usize) -> bool {
        for i in 0..dim {
            self.rhs[i] = -self.r[i];
            for j in 0..dim {
                self.mat[(i, j)] = self.jac[i * dim + j];
            }
        }
        let lu = self.mat.clone().lu();
        lu.solve_mut(&mut self.rhs) && self.rhs.iter().all(|v| v.is_finite())
    }

    /// Whether the buffers are for `dim` unknowns.
    fn fits(&self, dim: usize) -> bool {
        let square = dim.checked_mul(dim);
        self.r.len() == dim
            && self.trial.len() == dim
            && self.r_trial.len() == dim
            && self.rhs.len() == dim
            && Some(self.jac.len()) == square
            && self.mat.shape() == (dim, dim)
    }
}

/// How a converged Newton solve went.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonReport {
    /// Iterations (Jacobian factorisations).
    pub iterations: usize,
    /// Infinity norm of the last correction.
    pub last_increment: f64,
}

/// How a Newton solve failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonFailure {
    /// What went wrong.
    pub failure: StepFailure,
    /// Infinity norm of the residual at the last iterate.
    pub residual: f64,
    /// Iterations spent.
    pub iterations: usize,
}

fn inf_norm(x: &[f64]) -> f64 {
    x.iter()
        .fold(0.0f64, |m, v| if v.is_nan() { f64::NAN } else { m.max(v.abs()) })
}

/// Solves r(x) = 0 from the guess in `x`. `eval(x, r, jac)` writes the residual into `r` and,
/// when `jac` is `Some`, the row-major Jacobian into it. Converged when the Newton correction
/// is at most `tol · scale(x)` in the infinity norm. `work` made for another number of
/// unknowns than `x.len()` is made again for it.
///
/// # Errors
/// [`NewtonFailure`] on a singular Jacobian, a non-finite value, a line search that cannot
/// decrease the residual, or the iteration cap.
pub fn newton_dense<F, S>(
    x: &mut [f64],
    tol: f64,
    max_iterations: usize,
    scale: S,
    work: &mut DenseNewtonWork,
    mut eval: F,
) -> Result<NewtonReport, NewtonFailure>
where
    F: FnMut(&[f64], &mut [f64], Option<&mut [f64]>),
    S: Fn(&[f64]) -> f64,
{
    let dim = x.len();
    let fail = |failure, residual, iterations| NewtonFailure {
        failure,
        residual,
        iterations,
    };
    if dim == 0 {
        return Ok(NewtonReport {
            iterations: 0,
            last_increment: 0.0,
        });
    }
    if !work.fits(dim) {
        *work = DenseNewtonWork::new(dim);
    }
    eval(x, &mut work.r, Some(&mut work.jac));
    for it in 1..=max_iterations {
        let rnorm = inf_norm(&work.r);
        if !rnorm.is_finite() || !work.jac.iter().all(|v| v.is_finite()) {
            return Err(fail(StepFailure::NonFinite, rnorm, it - 1));
        }
        if rnorm == 0.0 {
            return Ok(NewtonReport {
                iterations: it - 1,
                last_increment: 0.0,
            });
        }
        if !work.correction(dim) {
            return Err(fail(StepFailure::Singular, rnorm, it));
        }
        let dnorm = work.rhs.amax();
        let sc = scale(x);
        let converged_step = dnorm <= tol * sc;
        let near = dnorm <= 1e3 * tol * sc;
        // Whether `r_trial` holds the residual at the accepted trial point.
        let Some((lambda, trial_evaluated)) = line_search(x, work, &mut eval, converged_step, near) else {
            return Err(fail(StepFailure::Stalled, rnorm, it));
        };
        x.copy_from_slice(&work.trial);
        if converged_step || lambda * dnorm <= tol * sc {
            // The caller reads what the last evaluation left (e.g. the derivatives at the
            // quadrature points): it must be at x, which the line search already evaluated.
            if trial_evaluated {
                std::mem::swap(&mut work.r, &mut work.r_trial);
            } else {
                eval(x, &mut work.r, None);
            }
            return Ok(NewtonReport {
                iterations: it,
                last_increment: lambda * dnorm,
            });
        }
        eval(x, &mut work.r, Some(&mut work.jac));
    }
    Err(fail(StepFailure::NotConverged, inf_norm(&work.r), max_iterations))
}

/// Backtracking on ½‖r‖² (2-norm) from `x` along the correction in `work.rhs`, leaving the
/// accepted point in `work.trial`: returns the step λ and whether `work.r_trial` holds the
/// residual there, or None if the residual cannot be decreased. The full step is taken at once
/// when `full` (the correction is at round-off level, where the residual cannot decrease any
/// more), and after ten halvings when `near` (stuck at round-off just above the tolerance).
fn line_search<F>(x: &[f64], work: &mut DenseNewtonWork, eval: &mut F, full: bool, near: bool) -> Option<(f64, bool)>
where
    F: FnMut(&[f64], &mut [f64], Option<&mut [f64]>),
{
    let dim = x.len();
    let r2: f64 = work.r.iter().map(|v| v * v).sum();
    let mut lambda = 1.0;
    loop {
        for i in 0..dim {
            work.trial[i] = x[i] + lambda * work.rhs[i];
        }
        eval(&work.trial, &mut work.r_trial, None);
        let t2: f64 = work.r_trial.iter().map(|v| v * v).sum();
        if full || (t2.is_finite() && t2 <= (1.0 - 1e-4 * lambda) * r2) {
            return Some((lambda, true));
        }
        lambda *= 0.5;
        if lambda < 1.0 / 1024.0 {
            if !near {
                return None;
            }
            for i in 0..dim {
                work.trial[i] = x[i] + work.rhs[i];
            }
            return Some((1.0, false));
        }
    }
}
