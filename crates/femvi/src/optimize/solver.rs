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
use super::kkt::{bordered_solve, dot};
use super::system::Controls;
use crate::error::Result;
use crate::lagrangian::Lagrangian;
use crate::solve::BandMatrix;

/// A bounded unknown: a banded index or the final time, with its bounds (infinite when
/// absent).
#[derive(Debug, Clone, Copy)]
pub(super) struct Bound {
    pub(super) var: Option<usize>,
    pub(super) lo: f64,
    pub(super) up: f64,
}

/// The iterate: banded unknowns (positions, controls, multipliers), final time, bound duals.
#[derive(Debug, Clone)]
pub(super) struct Iterate {
    pub(super) x: Vec<f64>,
    pub(super) t1: f64,
    pub(super) zl: Vec<f64>,
    pub(super) zu: Vec<f64>,
}

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

fn value_of(it: &Iterate, b: &Bound) -> f64 {
    b.var.map_or(it.t1, |i| it.x[i])
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
        super::multipliers::least_squares(model, &mut it, bounds, &lambda_rows)?;
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
            &grad,
            &border,
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
        // Fraction to the boundary for the primal step; the duals' steps.
        let tau = 0.99f64.max(1.0 - mu);
        let mut alpha = 1.0f64;
        let mut dz = Vec::with_capacity(bounds.len());
        for (k, b) in bounds.iter().enumerate() {
            let (x, d) = (value_of(&it, b), b.var.map_or(dt, |i| dx[i]));
            if b.lo.is_finite() && d < 0.0 {
                alpha = alpha.min(-tau * (x - b.lo) / d);
            }
            if b.up.is_finite() && d > 0.0 {
                alpha = alpha.min(tau * (b.up - x) / d);
            }
            let dzl = if b.lo.is_finite() {
                mu / (x - b.lo) - it.zl[k] - it.zl[k] / (x - b.lo) * d
            } else {
                0.0
            };
            let dzu = if b.up.is_finite() {
                mu / (b.up - x) - it.zu[k] + it.zu[k] / (b.up - x) * d
            } else {
                0.0
            };
            dz.push((dzl, dzu));
        }
        let mut alpha_z = 1.0f64;
        for (k, &(dzl, dzu)) in dz.iter().enumerate() {
            if dzl < 0.0 {
                alpha_z = alpha_z.min(-tau * it.zl[k] / dzl);
            }
            if dzu < 0.0 {
                alpha_z = alpha_z.min(-tau * it.zu[k] / dzu);
            }
        }
        // Line search on the exact penalty.
        let lam_new = lambda_rows.iter().map(|&i| (it.x[i] + dx[i]).abs()).fold(0.0, f64::max);
        // Powell's update: ν stays above the multipliers but relaxes towards them, so that
        // one wild early step does not leave a penalty that shortens every later step. (A
        // monotone ν = max(ν, 1.1|Λ|) took the constrained free-end pendulum at 200
        // elements, degree 1, 83 iterations, and failed at 400; with this update 28 and 46.)
        nu = (1.1 * lam_new).max(0.5 * (nu + 1.1 * lam_new)).max(1.0);
        let vals = model.values(&it.x, it.t1);
        let c1: f64 = lambda_rows.iter().map(|&i| vals.c[i].abs()).sum();
        let phi0 = vals.objective + barrier(&it, bounds, mu) + nu * c1;
        let gbar = barrier_gradient(&it, bounds, &grad, border.grad, &lambda_rows, mu, &dx, dt);
        let slope = gbar - nu * c1 + lambda_rows.iter().map(|&i| it.x[i] * vals.c[i]).sum::<f64>();
        let merit = |trial: &Iterate| {
            let tv = model.values(&trial.x, trial.t1);
            let tc: f64 = lambda_rows.iter().map(|&i| tv.c[i].abs()).sum();
            (tv.objective + barrier(trial, bounds, mu) + nu * tc, tv.c)
        };
        // A decrease below the rounding of φ itself cannot be asked for: that of J, and ν
        // times that of ‖c‖₁, whose rows are sums of terms of size (|K||x|)_i (at 10⁴
        // elements ν‖c‖₁ rounds at 1e-6 while a step near the optimum gains 1e-8).
        let noise = 10.0 * f64::EPSILON * phi0.abs() + nu * c_noise;
        let armijo =
            |phi: f64, alpha: f64| phi.is_finite() && (slope >= 0.0 || phi <= phi0 + 1e-4 * alpha * slope + noise);
        let mut accepted = None;
        for _ in 0..40 {
            let trial = moved(&it, &dx, dt, alpha);
            let (phi, c) = merit(&trial);
            if armijo(phi, alpha) {
                accepted = Some(trial);
                break;
            }
            if alpha == 1.0 {
                // A second-order correction of the full step (against the Maratos effect):
                // the least change that removes the constraint residual the step left.
                let mut soc = vec![0.0; dx.len()];
                lambda_rows.iter().for_each(|&i| soc[i] = -c[i]);
                if let Some(dts) = bordered_solve(&band, model.free, &border.col, diag, &mut soc, 0.0)? {
                    let mut corrected = trial.clone();
                    corrected.x.iter_mut().zip(&soc).for_each(|(x, d)| *x += d);
                    corrected.t1 += dts;
                    if within(&corrected, bounds) && armijo(merit(&corrected).0, 1.0) {
                        accepted = Some(corrected);
                        break;
                    }
                }
            }
            alpha *= 0.5;
        }
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

/// The sizes of the last two steps (max |Δxᵢ| / (1 + |xᵢ|), the final time's included) at
/// the current barrier, for the round-off stop: Newton's full steps shrink at least
/// quadratically until the round-off of the residual they correct is all that is left, then
/// they stay at its size. So a full step no smaller than half the full step before it
/// marks the floor; so do four iterations already taken in the noise (a floor that keeps
/// moving).
#[derive(Debug, Clone, Copy, Default)]
struct Floor {
    last: Option<(f64, bool)>,
    before: Option<(f64, bool)>,
    /// Iterations that went on at the smallest barrier with the backward error in the noise.
    noisy: usize,
}

impl Floor {
    fn push(&mut self, size: f64, full: bool) {
        self.before = self.last;
        self.last = Some((size, full));
    }

    fn reached(&self) -> bool {
        let stalled = match (self.before, self.last) {
            (Some((a, true)), Some((b, true))) => b >= 0.5 * a,
            _ => false,
        };
        stalled || self.noisy >= 4
    }
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

/// The step from `it` by α (multipliers too).
fn moved(it: &Iterate, dx: &[f64], dt: f64, alpha: f64) -> Iterate {
    let mut next = it.clone();
    next.x.iter_mut().zip(dx).for_each(|(x, d)| *x += alpha * d);
    next.t1 += alpha * dt;
    next
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

/// Whether every bounded unknown is strictly inside its bounds.
fn within(it: &Iterate, bounds: &[Bound]) -> bool {
    bounds.iter().all(|b| {
        let x = value_of(it, b);
        x > b.lo && x < b.up
    })
}

/// −μ Σ ln(x − l) + ln(u − x); +∞ outside the bounds.
fn barrier(it: &Iterate, bounds: &[Bound], mu: f64) -> f64 {
    let mut s = 0.0;
    for b in bounds {
        let x = value_of(it, b);
        for gap in [x - b.lo, b.up - x] {
            if gap.is_finite() {
                s -= if gap > 0.0 { mu * gap.ln() } else { f64::NEG_INFINITY };
            }
        }
    }
    s
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

/// ∇J_μ·d less the multiplier part: g_μ·dx where g_μ is the barrier gradient of the KKT
/// Lagrangian (the Λ·c term is added by the caller).
#[allow(clippy::too_many_arguments)]
fn barrier_gradient(
    it: &Iterate,
    bounds: &[Bound],
    grad: &[f64],
    grad_t: f64,
    lambda_rows: &[usize],
    mu: f64,
    dx: &[f64],
    dt: f64,
) -> f64 {
    let mut s = dot(grad, dx) + grad_t * dt - lambda_rows.iter().map(|&i| grad[i] * dx[i]).sum::<f64>();
    for b in bounds {
        let x = value_of(it, b);
        let d = b.var.map_or(dt, |i| dx[i]);
        if b.lo.is_finite() {
            s -= mu / (x - b.lo) * d;
        }
        if b.up.is_finite() {
            s += mu / (b.up - x) * d;
        }
    }
    s
}

/// The Newton step (dx over the banded unknowns, dt1), with the Hessian block raised until
/// its curvature along the step is positive. `None` if no regularisation makes the matrix
/// factorisable.
#[allow(clippy::too_many_arguments)]
fn newton_step<L: Lagrangian + ?Sized, C: Controls>(
    model: &Model<'_, L, C>,
    band: &mut BandMatrix,
    grad: &[f64],
    border: &Border,
    it: &Iterate,
    bounds: &[Bound],
    mu: f64,
    delta: &mut f64,
    lambda_rows: &[usize],
) -> Result<Option<(Vec<f64>, f64, f64)>> {
    let size = grad.len();
    let mut is_lambda = vec![false; size];
    lambda_rows.iter().for_each(|&i| is_lambda[i] = true);
    // Barrier gradient and Σ.
    let mut rhs: Vec<f64> = grad.iter().map(|g| -g).collect();
    let mut rho = -border.grad;
    let mut sigma = vec![0.0; size];
    let mut sigma_t = 0.0;
    for (k, b) in bounds.iter().enumerate() {
        let x = value_of(it, b);
        let (mut g, mut s) = (0.0, 0.0);
        if b.lo.is_finite() {
            g -= mu / (x - b.lo);
            s += it.zl[k] / (x - b.lo);
        }
        if b.up.is_finite() {
            g += mu / (b.up - x);
            s += it.zu[k] / (b.up - x);
        }
        match b.var {
            Some(i) => {
                rhs[i] -= g;
                sigma[i] += s;
            }
            None => {
                rho -= g;
                sigma_t += s;
            }
        }
    }
    // The assembled matrix is kept for the retries; the first try factors `band` as it is.
    let base = band.clone();
    let mut tries = 0;
    loop {
        if tries > 0 {
            band.clone_from(&base);
        }
        for i in (0..size).filter(|&i| !is_lambda[i]) {
            band.add(i, i, sigma[i] + *delta)?;
        }
        let diag = border.diag + sigma_t + if model.free { *delta } else { 0.0 };
        let mut d = rhs.clone();
        let solved = if band.factor() {
            bordered_solve(band, model.free, &border.col, diag, &mut d, rho)?
        } else {
            None
        };
        if let Some(dt) = solved {
            // dxᵀ W dx = −dx·g + dΛ·c with g the barrier gradient (rhs = −g, −c).
            let (mut curv, mut norm) = (0.0, 0.0);
            for i in 0..size {
                if is_lambda[i] {
                    curv -= d[i] * rhs[i];
                } else {
                    curv += d[i] * rhs[i];
                    norm += d[i] * d[i];
                }
            }
            curv += dt * rho;
            norm += dt * dt;
            if curv.is_finite() && curv >= 1e-8 * norm {
                // The next step tries a third of this, or none once it is small.
                *delta = if *delta < 1e-6 { 0.0 } else { *delta / 3.0 };
                return Ok(Some((d, dt, diag)));
            }
        }
        tries += 1;
        if tries > 30 {
            return Ok(None);
        }
        *delta = if *delta == 0.0 { 1e-4 } else { 10.0 * *delta };
    }
}
