//! Quadrature rules on [0, 1] (nodes c_i, weights b_i with Σ b_i = 1) that integrate the
//! Lagrangian over an element: midpoint (the paper's (2.19)/(2.20)), trapezoid (Störmer–Verlet
//! for degree 1), Simpson, and Gauss–Legendre and Gauss–Lobatto rules of any number of points.
//!
//! Gauss rules are computed by Newton's method on the Legendre recurrence in double-double
//! arithmetic and rounded once, so nodes and weights are correct to the last bit of f64 (up to
//! rare rounding ties) for any r. Hand-written because the quadrature crates compute in f64
//! (losing a few ulps for large r), and the `twofloat` crate's division was measured to lose
//! ~1e-16 relative, which defeats the purpose; the ~40 lines of `Dd` are exact to ~1e-32.

use crate::error::{invalid, Result};

use super::dd::Dd;

/// The most points of a Gauss rule: computing one costs O(r²) double-double operations
/// (about a second at this limit), and no element needs more.
pub const MAX_POINTS: usize = 1000;

/// Which quadrature family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QuadratureKind {
    /// One point at the centre.
    Midpoint,
    /// Both end points, weights ½.
    Trapezoid,
    /// Ends and centre, weights 1/6, 4/6, 1/6.
    Simpson,
    /// Gauss–Legendre with the given number of points (exact for degree 2r − 1).
    GaussLegendre(usize),
    /// Gauss–Lobatto with the given number of points ≥ 2 (exact for degree 2r − 3).
    GaussLobatto(usize),
}

/// A quadrature rule on [0, 1]: plain data.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadratureRule {
    /// The family it came from.
    pub kind: QuadratureKind,
    /// Nodes c_i in [0, 1], increasing.
    pub nodes: Vec<f64>,
    /// Weights b_i, summing to 1.
    pub weights: Vec<f64>,
}

impl QuadratureRule {
    /// Builds the rule of the given kind.
    ///
    /// # Errors
    /// A Gauss–Legendre rule with no point, a Gauss–Lobatto rule with fewer than two, or a
    /// Gauss rule with more than [`MAX_POINTS`].
    pub fn new(kind: QuadratureKind) -> Result<Self> {
        if let QuadratureKind::GaussLegendre(r) | QuadratureKind::GaussLobatto(r) = kind {
            if r > MAX_POINTS {
                return Err(invalid(
                    "quadrature points",
                    format!("{r} is more than the largest supported rule, {MAX_POINTS} points"),
                ));
            }
        }
        let (nodes, weights) = match kind {
            QuadratureKind::Midpoint => (vec![0.5], vec![1.0]),
            QuadratureKind::Trapezoid => (vec![0.0, 1.0], vec![0.5, 0.5]),
            QuadratureKind::Simpson => (vec![0.0, 0.5, 1.0], vec![1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0]),
            QuadratureKind::GaussLegendre(r) => {
                if r == 0 {
                    return Err(invalid("quadrature points", "Gauss-Legendre needs at least 1 point"));
                }
                gauss_legendre(r)
            }
            QuadratureKind::GaussLobatto(r) => {
                if r < 2 {
                    return Err(invalid("quadrature points", "Gauss-Lobatto needs at least 2 points"));
                }
                gauss_lobatto(r)
            }
        };
        Ok(Self { kind, nodes, weights })
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the rule has no point (never, for a rule built by [`QuadratureRule::new`]).
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Highest polynomial degree the rule integrates exactly.
    pub fn exact_degree(&self) -> usize {
        match self.kind {
            QuadratureKind::Midpoint | QuadratureKind::Trapezoid => 1,
            QuadratureKind::Simpson => 3,
            QuadratureKind::GaussLegendre(r) => r.saturating_mul(2).saturating_sub(1),
            QuadratureKind::GaussLobatto(r) => r.saturating_mul(2).saturating_sub(3),
        }
    }
}

/// Legendre P_n(x) and P_{n-1}(x) by the three-term recurrence, in double-double.
fn legendre(n: usize, x: Dd) -> (Dd, Dd) {
    let mut p0 = Dd::new(1.0);
    let mut p1 = x;
    if n == 0 {
        return (p0, Dd::new(0.0));
    }
    for k in 2..=n {
        let kf = k as f64;
        let p2 = x.mul(p1).mulf(2.0 * kf - 1.0).sub(p0.mulf(kf - 1.0)).divf(kf);
        p0 = p1;
        p1 = p2;
    }
    (p1, p0)
}

/// Maps a node x ∈ [-1, 1] and weight w of a rule for [-1, 1] to [0, 1].
fn to_unit(x: Dd, w: Dd) -> (f64, f64) {
    (x.add(Dd::new(1.0)).divf(2.0).round(), w.divf(2.0).round())
}

fn gauss_legendre(r: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; r];
    let mut weights = vec![0.0; r];
    let n = r as f64;
    for i in 0..r.div_ceil(2) {
        // Tricomi's initial guess for the i-th largest root, then Newton in double-double.
        let guess = (std::f64::consts::PI * (i as f64 + 0.75) / (n + 0.5)).cos();
        let mut x = Dd::new(guess);
        let mut dp = Dd::new(1.0);
        for _ in 0..100 {
            let (p, pm1) = legendre(r, x);
            dp = x.mul(p).sub(pm1).mulf(n).div(x.mul(x).sub(Dd::new(1.0)));
            let dx = p.div(dp);
            x = x.sub(dx);
            if dx.hi.abs() <= 1e-32 * x.hi.abs().max(1e-300) {
                break;
            }
        }
        let (p, pm1) = legendre(r, x);
        if p.hi != 0.0 {
            dp = x.mul(p).sub(pm1).mulf(n).div(x.mul(x).sub(Dd::new(1.0)));
        }
        let w = Dd::new(2.0).div(Dd::new(1.0).sub(x.mul(x)).mul(dp).mul(dp));
        // x is the (i+1)-th largest root; the mirror is −x.
        let (c_hi, b) = to_unit(x, w);
        let (c_lo, _) = to_unit(x.neg(), w);
        nodes[r - 1 - i] = c_hi;
        weights[r - 1 - i] = b;
        nodes[i] = c_lo;
        weights[i] = b;
    }
    if r % 2 == 1 {
        nodes[r / 2] = 0.5;
    }
    (nodes, weights)
}

fn gauss_lobatto(r: usize) -> (Vec<f64>, Vec<f64>) {
    // Interior nodes: roots of P'_{n}, n = r − 1; weights 2 / (n (n+1) P_n(x)²).
    let n = r - 1;
    let nf = n as f64;
    let mut nodes = vec![0.0; r];
    let mut weights = vec![0.0; r];
    let end_w = 2.0 / (nf * (nf + 1.0));
    nodes[0] = 0.0;
    nodes[r - 1] = 1.0;
    weights[0] = end_w / 2.0;
    weights[r - 1] = end_w / 2.0;
    for i in 1..=(r - 2).div_ceil(2) {
        // i-th largest interior root; Chebyshev–Gauss–Lobatto guess.
        let guess = (std::f64::consts::PI * i as f64 / nf).cos();
        let mut x = Dd::new(guess);
        for _ in 0..100 {
            let (p, pm1) = legendre(n, x);
            let one_m_x2 = Dd::new(1.0).sub(x.mul(x));
            let dp = pm1.sub(x.mul(p)).mulf(nf).div(one_m_x2);
            let ddp = x.mul(dp).mulf(2.0).sub(p.mulf(nf * (nf + 1.0))).div(one_m_x2);
            let dx = dp.div(ddp);
            x = x.sub(dx);
            if dx.hi.abs() <= 1e-32 * x.hi.abs().max(1e-300) {
                break;
            }
        }
        let (p, _) = legendre(n, x);
        let w = Dd::new(2.0).divf(nf * (nf + 1.0)).div(p.mul(p));
        let (c_hi, b) = to_unit(x, w);
        let (c_lo, _) = to_unit(x.neg(), w);
        nodes[r - 1 - i] = c_hi;
        weights[r - 1 - i] = b;
        nodes[i] = c_lo;
        weights[i] = b;
    }
    if r % 2 == 1 {
        nodes[r / 2] = 0.5;
    }
    (nodes, weights)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact ∫₀¹ τ^k dτ.
    fn moment(k: usize) -> f64 {
        1.0 / (k as f64 + 1.0)
    }

    #[test]
    fn closed_forms_to_the_last_bit() {
        // Gauss–Legendre 2, 3 points: ±1/√3, ±√(3/5), weights 5/9, 8/9 on [-1, 1].
        let g2 = QuadratureRule::new(QuadratureKind::GaussLegendre(2)).unwrap();
        let x = 0.5 - 0.5 / 3f64.sqrt();
        assert!((g2.nodes[0] - x).abs() <= f64::EPSILON * x, "{} vs {}", g2.nodes[0], x);
        assert_eq!(g2.weights, vec![0.5, 0.5]);
        let g3 = QuadratureRule::new(QuadratureKind::GaussLegendre(3)).unwrap();
        let x = 0.5 - 0.5 * 0.6f64.sqrt();
        assert!((g3.nodes[0] - x).abs() <= f64::EPSILON * x);
        assert_eq!(g3.weights[1], 4.0 / 9.0);
        assert!((g3.weights[0] - 5.0 / 18.0).abs() <= f64::EPSILON * 0.3);
        // Gauss–Lobatto 4 points: ±1, ±1/√5; weights 1/6, 5/6 on [-1, 1].
        let l4 = QuadratureRule::new(QuadratureKind::GaussLobatto(4)).unwrap();
        let x = 0.5 - 0.5 / 5f64.sqrt();
        assert!((l4.nodes[1] - x).abs() <= f64::EPSILON * x);
        assert_eq!(l4.weights[0], 1.0 / 12.0);
        assert!((l4.weights[1] - 5.0 / 12.0).abs() <= f64::EPSILON);
    }

    #[test]
    fn gauss_rules_are_exact_up_to_their_degree_for_many_points() {
        for r in (1..=64).chain([80, 100]) {
            for kind in [QuadratureKind::GaussLegendre(r), QuadratureKind::GaussLobatto(r.max(2))] {
                let rule = QuadratureRule::new(kind).unwrap();
                let deg = rule.exact_degree();
                for k in 0..=deg.min(60) {
                    let s: f64 = rule
                        .nodes
                        .iter()
                        .zip(&rule.weights)
                        .map(|(c, b)| b * c.powi(k as i32))
                        .sum();
                    let err = (s - moment(k)).abs() / moment(k);
                    assert!(err < 2e-14, "{kind:?} k={k}: rel err {err:e}");
                }
                // Symmetry about ½ to the last bit, and increasing nodes.
                let m = rule.len();
                for i in 0..m {
                    assert_eq!(rule.weights[i], rule.weights[m - 1 - i], "{kind:?}");
                    assert!((rule.nodes[i] + rule.nodes[m - 1 - i] - 1.0).abs() <= f64::EPSILON);
                    if i > 0 {
                        assert!(rule.nodes[i] > rule.nodes[i - 1]);
                    }
                }
            }
        }
    }

    #[test]
    fn nodes_are_roots_in_double_double() {
        // Independent check of the last bits: the f64 node must be the root rounded, so P_r
        // must change sign between its neighbouring floats (or vanish at the node itself).
        for r in [5, 17, 33, 64] {
            let rule = QuadratureRule::new(QuadratureKind::GaussLegendre(r)).unwrap();
            for &c in &rule.nodes[..r / 2] {
                let x = |c: f64| Dd::new(2.0 * c).sub(Dd::new(1.0));
                let below = legendre(r, x(f64::from_bits(c.to_bits() - 1))).0.hi;
                let above = legendre(r, x(f64::from_bits(c.to_bits() + 1))).0.hi;
                assert!(below * above <= 0.0, "r={r} c={c}: no sign change within one ulp");
            }
        }
    }

    #[test]
    fn rejects_empty_rules() {
        assert!(QuadratureRule::new(QuadratureKind::GaussLegendre(0)).is_err());
        assert!(QuadratureRule::new(QuadratureKind::GaussLobatto(1)).is_err());
    }
}
