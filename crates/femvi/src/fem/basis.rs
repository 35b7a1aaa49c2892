//! Lagrange shape functions of degree s on the reference element τ ∈ [0, 1]: the paper's
//! linear (2.24)–(2.25) and quadratic (2.34)–(2.37) hat functions, for any degree, with
//! equispaced nodes (as in the paper) or Gauss–Lobatto nodes (better conditioned for large s).
//!
//! Tabulated values are corrected so that Σ_j ℓ_j(c) = 1 and Σ_j ℓ_j'(c) = 0 hold to the last
//! rounding (DESIGN.md §2): the element is then invariant under translations of all
//! nodal values to the last bit, which keeps high-degree elements from drifting.

use super::quadrature::{QuadratureKind, QuadratureRule};
use crate::error::{invalid, Result};

/// The highest degree of a basis (and so of an element): tabulation costs O(r s²) and the
/// step O(r s n), and equispaced nodes are useless far below it.
pub const MAX_DEGREE: usize = 100;

/// How the nodes τ_0 = 0 < τ_1 < … < τ_s = 1 of an element are placed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NodeFamily {
    /// τ_j = j / s, as in the paper.
    Equispaced,
    /// The s + 1 Gauss–Lobatto points.
    Lobatto,
}

/// The Lagrange basis of one degree on [0, 1].
#[derive(Debug, Clone, PartialEq)]
pub struct LagrangeBasis {
    /// Polynomial degree s ≥ 1.
    pub degree: usize,
    /// Node family.
    pub family: NodeFamily,
    /// Nodes τ_0 … τ_s.
    pub nodes: Vec<f64>,
}

impl LagrangeBasis {
    /// The basis of degree `degree` on nodes of the given family.
    ///
    /// # Errors
    /// Degree 0, or a degree above [`MAX_DEGREE`].
    pub fn new(degree: usize, family: NodeFamily) -> Result<Self> {
        if degree == 0 {
            return Err(invalid("element degree", "the degree must be at least 1"));
        }
        if degree > MAX_DEGREE {
            return Err(invalid(
                "element degree",
                format!("{degree} is above the largest supported degree, {MAX_DEGREE}"),
            ));
        }
        let nodes = match family {
            NodeFamily::Equispaced => (0..=degree).map(|j| j as f64 / degree as f64).collect(),
            NodeFamily::Lobatto => QuadratureRule::new(QuadratureKind::GaussLobatto(degree + 1))?.nodes,
        };
        Ok(Self { degree, family, nodes })
    }

    /// Number of nodes, s + 1.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Always false: a basis has at least two nodes.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// ℓ_j(τ) for all j, written into `out` (length s + 1; any other length gets NaN).
    pub fn values_in_place(&self, tau: f64, out: &mut [f64]) {
        let nodes = &self.nodes;
        if out.len() != nodes.len() {
            out.iter_mut().for_each(|o| *o = f64::NAN);
            return;
        }
        for (j, o) in out.iter_mut().enumerate() {
            let mut v = 1.0;
            for (m, &tm) in nodes.iter().enumerate() {
                if m != j {
                    v *= (tau - tm) / (nodes[j] - tm);
                }
            }
            *o = v;
        }
    }

    /// ℓ_j'(τ) for all j, written into `out` (length s + 1; any other length gets NaN).
    pub fn derivatives_in_place(&self, tau: f64, out: &mut [f64]) {
        let nodes = &self.nodes;
        if out.len() != nodes.len() {
            out.iter_mut().for_each(|o| *o = f64::NAN);
            return;
        }
        for (j, o) in out.iter_mut().enumerate() {
            let mut sum = 0.0;
            for (m, &tm) in nodes.iter().enumerate() {
                if m == j {
                    continue;
                }
                let mut prod = 1.0 / (nodes[j] - tm);
                for (l, &tl) in nodes.iter().enumerate() {
                    if l != j && l != m {
                        prod *= (tau - tl) / (nodes[j] - tl);
                    }
                }
                sum += prod;
            }
            *o = sum;
        }
    }

    /// Values and derivatives at the points `c`, as row-major tables (row i = point c_i),
    /// corrected so that each row of values sums to exactly 1 and each row of derivatives
    /// to exactly 0.
    pub fn tabulate(&self, c: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let w = self.len();
        let mut phi = vec![0.0; c.len() * w];
        let mut dphi = vec![0.0; c.len() * w];
        for (i, &ci) in c.iter().enumerate() {
            let row = &mut phi[i * w..(i + 1) * w];
            self.values_in_place(ci, row);
            fix_sum(row, 1.0);
            let row = &mut dphi[i * w..(i + 1) * w];
            self.derivatives_in_place(ci, row);
            fix_sum(row, 0.0);
        }
        (phi, dphi)
    }
}

/// Makes `row` sum to `target` in floating point by setting its largest entry to the target
/// minus the sum of the others (the smallest relative change).
fn fix_sum(row: &mut [f64], target: f64) {
    if row.is_empty() {
        return;
    }
    let big = (0..row.len())
        .max_by(|&a, &b| row[a].abs().total_cmp(&row[b].abs()))
        .unwrap_or(0);
    let others: f64 = row.iter().enumerate().filter(|&(j, _)| j != big).map(|(_, v)| v).sum();
    row[big] = target - others;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_shape_functions() {
        // (2.34)–(2.37) on the reference element: f_k = (2τ − 1)(τ − 1), f_{k+1/2} = 4τ(1 − τ),
        // f_{k+1} = (2(1−τ) − 1)(−τ) = τ(2τ − 1).
        let b = LagrangeBasis::new(2, NodeFamily::Equispaced).unwrap();
        let mut v = [0.0; 3];
        let mut d = [0.0; 3];
        for tau in [0.0, 0.1, 0.37, 0.5, 0.9, 1.0] {
            b.values_in_place(tau, &mut v);
            b.derivatives_in_place(tau, &mut d);
            let exact = [
                (2.0 * tau - 1.0) * (tau - 1.0),
                4.0 * tau * (1.0 - tau),
                tau * (2.0 * tau - 1.0),
            ];
            let dexact = [4.0 * tau - 3.0, 4.0 - 8.0 * tau, 4.0 * tau - 1.0];
            for j in 0..3 {
                assert!((v[j] - exact[j]).abs() < 1e-15);
                assert!((d[j] - dexact[j]).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn tabulated_rows_sum_exactly() {
        for s in 1..=12 {
            for fam in [NodeFamily::Equispaced, NodeFamily::Lobatto] {
                let b = LagrangeBasis::new(s, fam).unwrap();
                let c = QuadratureRule::new(QuadratureKind::GaussLegendre(s + 1)).unwrap().nodes;
                let (phi, dphi) = b.tabulate(&c);
                for i in 0..c.len() {
                    // Summed in another order than the correction used: within one rounding.
                    let r = &phi[i * (s + 1)..(i + 1) * (s + 1)];
                    let big = r.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                    assert!((r.iter().sum::<f64>() - 1.0).abs() <= (s + 1) as f64 * f64::EPSILON * big);
                    let r = &dphi[i * (s + 1)..(i + 1) * (s + 1)];
                    let big = r.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                    assert!(r.iter().sum::<f64>().abs() <= (s + 1) as f64 * f64::EPSILON * big);
                }
                // Reproduces τ^s exactly (up to round-off).
                let mut v = vec![0.0; s + 1];
                b.values_in_place(0.3, &mut v);
                let interp: f64 = b.nodes.iter().zip(&v).map(|(t, l)| t.powi(s as i32) * l).sum();
                assert!((interp - 0.3f64.powi(s as i32)).abs() < 1e-12, "s={s}");
            }
        }
    }
}
