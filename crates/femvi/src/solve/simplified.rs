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

use crate::error::StepFailure;

/// The contraction θ above which the iteration is abandoned (refresh the Jacobian).
pub const THETA_SLOW: f64 = 0.5;

/// Corrections below this many round-off units of the unknowns are left out of the reported
/// θ (their ratios are noise).
const NOISE: f64 = 100.0;

/// A factorised Jacobian and the buffers of the iteration. The factorisation is kept as the
/// explicit inverse: each iteration is then one matrix-vector product,
/// which for the small systems of an element (dim = s·n) costs a fraction of the triangular
/// solves (measured: those took a tenth of a relativistic Kepler step). Its rounding only
/// changes the rate of convergence, not the solution, which is set by the residual.
#[derive(Debug, Clone)]
pub struct FrozenJacobian {
    /// Residual at the last iterate evaluated (after convergence, the one before the last
    /// correction when that correction was below round-off: see [`simplified_newton`]).
    pub r: Vec<f64>,
    /// Jacobian to factorise, row-major (filled by the caller before [`FrozenJacobian::factor`]).
    pub jac: Vec<f64>,
    /// J⁻¹, row-major (empty: nothing factorised).
    inv: Vec<f64>,
    rhs: Vec<f64>,
    work: Vec<f64>,
}

/// Reduces `a` (row-major dim × dim) to the identity by row operations with partial
/// pivoting, applying them to `b`: b becomes a⁻¹b. False if a pivot is zero.
fn gauss_jordan(a: &mut [f64], b: &mut [f64], dim: usize) -> bool {
    for col in 0..dim {
        let Some(piv) = (col..dim).max_by(|&i, &j| a[i * dim + col].abs().total_cmp(&a[j * dim + col].abs())) else {
            return false;
        };
        let p = a[piv * dim + col];
        if p == 0.0 || !p.is_finite() {
            return false;
        }
        if piv != col {
            for k in 0..dim {
                a.swap(piv * dim + k, col * dim + k);
                b.swap(piv * dim + k, col * dim + k);
            }
        }
        for k in 0..dim {
            a[col * dim + k] /= p;
            b[col * dim + k] /= p;
        }
        for i in (0..dim).filter(|&i| i != col) {
            let f = a[i * dim + col];
            if f != 0.0 {
                for k in 0..dim {
                    a[i * dim + k] -= f * a[col * dim + k];
                    b[i * dim + k] -= f * b[col * dim + k];
                }
            }
        }
    }
    true
}

/// [`gauss_jordan`] for dim = D on rows of fixed size: the same pivots and the same
/// operations in the same order (same bits), unrolled by the compiler (with a run-time dim,
/// inverting an 8 × 8 Jacobian took ~20 000 instructions). False if a or b is not D × D.
fn gauss_jordan_fixed<const D: usize>(a: &mut [f64], b: &mut [f64]) -> bool {
    let (Ok(a), Ok(b)) = (
        <&mut [[f64; D]; D]>::try_from(a.as_chunks_mut::<D>().0),
        <&mut [[f64; D]; D]>::try_from(b.as_chunks_mut::<D>().0),
    ) else {
        return false;
    };
    for col in 0..D {
        let Some(piv) = (col..D).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs())) else {
            return false;
        };
        let p = a[piv][col];
        if p == 0.0 || !p.is_finite() {
            return false;
        }
        if piv != col {
            a.swap(piv, col);
            b.swap(piv, col);
        }
        for k in 0..D {
            a[col][k] /= p;
            b[col][k] /= p;
        }
        let (ac, bc) = (a[col], b[col]);
        for i in (0..D).filter(|&i| i != col) {
            let f = a[i][col];
            if f != 0.0 {
                for k in 0..D {
                    a[i][k] -= f * ac[k];
                    b[i][k] -= f * bc[k];
                }
            }
        }
    }
    true
}

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

impl FrozenJacobian {
    /// Buffers for `dim` unknowns, nothing factorised (the caller bounds dim: like any
    /// allocation, dim² numbers that do not fit in memory abort).
    pub fn new(dim: usize) -> Self {
        Self {
            r: vec![0.0; dim],
            jac: vec![0.0; dim * dim],
            inv: Vec::new(),
            rhs: vec![0.0; dim],
            work: Vec::new(),
        }
    }

    /// Number of unknowns.
    pub fn dim(&self) -> usize {
        self.r.len()
    }

    /// Whether a factorisation is held.
    pub fn is_factored(&self) -> bool {
        !self.inv.is_empty()
    }

    /// Drops the factorisation.
    pub fn clear(&mut self) {
        self.inv.clear();
    }

    /// Inverts `jac` by Gauss–Jordan elimination with partial pivoting; false, holding
    /// nothing, if it is not finite or singular. (By hand rather than nalgebra's LU and
    /// inverse: those allocate four matrices, and a refresh of an 8 × 8 Jacobian spent more
    /// time there than in the Hessian.)
    pub fn factor(&mut self) -> bool {
        let dim = self.dim();
        self.inv.clear();
        if !self.jac.iter().all(|v| v.is_finite()) {
            return false;
        }
        let mut a = std::mem::take(&mut self.work);
        a.clear();
        a.extend_from_slice(&self.jac);
        // The inverse's buffer is reused (a refresh happens inside a run of steps).
        let mut inv = std::mem::take(&mut self.inv);
        inv.clear();
        inv.resize(dim * dim, 0.0);
        for i in 0..dim {
            inv[i * dim + i] = 1.0;
        }
        macro_rules! fixed {
            ($($d:literal)*) => {
                match dim {
                    $($d => gauss_jordan_fixed::<$d>(&mut a, &mut inv),)*
                    _ => gauss_jordan(&mut a, &mut inv, dim),
                }
            };
        }
        let ok = fixed!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16);
        self.work = a;
        if !(ok && inv.iter().all(|v| v.is_finite())) {
            // Nothing factorised: empty, its capacity kept.
            inv.clear();
        }
        self.inv = inv;
        self.is_factored()
    }

    /// The correction −J⁻¹r into `rhs`; false without a factorisation or if not finite.
    fn correction(&mut self) -> bool {
        let dim = self.dim();
        if self.inv.len() != dim * dim {
            return false;
        }
        macro_rules! fixed {
            ($($d:literal)*) => {
                match dim {
                    $($d => product::<$d>(&self.inv, &self.r, &mut self.rhs),)*
                    _ => product_any(&self.inv, &self.r, &mut self.rhs),
                }
            };
        }
        fixed!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16);
        self.rhs.iter().all(|v| v.is_finite())
    }
}

/// rhs = −A r for A row-major dim × dim, dim = r's length (the caller's check).
fn product_any(a: &[f64], r: &[f64], rhs: &mut [f64]) {
    for (d, row) in rhs.iter_mut().zip(a.chunks_exact(r.len())) {
        *d = -row.iter().zip(r).map(|(a, b)| a * b).sum::<f64>();
    }
}

/// [`product_any`] for dim = D (nothing done if r or rhs is not of length D: the caller
/// checks): the same sums in the same order, unrolled by the compiler
/// (with a run-time dim the loop overhead was twice the flops of an 8 × 8 product).
fn product<const D: usize>(a: &[f64], r: &[f64], rhs: &mut [f64]) {
    let (rows, _) = a.as_chunks::<D>();
    let (Ok(r), Some(rhs)) = (<&[f64; D]>::try_from(r), rhs.first_chunk_mut::<D>()) else {
        return;
    };
    for (d, row) in rhs.iter_mut().zip(rows) {
        *d = -row.iter().zip(r).map(|(a, b)| a * b).sum::<f64>();
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Pseudo-random numbers in [−½, ½) (a linear congruential generator: reproducible).
    fn uniform(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        }
    }

    /// The unrolled inversion against the loop, bit for bit, for every unrolled size (with
    /// pivoting: the matrices are far from diagonally dominant).
    #[test]
    fn fixed_size_inverse_equals_the_loop_bit_for_bit() {
        let mut rand = uniform(11);
        for dim in 1..=17 {
            let jac: Vec<f64> = (0..dim * dim).map(|_| rand()).collect();
            let mut frozen = FrozenJacobian::new(dim);
            frozen.jac = jac.clone();
            assert!(frozen.factor(), "dim {dim}");
            let (mut a, mut want) = (jac, vec![0.0; dim * dim]);
            (0..dim).for_each(|i| want[i * dim + i] = 1.0);
            assert!(gauss_jordan(&mut a, &mut want, dim));
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&frozen.inv), bits(&want), "dim {dim}");
        }
    }

    /// The unrolled product against the loop, bit for bit, for every unrolled size.
    #[test]
    fn fixed_size_product_equals_the_loop_bit_for_bit() {
        let mut rand = uniform(7);
        for dim in 1..=17 {
            let a: Vec<f64> = (0..dim * dim).map(|_| rand() * 1e3).collect();
            let r: Vec<f64> = (0..dim).map(|_| rand() * 1e-3).collect();
            let mut frozen = FrozenJacobian::new(dim);
            frozen.inv = a.clone();
            frozen.r = r.clone();
            assert!(frozen.correction());
            let mut want = vec![0.0; dim];
            product_any(&a, &r, &mut want);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&frozen.rhs), bits(&want), "dim {dim}");
        }
    }
}
