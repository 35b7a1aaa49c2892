//! The one-dimensional search of the energy mode (paper §3): the step h_k with
//! g(h) = E_k⁻(w_k(h)) − E_k = 0, where each evaluation of g solves the element's step
//! equations at that h. Secant iterations from h_{k−1} (trust region [h/2, 2h], clamped to
//! [min_step, max_step]) until a sign change brackets the root, then regula falsi (Illinois).
//! Shared by the conservative energy mode (`energy.rs`) and the forced one
//! ([`crate::forces`], where g gains the element's share of the discrete work); the caller
//! supplies g as a closure, so both searches are the same arithmetic.

use super::energy::EnergyOptions;
use crate::error::{StepError, StepFailure};

/// Relative size of |g| at which the search stops; the residual left is at round-off level.
pub(crate) const ACCEPT: f64 = 0.25 * f64::EPSILON;
/// Relative size of |g| above which a step counts as having no admissible root. For degree
/// s the discrete energy depends on h only at O(h^{2s}), so for s ≥ 3 g is nearly flat and
/// its round-off noise hides the root: such steps are degenerate, not accepted loosely.
pub(crate) const REJECT: f64 = 64.0 * f64::EPSILON;

/// Finds h in the bounds of `opts` with g(h) = 0, starting from `h_prev`. `gap(h)` solves the
/// step at h and returns (g, the element's carried change, magnitude of the energy terms), or
/// None if the solve fails at h; the last call of `gap` is at the returned h, so the caller's
/// solve is left there. Returns (h, change, |g| / |target|); a step without an admissible root
/// is a [`StepFailure::NoAdmissibleStep`] naming `(step, t)`.
pub(crate) fn search_step(
    h_prev: f64,
    target: f64,
    opts: EnergyOptions,
    (step, t): (usize, f64),
    mut gap: impl FnMut(f64) -> Option<(f64, f64, f64)>,
) -> Result<(f64, f64, f64), StepError> {
    let (lo, hi) = (opts.min_step, opts.max_step);
    let fail = |residual: f64, iterations: usize| StepError {
        step,
        t,
        residual,
        iterations,
        failure: StepFailure::NoAdmissibleStep,
    };
    let mut evals = 0;
    // First point: the previous step.
    let mut h0 = h_prev.clamp(lo, hi);
    let Some((mut g0, e0, mag)) = gap(h0) else {
        return Err(fail(f64::NAN, 1));
    };
    evals += 1;
    let tol = ACCEPT * mag;
    let scale = target.abs().max(f64::MIN_POSITIVE);
    if g0.abs() <= tol {
        return Ok((h0, e0, g0.abs() / scale));
    }
    let mut h1 = if h0 * 1.001 <= hi { h0 * 1.001 } else { h0 * 0.999 };
    let (mut g1, mut e1) = match gap(h1) {
        Some((g, e, _)) => (g, e),
        None => return Err(fail(g0.abs() / scale, 2)),
    };
    evals += 1;
    // Secant phase, trust region [h/2, 2h], until a sign change or convergence.
    while g0.signum() == g1.signum() {
        if g1.abs() <= tol {
            return Ok((h1, e1, g1.abs() / scale));
        }
        let slope = (g1 - g0) / (h1 - h0);
        let mut h2 = if slope != 0.0 && slope.is_finite() {
            h1 - g1 / slope
        } else {
            f64::NAN
        };
        if !h2.is_finite() {
            // Flat: the energy does not depend on h here (c₂ ≈ 0).
            h2 = if g1.abs() < g0.abs() {
                2.0 * h1 - h0
            } else {
                2.0 * h0 - h1
            };
        }
        h2 = h2.clamp(0.5 * h1, 2.0 * h1).clamp(lo, hi);
        if (h2 - h1).abs() <= 4.0 * f64::EPSILON * h1 || evals >= 60 {
            // Stuck at a bound or no progress: accept only a round-off-level residual.
            return if g1.abs() <= REJECT * mag {
                Ok((h1, e1, g1.abs() / scale))
            } else {
                Err(fail(g1.abs() / scale, evals))
            };
        }
        let Some((g2, e2, _)) = gap(h2) else {
            return Err(fail(g1.abs() / scale, evals));
        };
        evals += 1;
        (h0, g0) = (h1, g1);
        (h1, g1, e1) = (h2, g2, e2);
    }
    // Bracketed between h0 and h1: Illinois regula falsi.
    let (best_h, best_g) = illinois([(h0, g0), (h1, g1)], tol, &mut evals, &mut gap)
        .map_err(|(best_g, evals)| fail(best_g.abs() / scale, evals))?;
    if best_g.abs() > REJECT * mag {
        return Err(fail(best_g.abs() / scale, evals));
    }
    // Leave the state solved at the chosen step.
    let Some((g, e, _)) = gap(best_h) else {
        return Err(fail(best_g.abs() / scale, evals));
    };
    Ok((best_h, e, g.abs() / scale))
}

/// Regula falsi (Illinois) on g between two steps whose g have opposite signs; returns the
/// best (h, g) found, or (best g so far, evaluations) if a trial solve fails.
fn illinois(
    [(h0, g0), (h1, g1)]: [(f64, f64); 2],
    tol: f64,
    evals: &mut usize,
    gap: &mut impl FnMut(f64) -> Option<(f64, f64, f64)>,
) -> Result<(f64, f64), (f64, usize)> {
    let (mut ha, mut ga, mut hb, mut gb) = (h0, g0, h1, g1);
    let (mut best_h, mut best_g) = if g0.abs() < g1.abs() { (h0, g0) } else { (h1, g1) };
    while *evals < 100 && (hb - ha).abs() > 4.0 * f64::EPSILON * hb.abs().max(ha.abs()) {
        let mut hc = (ha * gb - hb * ga) / (gb - ga);
        if !hc.is_finite() || hc <= ha.min(hb) || hc >= ha.max(hb) {
            hc = 0.5 * (ha + hb);
        }
        let Some((gc, _, _)) = gap(hc) else {
            return Err((best_g, *evals));
        };
        *evals += 1;
        if gc.abs() < best_g.abs() {
            (best_h, best_g) = (hc, gc);
        }
        if gc.abs() <= tol {
            break;
        }
        if gc.signum() != gb.signum() {
            (ha, ga) = (hb, gb);
        } else {
            ga *= 0.5;
        }
        (hb, gb) = (hc, gc);
    }
    Ok((best_h, best_g))
}
