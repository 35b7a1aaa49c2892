//! The fixed-point form of the step equations for mechanical Lagrangians
//! L = ½vᵀMv − V(t, q) (DESIGN.md §2). With increments ΔQ^m = Q^m − q_k the kinetic part of
//! p_k = −∂L_d/∂Q^0, ∂L_d/∂Q^j = 0 is linear, (1/h) Σ_m K_jm M ΔQ^m with the element
//! stiffness K, and does not depend on h in the reference element. Solving it once gives
//!
//!   ΔQ^m = h α_m u + h² Σ_i β_mi M⁻¹ f_i,    u = M⁻¹ p_k,  f_i = −∇V(t_k + c_i h, q(c_i)),
//!
//! and at the quadrature points Y_l = q(c_l) − q_k = h a_l u + h² Σ_i B_li M⁻¹ f_i, an
//! iteration on force evaluations only (no Hessians), as GNI_IRK2 does for Gauss methods.
//! The momentum update is p_{k+1} = p_k + h Σ_i b_i f_i (the sum of all element equations).

use crate::discrete::Element;
use crate::error::{invalid, Result};
use crate::fem::dd::Dd;

/// The h-independent tables of the fixed-point iteration of one element.
#[derive(Debug, Clone, PartialEq)]
pub struct FixedPointTables {
    /// α_m, m = 1 … s.
    pub alpha: Vec<f64>,
    /// β_mi, row-major s×r.
    pub beta: Vec<f64>,
    /// a_l, l = 1 … r.
    pub a: Vec<f64>,
    /// B_li, row-major r×r.
    pub b: Vec<f64>,
    /// The rounding errors of the four tables above (exact value − table), same layouts.
    pub alpha_lo: Vec<f64>,
    /// See `alpha_lo`.
    pub beta_lo: Vec<f64>,
    /// See `alpha_lo`.
    pub a_lo: Vec<f64>,
    /// See `alpha_lo`.
    pub b_lo: Vec<f64>,
}

impl FixedPointTables {
    /// Tables of `element`.
    ///
    /// # Errors
    /// The stiffness block K[0..s, 1..=s] is singular (a degenerate element).
    pub fn new(element: &Element) -> Result<Self> {
        element.check_nondegenerate()?;
        // Everything in double-double, rounded once: in f64 the inverse of the stiffness block
        // carries cond·ε errors into β and B, which showed as a round-off floor ~1e-12 (vs
        // ~1e-14 for Newton) over 10 Kepler periods with degree 6.
        let s = element.degree();
        let r = element.points();
        let w = s + 1;
        let tau: Vec<Dd> = element.basis.nodes.iter().map(|&t| Dd::new(t)).collect();
        let (phi, dphi) = basis_dd(&tau, &element.rule.nodes);
        let bw: Vec<Dd> = element.rule.weights.iter().map(|&b| Dd::new(b)).collect();
        // A_jm = K_j,m+1 = Σ_i b_i ℓ_j'(c_i) ℓ_{m+1}'(c_i), j, m < s.
        let mut a_mat = vec![Dd::new(0.0); s * s];
        for j in 0..s {
            for m in 0..s {
                let mut acc = Dd::new(0.0);
                for i in 0..r {
                    acc = acc.add(bw[i].mul(dphi[i * w + j]).mul(dphi[i * w + m + 1]));
                }
                a_mat[j * s + m] = acc;
            }
        }
        let inv = invert(s, a_mat).ok_or_else(|| invalid("scheme", "the element stiffness is singular"))?;
        // Unknown m (1..=s) is row m−1 of inv; equation j (0..s) is column j.
        let alpha_dd: Vec<Dd> = (0..s).map(|m| inv[m * s].neg()).collect();
        let mut beta_dd = vec![Dd::new(0.0); s * r];
        for m in 0..s {
            for i in 0..r {
                let mut acc = Dd::new(0.0);
                for j in 0..s {
                    acc = acc.add(inv[m * s + j].mul(bw[i]).mul(phi[i * w + j]));
                }
                beta_dd[m * r + i] = acc.neg();
            }
        }
        let mut a = vec![0.0; r];
        let mut b = vec![0.0; r * r];
        let mut a_lo = vec![0.0; r];
        let mut b_lo = vec![0.0; r * r];
        let lo = |x: Dd| x.sub(Dd::new(x.round())).round();
        for l in 0..r {
            let mut acc = Dd::new(0.0);
            for m in 0..s {
                acc = acc.add(phi[l * w + m + 1].mul(alpha_dd[m]));
            }
            a[l] = acc.round();
            a_lo[l] = lo(acc);
            for i in 0..r {
                let mut acc = Dd::new(0.0);
                for m in 0..s {
                    acc = acc.add(phi[l * w + m + 1].mul(beta_dd[m * r + i]));
                }
                b[l * r + i] = acc.round();
                b_lo[l * r + i] = lo(acc);
            }
        }
        Ok(Self {
            alpha: alpha_dd.iter().map(|x| x.round()).collect(),
            beta: beta_dd.iter().map(|x| x.round()).collect(),
            a,
            b,
            alpha_lo: alpha_dd.iter().map(|&x| lo(x)).collect(),
            beta_lo: beta_dd.iter().map(|&x| lo(x)).collect(),
            a_lo,
            b_lo,
        })
    }
}

/// The tables of one element scaled by one step h, from the exact (double-double) values: for
/// the stages h a_l and h² B_li correctly rounded (B row-major), for the update
/// h α_m, h² β_mi and h b_i each as the rounded value and its rounding error (applied as a
/// second, small sum, so that the update's coefficients are exact: see the integrator's
/// `COEFFICIENT_ROUNDING`). Built with Dekker products (plain f64 arithmetic), since on a
/// variable grid this runs every step.
#[derive(Debug, Clone, PartialEq)]
pub struct StepTables {
    /// h as bits (NaN: not built).
    pub h_bits: u64,
    /// h a_l.
    pub ha: Vec<f64>,
    /// h² B_li, column-major (entry (l, i) at i r + l).
    pub h2b: Vec<f64>,
    /// h α_m and its rounding error.
    pub h_alpha: Vec<f64>,
    /// See `h_alpha`.
    pub h_alpha_lo: Vec<f64>,
    /// h² β_mi (column-major: entry (m, i) at i s + m) and its rounding error.
    pub h2_beta: Vec<f64>,
    /// See `h2_beta`.
    pub h2_beta_lo: Vec<f64>,
    /// h b_i (quadrature weights) and its rounding error.
    pub hw: Vec<f64>,
    /// See `hw`.
    pub hw_lo: Vec<f64>,
}

impl StepTables {
    /// Empty tables for an element of degree s with r points.
    pub fn new(s: usize, r: usize) -> Self {
        Self {
            h_bits: f64::NAN.to_bits(),
            ha: vec![0.0; r],
            h2b: vec![0.0; r * r],
            h_alpha: vec![0.0; s],
            h_alpha_lo: vec![0.0; s],
            h2_beta: vec![0.0; s * r],
            h2_beta_lo: vec![0.0; s * r],
            hw: vec![0.0; r],
            hw_lo: vec![0.0; r],
        }
    }

    /// Fills the tables for step h from `tab` and the quadrature weights.
    pub fn build(&mut self, tab: &FixedPointTables, weights: &[f64], h: f64) {
        let (s, r) = (tab.alpha.len(), tab.a.len());
        self.h_bits = h.to_bits();
        let hd = Dd::new(h);
        let h2 = Dd::two_prod(h, h);
        let split = |x: Dd| {
            let hi = x.round();
            (hi, x.sub(Dd::new(hi)).round())
        };
        let dd = |hi: f64, lo: f64| Dd { hi, lo };
        for l in 0..r {
            self.ha[l] = hd.mul(dd(tab.a[l], tab.a_lo[l])).round();
            for i in 0..r {
                self.h2b[i * r + l] = h2.mul(dd(tab.b[l * r + i], tab.b_lo[l * r + i])).round();
            }
            (self.hw[l], self.hw_lo[l]) = split(Dd::two_prod(h, weights[l]));
        }
        for m in 0..s {
            (self.h_alpha[m], self.h_alpha_lo[m]) = split(hd.mul(dd(tab.alpha[m], tab.alpha_lo[m])));
            for i in 0..r {
                (self.h2_beta[i * s + m], self.h2_beta_lo[i * s + m]) =
                    split(h2.mul(dd(tab.beta[m * r + i], tab.beta_lo[m * r + i])));
            }
        }
    }
}

/// Rows up to which [`affine`] runs with the row count fixed at compile time.
const UNROLLED_ROWS: usize = 16;

/// The affine map all of the fixed-point step is made of: for each component c < n and row
/// l < rows,
///
///   out_{l,c} = a_l u_c + Σ_j m_{jl} x_{j,c},   j = 0, 1, …, cols − 1 summed in this order,
///
/// with `m` column-major (cols × rows, column j contiguous), `x` row-major (cols × n) and
/// `out` row-major (rows × n). With `track`, returns the largest |out − old out| and |out|
/// and the sum of out·0 (NaN exactly when a value is not finite); otherwise zeros.
///
/// Hand-written because it is the fast path's inner loop, which no linear-algebra crate
/// serves at these sizes (8 × 8, n = 1): with the row count a compile-time constant (a
/// `match` up to [`UNROLLED_ROWS`]) a column of results lives in registers and the compiler
/// vectorises over the rows. Measured on P3 (degree 8, h = 1): 1490 instructions per sweep
/// of eight stages before, of which the sine is about 600.
#[allow(clippy::too_many_arguments)]
pub(crate) fn affine(
    rows: usize,
    n: usize,
    a: &[f64],
    u: &[f64],
    m: &[f64],
    cols: usize,
    x: &[f64],
    out: &mut [f64],
    track: bool,
) -> (f64, f64, f64) {
    macro_rules! unrolled {
        ($($r:literal)*) => {
            match rows {
                $($r => affine_rows::<$r>(n, a, u, m, cols, x, out, track),)*
                _ => affine_any(rows, n, a, u, m, cols, x, out, track),
            }
        };
    }
    const _: () = assert!(UNROLLED_ROWS == 16);
    unrolled!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16)
}

/// [`affine`] with `R` rows.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn affine_rows<const R: usize>(
    n: usize,
    a: &[f64],
    u: &[f64],
    m: &[f64],
    cols: usize,
    x: &[f64],
    out: &mut [f64],
    track: bool,
) -> (f64, f64, f64) {
    let a: &[f64; R] = a[..R].try_into().expect("R rows");
    // The columns that have an x row (as the zip of the two would give), counted once: a
    // zip of chunk iterators inside the component loop divided x's length by n each time.
    let cols = cols.min(x.len() / n.max(1));
    let (m, x) = (&m[..cols * R], &x[..cols * n]);
    let (mut delta, mut ymax, mut probe) = (0.0f64, 0.0f64, 0.0f64);
    for c in 0..n {
        let mut z = [0.0f64; R];
        for l in 0..R {
            z[l] = a[l] * u[c];
        }
        for j in 0..cols {
            // As an array, so that the row loop has no bounds checks and vectorises.
            let col: &[f64; R] = m[j * R..(j + 1) * R].try_into().expect("R rows");
            let xjc = x[j * n + c];
            for l in 0..R {
                z[l] += col[l] * xjc;
            }
        }
        for (l, &zl) in z.iter().enumerate() {
            let o = &mut out[l * n + c];
            if track {
                let d = (zl - *o).abs();
                if d > delta {
                    delta = d;
                }
                if zl.abs() > ymax {
                    ymax = zl.abs();
                }
                probe += zl * 0.0;
            }
            *o = zl;
        }
    }
    (delta, ymax, probe)
}

/// [`affine`] for any number of rows.
#[allow(clippy::too_many_arguments)]
fn affine_any(
    rows: usize,
    n: usize,
    a: &[f64],
    u: &[f64],
    m: &[f64],
    cols: usize,
    x: &[f64],
    out: &mut [f64],
    track: bool,
) -> (f64, f64, f64) {
    let (mut delta, mut ymax, mut probe) = (0.0f64, 0.0f64, 0.0f64);
    for c in 0..n {
        for l in 0..rows {
            let mut z = a[l] * u[c];
            for j in 0..cols {
                z += m[j * rows + l] * x[j * n + c];
            }
            let o = &mut out[l * n + c];
            if track {
                delta = delta.max((z - *o).abs());
                ymax = ymax.max(z.abs());
                probe += z * 0.0;
            }
            *o = z;
        }
    }
    (delta, ymax, probe)
}

/// Lagrange basis values ℓ_j(c_i) and derivatives ℓ_j'(c_i) on nodes `tau`, row-major by point.
pub(crate) fn basis_dd(tau: &[Dd], c: &[f64]) -> (Vec<Dd>, Vec<Dd>) {
    let w = tau.len();
    let mut phi = vec![Dd::new(0.0); c.len() * w];
    let mut dphi = vec![Dd::new(0.0); c.len() * w];
    for (i, &ci) in c.iter().enumerate() {
        let ci = Dd::new(ci);
        for j in 0..w {
            let mut v = Dd::new(1.0);
            let mut d = Dd::new(0.0);
            for m in 0..w {
                if m == j {
                    continue;
                }
                let denom = tau[j].sub(tau[m]);
                v = v.mul(ci.sub(tau[m])).div(denom);
                let mut prod = Dd::new(1.0).div(denom);
                for l in 0..w {
                    if l != j && l != m {
                        prod = prod.mul(ci.sub(tau[l])).div(tau[j].sub(tau[l]));
                    }
                }
                d = d.add(prod);
            }
            phi[i * w + j] = v;
            dphi[i * w + j] = d;
        }
    }
    (phi, dphi)
}

/// Gauss–Jordan inverse with partial pivoting of a row-major n×n matrix, in double-double.
pub(crate) fn invert(n: usize, mut a: Vec<Dd>) -> Option<Vec<Dd>> {
    let mut inv = vec![Dd::new(0.0); n * n];
    for i in 0..n {
        inv[i * n + i] = Dd::new(1.0);
    }
    for col in 0..n {
        let piv = (col..n).max_by(|&x, &y| a[x * n + col].hi.abs().total_cmp(&a[y * n + col].hi.abs()))?;
        if a[piv * n + col].hi == 0.0 {
            return None;
        }
        for k in 0..n {
            a.swap(col * n + k, piv * n + k);
            inv.swap(col * n + k, piv * n + k);
        }
        let p = a[col * n + col];
        for k in 0..n {
            a[col * n + k] = a[col * n + k].div(p);
            inv[col * n + k] = inv[col * n + k].div(p);
        }
        for row in 0..n {
            if row == col {
                continue;
            }
            let f = a[row * n + col];
            for k in 0..n {
                a[row * n + k] = a[row * n + k].sub(f.mul(a[col * n + k]));
                inv[row * n + k] = inv[row * n + k].sub(f.mul(inv[col * n + k]));
            }
        }
    }
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::{NodeFamily, QuadratureKind};

    #[test]
    fn end_node_moves_with_the_initial_velocity() {
        // Free particle: ΔQ^s = h u exactly, so α_s = 1; and Y_l = c_l h u, so a_l = c_l.
        for s in 1..=6 {
            let e = Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap();
            let t = FixedPointTables::new(&e).unwrap();
            assert!((t.alpha[s - 1] - 1.0).abs() < 1e-12, "s={s}: {}", t.alpha[s - 1]);
            for (l, c) in e.rule.nodes.iter().enumerate() {
                assert!((t.a[l] - c).abs() < 1e-12);
            }
        }
    }

    /// The `_lo` tables are the rounding errors of the f64 tables: zero where the exact value
    /// is a binary fraction (the midpoint rule's 1/2, 1/4, 1), and otherwise at most half an
    /// ulp of the value and not all zero (so the value is the correctly rounded one).
    #[test]
    fn low_parts_are_the_rounding_errors() {
        let t = FixedPointTables::new(&Element::midpoint()).unwrap();
        assert!(t
            .a_lo
            .iter()
            .chain(&t.b_lo)
            .chain(&t.alpha_lo)
            .chain(&t.beta_lo)
            .all(|&x| x == 0.0));
        for s in 2..=8 {
            let e = Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap();
            let t = FixedPointTables::new(&e).unwrap();
            let pairs = [
                (&t.a, &t.a_lo),
                (&t.b, &t.b_lo),
                (&t.alpha, &t.alpha_lo),
                (&t.beta, &t.beta_lo),
            ];
            let mut nonzero = 0;
            for (hi, lo) in pairs {
                for (&h, &l) in hi.iter().zip(lo) {
                    let half_ulp = (h.abs() * f64::EPSILON * 0.5).max(f64::MIN_POSITIVE);
                    assert!(l.abs() <= half_ulp * 1.000001, "s = {s}: {h:e} + {l:e}");
                    nonzero += usize::from(l != 0.0);
                }
            }
            assert!(nonzero > 0, "s = {s}: no rounding error recorded");
        }
    }

    #[test]
    fn gauss_tables_are_the_gauss_collocation_coefficients() {
        // s = 1 with the midpoint rule is the implicit midpoint rule: Y = h/2 u + h²/4 f.
        let e = Element::midpoint();
        let t = FixedPointTables::new(&e).unwrap();
        assert!((t.b[0] - 0.25).abs() < 1e-15 && (t.a[0] - 0.5).abs() < 1e-15);
        // Degree 2 with the one-point rule is degenerate.
        let e = Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::Midpoint).unwrap();
        assert!(FixedPointTables::new(&e).is_err());
    }

    /// The unrolled kernels and the general one against the plain double loop, summed in the
    /// same order: equal bit for bit, for rows on both sides of `UNROLLED_ROWS`, several
    /// components and more columns than rows; the tracked maxima and the NaN probe.
    #[test]
    fn affine_is_the_plain_sum_in_order() {
        let mut uniform = crate::testing::uniform(0x2545_f491_4f6c_dd1d);
        let mut rand = || uniform() - 0.5;
        for rows in (1..=UNROLLED_ROWS + 3).chain([31]) {
            for n in [1, 2, 3, 9] {
                let cols = rows + 3;
                let a: Vec<f64> = (0..rows).map(|_| rand()).collect();
                let u: Vec<f64> = (0..n).map(|_| rand()).collect();
                let m: Vec<f64> = (0..cols * rows).map(|_| rand()).collect();
                let x: Vec<f64> = (0..cols * n).map(|_| rand() * 1e3).collect();
                let old: Vec<f64> = (0..rows * n).map(|_| rand()).collect();
                let mut expect = vec![0.0; rows * n];
                let (mut delta, mut ymax) = (0.0f64, 0.0f64);
                for l in 0..rows {
                    for c in 0..n {
                        let mut z = a[l] * u[c];
                        for j in 0..cols {
                            z += m[j * rows + l] * x[j * n + c];
                        }
                        expect[l * n + c] = z;
                        delta = delta.max((z - old[l * n + c]).abs());
                        ymax = ymax.max(z.abs());
                    }
                }
                let mut out = old.clone();
                let (d, y, probe) = affine(rows, n, &a, &u, &m, cols, &x, &mut out, true);
                assert_eq!(out, expect, "rows {rows}, n {n}");
                assert_eq!((d, y, probe), (delta, ymax, 0.0), "rows {rows}, n {n}");
                let mut out = old.clone();
                assert_eq!(affine(rows, n, &a, &u, &m, cols, &x, &mut out, false), (0.0, 0.0, 0.0));
                assert_eq!(out, expect);
                let mut bad = x.clone();
                bad[0] = f64::INFINITY;
                let (_, _, probe) = affine(rows, n, &a, &u, &m, cols, &bad, &mut out, true);
                assert!(probe.is_nan(), "rows {rows}, n {n}: an infinite input not flagged");
            }
        }
    }
}
