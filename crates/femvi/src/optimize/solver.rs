//! The primal–dual interior-point iteration on the KKT system (after IPOPT: Wächter and
//! Biegler, Math. Program. 106, 2006, in a plain form). Bounds l ≤ x ≤ u on controls, on
//! coordinates and on a free final time enter through the barrier −μ Σ ln(x − l) + ln(u − x) and their dual
//! variables z; each Newton step solves the banded KKT system (`kkt.rs`) with the Hessian
//! block raised by Σ = z_l/(x − l) + z_u/(u − x). Globalisation:
//! - a Hessian block with the wrong curvature along the step (dᵀWd ≤ 10⁻⁸|d|², read off the
//!   solved system as −d·g + dΛ·c, with no extra product) is raised by δI, δ growing tenfold,
//!   and the step solved again (the inertia-free test of Chiang and Zavala, 2016);
//! - steps stay a fraction 0.99 inside the bounds;
//! - a backtracking search on the exact penalty φ = J_μ + ν‖c‖₁ (Armijo, 10⁻⁴), ν at least the
//!   largest multiplier and relaxed towards it by Powell's update;
//! - with constraints, the first multipliers by least squares (`multipliers.rs`).
//!
//! The barrier μ starts at 0.1 and falls to max(μ_min, min(μ/5, μ^1.5)), μ_min = tol/(10·bounds), once the barrier
//! problem is solved to 10μ. The iteration stops when the constraint violation ‖c‖∞, the
//! optimality residual ‖∇ₓℒ − z_l + z_u‖∞ / h and the complementarity are all at most the
//! tolerance, or, at the smallest μ, at the round-off floor: when a full step changes no
//! unknown by more than 10⁻¹² of its size, or when the componentwise backward error is within
//! the tolerance, the KKT error no longer halves and neither do Newton's full steps. The best
//! iterate seen (smallest of the three residuals) is what either stop and a failure return.

use super::assemble::{Border, Model};
use super::floor::Floor;
use super::iterate::{value_of, Bound, Iterate};
use super::newton::newton_step;
use super::search::{line_search, to_the_boundary, Kkt, Penalty};
use super::system::Controls;
use crate::error::Result;
use crate::lagrangian::Lagrangian;
use crate::solve::BandMatrix;

/// How the iteration ended.
#[derive(Debug, Clone)]
pub(super) struct Outcome {
    pub(super) best: Iterate,
    pub(super) iterations: usize,
    pub(super) violation: f64,
    pub(super) optimality: f64,
    pub(super) converged: bool,
    /// Why it stopped, if not converged.
    pub(super) reason: Option<String>,
}

/// Iteration limits and tolerance.
#[derive(Debug, Clone, Copy)]
pub(super) struct Settings {
    pub(super) tolerance: f64,
    pub(super) max_iterations: usize,
}

struct Residuals {
    violation: f64,
    optimality: f64,
    complementarity: f64,
}

impl Residuals {
    fn error(&self) -> f64 {
        self.violation.max(self.optimality).max(self.complementarity)
    }
}

/// The interior-point iteration from `start`.
pub(super) fn solve<L: Lagrangian + ?Sized, C: Controls>(
    model: &Model<'_, L, C>,
    bounds: &[Bound],
    start: Iterate,
    settings: Settings,
) -> Result<Outcome> {
    let size = model.layout.size();
    let bw = model.layout.bandwidth();
    let mut band = BandMatrix::zeros(size, bw, bw)?;
    let mut grad = vec![0.0; size];
    let mut border = Border {
        col: vec![0.0; size],
        diag: 0.0,
        grad: 0.0,
    };
    let mut it = start;
    let mut mu = 0.1f64;
    let mut nu = 1.0f64;
    let mut delta = 0.0f64;
    let mut best: Option<(f64, Iterate, Residuals)> = None;
    let lambda_rows = lambda_mask(model);
    // With constraints, the first multipliers by least squares (`multipliers.rs`); without,
    // they changed no iteration count of the cart-pole (degrees 1–3, 25 to 1000 elements),
    // so the extra factorisation is not spent.
    if model.layout.mc > 0 {
        super::multipliers::least_squares(model, &mut band, &mut grad, &mut border, &mut it, bounds, &lambda_rows)?;
    }
    let mut reason = None;
    let mut iterations = 0;
    let mut prev_err = None;
    let mut steps = Floor::default();
    // Each bound's barrier moves the optimum by about μ, and the final time feels them all:
    // the smallest barrier is the tolerance shared among the bounds.
    let mu_min = settings.tolerance / (10.0 * bounds.len().max(1) as f64);
    while iterations < settings.max_iterations {
        model.assemble(&it.x, it.t1, &mut band, &mut grad, &mut border)?;
        let res = residuals(model, &it, bounds, &grad, border.grad, &lambda_rows, 0.0);
        let err = res.error();
        let (eta, c_noise) = backward_error(&band, bw, &it, bounds, &border, &grad, &lambda_rows);
        if best.as_ref().is_none_or(|(e, ..)| err < *e) {
            best = Some((err, it.clone(), res));
        }
        if !err.is_finite() {
            reason = Some("the residuals are not finite".to_string());
            break;
        }
        // At the smallest barrier the residual stops falling at its round-off floor, which
        // grows with N (the optimality residual is divided by h, and its terms grow like
        // 1/h): there a componentwise backward error ω = max_i |∇ℒ_i| / (|K||x|)_i within
        // the tolerance (each equation holds to that fraction of the size of its terms) and
        // a KKT error that no longer halves mean converged. Measured at the cart-pole's
        // optimum: ω = 1.2e-10 at 1000 elements, where the optimality residual stalls at
        // 6e-8; on the way there ω ≥ 1e-6.
        // ω within the tolerance still leaves each equation wrong by up to that fraction of
        // its terms (the cart-pole at 10⁵ elements, degree 2, stopped there with its cost
        // 9.4e-10 off), so the iteration goes on until Newton's full steps stop shrinking:
        // then the iterate sits at the floor that round-off sets (`Floor`).
        // Above the smallest barrier the same noise ends the barrier problem instead.
        let noisy = eta <= settings.tolerance && prev_err.is_some_and(|p: f64| err > 0.5 * p);
        if err <= settings.tolerance || (mu <= mu_min && noisy && steps.reached()) {
            return Ok(finish(best, iterations, true, None));
        }
        if mu <= mu_min && noisy {
            steps.noisy += 1;
        }
        if noisy && mu > mu_min {
            mu = mu_min;
            steps = Floor::default();
        }
        prev_err = Some(err);
        while mu > mu_min && residuals(model, &it, bounds, &grad, border.grad, &lambda_rows, mu).error() <= 10.0 * mu {
            mu = mu_min.max((0.2 * mu).min(mu.powf(1.5)));
            steps = Floor::default();
        }
        iterations += 1;
        let Some(step) = newton_step(
            model,
            &mut band,
            &mut grad,
            &mut border,
            &it,
            bounds,
            mu,
            &mut delta,
            &lambda_rows,
        )?
        else {
            reason = Some("the KKT matrix is singular".to_string());
            break;
        };
        let (dx, dt, diag) = step;
        let (mut alpha, alpha_z, dz) = to_the_boundary(&it, bounds, &dx, dt, mu);
        let lam_new = lambda_rows.iter().map(|&i| (it.x[i] + dx[i]).abs()).fold(0.0, f64::max);
        // Powell's update: ν stays above the multipliers but relaxes towards them, so that
        // one wild early step does not leave a penalty that shortens every later step. (A
        // monotone ν = max(ν, 1.1|Λ|) took the constrained free-end pendulum at 200
        // elements, degree 1, 83 iterations, and failed at 400; with this update 28 and 46.)
        nu = (1.1 * lam_new).max(0.5 * (nu + 1.1 * lam_new)).max(1.0);
        let kkt = Kkt {
            band: &band,
            border: &border,
            diag,
            grad: &grad,
            lambda_rows: &lambda_rows,
        };
        let penalty = Penalty { mu, nu, c_noise };
        let accepted = line_search(model, &it, bounds, &kkt, penalty, (&dx, dt), &mut alpha)?;
        let Some(next) = accepted else {
            if eta <= settings.tolerance {
                if mu <= mu_min {
                    return Ok(finish(best, iterations, true, None));
                }
                mu = mu_min;
                prev_err = None;
                steps = Floor::default();
                continue;
            }
            reason = Some("the line search found no decrease of the merit function".to_string());
            break;
        };
        let size = dx
            .iter()
            .zip(&it.x)
            .map(|(d, x)| (alpha * d).abs() / (1.0 + x.abs()))
            .fold((alpha * dt).abs() / (1.0 + it.t1.abs()), f64::max);
        let small = size <= 1e-12;
        steps.push(size, alpha == 1.0);
        it = next;
        // A short step raises the next step's regularisation (Levenberg–Marquardt): the
        // Newton model was not trusted this far.
        if alpha < 0.5 {
            delta = (10.0 * delta).max(1e-4);
        }
        for (k, &(dzl, dzu)) in dz.iter().enumerate() {
            it.zl[k] += alpha_z * dzl;
            it.zu[k] += alpha_z * dzu;
        }
        if small && mu <= settings.tolerance && alpha == 1.0 {
            model.assemble(&it.x, it.t1, &mut band, &mut grad, &mut border)?;
            let res = residuals(model, &it, bounds, &grad, border.grad, &lambda_rows, 0.0);
            let err = res.error();
            best = Some((err, it, res));
            return Ok(finish(best, iterations, true, None));
        }
    }
    let reason = reason.or_else(|| Some(format!("no convergence in {} iterations", settings.max_iterations)));
    Ok(finish(best, iterations, false, reason))
}

fn finish(
    best: Option<(f64, Iterate, Residuals)>,
    iterations: usize,
    converged: bool,
    reason: Option<String>,
) -> Outcome {
    let (_, best, res) = best.unwrap_or_else(|| unreachable!("the first iterate is always recorded"));
    Outcome {
        best,
        iterations,
        violation: res.violation,
        optimality: res.optimality,
        converged,
        reason,
    }
}

/// Banded indices of the multipliers: Λ, and with constraints κ and the hidden constraints'.
fn lambda_mask<L: Lagrangian + ?Sized, C: Controls>(model: &Model<'_, L, C>) -> Vec<usize> {
    let l = model.layout;
    let mut rows: Vec<usize> = (0..l.nodes())
        .flat_map(|g| (0..l.n).map(move |i| l.lambda(g) + i))
        .collect();
    for g in 0..l.nodes() {
        if let Some(k) = l.kappa(g) {
            rows.extend(k..k + l.mc);
        }
    }
    if let Some(h) = l.hidden() {
        rows.extend(h..h + l.mc);
    }
    rows
}

/// ω = max_i |g_i| / d_i with g the gradient of the barrier problem (∇ℒ − z_l + z_u: at a
/// barrier's solution ∇ℒ itself is μ/(x − l) on bounded rows, not round-off) and
/// d_i = (|K||x|)_i (the border included), floored at 1e-8 of the largest d so that rows
/// whose terms all vanish are held to the largest row's scale; and the rounding of ‖c‖₁,
/// 10 ε Σ d_i over the multiplier rows.
fn backward_error(
    band: &BandMatrix,
    bw: usize,
    it: &Iterate,
    bounds: &[Bound],
    border: &Border,
    grad: &[f64],
    lambda_rows: &[usize],
) -> (f64, f64) {
    let mut grad = grad.to_vec();
    for (k, b) in bounds.iter().enumerate() {
        if let Some(i) = b.var {
            grad[i] += it.zu[k] - it.zl[k];
        }
    }
    let size = band.size();
    let scale: Vec<f64> = (0..size)
        .map(|i| {
            let j1 = (i + bw).min(size.saturating_sub(1));
            let row: f64 = (i.saturating_sub(bw)..=j1)
                .map(|j| band.get(i, j).abs() * it.x[j].abs())
                .sum();
            row + border.col[i].abs() * it.t1.abs()
        })
        .collect();
    let floor = 1e-8 * scale.iter().fold(0.0f64, |m, v| m.max(*v));
    let rows = grad
        .iter()
        .zip(&scale)
        .map(|(g, d)| g.abs() / d.max(floor).max(f64::MIN_POSITIVE));
    let omega = rows.fold(0.0f64, |m, v| if v.is_nan() { f64::NAN } else { m.max(v) });
    let c_noise = 10.0 * f64::EPSILON * lambda_rows.iter().map(|&i| scale[i]).sum::<f64>();
    (omega, c_noise)
}

/// ‖c‖∞, the scaled optimality residual and the complementarity at barrier μ.
#[allow(clippy::too_many_arguments)]
fn residuals<L: Lagrangian + ?Sized, C: Controls>(
    model: &Model<'_, L, C>,
    it: &Iterate,
    bounds: &[Bound],
    grad: &[f64],
    grad_t: f64,
    lambda_rows: &[usize],
    mu: f64,
) -> Residuals {
    let violation = lambda_rows.iter().map(|&i| grad[i].abs()).fold(0.0, f64::max);
    let mut g = grad.to_vec();
    let mut gt = grad_t;
    let mut complementarity = 0.0f64;
    for (k, b) in bounds.iter().enumerate() {
        let x = value_of(it, b);
        let z = it.zu[k] - it.zl[k];
        match b.var {
            Some(i) => g[i] += z,
            None => gt += z,
        }
        if b.lo.is_finite() {
            complementarity = complementarity.max((it.zl[k] * (x - b.lo) - mu).abs());
        }
        if b.up.is_finite() {
            complementarity = complementarity.max((it.zu[k] * (b.up - x) - mu).abs());
        }
    }
    lambda_rows.iter().for_each(|&i| g[i] = 0.0);
    let h = model.step(it.t1);
    let optimality = g.iter().fold(gt.abs(), |m, v| m.max(v.abs())) / h;
    Residuals {
        violation,
        optimality,
        complementarity,
    }
}
