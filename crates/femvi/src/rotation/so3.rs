//! The rotation group SO(3) and its algebra so(3) ≅ R³ over any scalar type (f64 or num-dual
//! numbers, so that the element's action can be differentiated): the hat map, the exponential
//! (Rodrigues), the derivative of the exponential and its inverse, and unit quaternions.
//!
//! Conventions (DESIGN.md, rotations): ŵ x = w × x; exp(ξ) = 1 + A ξ̂ + B ξ̂² with
//! A = sin θ/θ, B = (1 − cos θ)/θ², θ = |ξ|; the right-trivialised derivative
//! d/dε exp(ξ + εδ) = (dexp_ξ δ)^ exp(ξ) = exp(ξ) (dexp_{−ξ} δ)^ with
//! dexp_ξ = 1 + B ξ̂ + C ξ̂², C = (θ − sin θ)/θ³, and its inverse
//! dexp_ξ⁻¹ = 1 − ½ ξ̂ + E ξ̂², E = (1 − (θ/2) cot(θ/2))/θ² (Iserles, Munthe-Kaas, Nørsett,
//! Zanna, Acta Numerica 2000, §2; Hairer, Lubich, Wanner, *Geometric Numerical Integration*,
//! III.4). The coefficients are functions of x = θ²; below θ = 1/2 they are summed as their
//! Taylor series in x (to x⁸, a remainder below 1e-22), so that derivatives stay exact at
//! ξ = 0, where the closed forms divide zero by zero.

use crate::lagrangian::Scalar;

/// A 3×3 matrix, row-major.
pub type Mat3<D> = [D; 9];

/// Where the coefficient functions switch from their series in x = θ² to the closed forms.
const SERIES_BELOW: f64 = 0.25;

/// Σ_k coef[k] x^k by Horner's rule.
fn series<D: Scalar>(x: D, coef: &[f64]) -> D {
    coef.iter().rev().fold(D::from(0.0), |acc, &c| acc * x + c)
}

/// (A, B) = (sin θ/θ, (1 − cos θ)/θ²) of x = θ².
fn exp_coefficients<D: Scalar>(x: D) -> (D, D) {
    if x.re() < SERIES_BELOW {
        // sin θ/θ = Σ (−x)^k/(2k+1)!, (1 − cos θ)/θ² = Σ (−x)^k/(2k+2)!.
        const A: [f64; 9] = [
            1.0,
            -1.0 / 6.0,
            1.0 / 120.0,
            -1.0 / 5040.0,
            1.0 / 362_880.0,
            -1.0 / 39_916_800.0,
            1.0 / 6_227_020_800.0,
            -1.0 / 1_307_674_368_000.0,
            1.0 / 355_687_428_096_000.0,
        ];
        const B: [f64; 9] = [
            0.5,
            -1.0 / 24.0,
            1.0 / 720.0,
            -1.0 / 40_320.0,
            1.0 / 3_628_800.0,
            -1.0 / 479_001_600.0,
            1.0 / 87_178_291_200.0,
            -1.0 / 20_922_789_888_000.0,
            1.0 / 6_402_373_705_728_000.0,
        ];
        (series(x, &A), series(x, &B))
    } else {
        let th = x.sqrt();
        let half = (th * 0.5).sin();
        (th.sin() / th, half * half * 2.0 / x)
    }
}

/// C = (θ − sin θ)/θ³ of x = θ².
fn dexp_coefficient<D: Scalar>(x: D) -> D {
    if x.re() < SERIES_BELOW {
        // Σ (−x)^k/(2k+3)!.
        const C: [f64; 9] = [
            1.0 / 6.0,
            -1.0 / 120.0,
            1.0 / 5040.0,
            -1.0 / 362_880.0,
            1.0 / 39_916_800.0,
            -1.0 / 6_227_020_800.0,
            1.0 / 1_307_674_368_000.0,
            -1.0 / 355_687_428_096_000.0,
            1.0 / 121_645_100_408_832_000.0,
        ];
        series(x, &C)
    } else {
        let th = x.sqrt();
        (th - th.sin()) / (th * x)
    }
}

/// E = (1 − (θ/2) cot(θ/2))/θ² of x = θ².
fn dexp_inv_coefficient<D: Scalar>(x: D) -> D {
    if x.re() < SERIES_BELOW {
        // (z/2) cot(z/2) = Σ (−1)^n B_2n z^2n/(2n)!, so E = Σ_{n≥1} |B_2n|/(2n)! x^{n−1}.
        const E: [f64; 9] = [
            1.0 / 12.0,
            1.0 / 720.0,
            1.0 / 30_240.0,
            1.0 / 1_209_600.0,
            1.0 / 47_900_160.0,
            691.0 / 2730.0 / 479_001_600.0,
            7.0 / 6.0 / 87_178_291_200.0,
            3617.0 / 510.0 / 20_922_789_888_000.0,
            43_867.0 / 798.0 / 6_402_373_705_728_000.0,
        ];
        series(x, &E)
    } else {
        let half = x.sqrt() * 0.5;
        (D::from(1.0) - half * half.cos() / half.sin()) / x
    }
}

/// |ξ|².
#[inline]
fn norm2<D: Scalar>(xi: &[D; 3]) -> D {
    xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]
}

/// a × b.
#[inline]
pub fn cross<D: Scalar>(a: &[D; 3], b: &[D; 3]) -> [D; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// (1 + a ξ̂ + b ξ̂²) y = y + a ξ × y + b ξ × (ξ × y).
#[inline]
fn apply_poly<D: Scalar>(a: D, b: D, xi: &[D; 3], y: &[D; 3]) -> [D; 3] {
    let c1 = cross(xi, y);
    let c2 = cross(xi, &c1);
    [
        y[0] + c1[0] * a + c2[0] * b,
        y[1] + c1[1] * a + c2[1] * b,
        y[2] + c1[2] * a + c2[2] * b,
    ]
}

/// The hat map: ŵ, with ŵ x = w × x (row-major).
///
/// # Example
/// ```
/// use femvi::rotation::so3::{hat, vee};
/// let w = [1.0, 2.0, 3.0];
/// assert_eq!(vee(&hat(&w)), w);
/// ```
pub fn hat<D: Scalar>(w: &[D; 3]) -> Mat3<D> {
    let z = D::from(0.0);
    [z, -w[2], w[1], w[2], z, -w[0], -w[1], w[0], z]
}

/// The inverse of the hat map on the skew part: vee(A) = ½ (A₃₂ − A₂₃, A₁₃ − A₃₁, A₂₁ − A₁₂).
pub fn vee<D: Scalar>(a: &Mat3<D>) -> [D; 3] {
    [(a[7] - a[5]) * 0.5, (a[2] - a[6]) * 0.5, (a[3] - a[1]) * 0.5]
}

/// The product a b of two 3×3 matrices.
pub fn mul<D: Scalar>(a: &Mat3<D>, b: &Mat3<D>) -> Mat3<D> {
    std::array::from_fn(|k| {
        let (i, j) = (k / 3, k % 3);
        a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j]
    })
}

/// aᵀ b.
pub fn mul_tn<D: Scalar>(a: &Mat3<D>, b: &Mat3<D>) -> Mat3<D> {
    std::array::from_fn(|k| {
        let (i, j) = (k / 3, k % 3);
        a[i] * b[j] + a[3 + i] * b[3 + j] + a[6 + i] * b[6 + j]
    })
}

/// The exponential exp(ξ̂) ∈ SO(3) (Rodrigues' formula; exact derivatives at ξ = 0).
///
/// # Example
/// ```
/// use femvi::rotation::so3::exp;
/// let r = exp(&[0.0, 0.0, std::f64::consts::FRAC_PI_2]);
/// // A quarter turn about z takes x to y.
/// assert!((r[3] - 1.0).abs() < 1e-15 && r[0].abs() < 1e-15);
/// ```
pub fn exp<D: Scalar>(xi: &[D; 3]) -> Mat3<D> {
    let (a, b) = exp_coefficients(norm2(xi));
    let h = hat(xi);
    let h2 = mul(&h, &h);
    std::array::from_fn(|k| {
        let one = if k % 4 == 0 { 1.0 } else { 0.0 };
        h[k] * a + h2[k] * b + one
    })
}

/// dexp_ξ δ (the right-trivialised derivative of the exponential): exp(ξ + εδ) =
/// exp(ε dexp_ξ δ + O(ε²)) exp(ξ).
pub fn dexp<D: Scalar>(xi: &[D; 3], delta: &[D; 3]) -> [D; 3] {
    let x = norm2(xi);
    let (_, b) = exp_coefficients(x);
    apply_poly(b, dexp_coefficient(x), xi, delta)
}

/// dexp_ξ⁻¹ δ: exp(εδ) exp(ξ) = exp(ξ + ε dexp_ξ⁻¹ δ + O(ε²)).
pub fn dexp_inv<D: Scalar>(xi: &[D; 3], delta: &[D; 3]) -> [D; 3] {
    let e = dexp_inv_coefficient(norm2(xi));
    apply_poly(D::from(-0.5), e, xi, delta)
}

/// The transpose (dexp_ξ⁻¹)ᵀ δ = dexp_{−ξ}⁻¹ δ (ξ̂ is skew, ξ̂² symmetric).
pub fn dexp_inv_transpose<D: Scalar>(xi: &[D; 3], delta: &[D; 3]) -> [D; 3] {
    let e = dexp_inv_coefficient(norm2(xi));
    apply_poly(D::from(0.5), e, xi, delta)
}

/// The rotation matrix of the unit quaternion (w, x, y, z) (scalar first, Hamilton
/// convention), after normalising it; None for a quaternion of zero or non-finite norm.
///
/// # Example
/// ```
/// use femvi::rotation::so3::from_quaternion;
/// let half = std::f64::consts::FRAC_PI_4; // a quarter turn about z
/// let r = from_quaternion([half.cos(), 0.0, 0.0, half.sin()]).unwrap();
/// assert!((r[3] - 1.0).abs() < 1e-15);
/// ```
pub fn from_quaternion(q: [f64; 4]) -> Option<Mat3<f64>> {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if !(n.is_finite() && n > 0.0) {
        return None;
    }
    let [w, x, y, z] = q.map(|c| c / n);
    Some([
        1.0 - 2.0 * (y * y + z * z),
        2.0 * (x * y - w * z),
        2.0 * (x * z + w * y),
        2.0 * (x * y + w * z),
        1.0 - 2.0 * (x * x + z * z),
        2.0 * (y * z - w * x),
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        1.0 - 2.0 * (x * x + y * y),
    ])
}

/// The unit quaternion (w, x, y, z) of a rotation matrix, with w ≥ 0 (Shepperd's method: the
/// largest of the four squares is taken first, so that no division is by a small number).
///
/// # Example
/// ```
/// use femvi::rotation::so3::{exp, from_quaternion, to_quaternion};
/// let r = exp(&[0.3, -0.2, 0.9]);
/// let back = from_quaternion(to_quaternion(&r)).unwrap();
/// assert!(r.iter().zip(&back).all(|(a, b)| (a - b).abs() < 1e-15));
/// ```
pub fn to_quaternion(r: &Mat3<f64>) -> [f64; 4] {
    let tr = r[0] + r[4] + r[8];
    let cand = [tr, r[0], r[4], r[8]];
    let big = (0..4).fold(0, |b, i| if cand[i] > cand[b] { i } else { b });
    let q = match big {
        0 => {
            let s = (1.0 + tr).sqrt() * 2.0;
            [s / 4.0, (r[7] - r[5]) / s, (r[2] - r[6]) / s, (r[3] - r[1]) / s]
        }
        1 => {
            let s = (1.0 + r[0] - r[4] - r[8]).sqrt() * 2.0;
            [(r[7] - r[5]) / s, s / 4.0, (r[1] + r[3]) / s, (r[2] + r[6]) / s]
        }
        2 => {
            let s = (1.0 + r[4] - r[0] - r[8]).sqrt() * 2.0;
            [(r[2] - r[6]) / s, (r[1] + r[3]) / s, s / 4.0, (r[5] + r[7]) / s]
        }
        _ => {
            let s = (1.0 + r[8] - r[0] - r[4]).sqrt() * 2.0;
            [(r[3] - r[1]) / s, (r[2] + r[6]) / s, (r[5] + r[7]) / s, s / 4.0]
        }
    };
    if q[0] < 0.0 {
        q.map(|c| -c)
    } else {
        q
    }
}

/// The logarithm of a rotation of angle below π: ψ with exp(ψ̂) = R, from
/// ψ = θ/sin θ · vee(R) (vee takes the skew part) and cos θ = (tr R − 1)/2; near θ = 0 the
/// factor is its series 1 + θ²/6 + 7θ⁴/360. Near θ = π the axis is ill-conditioned (the
/// elements of a run turn far less in a step).
///
/// # Example
/// ```
/// use femvi::rotation::so3::{exp, log};
/// let psi = [0.3, -0.2, 0.5];
/// let back = log(&exp(&psi));
/// assert!((0..3).all(|c| (back[c] - psi[c]).abs() < 1e-15));
/// ```
pub fn log(r: &Mat3<f64>) -> [f64; 3] {
    let c = ((r[0] + r[4] + r[8] - 1.0) * 0.5).clamp(-1.0, 1.0);
    let skew = vee(r);
    let s = (skew[0] * skew[0] + skew[1] * skew[1] + skew[2] * skew[2]).sqrt();
    let theta = s.atan2(c);
    let factor = if theta < 1e-4 {
        let t2 = theta * theta;
        1.0 + t2 / 6.0 + 7.0 * t2 * t2 / 360.0
    } else {
        theta / theta.sin()
    };
    skew.map(|x| x * factor)
}

/// max |RᵀR − 1| over the entries: how far a matrix is from SO(3)'s orthogonality.
pub fn orthogonality_defect(r: &Mat3<f64>) -> f64 {
    let g = mul_tn(r, r);
    (0..9).fold(0.0, |m, k| {
        let one = if k % 4 == 0 { 1.0 } else { 0.0 };
        f64::max(m, (g[k] - one).abs())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::Dual64;

    /// exp by its power series (to 40 terms), for moderate |ξ|.
    fn exp_series(xi: &[f64; 3]) -> Mat3<f64> {
        let h = hat(xi);
        let mut term: Mat3<f64> = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let mut sum = term;
        for k in 1..40 {
            term = mul(&term, &h).map(|v| v / k as f64);
            sum.iter_mut().zip(&term).for_each(|(s, t)| *s += t);
        }
        sum
    }

    #[test]
    fn exp_matches_its_series_on_both_sides_of_the_switch() {
        for scale in [1e-9, 1e-3, 0.3, 0.49, 0.51, 0.7, 2.0] {
            let xi = [0.48 * scale, -0.6 * scale, 0.64 * scale]; // |ξ| = scale
            let (a, b) = (exp(&xi), exp_series(&xi));
            let err = a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            assert!(err < 4e-16, "|ξ| = {scale}: {err:e}");
            assert!(orthogonality_defect(&a) < 5e-16);
        }
    }

    #[test]
    fn dexp_is_the_derivative_of_exp_and_dexp_inv_its_inverse() {
        for scale in [1e-7, 0.2, 0.5, 0.8, 2.5] {
            let xi = [0.48 * scale, -0.6 * scale, 0.64 * scale];
            let delta = [0.3, 0.1, -0.7];
            // d/dε exp(ξ + εδ) exp(ξ)ᵀ = (dexp_ξ δ)^, by one dual pass.
            let xd: [Dual64; 3] = std::array::from_fn(|c| Dual64::new(xi[c], delta[c]));
            let e = exp(&xd);
            let re: Mat3<f64> = e.map(|v| v.re);
            let de: Mat3<f64> = e.map(|v| v.eps);
            let w = vee(&mul(
                &de,
                &[re[0], re[3], re[6], re[1], re[4], re[7], re[2], re[5], re[8]],
            ));
            let d = dexp(&xi, &delta);
            assert!(w.iter().zip(&d).all(|(a, b)| (a - b).abs() < 1e-15), "{w:?} {d:?}");
            let back = dexp_inv(&xi, &d);
            assert!(back.iter().zip(&delta).all(|(a, b)| (a - b).abs() < 1e-14), "{back:?}");
            // The transpose, against ⟨dexp⁻¹ a, b⟩ = ⟨a, dexp⁻ᵀ b⟩.
            let (a, b) = ([0.2, -0.5, 0.9], [1.1, 0.4, -0.3]);
            let lhs: f64 = dexp_inv(&xi, &a).iter().zip(&b).map(|(x, y)| x * y).sum();
            let rhs: f64 = a.iter().zip(&dexp_inv_transpose(&xi, &b)).map(|(x, y)| x * y).sum();
            assert!((lhs - rhs).abs() < 1e-15);
        }
    }

    #[test]
    fn coefficients_are_smooth_across_the_switch() {
        // The series and the closed forms agree where they meet, in value and derivative.
        let x = Dual64::new(SERIES_BELOW, 1.0);
        let below = Dual64::new(SERIES_BELOW * (1.0 - 1e-15), 1.0);
        let pairs = [
            (exp_coefficients(x).0, exp_coefficients(below).0),
            (exp_coefficients(x).1, exp_coefficients(below).1),
            (dexp_coefficient(x), dexp_coefficient(below)),
            (dexp_inv_coefficient(x), dexp_inv_coefficient(below)),
        ];
        for (a, b) in pairs {
            assert!(
                (a.re - b.re).abs() < 1e-15 && (a.eps - b.eps).abs() < 1e-13,
                "{a:?} {b:?}"
            );
        }
    }
}
