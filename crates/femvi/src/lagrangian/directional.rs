//! Directional derivatives of the force, (∂f/∂q)(t, q)·dq with f = ∂L/∂q at v = 0 (for a
//! mechanical Lagrangian f = −∇V): what the tangent map of a mechanical step needs at each
//! quadrature point (`step/tangent_mechanical.rs`), one product instead of the n×n Jacobian.
//! The defaults here differentiate the value twice with hyper-dual numbers, one pass per
//! component (ε₁ along dq, ε₂ along e_i), so n passes where the Jacobian took n(n+1)/2;
//! models and compiled expressions override them with their own code.

use super::{Lagrangian, Potential};
use num_dual::HyperDual64;

/// Hyper-dual copies of q with ε₁ = dq (the direction), ε₂ = 0.
fn seeded(q: &[f64], dq: &[f64]) -> Vec<HyperDual64> {
    q.iter()
        .zip(dq)
        .map(|(&x, &d)| HyperDual64::new(x, d, 0.0, 0.0))
        .collect()
}

/// out_i = ∂²L/∂q_i∂q · dq at v = 0 (the default of [`Lagrangian::force_derivative`]).
pub(super) fn lagrangian_default<L: Lagrangian + ?Sized>(lag: &L, t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
    let mut buf = seeded(q, dq);
    let zeros = vec![HyperDual64::from(0.0); q.len()];
    for (i, o) in out.iter_mut().enumerate().take(q.len()) {
        buf[i].eps2 = 1.0;
        *o = lag.value(HyperDual64::from(t), &buf, &zeros).eps1eps2;
        buf[i].eps2 = 0.0;
    }
}

/// out_i = −∂²V/∂q_i∂q · dq (the default of [`Potential::force_derivative`]).
pub(super) fn potential_default<P: Potential + ?Sized>(pot: &P, t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
    let mut buf = seeded(q, dq);
    for (i, o) in out.iter_mut().enumerate().take(q.len()) {
        buf[i].eps2 = 1.0;
        *o = -pot.value(HyperDual64::from(t), &buf).eps1eps2;
        buf[i].eps2 = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use crate::lagrangian::{Lagrangian, Potential};
    use crate::models;

    /// The hand-written products of the models against their Jacobians (and the defaults).
    #[test]
    fn force_derivatives_agree_with_the_jacobians() {
        fn check<P: Potential>(pot: &P, q: &[f64]) {
            let n = q.len();
            let dq: Vec<f64> = (0..n).map(|i| 0.3 - 0.17 * i as f64).collect();
            let mut jac = vec![0.0; n * n];
            pot.force_jacobian(0.0, q, &mut jac);
            let (mut own, mut dflt) = (vec![0.0; n], vec![0.0; n]);
            pot.force_derivative(0.0, q, &dq, &mut own);
            super::potential_default(pot, 0.0, q, &dq, &mut dflt);
            for i in 0..n {
                let want: f64 = (0..n).map(|j| jac[i * n + j] * dq[j]).sum();
                let scale = want.abs().max(1.0);
                assert!((own[i] - want).abs() < 1e-13 * scale, "{i}: {} vs {want}", own[i]);
                assert!((dflt[i] - want).abs() < 1e-13 * scale, "{i}: {} vs {want}", dflt[i]);
            }
        }
        check(&models::kepler(1.3).unwrap().potential, &[0.4, -0.7]);
        check(&models::henon_heiles().potential, &[0.2, -0.1]);
        check(&models::pendulum(1.0, 9.81, 0.5).unwrap().potential, &[0.7]);
        check(&models::harmonic(2.0, 3.0).unwrap().potential, &[0.7]);
        check(
            &models::fpu(7, 0.25, 0.7).unwrap().potential,
            &[0.1, -0.3, 0.2, 0.5, -0.1, 0.0, 0.4],
        );
        let planets = models::n_body(1.0, vec![1.0, 1e-3, 3e-4], 3).unwrap();
        check(&planets.potential, &[0.0, 0.1, 0.0, 1.0, 0.0, 0.2, -1.3, 0.4, 0.1]);
        let planar = models::n_body(2.0, vec![1.0, 0.5], 2).unwrap();
        check(&planar.potential, &[0.0, 0.1, 1.0, 0.3]);
        // The Lagrangian's default: ∂²L/∂q² dq at v = 0, here −∇²V dq.
        let lag = models::henon_heiles();
        let (q, dq) = ([0.2, -0.1], [0.5, 0.25]);
        let (mut a, mut b) = ([0.0; 2], [0.0; 2]);
        super::lagrangian_default(&lag, 0.0, &q, &dq, &mut a);
        lag.force_derivative(0.0, &q, &dq, &mut b);
        assert!((a[0] - b[0]).abs() < 1e-15 && (a[1] - b[1]).abs() < 1e-15);
    }
}
