//! The indicators as running sums over the steps of a run, from the growth of tangent
//! vectors under the step maps:
//! - MEGNO (Cincotta & Simó 2000) for a map with steps h_j: with γ_j = ln(|δ_j|/|δ_{j−1}|),
//!   Y_k = (2/t_k) Σ_{j≤k} t_j γ_j and ⟨Y⟩_k = (1/t_k) Σ_{j≤k} h_j Y_j (t from the run's
//!   start). |δ| ∝ t (regular motion with shear) gives Y → 2; |δ| ∝ e^{λt} gives
//!   Y ≈ λt and ⟨Y⟩ ≈ λt/2.
//! - FLI (Froeschlé, Lega & Gonczi 1997): the largest ln|δ| so far.
//! - Lyapunov exponents (Benettin et al. 1980): the tangent vectors re-orthonormalised by
//!   modified Gram–Schmidt (a QR factorisation), λ_i = (Σ ln R_ii)/t.

/// A tangent vector's growth, tracked as a unit vector and the logarithm of its length.
#[derive(Debug, Clone)]
pub(crate) struct Growth {
    /// ln|δ| accumulated so far (δ(0) of unit length).
    pub(crate) log_norm: f64,
    pub(crate) fli: f64,
    /// Σ t_j γ_j and Σ h_j Y_j.
    weighted: f64,
    mean_sum: f64,
    pub(crate) megno: f64,
    pub(crate) mean_megno: f64,
}

impl Growth {
    pub(crate) fn new() -> Self {
        Self {
            log_norm: 0.0,
            fli: 0.0,
            weighted: 0.0,
            mean_sum: 0.0,
            megno: 0.0,
            mean_megno: 0.0,
        }
    }

    /// Records one step of length h ending at elapsed time t, over which |δ| grew by
    /// e^{gamma}.
    pub(crate) fn step(&mut self, gamma: f64, h: f64, t: f64) {
        self.log_norm += gamma;
        self.fli = self.fli.max(self.log_norm);
        self.weighted += t * gamma;
        self.megno = 2.0 * self.weighted / t;
        self.mean_sum += h * self.megno;
        self.mean_megno = self.mean_sum / t;
    }
}

/// Applies the row-major d×d matrix `m` to the d×k column vectors `w` (column-major, one
/// vector after another) in place; `tmp` has length d.
pub(crate) fn apply(m: &[f64], d: usize, w: &mut [f64], tmp: &mut [f64]) {
    for v in w.chunks_exact_mut(d) {
        for (i, t) in tmp.iter_mut().enumerate() {
            *t = m[i * d..(i + 1) * d].iter().zip(v.iter()).map(|(a, b)| a * b).sum();
        }
        v.copy_from_slice(tmp);
    }
}

/// Euclidean norm.
pub(crate) fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn megno_of_linear_growth_tends_to_two_and_of_exponential_growth_to_half_lambda_t() {
        let (h, steps) = (0.01, 200_000);
        let (mut lin, mut exp) = (Growth::new(), Growth::new());
        let lambda = 0.3;
        for j in 1..=steps {
            let t = j as f64 * h;
            // |δ| = 1 + t (regular) and e^{λt} (chaotic).
            lin.step(((1.0 + t) / (1.0 + t - h)).ln(), h, t);
            exp.step(lambda * h, h, t);
        }
        let t = steps as f64 * h;
        // Continuous MEGNO of |δ| = 1 + t: Y(s) = 2 − 2 ln(1 + s)/s, ⟨Y⟩ its mean over [0, t]
        // (→ 2 like (ln t)²/t), by the midpoint rule on a fine grid.
        let m = 1_000_000;
        let y = |s: f64| 2.0 - 2.0 * (1.0 + s).ln() / s;
        let mean = (0..m).map(|i| y((i as f64 + 0.5) * t / m as f64)).sum::<f64>() / m as f64;
        assert!(
            (lin.mean_megno - mean).abs() < 1e-3,
            "{} against {mean}",
            lin.mean_megno
        );
        assert!((mean - 2.0).abs() < 0.04);
        assert!(
            (exp.mean_megno / (lambda * t / 2.0) - 1.0).abs() < 1e-3,
            "{}",
            exp.mean_megno
        );
        assert!((exp.fli - lambda * t).abs() < 1e-9);
    }
}
