//! One sweep of the fixed-point step (`super`): the starting points, the forces and jets at
//! the current points, the parts of the points without the multipliers, and the new points
//! from the solved multipliers.

use super::super::small::mass_solve;
use super::super::Constraints;
use super::{all_finite, ShakeStep};

/// Whether the start extrapolates the last two elements (else the last one).
const TWO_ELEMENT_START: bool = true;
use crate::lagrangian::{Lagrangian, MassMatrix};

impl ShakeStep {
    /// h a_l, h² B_l· (and h α_s, h² β_s·) for the step h (kept while h repeats).
    pub(super) fn scale_tables(&mut self, h: f64) {
        if h == self.h_tables {
            return;
        }
        let h2 = h * h;
        let w = self.r + 1;
        for (hrow, row) in self.htab.chunks_exact_mut(w).zip(self.tab.chunks_exact(w)) {
            hrow[0] = h * row[0];
            for (x, &y) in hrow[1..].iter_mut().zip(&row[1..]) {
                *x = h2 * y;
            }
        }
        self.h_tables = h;
    }
    /// The starting points: the last element's polynomial extrapolated, or the straight line
    /// with velocity `v` on the first step.
    pub(super) fn guess(&mut self, h: f64, v: &[f64]) {
        let (n, s, r) = (self.n, self.s, self.r);
        if !self.have_last {
            for (l, row) in self.pts.chunks_exact_mut(n).enumerate() {
                let c = if l < r { self.c[l] } else { 1.0 };
                for (y, &vc) in row.iter_mut().zip(v) {
                    *y = c * h * vc;
                }
            }
            return;
        }
        if self.have_last2 && TWO_ELEMENT_START {
            self.guess_from_two(h);
            return;
        }
        let rho = h / self.last_h;
        let (w, end) = (s + 1, s * n);
        if rho != self.rho {
            for l in 0..=r {
                let tau = 1.0 + rho * if l < r { self.c[l] } else { 1.0 };
                self.lagrange.values_in_place(tau, &mut self.extrap[l * w..(l + 1) * w]);
            }
            self.rho = rho;
        }
        let last_end = &self.last[end..];
        for (row, basis) in self.pts.chunks_exact_mut(n).zip(self.extrap.chunks_exact(w)) {
            for (a, o) in row.iter_mut().enumerate() {
                *o = basis
                    .iter()
                    .zip(self.last.chunks_exact(n))
                    .map(|(bj, node)| bj * (node[a] - last_end[a]))
                    .sum();
            }
        }
    }

    /// The start from the polynomial through the 2s + 1 nodes of the last two elements (times
    /// in steps h from t_k: ρ₁(τ_j − 1) for the last, −ρ₁ + ρ₂(τ_j − 1) for the one before,
    /// ρ = their step over h), evaluated at the stages and the end.
    fn guess_from_two(&mut self, h: f64) {
        let (n, s, r) = (self.n, self.s, self.r);
        let rho = (self.last_h / h, self.last_h2 / h);
        let np = 2 * s + 1;
        if rho != self.rho2 {
            let tau = &self.lagrange.nodes;
            for j in 0..s {
                self.xs[j] = -rho.0 + rho.1 * (tau[j] - 1.0);
            }
            for j in 0..=s {
                self.xs[s + j] = rho.0 * (tau[j] - 1.0);
            }
            for l in 0..=r {
                let x = if l < r { self.c[l] } else { 1.0 };
                for p in 0..np {
                    let xp = self.xs[p];
                    self.extrap2[l * np + p] = (0..np)
                        .filter(|&q| q != p)
                        .map(|q| (x - self.xs[q]) / (xp - self.xs[q]))
                        .product();
                }
            }
            self.rho2 = rho;
        }
        let end = s * n;
        for a in 0..n {
            let (e1, e2) = (self.last[end + a], self.last2[end + a]);
            for j in 0..s {
                self.vals[j] = (self.last2[j * n + a] - e2) - e1;
            }
            for j in 0..=s {
                self.vals[s + j] = self.last[j * n + a] - e1;
            }
            for (l, basis) in self.extrap2.chunks_exact(np).enumerate() {
                self.pts[l * n + a] = basis.iter().zip(&self.vals).map(|(b, v)| b * v).sum();
            }
        }
    }
    /// Forces, jets and W at the current points and the end jet at the node to be committed;
    /// false if anything is not finite.
    pub(super) fn evaluate<L: Lagrangian, C: Constraints>(
        &mut self,
        (lag, mass, con): (&L, &MassMatrix, &C),
        (t, h): (f64, f64),
        q: &[f64],
        comp: &[f64],
    ) -> bool {
        let (n, m, r) = (self.n, self.m, self.r);
        let mut finite = true;
        let stages = self
            .pts
            .chunks_exact(n)
            .zip(self.f.chunks_exact_mut(n))
            .zip(self.mf.chunks_exact_mut(n));
        for (l, ((y, f), mf)) in stages.enumerate() {
            for ((x, &qa), &ya) in self.pos.iter_mut().zip(q).zip(y) {
                *x = qa + ya;
            }
            lag.force(t + self.c[l] * h, &self.pos, f);
            mass_solve(mass, f, mf);
            finite &= f.iter().all(|x| x.is_finite());
            if self.points {
                let jet = &mut self.jets[l];
                jet.eval(con, &self.pos, false);
                finite &= all_finite(jet);
                let wl = &mut self.w[l * m * n..(l + 1) * m * n];
                for (row, g) in wl.chunks_exact_mut(n).zip(jet.jac.chunks_exact(n)) {
                    mass_solve(mass, g, row);
                }
            }
        }
        let dqs = &self.pts[r * n..];
        for (((x, &qa), &d), &c) in self.pos.iter_mut().zip(q).zip(dqs).zip(comp) {
            *x = qa + (d + c);
        }
        let end = &mut self.jets[r];
        end.eval(con, &self.pos, false);
        finite && all_finite(end)
    }
    /// The parts of Y_l and ΔQ^s without the multipliers: h a_l u + h² Σ_i B_li M⁻¹f_i.
    pub(super) fn free_parts(&mut self) {
        let (n, r) = (self.n, self.r);
        let w = r + 1;
        for l in 0..w {
            let (row, out) = (l * w, l * n);
            for c in 0..n {
                let mut x = self.htab[row] * self.u[c];
                for i in 0..r {
                    x += self.htab[row + 1 + i] * self.mf[i * n + c];
                }
                self.free[out + c] = x;
            }
        }
    }
    /// The new points from the solved unknowns: Y_l = free_l − a_l W(q_k)u₀ − Σ_i B_li κ_i W_i Λ_i
    /// (and ΔQ^s with α_s, β_s·); returns the largest change.
    pub(super) fn update(&mut self) -> f64 {
        let (n, m, r, sites) = (self.n, self.m, self.r, self.sites);
        let w = r + 1;
        // W(q_k) u₀ into row r of `wl`, κ_i W_i Λ_i into row i.
        let wk = r * m * n;
        for c in 0..n {
            let mut x = 0.0;
            for e in 0..m {
                x += self.z[e] * self.w[wk + e * n + c];
            }
            self.wl[r * n + c] = x;
        }
        if self.points {
            for i in 0..r {
                for e in 0..m {
                    let psi = &self.psi[i * sites..(i + 1) * sites];
                    self.lam[i * m + e] = psi.iter().enumerate().map(|(c, p)| p * self.z[m + c * m + e]).sum();
                }
                for c in 0..n {
                    let mut x = 0.0;
                    for e in 0..m {
                        x += (self.kappa[i] * self.lam[i * m + e]) * self.w[(i * m + e) * n + c];
                    }
                    self.wl[i * n + c] = x;
                }
            }
        }
        let mut change = 0.0f64;
        for l in 0..w {
            let row = l * w;
            for a in 0..n {
                let mut x = self.free[l * n + a] - self.tab[row] * self.wl[r * n + a];
                if self.points {
                    for i in 0..r {
                        x -= self.tab[row + 1 + i] * self.wl[i * n + a];
                    }
                }
                let old = &mut self.pts[l * n + a];
                change = change.max((x - *old).abs());
                *old = x;
            }
        }
        change
    }
}
