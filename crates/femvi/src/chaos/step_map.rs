//! The tangent map of the last step in (q, p), whichever way the steps are chosen: with steps
//! as parameters it is `Integrator::tangent_map`; with time steps as variables (paper §3,
//! autonomous L) it is the (q, p) block of the extended map on (q, t; p, −E)
//! (`Integrator::extended_tangent_map`, the paper's (3.6)). For autonomous L the energy-mode
//! step keeps E exactly, so on vectors with dt = dE = 0 the extended form dq∧dp − dt∧dE
//! reduces to dq∧dp: the block is symplectic, the map of the discrete flow at the run's
//! energy. Whole-run sensitivities in energy mode also follow the carried energy's
//! dependence on the start (`ExtendedProduct`).

use crate::error::Result;
use crate::lagrangian::Lagrangian;
use crate::step::Integrator;

/// Index of (q, p) component i (i < 2n) among the extended variables (q, t, p, −E).
fn extended_index(i: usize, n: usize) -> usize {
    if i < n {
        i
    } else {
        i + 1
    }
}

/// The last step's tangent map ∂(q', p')/∂(q, p), row-major 2n×2n (energy mode: at fixed
/// carried energy and time).
pub(crate) fn step_map<L: Lagrangian>(it: &mut Integrator<'_, L>) -> Result<Vec<f64>> {
    if it.energy_stats().is_none() {
        return it.tangent_map();
    }
    let n = it.lagrangian().dim();
    let (d, de) = (2 * n, 2 * n + 2);
    let ext = it.extended_tangent_map()?;
    let mut out = vec![0.0; d * d];
    for (i, row) in out.chunks_exact_mut(d).enumerate() {
        let ei = extended_index(i, n);
        for (j, x) in row.iter_mut().enumerate() {
            *x = ext[ei * de + extended_index(j, n)];
        }
    }
    Ok(out)
}

/// The product of a run's step maps applied to the 2n start directions (dq, dp) — in energy
/// mode on extended phase space, so that the carried energy's dependence on the start (fixed
/// by the first element) is followed. Column-major, as `accumulate::apply` expects.
pub(crate) struct ExtendedProduct {
    n: usize,
    /// Rows per column: 2n, or 2n + 2 in energy mode.
    rows: usize,
    w: Vec<f64>,
    tmp: Vec<f64>,
}

impl ExtendedProduct {
    pub(crate) fn new(n: usize, energy: bool) -> Self {
        let rows = if energy { 2 * n + 2 } else { 2 * n };
        let mut w = vec![0.0; rows * 2 * n];
        for j in 0..2 * n {
            let i = if energy { extended_index(j, n) } else { j };
            w[j * rows + i] = 1.0;
        }
        Self {
            n,
            rows,
            w,
            tmp: vec![0.0; rows],
        }
    }

    /// Applies the last step's map.
    pub(crate) fn step<L: Lagrangian>(&mut self, it: &mut Integrator<'_, L>) -> Result<()> {
        let m = if self.rows == 2 * self.n {
            it.tangent_map()?
        } else {
            it.extended_tangent_map()?
        };
        super::accumulate::apply(&m, self.rows, &mut self.w, &mut self.tmp);
        Ok(())
    }

    /// ∂(q_N, p_N)/∂(q_0, p_0), row-major 2n×2n.
    pub(crate) fn sensitivity(&self) -> Vec<f64> {
        let (n, d) = (self.n, 2 * self.n);
        let energy = self.rows != d;
        let mut out = vec![0.0; d * d];
        for (i, row) in out.chunks_exact_mut(d).enumerate() {
            let ri = if energy { extended_index(i, n) } else { i };
            for (j, x) in row.iter_mut().enumerate() {
                *x = self.w[j * self.rows + ri];
            }
        }
        out
    }
}
