//! Proof in numbers: quantities that check the paper's claims on a computed trajectory —
//! the symplecticity defect of step maps ((2.17), (2.46): the tangent map M of a step
//! satisfies MᵀJM = J), energy errors and their drift, least-squares order fits, and closed
//! forms to measure errors against.

pub mod check;
pub mod exact;
mod symmetry;
pub mod trajectory;

pub use check::{check, CheckReport, TwoFormCheck};
pub use symmetry::Symmetry;
pub use trajectory::{L2Sum, PiecewiseTrajectory};

/// max |MᵀJM − J| for a row-major 2n×2n tangent map M in variables (q, p), with
/// J = [[0, I], [−I, 0]]. Zero for a symplectic map (up to round-off); NaN if `m` does not
/// have (2n)² entries.
pub fn symplecticity_defect(m: &[f64], n: usize) -> f64 {
    let Some(d) = n.checked_mul(2).filter(|d| d.checked_mul(*d) == Some(m.len())) else {
        return f64::NAN;
    };
    let j = |a: usize, b: usize| -> f64 {
        if a < n && b == a + n {
            1.0
        } else if a >= n && b + n == a {
            -1.0
        } else {
            0.0
        }
    };
    // (MᵀJM)_ab = Σ_cd M_ca J_cd M_db.
    let mut worst = 0.0f64;
    for a in 0..d {
        for b in 0..d {
            let mut acc = 0.0;
            for c in 0..d {
                for e in 0..d {
                    let jc = j(c, e);
                    if jc != 0.0 {
                        acc += m[c * d + a] * jc * m[e * d + b];
                    }
                }
            }
            let dev = (acc - j(a, b)).abs();
            worst = if dev.is_nan() { f64::NAN } else { worst.max(dev) };
        }
    }
    worst
}

/// Slope of the least-squares line through (x, y).
pub fn linear_slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    if sxx == 0.0 {
        0.0
    } else {
        sxy / sxx
    }
}

/// Observed order of convergence: the slope of ln(error) against ln(step).
pub fn fit_order(steps: &[f64], errors: &[f64]) -> f64 {
    let x: Vec<f64> = steps.iter().map(|v| v.ln()).collect();
    let y: Vec<f64> = errors.iter().map(|v| v.ln()).collect();
    linear_slope(&x, &y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_is_symplectic_and_scaling_is_not() {
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        assert!(symplecticity_defect(&[c, s, -s, c], 1) < 1e-15);
        assert!((symplecticity_defect(&[2.0, 0.0, 0.0, 1.0], 1) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn order_of_a_power_law() {
        let h = [0.1, 0.05, 0.025];
        let e: Vec<f64> = h.iter().map(|h: &f64| 3.0 * h.powi(4)).collect();
        assert!((fit_order(&h, &e) - 4.0).abs() < 1e-12);
    }
}
