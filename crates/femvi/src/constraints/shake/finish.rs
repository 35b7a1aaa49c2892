//! After the fixed-point step (`super`) converged: the unknowns in the dense step's layout,
//! the momentum before its projection, and the jet at the new node.

use super::super::jet::ConstraintJet;
use super::super::small::copy;
use super::ShakeStep;

impl ShakeStep {
    /// The jet (g, G) at the end node of the last [`ShakeStep::solve`]: the node that the
    /// compensated summation commits, q_k + (ΔQ^s + `comp`).
    pub fn end_jet(&self) -> &ConstraintJet {
        &self.jets[self.r]
    }
    /// After [`ShakeStep::solve`]: the unknowns in the dense step's layout into `x` (ΔQ^1 …
    /// ΔQ^s, then u₀ = hλ̂ and U = hΛ̂), p̃ into `ptilde` (from p_k; `start` the jet at q_k), and
    /// the element kept as the next step's start.
    pub fn finish(&mut self, start: &ConstraintJet, (h, p): (f64, &[f64]), x: &mut [f64]) {
        let (n, m, r, s) = (self.n, self.m, self.r, self.s);
        for j in 1..s {
            let (a, beta) = (self.fixed.alpha[j - 1], &self.fixed.beta[(j - 1) * r..j * r]);
            for c in 0..n {
                let mut acc = h * a * self.u[c] - a * self.wl[r * n + c];
                for (i, &bi) in beta.iter().enumerate() {
                    acc += h * h * bi * self.mf[i * n + c];
                    if self.points {
                        acc -= bi * self.wl[i * n + c];
                    }
                }
                x[(j - 1) * n + c] = acc;
            }
        }
        copy(&mut x[(s - 1) * n..s * n], &self.pts[r * n..]);
        copy(&mut x[s * n..s * n + self.z.len()], &self.z);
        // p̃ = p_k + [h Σ_i b_i f_i − G(q_k)ᵀλ̂ − Σ_i ω_i G(y_i)ᵀΛ_i].
        for (c, pt) in self.ptilde.iter_mut().enumerate() {
            *pt = h * (0..r).map(|i| self.b[i] * self.f[i * n + c]).sum::<f64>();
        }
        for (g, &z) in start.jac.chunks_exact(n).zip(&self.z[..m]) {
            let lam = z / h;
            for (pt, &ga) in self.ptilde.iter_mut().zip(g) {
                *pt -= lam * ga;
            }
        }
        if self.points {
            for (i, jet) in self.jets[..r].iter().enumerate() {
                for (g, &l) in jet.jac.chunks_exact(n).zip(&self.lam[i * m..(i + 1) * m]) {
                    let f = self.omega[i] * (l / h);
                    for (pt, &ga) in self.ptilde.iter_mut().zip(g) {
                        *pt -= f * ga;
                    }
                }
            }
        }
        for (pt, &pk) in self.ptilde.iter_mut().zip(p) {
            *pt += pk;
        }
        std::mem::swap(&mut self.last, &mut self.last2);
        (self.last_h2, self.have_last2) = (self.last_h, self.have_last);
        self.last[..n].iter_mut().for_each(|v| *v = 0.0);
        copy(&mut self.last[n..], &x[..s * n]);
        self.last_h = h;
        self.have_last = true;
    }
}
