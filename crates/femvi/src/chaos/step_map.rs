//! Tangent vectors through the last step in (q, p), whichever way the steps are chosen, all
//! through `Integrator::tangent_apply`: with steps as parameters by the mechanical tangent
//! (`step/tangent_mechanical.rs`) or `Integrator::tangent_map`; under forces by the forced
//! step's linearisation (`step/term_tangent.rs`); with time steps as variables (paper §3,
//! autonomous L) by the (q, p) block of the extended map on (q, t; p, −E) (the paper's (3.6)),
//! applied as one linearised solve per vector (`Integrator::extended_tangent_apply`: for
//! degree ≥ 2 the assembled map has entries of size 1/g_h that a product would lose digits
//! to). For autonomous L the energy-mode step keeps E exactly, so on vectors with
//! dt = dE = 0 the extended form dq∧dp − dt∧dE reduces to dq∧dp: the block is symplectic, the map of the discrete flow at the run's
//! energy. Whole-run sensitivities in energy mode also follow the carried energy's
//! dependence on the start (`ExtendedProduct`).

use crate::error::Result;
use crate::lagrangian::Lagrangian;
use crate::step::tangent_apply::extended_index;
use crate::step::Integrator;

/// The product of a run's step maps applied to the 2n start directions (dq, dp) — in energy
/// mode on extended phase space, so that the carried energy's dependence on the start (fixed
/// by the first element) is followed. Column-major, as `Integrator::tangent_apply` expects.
pub(crate) struct ExtendedProduct {
    n: usize,
    /// Rows per column: 2n, or 2n + 2 in energy mode.
    rows: usize,
    w: Vec<f64>,
}

impl ExtendedProduct {
    pub(crate) fn new(n: usize, energy: bool) -> Self {
        let rows = if energy { 2 * n + 2 } else { 2 * n };
        let mut w = vec![0.0; rows * 2 * n];
        for j in 0..2 * n {
            let i = if energy { extended_index(j, n) } else { j };
            w[j * rows + i] = 1.0;
        }
        Self { n, rows, w }
    }

    /// Applies the last step's map (energy mode: by one linearised solve per column, see the
    /// module docs).
    pub(crate) fn step<L: Lagrangian>(&mut self, it: &mut Integrator<'_, L>) -> Result<()> {
        if self.rows == 2 * self.n {
            it.tangent_apply(&mut self.w)
        } else {
            it.extended_tangent_apply(&mut self.w)
        }
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
