//! Newton's iteration of the inverse Legendre transform, p = ∂L/∂v(t, q, v) solved for v
//! (behind [`super::velocity_from_momentum`], for Lagrangians without a constant mass matrix).
//!
//! **Stopping rule.** The iteration stops when a correction is below 10⁻¹⁵ of the velocity's
//! scale, or when it has reached the level of round-off: a correction at most
//! [`STAGNATION`] of the scale that is no longer contracting (at least a quarter of the one
//! before; Newton's corrections shrink quadratically until rounding in p − ∂L/∂v, amplified by
//! the condition number of ∂²L/∂v², sets a floor). Without the second test a regular system
//! whose floor lies above 10⁻¹⁵ (a double pendulum with l₂ = 0.8, issue 34) was reported as
//! degenerate. Since H = p·v − L is stationary in v at the solution, the node energy is
//! insensitive to that floor (its error is quadratic in it).
//!
//! **Safeguard.** A correction that makes the residual grow more than twofold, above the
//! level of round-off, is halved (at most [`MAX_HALVINGS`] times) before it is taken.
//!
//! **Failure.** If the iteration does not stop within [`MAX_ITERATIONS`], the condition number
//! κ of ∂²L/∂v² at the last iterate decides the error: [`Error::DegenerateLagrangian`] when it
//! is singular, not finite or κ > [`DEGENERATE_CONDITION`] (with κ in the message), otherwise
//! [`Error::LegendreNotConverged`] (a regular Hessian, an iteration that did not converge).
//!
//! For 1 to 4 coordinates it runs on fixed-size nalgebra matrices: the same derivatives, the
//! same LU factorisation with partial pivoting (nalgebra's generic code, instantiated on
//! fixed sizes) and the same stopping test as the loop for any n, so the same velocity bit for
//! bit, without the n×n matrix, its copy, the LU's permutation and the solution that loop
//! allocates at every iteration: a third of the cost of the energy at every node of a
//! relativistic Kepler expression's run (callgrind, `femvi run`, degree 2), where the energy
//! took 45 % of the run.

use super::{Lagrangian, PointDerivatives};
use crate::error::{Error, Result};
use nalgebra::{Const, DMatrix, DimMin, SMatrix, SVector};

/// Newton iterations before the transform gives up.
pub const MAX_ITERATIONS: usize = 50;
/// The largest correction, relative to the velocity's scale, that can be taken as
/// round-off-level stagnation (it must also be within 64 κ ε of the scale, κ the condition
/// number of ∂²L/∂v²).
pub const STAGNATION: f64 = 1e-6;
/// How many times a correction that made the residual grow is halved.
pub const MAX_HALVINGS: usize = 30;
/// The condition number of ∂²L/∂v² beyond which the Lagrangian is reported as degenerate.
pub const DEGENERATE_CONDITION: f64 = 1e12;

/// Newton for v from the guess in `v` (sizes checked by the caller: q, p, v and `work` of the
/// Lagrangian's dimension n ≥ 1).
///
/// # Errors
/// [`Error::DegenerateLagrangian`] if ∂²L/∂v² is singular, not finite or has a condition
/// number above [`DEGENERATE_CONDITION`] where Newton stops; [`Error::LegendreNotConverged`]
/// if it is regular there but Newton did not converge in [`MAX_ITERATIONS`] iterations.
pub(super) fn newton<L: Lagrangian>(
    lag: &L,
    t: f64,
    (q, p): (&[f64], &[f64]),
    v: &mut [f64],
    work: &mut PointDerivatives,
) -> Result<()> {
    match q.len() {
        1 => newton_fixed::<1, L>(lag, t, (q, p), v, work),
        2 => newton_fixed::<2, L>(lag, t, (q, p), v, work),
        3 => newton_fixed::<3, L>(lag, t, (q, p), v, work),
        4 => newton_fixed::<4, L>(lag, t, (q, p), v, work),
        _ => newton_any(lag, t, (q, p), v, work),
    }
}

/// [`newton`] for any n, on dynamically sized matrices.
fn newton_any<L: Lagrangian>(
    lag: &L,
    t: f64,
    (q, p): (&[f64], &[f64]),
    v: &mut [f64],
    work: &mut PointDerivatives,
) -> Result<()> {
    let n = q.len();
    let mut hvv = DMatrix::zeros(n, n);
    let mut rhs = nalgebra::DVector::zeros(n);
    let mut dv = vec![0.0; n];
    iterate(lag, t, (q, p), v, work, &mut dv, |work, dv| {
        for i in 0..n {
            rhs[i] = p[i] - work.l_v()[i];
            for j in 0..n {
                hvv[(i, j)] = work.h(1 + n + i, 1 + n + j);
            }
        }
        let x = hvv.clone().lu().solve(&rhs)?;
        dv.copy_from_slice(x.as_slice());
        Some(())
    })
}

/// [`newton`] for n = N on fixed-size matrices (the same operations as [`newton_any`]).
fn newton_fixed<const N: usize, L: Lagrangian>(
    lag: &L,
    t: f64,
    (q, p): (&[f64], &[f64]),
    v: &mut [f64],
    work: &mut PointDerivatives,
) -> Result<()>
where
    Const<N>: DimMin<Const<N>, Output = Const<N>>,
{
    let mut dv = [0.0; N];
    iterate(lag, t, (q, p), v, work, &mut dv, |work, dv| {
        let rhs = SVector::<f64, N>::from_iterator(p.iter().zip(work.l_v()).map(|(pi, li)| pi - li));
        let hvv = SMatrix::<f64, N, N>::from_fn(|i, j| work.h(1 + N + i, 1 + N + j));
        let x = hvv.lu().solve(&rhs)?;
        dv.copy_from_slice(x.as_slice());
        Some(())
    })
}

/// The safeguarded Newton loop shared by both sizes; `solve` evaluates the correction dv
/// from the derivatives at v (None if ∂²L/∂v² is singular to the LU).
fn iterate<L: Lagrangian>(
    lag: &L,
    t: f64,
    (q, p): (&[f64], &[f64]),
    v: &mut [f64],
    work: &mut PointDerivatives,
    dv: &mut [f64],
    mut solve: impl FnMut(&PointDerivatives, &mut [f64]) -> Option<()>,
) -> Result<()> {
    let n = q.len();
    // The correction last taken (halved by the safeguard) and its size, the residual before it.
    let mut taken = [0.0f64; 4];
    let mut taken_any = if n > 4 { vec![0.0; n] } else { Vec::new() };
    let (mut prev_dv, mut prev_residual, mut halvings) = (f64::INFINITY, f64::INFINITY, 0);
    for _ in 0..MAX_ITERATIONS {
        lag.second_derivatives(t, q, v, false, work);
        let residual = residual(p, work);
        let last: &mut [f64] = if n > 4 { &mut taken_any } else { &mut taken[..n] };
        if residual > 2.0 * prev_residual && prev_dv.is_finite() && halvings < MAX_HALVINGS {
            // The last correction made things worse: take half of it back.
            for (vi, d) in v.iter_mut().zip(last.iter_mut()) {
                *d *= 0.5;
                *vi -= *d;
            }
            halvings += 1;
            continue;
        }
        if solve(work, dv).is_none() {
            return Err(degenerate(work, t));
        }
        let Some(scale) = add_step(v, dv) else {
            return Err(degenerate(work, t));
        };
        let size = dv.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if size <= 1e-15 * scale {
            return Ok(());
        }
        if size > 0.25 * prev_dv && size <= STAGNATION * scale {
            // No longer contracting: converged if the correction is at the round-off floor
            // that the conditioning of ∂²L/∂v² allows.
            let kappa = condition(work);
            if kappa.is_finite() && size <= 64.0 * kappa * f64::EPSILON * scale {
                return Ok(());
            }
        }
        last.copy_from_slice(dv);
        (prev_dv, prev_residual) = (size, residual);
    }
    lag.second_derivatives(t, q, v, false, work);
    let kappa = condition(work);
    if kappa.is_nan() || kappa > DEGENERATE_CONDITION {
        return Err(Error::DegenerateLagrangian { t, condition: kappa });
    }
    let residual = residual(p, work);
    Err(Error::LegendreNotConverged {
        t,
        iterations: MAX_ITERATIONS,
        residual,
        condition: kappa,
    })
}

/// max |p − ∂L/∂v| with ∂L/∂v in `work`.
fn residual(p: &[f64], work: &PointDerivatives) -> f64 {
    p.iter()
        .zip(work.l_v())
        .fold(0.0f64, |m, (pi, li)| m.max((pi - li).abs()))
}

/// [`Error::DegenerateLagrangian`] with the condition number of ∂²L/∂v² in `work`.
fn degenerate(work: &PointDerivatives, t: f64) -> Error {
    Error::DegenerateLagrangian {
        t,
        condition: condition(work),
    }
}

/// The condition number (largest over smallest singular value) of ∂²L/∂v² held in `work`:
/// infinite if it is singular or has an entry that is not finite (checked before the SVD).
pub(crate) fn condition(work: &PointDerivatives) -> f64 {
    let n = work.dim();
    let hvv = DMatrix::from_fn(n, n, |i, j| work.h(1 + n + i, 1 + n + j));
    condition_of(hvv)
}

/// The condition number of a square matrix (2-norm): infinite if it is singular or not
/// finite. The entries are checked before the singular values are computed (nalgebra's SVD
/// panics on NaN).
pub(crate) fn condition_of(m: DMatrix<f64>) -> f64 {
    if m.is_empty() || !m.iter().all(|x| x.is_finite()) {
        return f64::INFINITY;
    }
    let sv = m.singular_values();
    let (lo, hi) = (sv.min(), sv.max());
    if lo > 0.0 && hi.is_finite() {
        hi / lo
    } else {
        f64::INFINITY
    }
}

/// Adds the Newton step dv to v; the largest |v| (at least 1) before the step, which scales
/// the stopping test, or None if the step is not finite.
fn add_step(v: &mut [f64], dv: &[f64]) -> Option<f64> {
    let scale = v.iter().fold(1.0f64, |m, x| m.max(x.abs()));
    for (vi, d) in v.iter_mut().zip(dv) {
        *vi += d;
    }
    dv.iter().all(|x| x.is_finite()).then_some(scale)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lagrangian::Scalar;
    use crate::models::RelativisticKepler;

    /// A velocity-dependent Lagrangian of N coordinates with coupled velocities (a
    /// non-diagonal ∂²L/∂v², so pivoting and every entry of the LU matter).
    struct Coupled<const N: usize>;

    impl<const N: usize> Lagrangian for Coupled<N> {
        fn dim(&self) -> usize {
            N
        }
        fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
            let zero = t * 0.0;
            let l = q.iter().zip(v).fold(zero, |acc, (&qi, &vi)| {
                let vv = vi * vi;
                acc + vv * (qi * qi + 1.0) * 0.5 + vv * vv * 0.05 - qi.cos()
            });
            let s = v.iter().zip(1..).fold(zero, |acc, (&vi, k)| acc + vi * f64::from(k));
            l + s * s * 0.3 + v[0] * q[N - 1] * t.sin()
        }
    }

    /// Deterministic pseudo-random numbers in [−1, 1).
    fn draws(seed: u64, k: usize) -> Vec<f64> {
        let mut x = seed;
        (0..k)
            .map(|_| {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (x >> 11) as f64 / (1u64 << 52) as f64 - 1.0
            })
            .collect()
    }

    /// The velocity of the fixed-size iteration and of the one for any n, bit for bit (or
    /// the same error), from the same guess at random points.
    fn agrees<const N: usize, L: Lagrangian>(lag: &L)
    where
        Const<N>: DimMin<Const<N>, Output = Const<N>>,
    {
        let mut converged = 0;
        for seed in 0..200 {
            let z = draws(seed, 3 * N + 1);
            let (q, p, guess) = (&z[..N], &z[N..2 * N], &z[2 * N..3 * N]);
            let t = z[3 * N];
            let (mut v1, mut v2) = (guess.to_vec(), guess.to_vec());
            let (mut w1, mut w2) = (PointDerivatives::new(N), PointDerivatives::new(N));
            let fixed = newton_fixed::<N, L>(lag, t, (q, p), &mut v1, &mut w1);
            let any = newton_any(lag, t, (q, p), &mut v2, &mut w2);
            match (fixed, any) {
                (Ok(()), Ok(())) => {
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&v1), bits(&v2), "seed {seed}");
                    converged += 1;
                }
                (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
                (a, b) => panic!("seed {seed}: {a:?} against {b:?}"),
            }
        }
        // Both Lagrangians are convex in v there: Newton converges from every guess.
        assert_eq!(converged, 200);
    }

    #[test]
    fn fixed_size_newton_equals_the_one_for_any_n_bit_for_bit() {
        agrees::<1, _>(&Coupled::<1>);
        agrees::<2, _>(&Coupled::<2>);
        agrees::<3, _>(&Coupled::<3>);
        agrees::<4, _>(&Coupled::<4>);
        agrees::<2, _>(&RelativisticKepler { c: 10.0 });
    }
}
