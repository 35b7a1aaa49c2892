//! Closed-form solutions used as references: the harmonic oscillator and Kepler's problem
//! (elliptic orbits from any state, by Kepler's equation).

/// State (q, p) at time t of m ẍ = −k x from (q0, p0) at time t0.
pub fn harmonic(m: f64, k: f64, t0: f64, q0: f64, p0: f64, t: f64) -> (f64, f64) {
    let w = (k / m).sqrt();
    let (s, c) = (w * (t - t0)).sin_cos();
    let v0 = p0 / m;
    let q = q0 * c + v0 / w * s;
    let v = -q0 * w * s + v0 * c;
    (q, m * v)
}

/// State at time t of the planar Kepler problem q̈ = −μ q/|q|³ (unit mass) from (q0, p0) at
/// t0, for a bound orbit. Returns None for unbound or degenerate (radial) orbits.
pub fn kepler(mu: f64, t0: f64, q0: [f64; 2], p0: [f64; 2], t: f64) -> Option<([f64; 2], [f64; 2])> {
    let r0 = (q0[0] * q0[0] + q0[1] * q0[1]).sqrt();
    let v2 = p0[0] * p0[0] + p0[1] * p0[1];
    let energy = 0.5 * v2 - mu / r0;
    let ang = q0[0] * p0[1] - q0[1] * p0[0];
    if energy.is_nan() || energy >= 0.0 || ang == 0.0 {
        return None;
    }
    let a = -mu / (2.0 * energy);
    let rv = q0[0] * p0[0] + q0[1] * p0[1];
    // Eccentricity vector.
    let ex = ((v2 - mu / r0) * q0[0] - rv * p0[0]) / mu;
    let ey = ((v2 - mu / r0) * q0[1] - rv * p0[1]) / mu;
    let e = (ex * ex + ey * ey).sqrt();
    let n = (mu / (a * a * a)).sqrt();
    let sense = ang.signum();
    if e < 1e-12 {
        // Circular: a rotation by n (t − t0).
        let (s, c) = (sense * n * (t - t0)).sin_cos();
        return Some((
            [c * q0[0] - s * q0[1], s * q0[0] + c * q0[1]],
            [c * p0[0] - s * p0[1], s * p0[0] + c * p0[1]],
        ));
    }
    let omega = ey.atan2(ex);
    // Eccentric anomaly at t0 from r0 = a(1 − e cos E) and r·v = e √(μ a) sin E.
    let e0 = (rv / (e * (mu * a).sqrt())).atan2((1.0 - r0 / a) / e);
    // The position depends on E modulo 2π only: solve with M reduced to [−π, π].
    let two_pi = 2.0 * std::f64::consts::PI;
    let m = e0 - e * e0.sin() + n * (t - t0);
    let m = m - two_pi * (m / two_pi).round();
    let mut big_e = if e < 0.8 { m } else { std::f64::consts::PI.copysign(m) };
    for _ in 0..100 {
        let d = (big_e - e * big_e.sin() - m) / (1.0 - e * big_e.cos());
        big_e -= d;
        if d.abs() <= 1e-16 * big_e.abs().max(1.0) {
            break;
        }
    }
    let (s, c) = big_e.sin_cos();
    let b = a * (1.0 - e * e).sqrt();
    let edot = n / (1.0 - e * c);
    let (x, y) = (a * (c - e), sense * b * s);
    let (vx, vy) = (-a * s * edot, sense * b * c * edot);
    let (so, co) = omega.sin_cos();
    Some((
        [co * x - so * y, so * x + co * y],
        [co * vx - so * vy, so * vx + co * vy],
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kepler_returns_to_its_start_after_a_period_and_conserves_invariants() {
        let (q0, p0) = ([0.4, 0.0], [0.0, 2.0]);
        let (q, p) = kepler(1.0, 0.0, q0, p0, 2.0 * std::f64::consts::PI).unwrap();
        assert!((q[0] - 0.4).abs() < 1e-13 && q[1].abs() < 1e-13 && p[0].abs() < 1e-12 && (p[1] - 2.0).abs() < 1e-12);
        // A generic state: energy and angular momentum along the exact solution.
        let (q0, p0): ([f64; 2], [f64; 2]) = ([0.3, -0.7], [0.9, 0.4]);
        let h0 = 0.5 * (p0[0] * p0[0] + p0[1] * p0[1]) - 1.0 / (q0[0] * q0[0] + q0[1] * q0[1]).sqrt();
        for t in [0.3, 1.7, 5.0, -2.0] {
            let (q, p) = kepler(1.0, 0.0, q0, p0, t).unwrap();
            let h = 0.5 * (p[0] * p[0] + p[1] * p[1]) - 1.0 / (q[0] * q[0] + q[1] * q[1]).sqrt();
            assert!((h - h0).abs() < 1e-13, "t={t}");
            assert!((q[0] * p[1] - q[1] * p[0] - (q0[0] * p0[1] - q0[1] * p0[0])).abs() < 1e-13);
        }
        // Small t: the Taylor step q0 + t p0 + t²/2 f(q0).
        let t = 1e-3;
        let (q, _) = kepler(1.0, 0.0, q0, p0, t).unwrap();
        let r3 = (q0[0] * q0[0] + q0[1] * q0[1]).powf(1.5);
        let taylor = q0[0] + t * p0[0] - 0.5 * t * t * q0[0] / r3;
        assert!((q[0] - taylor).abs() < 1e-8);
    }

    #[test]
    fn harmonic_closed_form() {
        let (q, p) = harmonic(2.0, 8.0, 1.0, 1.0, 0.0, 1.0 + std::f64::consts::FRAC_PI_2);
        assert!((q - 1.0 * (2.0 * std::f64::consts::FRAC_PI_2).cos()).abs() < 1e-15 && p.abs() < 1e-14);
    }
}
