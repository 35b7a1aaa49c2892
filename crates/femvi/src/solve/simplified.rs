//! Simplified Newton iteration: the Jacobian is factorised once and kept, each iteration
//! costs one residual and one matrix-vector product with the kept inverse (Hairer, Wanner,
//! *Solving ODEs II*, §IV.8, the iteration of RADAU5). Its convergence is linear with rate θ,
//! estimated as θ_k = ‖δ_k‖/‖δ_{k−1}‖. It stops when the estimated error θ/(1−θ)·‖δ_k‖ has met
//! tol·scale (at the first iteration, which has no θ yet, ‖δ_1‖ stands for the error) and the
//! correction just applied, ‖δ_k‖ itself, is at most the round-off of the unknowns, ε·max|x|:
//! the iterate is then off by about θ·‖δ_k‖, far below round-off, as full Newton's last
//! iterate is after a quadratically convergent step. Stopping on the estimated error instead
//! (θ/(1−θ)·‖δ‖ ≤ ε·max|x|) left errors of about one round-off unit of the same sign every
//! step, and accepting the tolerance when the iteration budget ran out left errors of 40
//! units on the slow steps: both drifted the conserved quantities of long runs (issue 15,
//! `tests/adaptive_drift.rs`). It also stops, once the tolerance is met, when the corrections
//! stop decreasing (round-off noise). It gives up, for the caller to refresh the Jacobian or
//! fall back to full Newton, when θ > [`THETA_SLOW`] or when the iterations the estimated θ
//! predicts for the corrections to reach round-off would pass the budget. Used by the step of
//! general Lagrangians (`step/newton_step.rs`).

pub use super::frozen::FrozenJacobian;
use crate::error::StepFailure;

/// The contraction θ above which the iteration is abandoned (refresh the Jacobian).
pub const THETA_SLOW: f64 = 0.5;

/// Corrections below this many round-off units of the unknowns are left out of the reported
/// θ (their ratios are noise).
const NOISE: f64 = 100.0;

/// How a simplified Newton iteration ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Simplified {
    /// Converged: the caller's last residual evaluation was at the returned x, or at the
    /// iterate one correction before it when that correction was below the round-off of x
    /// (see [`simplified_newton`]).
    Converged {
        /// Corrections applied, each after a residual evaluation.
        iterations: usize,
        /// The largest contraction estimate met while the corrections were above round-off
        /// (0 if there was none).
        theta: f64,
    },
    /// Too slow or diverging (θ > [`THETA_SLOW`], or the budget would be passed); x is the
    /// last iterate that did not increase the correction.
    Slow {
        /// Iterations spent.
        iterations: usize,
    },
    /// A non-finite residual or correction, or no factorisation.
    Failed {
        /// Iterations spent.
        iterations: usize,
        /// What went wrong.
        failure: StepFailure,
    },
}

/// Whether `dn`, multiplied by θ = `t` at most `left` times, gets to `floor` or below.
fn reaches(dn: f64, t: f64, floor: f64, left: usize) -> bool {
    let mut e = dn;
    for _ in 0..left {
        if e <= floor {
            break;
        }
        e *= t;
    }
    e <= floor
}

/// Runs the simplified Newton iteration on r(x) = 0 from `x` with the factorisation held by
/// `frozen`: `residual(x, r)` evaluates the residual. At most `budget` iterations, and gives
/// up early when θ > [`THETA_SLOW`] or the iterations the estimated θ predicts would pass
/// `budget`. On convergence the last call of `residual` was at the returned x or, when the
/// iteration ended on a correction δ below the round-off of x (‖δ‖ ≤ ε·max|x|), at x − δ:
/// the residual at x would cost one more evaluation, a fifth to a quarter of a relativistic
/// Kepler step, to learn only that it is at round-off. A caller that takes other quantities
/// from that evaluation (the step's Δp) gets them at x − δ, off by their derivative times
/// δ: for Δp, (h L_qq + L_qv)·δ with δ ≤ ε·h|v|, a fraction hω of p's own round-off for a
/// step that resolves frequencies ω (long runs measured no drift from it: `step/newton_step.rs`).
///
/// # Example
///
/// ```
/// use femvi::solve::{simplified_newton, FrozenJacobian, Simplified};
/// // x² = 2 from x = 1.5 with the Jacobian 2·1.5 frozen: linear convergence to √2.
/// let mut frozen = FrozenJacobian::new(1);
/// frozen.jac[0] = 3.0;
/// assert!(frozen.factor());
/// let mut x = [1.5];
/// let out = simplified_newton(&mut x, 1e-14, 30, |_| 1.0, &mut frozen, |x, r| r[0] = x[0] * x[0] - 2.0);
/// assert!(matches!(out, Simplified::Converged { .. }));
/// assert!((x[0] - 2f64.sqrt()).abs() < 1e-15);
/// ```
#[inline]
pub fn simplified_newton<F, S>(
    x: &mut [f64],
    tol: f64,
    budget: usize,
    scale: S,
    frozen: &mut FrozenJacobian,
    mut residual: F,
) -> Simplified
where
    F: FnMut(&[f64], &mut [f64]),
    S: Fn(&[f64]) -> f64,
{
    if x.len() != frozen.dim() || !frozen.is_factored() {
        return Simplified::Failed {
            iterations: 0,
            failure: StepFailure::Singular,
        };
    }
    let mut previous: Option<f64> = None;
    let mut theta_max = 0.0f64;
    // Whether the estimated error has met the tolerance (then only round-off is sought).
    let mut met = false;
    for k in 1..=budget {
        residual(x, &mut frozen.r);
        if !frozen.r.iter().all(|v| v.is_finite()) {
            return Simplified::Failed {
                iterations: k - 1,
                failure: StepFailure::NonFinite,
            };
        }
        if frozen.r.iter().all(|&v| v == 0.0) {
            return Simplified::Converged {
                iterations: k - 1,
                theta: theta_max,
            };
        }
        if !frozen.correction() {
            return Simplified::Failed {
                iterations: k,
                failure: StepFailure::NonFinite,
            };
        }
        let dn = frozen.rhs.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let goal = tol * scale(x);
        let theta = previous.map(|p| dn / p);
        if let Some(t) = theta.filter(|&t| t >= THETA_SLOW) {
            if met {
                // The tolerance was met and the corrections stopped decreasing: round-off
                // noise. Keep x, where the last residual was evaluated.
                return Simplified::Converged {
                    iterations: k - 1,
                    theta: theta_max,
                };
            }
            if t >= 1.0 {
                // Diverging: keep the better iterate.
                return Simplified::Slow { iterations: k };
            }
        }
        for (xi, d) in x.iter_mut().zip(frozen.rhs.iter()) {
            *xi += d;
        }
        // The round-off of the unknowns: once the correction just applied is below it, the
        // new iterate is off by θ times that (see the module docs for why not the estimated
        // error).
        let floor = (f64::EPSILON * x.iter().fold(0.0f64, |m, v| m.max(v.abs()))).max(f64::MIN_POSITIVE);
        // The estimated error of the new iterate: θ/(1−θ)·‖δ‖ (at the first iteration, with
        // no θ yet, ‖δ‖ itself).
        let error = match theta {
            None => dn,
            Some(t) => {
                // The rate the caller keeps the Jacobian by: ratios of corrections near
                // round-off measure its noise, not the contraction, whichever of the two is
                // near it (with a guess close to the solution, the second correction often
                // is: counting it refreshed 225 Jacobians in 2 000 degree-4 steps, not 26).
                if dn > NOISE * floor && previous.is_some_and(|p| p > NOISE * floor) {
                    theta_max = theta_max.max(t);
                }
                t / (1.0 - t) * dn
            }
        };
        met |= error <= goal;
        if met && dn <= floor {
            // No evaluation at the new x: the one just made, a correction below round-off
            // away, serves the caller (see the function's docs).
            return Simplified::Converged {
                iterations: k,
                theta: theta_max,
            };
        }
        if let Some(t) = theta {
            // Whether the corrections reach round-off, shrinking by θ per iteration, within
            // the iterations left (by repeated products: ⌈ln(floor/‖δ‖)/ln θ⌉ took two
            // logarithms per iteration, 5 % of a relativistic Kepler step).
            if t > THETA_SLOW || !reaches(dn, t, floor, budget - k) {
                return Simplified::Slow { iterations: k };
            }
        }
        previous = Some(dn);
    }
    Simplified::Slow { iterations: budget }
}
