//! The multipliers of one sweep of the fixed-point step (`super`): the constraint rows
//! linearised at the current points, a dense system of m(1 + I) unknowns.

use super::super::jet::ConstraintJet;
use super::super::small::dot;
use super::ShakeStep;

impl ShakeStep {
    /// G_l,e · W_i,e2 for the row points l and column points i that the system reads.
    /// (Index arithmetic rather than `chunks_exact` over run-time sizes: each of those divides.)
    pub(super) fn dot_products(&mut self) {
        let (n, m, r) = (self.n, self.m, self.r);
        let (w, mw) = (r + 1, m * (r + 1));
        let first = if self.points { 0 } else { r };
        for l in first..w {
            let jac = &self.jets[l].jac;
            for e in 0..m {
                let g = &jac[e * n..(e + 1) * n];
                let base = (l * m + e) * mw;
                for i in first..w {
                    for e2 in 0..m {
                        let col = (i * m + e2) * n;
                        self.dots[base + i * m + e2] = dot(g, &self.w[col..col + n]);
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
        let (w, k_all, mw) = (r + 1, self.z.len(), m * (r + 1));
        let first = if self.points { 0 } else { r };
        // The row of (l, e) in every unknown.
        for l in first..w {
            let a = self.tab[l * w];
            let tb = l * r * sites;
            for e in 0..m {
                let (d, row) = ((l * m + e) * mw, (l * m + e) * k_all);
                for k in 0..m {
                    self.rows[row + k] = -a * self.dots[d + r * m + k];
                }
                for c2 in 0..sites {
                    for e2 in 0..m {
                        let mut acc = 0.0;
                        for i in 0..r {
                            acc += self.tb[tb + i * sites + c2] * self.dots[d + i * m + e2];
                        }
                        self.rows[row + m + c2 * m + e2] = -acc;
                    }
                }
            }
        }
        // The end rows as they are, the site rows weighted by ω_l Ψ_lc; right-hand sides
        // G·(Y − free) − g.
        for e in 0..m {
            let src = (r * m + e) * k_all;
            for k in 0..k_all {
                self.mat[e * k_all + k] = self.rows[src + k];
            }
            self.rhs[e] = self.residual_row(r, e, &self.jets[r]);
        }
        for c in 0..sites {
            for e in 0..m {
                let row = (m + c * m + e) * k_all;
                for k in 0..k_all {
                    self.mat[row + k] = 0.0;
                }
                let mut rhs = 0.0;
                for l in 0..r {
                    let wp = self.ta[c * r + l];
                    let src = (l * m + e) * k_all;
                    for k in 0..k_all {
                        self.mat[row + k] += wp * self.rows[src + k];
                    }
                    rhs += wp * self.residual_row(l, e, &self.jets[l]);
                }
                self.rhs[m + c * m + e] = rhs;
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
