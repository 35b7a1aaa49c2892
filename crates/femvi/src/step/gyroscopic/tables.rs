//! The tables of the gyroscopic fixed point (the module above derives them): α, γ, β from the
//! inverse of the element's stiffness block in double-double, the basis at the quadrature
//! points and the midpoint, and their scaling by one step h.

use crate::discrete::Element;
use crate::error::{invalid, Result};
use crate::fem::dd::Dd;
use crate::step::fixed_point::{basis_dd, invert};

/// The h-independent tables (double-double, rounded when scaled by h).
#[derive(Debug, Clone)]
pub(super) struct Tables {
    /// α_m (m = 1 … s).
    pub(super) alpha: Vec<Dd>,
    /// γ_mi and β_mi, row-major s×r.
    pub(super) gamma: Vec<Dd>,
    pub(super) beta: Vec<Dd>,
    /// ℓ_m(c_l) and ℓ_m'(c_l) for m = 1 … s, column-major r×s (entry (l, m) at m r + l,
    /// as [`affine`] takes them).
    pub(super) pos: Vec<f64>,
    pub(super) vel: Vec<Dd>,
    /// ℓ_m(½), m = 1 … s (the element's midpoint).
    pub(super) mid: Vec<f64>,
}

impl Tables {
    pub(super) fn new(element: &Element) -> Result<Self> {
        element.check_nondegenerate()?;
        let (s, r, w) = (element.degree(), element.points(), element.degree() + 1);
        let tau: Vec<Dd> = element.basis.nodes.iter().map(|&t| Dd::new(t)).collect();
        let (phi, dphi) = basis_dd(&tau, &element.rule.nodes);
        let bw: Vec<Dd> = element.rule.weights.iter().map(|&b| Dd::new(b)).collect();
        let mut k = vec![Dd::new(0.0); s * s];
        for j in 0..s {
            for m in 0..s {
                let mut acc = Dd::new(0.0);
                for i in 0..r {
                    acc = acc.add(bw[i].mul(dphi[i * w + j]).mul(dphi[i * w + m + 1]));
                }
                k[j * s + m] = acc;
            }
        }
        let inv = invert(s, k).ok_or_else(|| invalid("scheme", "the element stiffness is singular"))?;
        let alpha = (0..s).map(|m| inv[m * s].neg()).collect();
        let mut gamma = vec![Dd::new(0.0); s * r];
        let mut beta = vec![Dd::new(0.0); s * r];
        for m in 0..s {
            for i in 0..r {
                let (mut g, mut b) = (Dd::new(0.0), Dd::new(0.0));
                for j in 0..s {
                    g = g.add(inv[m * s + j].mul(bw[i]).mul(dphi[i * w + j]));
                    b = b.add(inv[m * s + j].mul(bw[i]).mul(phi[i * w + j]));
                }
                gamma[m * r + i] = g.neg();
                beta[m * r + i] = b.neg();
            }
        }
        let pos = (0..r * s).map(|k| phi[(k % r) * w + k / r + 1].round()).collect();
        let vel = (0..r * s).map(|k| dphi[(k % r) * w + k / r + 1]).collect();
        let (half, _) = basis_dd(&tau, &[0.5]);
        let mid = half[1..].iter().map(|x| x.round()).collect();
        Ok(Self {
            alpha,
            gamma,
            beta,
            pos,
            vel,
            mid,
        })
    }
}

/// The tables scaled by one step h.
#[derive(Debug, Clone)]
pub(super) struct Scaled {
    pub(super) h_bits: u64,
    /// h α_m.
    pub(super) ha: Vec<f64>,
    /// Column-major 2r × s (column j contiguous): h γ_·i in column 2i, h² β_·i in column
    /// 2i + 1, so that the gyroscopic terms (A_i, g_i by point) are its right-hand side as
    /// they come.
    pub(super) mat: Vec<f64>,
    /// The stages from the increments in one map: column-major 2r × s (column m contiguous),
    /// rows l < r the positions' ℓ_m(c_l) (`Tables::pos`), rows r + l the velocities'
    /// ℓ_m'(c_l)/h; `stage_a` the coefficients of q_k, ones for positions and zeros for
    /// velocities (the stage positions are q_k + Σ_m ℓ_m(c_l) ΔQ^m).
    pub(super) stage_tab: Vec<f64>,
    pub(super) stage_a: Vec<f64>,
    /// h b_i and its rounding error.
    pub(super) hw: Vec<f64>,
    pub(super) hw_lo: Vec<f64>,
}

impl Scaled {
    /// Unbuilt tables for degree s with r points.
    pub(super) fn new(s: usize, r: usize) -> Self {
        Self {
            h_bits: f64::NAN.to_bits(),
            ha: vec![0.0; s],
            mat: vec![0.0; 2 * r * s],
            stage_tab: vec![0.0; 2 * r * s],
            stage_a: (0..2 * r).map(|l| if l < r { 1.0 } else { 0.0 }).collect(),
            hw: vec![0.0; r],
            hw_lo: vec![0.0; r],
        }
    }

    pub(super) fn build(&mut self, tab: &Tables, weights: &[f64], h: f64) {
        let (s, r) = (tab.alpha.len(), weights.len());
        self.h_bits = h.to_bits();
        let (hd, h2) = (Dd::new(h), Dd::two_prod(h, h));
        for m in 0..s {
            self.ha[m] = hd.mul(tab.alpha[m]).round();
            for i in 0..r {
                self.mat[2 * i * s + m] = hd.mul(tab.gamma[m * r + i]).round();
                self.mat[(2 * i + 1) * s + m] = h2.mul(tab.beta[m * r + i]).round();
            }
        }
        for (col, (pos, vel)) in self
            .stage_tab
            .chunks_exact_mut(2 * r)
            .zip(tab.pos.chunks_exact(r).zip(tab.vel.chunks_exact(r)))
        {
            let (p, v) = col.split_at_mut(r);
            p.copy_from_slice(pos);
            for (v, d) in v.iter_mut().zip(vel) {
                *v = d.divf(h).round();
            }
        }
        for (i, &b) in weights.iter().enumerate() {
            let x = Dd::two_prod(h, b);
            self.hw[i] = x.round();
            self.hw_lo[i] = x.sub(Dd::new(self.hw[i])).round();
        }
    }
}
