//! The moving mesh (T. D. Lee's discrete mechanics, [`BvpOptions::moving_mesh`]): after the
//! fixed uniform mesh has been solved, the interior element end times t_1 … t_{N−1} become
//! unknowns beside the nodal values, and ∂S/∂t_k = 0 joins the equations — the discrete
//! energy equations (paper (3.3)), E_k⁺ of element k − 1 equal to E_k⁻ of element k. The
//! Newton iteration starts from the fixed mesh's solution at the uniform times.

use super::eval::Assembly;
use super::layout::Layout;
use super::newton::{newton, Converged};
use super::{qscale, BvpOptions};
use crate::error::Result;
use crate::lagrangian::Lagrangian;

/// Solves the moving-mesh problem from the fixed mesh's unknowns `x` (numbered by the fixed
/// layout of `asm`) on the `uniform` times, and leaves `asm` with the moving layout. Returns
/// the unknowns (numbered by the moving layout) and how the Newton iteration ended (the scaled
/// residual, reported only, measures the unknowns, times and nodal values, by the larger of
/// their scales; it does not stop the iteration here, see `newton.rs`).
pub(super) fn solve_moving<L: Lagrangian>(
    asm: &mut Assembly<'_, L>,
    x: &[f64],
    uniform: &[f64],
    options: BvpOptions,
) -> Result<(Vec<f64>, Converged)> {
    let (n, s, big_n, bv) = (asm.n, asm.element.degree(), asm.bv.elements, asm.bv);
    let moving = Layout {
        moving: true,
        ..asm.layout
    };
    asm.unpack(x);
    let mut y = vec![0.0; moving.len()];
    let mut is_time = vec![false; moving.len()];
    for g in 1..big_n * s {
        for c in 0..n {
            if let Some(i) = moving.node(g, c) {
                y[i] = asm.nodes[g * n + c];
            }
        }
    }
    for k in 1..big_n {
        if let Some(i) = moving.time(k) {
            y[i] = uniform[k];
            is_time[i] = true;
        }
    }
    asm.layout = moving;
    let tscale = bv.t0.abs().max(bv.t1.abs()).max(bv.t1 - bv.t0);
    // The nodal values' scale, as for the fixed mesh, over the entries that are not times.
    let qs = |x: &[f64]| {
        let qmax = x.iter().zip(&is_time).filter(|(_, t)| !**t).fold(0.0f64, |m, (v, _)| {
            if v.is_nan() {
                f64::NAN
            } else {
                m.max(v.abs())
            }
        });
        qscale(bv, &[qmax])
    };
    let rel = |x: &[f64], dx: &[f64]| {
        let qs = qs(x);
        dx.iter()
            .zip(&is_time)
            .map(|(d, &t)| d.abs() / if t { tscale } else { qs })
            .fold(0.0f64, |m, v| if v.is_nan() { f64::NAN } else { m.max(v) })
    };
    let done = newton(asm, &mut y, options, rel, |x| qs(x).max(tscale), false)?;
    Ok((y, done))
}
