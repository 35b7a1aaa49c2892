//! Newton's iteration of the inverse Legendre transform, p = ∂L/∂v(t, q, v) solved for v
//! (behind [`super::velocity_from_momentum`], for Lagrangians without a constant mass matrix).
//! For 1 to 4 coordinates it runs on fixed-size nalgebra matrices: the same derivatives, the
//! same LU factorisation with partial pivoting (nalgebra's generic code, instantiated on
//! fixed sizes) and the same stopping test as the loop for any n, so the same velocity bit for
//! bit, without the n×n matrix, its copy, the LU's permutation and the solution that loop
//! allocates at every iteration: a third of the cost of the energy at every node of a
//! relativistic Kepler expression's run (callgrind, `femvi run`, degree 2), where the energy
//! took 45 % of the run.

use super::{Lagrangian, PointDerivatives};
use crate::error::{Error, Result};
use nalgebra::{Const, DimMin, SMatrix, SVector};

/// Newton for v from the guess in `v` (sizes checked by the caller: q, p, v and `work` of the
/// Lagrangian's dimension n ≥ 1).
///
/// # Errors
/// [`Error::DegenerateLagrangian`] if ∂²L/∂v² is singular or Newton does not converge in 50
/// iterations.
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
    let mut hvv = nalgebra::DMatrix::zeros(n, n);
    let mut rhs = nalgebra::DVector::zeros(n);
    for _ in 0..50 {
        lag.second_derivatives(t, q, v, false, work);
        for i in 0..n {
            rhs[i] = p[i] - work.l_v()[i];
            for j in 0..n {
                hvv[(i, j)] = work.h(1 + n + i, 1 + n + j);
            }
        }
        let lu = hvv.clone().lu();
        let dv = lu.solve(&rhs).ok_or(Error::DegenerateLagrangian { t })?;
        let Some(scale) = add_step(v, dv.as_slice()) else {
            return Err(Error::DegenerateLagrangian { t });
        };
        if dv.amax() <= 1e-15 * scale {
            return Ok(());
        }
    }
    Err(Error::DegenerateLagrangian { t })
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
    for _ in 0..50 {
        lag.second_derivatives(t, q, v, false, work);
        let rhs = SVector::<f64, N>::from_iterator(p.iter().zip(work.l_v()).map(|(pi, li)| pi - li));
        let hvv = SMatrix::<f64, N, N>::from_fn(|i, j| work.h(1 + N + i, 1 + N + j));
        let dv = hvv.lu().solve(&rhs).ok_or(Error::DegenerateLagrangian { t })?;
        let Some(scale) = add_step(v, dv.as_slice()) else {
            return Err(Error::DegenerateLagrangian { t });
        };
        if dv.amax() <= 1e-15 * scale {
            return Ok(());
        }
    }
    Err(Error::DegenerateLagrangian { t })
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
