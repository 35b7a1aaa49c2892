//! The multipliers of one sweep of the fixed-point step (`super`): the constraint rows
//! linearised at the current points, a dense system of m(1 + I) unknowns.

use super::super::jet::ConstraintJet;
use super::super::small::{copy, dot};
use super::ShakeStep;

impl ShakeStep {
    /// G_l,e · W_i,e2 for the row points l and column points i that the system reads.
    pub(super) fn dot_products(&mut self) {
        let (n, m, r) = (self.n, self.m, self.r);
        let w = r + 1;
        let all = if self.points { 0 } else { r };
        for l in all..w {
            for (e, g) in self.jets[l].jac.chunks_exact(n).enumerate() {
                let base = (l * m + e) * w * m;
                for i in all..w {
                    let cols = &self.w[i * m * n..(i + 1) * m * n];
                    for (e2, col) in cols.chunks_exact(n).enumerate() {
                        self.dots[base + i * m + e2] = dot(g, col);
                    }
                }
            }
        }
    }
    /// The constraint rows linearised at the current points, in the unknowns (u₀, U):
    /// G_end·(new ΔQ^s − ΔQ^s) = −g_end and Σ_l ω_l Ψ_lc G_l·(new Y_l − Y_l) = −Σ_l ω_l Ψ_lc g_l,
    /// with new Y_l = free_l − a_l W(q_k) u₀ − Σ_i B_li κ_i W_i Σ_c Ψ_ic U_c.
    pub(super) fn system(&mut self) {
        let (m, r, sites) = (self.m, self.r, self.sites);
        let (w, k_all) = (r + 1, self.z.len());
        let all = if self.points { 0 } else { r };
        // The row of (l, e) in every unknown, and its right-hand side G·(Y − free) − g.
        for l in all..w {
            for e in 0..m {
                let d = &self.dots[(l * m + e) * w * m..(l * m + e + 1) * w * m];
                let row = &mut self.rows[(l * m + e) * k_all..(l * m + e + 1) * k_all];
                let (u0, sites_part) = row.split_at_mut(m);
                let a = self.tab[l * w];
                for (x, &dk) in u0.iter_mut().zip(&d[r * m..]) {
                    *x = -a * dk;
                }
                let tb = &self.tb[l * r * sites..(l + 1) * r * sites];
                for (c2, block) in sites_part.chunks_exact_mut(m).enumerate() {
                    for (e2, x) in block.iter_mut().enumerate() {
                        let mut acc = 0.0;
                        for (tbi, di) in tb.chunks_exact(sites).zip(d.chunks_exact(m)) {
                            acc += tbi[c2] * di[e2];
                        }
                        *x = -acc;
                    }
                }
            }
        }
        let end = &self.jets[r];
        for e in 0..m {
            let src = &self.rows[(r * m + e) * k_all..(r * m + e + 1) * k_all];
            copy(&mut self.mat[e * k_all..(e + 1) * k_all], src);
            self.rhs[e] = self.residual_row(r, e, end);
        }
        for c in 0..sites {
            for e in 0..m {
                let row = m + c * m + e;
                let mut rhs = 0.0;
                self.mat[row * k_all..(row + 1) * k_all]
                    .iter_mut()
                    .for_each(|x| *x = 0.0);
                for l in 0..r {
                    let wp = self.ta[c * r + l];
                    let src = &self.rows[(l * m + e) * k_all..(l * m + e + 1) * k_all];
                    for (x, &y) in self.mat[row * k_all..(row + 1) * k_all].iter_mut().zip(src) {
                        *x += wp * y;
                    }
                    rhs += wp * self.residual_row(l, e, &self.jets[l]);
                }
                self.rhs[row] = rhs;
            }
        }
    }
    /// G_l,e · (Y_l − free_l) − g_l,e: the right-hand side of the linearised constraint e at
    /// row point l.
    pub(super) fn residual_row(&self, l: usize, e: usize, jet: &ConstraintJet) -> f64 {
        let n = self.n;
        let g = &jet.jac[e * n..(e + 1) * n];
        let (y, fr) = (&self.pts[l * n..(l + 1) * n], &self.free[l * n..(l + 1) * n]);
        dot(g, y) - dot(g, fr) - jet.g[e]
    }
}
