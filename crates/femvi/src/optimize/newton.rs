//! The optimiser's Newton step: the banded KKT system (`kkt.rs`) with the barrier's Σ on the
//! diagonal, its Hessian block raised by δI until the curvature along the step is positive
//! (the inertia-free test of Chiang and Zavala, 2016), δ shrinking between steps.

use super::assemble::{Border, Model};
use super::iterate::{value_of, Bound, Iterate};
use super::kkt::bordered_solve;
use super::system::Controls;
use crate::error::Result;
use crate::lagrangian::Lagrangian;
use crate::solve::BandMatrix;

/// The Newton step (dx over the banded unknowns, dt1), with the Hessian block raised until
/// its curvature along the step is positive. `None` if no regularisation makes the matrix
/// factorisable. `band`, `grad` and `border` hold the system assembled at `it`; a retry
/// assembles them again.
#[allow(clippy::too_many_arguments)]
pub(super) fn newton_step<L: Lagrangian + ?Sized, C: Controls>(
    model: &Model<'_, L, C>,
    band: &mut BandMatrix,
    grad: &mut [f64],
    border: &mut Border,
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
    let mut tries = 0;
    loop {
        if tries > 0 {
            // The factorisation overwrote the matrix: a retry assembles it again (the same
            // arithmetic, so the same bits) rather than keeping a copy, which doubled the
            // peak memory.
            model.assemble(&it.x, it.t1, band, grad, border)?;
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
