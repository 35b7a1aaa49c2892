//! Monitor functions g(q) > 0 of the Poincaré time transformation dt/ds = g(q) (issue 21;
//! Hairer, Lubich, Wanner, *Geometric Numerical Integration*, §VIII.2): the physical time
//! that one unit of fictitious time s covers at q, i.e. the local step scale. A step ds in s
//! is a step g(q)·ds in t, so g should be small where the motion is fast.
//!
//! Built in: [`KeplerMonitor`] g = |q|^{3/2} (the orbital time scale √(r³/μ) of a Kepler
//! orbit at radius r), [`NBodyMonitor`] (the same for the closest pair of N bodies, smoothed),
//! and [`ExprMonitor`] (a math expression in the coordinates). A monitor is generic over the
//! scalar type like a [`Lagrangian`](crate::Lagrangian), because the transformed Lagrangian
//! needs its derivatives; a closure cannot be generic, so user monitors implement the trait.

use crate::expr::{ExprError, Program};
use crate::lagrangian::Scalar;

/// A monitor function g(q) > 0 (the local time scale).
///
/// # Example
///
/// ```
/// use femvi::adaptive::Monitor;
/// use femvi::Scalar;
///
/// /// g = 1 + q², a monitor written by hand.
/// struct Wide;
/// impl Monitor for Wide {
///     fn dim(&self) -> usize { 1 }
///     fn value<D: Scalar>(&self, q: &[D]) -> D { q[0] * q[0] + 1.0 }
/// }
/// assert_eq!(Wide.value(&[2.0]), 5.0);
/// ```
pub trait Monitor {
    /// Dimension n of the configuration space it reads (0: any).
    fn dim(&self) -> usize;

    /// g(q) for any scalar type (f64 or dual numbers). Called with slices of the
    /// Lagrangian's dimension only.
    fn value<D: Scalar>(&self, q: &[D]) -> D;

    /// g(q), its gradient into `grad` (n entries) and, if given, its Hessian into `hess`
    /// (row-major n²). The default differentiates [`Monitor::value`] with dual numbers (n
    /// passes, or n(n+1)/2 hyper-dual passes with the Hessian); override it with hand-coded
    /// derivatives for speed.
    fn derivatives(&self, q: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        match hess {
            Some(h) => super::derivatives::monitor_hessian(self, q, grad, h),
            None => super::derivatives::monitor_gradient(self, q, grad),
        }
    }
}

impl<G: Monitor> Monitor for &G {
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn value<D: Scalar>(&self, q: &[D]) -> D {
        (**self).value(q)
    }
    fn derivatives(&self, q: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        (**self).derivatives(q, grad, hess)
    }
}

/// g(q) = |q|^{3/2} (all coordinates), the Kepler monitor: √(r³/μ) is the orbital time
/// scale at radius r (μ = 1), so a fixed step ds in s is a step in t proportional to the local
/// time scale, from pericentre to apocentre alike.
///
/// ```
/// use femvi::adaptive::{KeplerMonitor, Monitor};
/// assert!((KeplerMonitor.value(&[3.0, 4.0]) - 5f64.powf(1.5)).abs() < 1e-14);
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct KeplerMonitor;

impl Monitor for KeplerMonitor {
    fn dim(&self) -> usize {
        0
    }
    fn value<D: Scalar>(&self, q: &[D]) -> D {
        let mut r2 = D::from(0.0);
        for &x in q {
            r2 += x * x;
        }
        // r^{3/2} = r·√r by square roots: cheaper on dual numbers than powf (ln and exp).
        let r = r2.sqrt();
        r * r.sqrt()
    }
    /// By hand: ∇g = (3/2)√r q/r, ∇²g = (3/2)(I/√r − q qᵀ/(2 r^{5/2})).
    fn derivatives(&self, q: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        let r = q.iter().map(|x| x * x).sum::<f64>().sqrt();
        let sr = r.sqrt();
        let c = 1.5 / sr; // (3/2) r^{-1/2}
        for (g, &x) in grad.iter_mut().zip(q) {
            *g = c * x;
        }
        if let Some(h) = hess {
            let n = q.len();
            let d = 0.5 * c / (r * r);
            for a in 0..n {
                for b in 0..n {
                    let eye = if a == b { c } else { 0.0 };
                    if let Some(hab) = h.get_mut(a * n + b) {
                        *hab = eye - d * q[a] * q[b];
                    }
                }
            }
        }
        r * sr
    }
}

/// The N-body monitor: g = (Σ_{i<j} r_ij^{−3})^{−1/2}, a smooth minimum of the pairwise
/// r_ij^{3/2}. With one close pair it is that pair's r^{3/2} (the Kepler monitor of the
/// pair); it is never above min r_ij^{3/2} and never below it by more than the factor
/// √(number of pairs). The plain minimum is not differentiable where the closest pair
/// changes, and the transformed Lagrangian needs ∇g and ∇²g: a kink there would cost the
/// method its order.
///
/// ```
/// use femvi::adaptive::{Monitor, NBodyMonitor};
/// // Two bodies in the plane at distance 4: g = 4^{3/2} = 8.
/// let g = NBodyMonitor::new(2, 2);
/// assert!((g.value::<f64>(&[0.0, 0.0, 4.0, 0.0]) - 8.0).abs() < 1e-14);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NBodyMonitor {
    bodies: usize,
    space: usize,
}

impl NBodyMonitor {
    /// For `bodies` bodies in `space` dimensions (coordinates body by body, as
    /// [`crate::models::n_body`]).
    pub fn new(bodies: usize, space: usize) -> Self {
        Self { bodies, space }
    }
}

impl Monitor for NBodyMonitor {
    fn dim(&self) -> usize {
        self.bodies * self.space
    }
    fn value<D: Scalar>(&self, q: &[D]) -> D {
        let d = self.space;
        let mut sum = D::from(0.0);
        for i in 0..self.bodies {
            for j in i + 1..self.bodies {
                let mut r2 = D::from(0.0);
                for c in 0..d {
                    let x = q[i * d + c] - q[j * d + c];
                    r2 += x * x;
                }
                // r^{-3} = (r²)^{-3/2}.
                sum += (r2 * r2 * r2).sqrt().recip();
            }
        }
        sum.sqrt().recip()
    }

    /// By hand (the dual-number default took most of a Pleiades step: n(n+1)/2 hyper-dual
    /// passes over all pairs). With S = Σ w_ij, w = r⁻³ of d = x_i − x_j: ∂w/∂d = −3r⁻⁵d,
    /// ∂²w/∂d² = −3r⁻⁵I + 15r⁻⁷ddᵀ; g = S^{−1/2}, ∇g = −½g³∇S, ∇²g = ¾g⁵∇S∇Sᵀ − ½g³∇²S.
    fn derivatives(&self, q: &[f64], grad: &mut [f64], mut hess: Option<&mut [f64]>) -> f64 {
        let (d, n) = (self.space, self.bodies * self.space);
        let fits = q.len() == n && grad.len() == n && hess.as_ref().is_none_or(|h| h.len() == n * n);
        if !fits || d > 3 {
            return match hess {
                Some(h) => super::derivatives::monitor_hessian(self, q, grad, h),
                None => super::derivatives::monitor_gradient(self, q, grad),
            };
        }
        // ∇S into `grad` and ∇²S into `hess` first.
        grad.iter_mut().for_each(|x| *x = 0.0);
        if let Some(h) = hess.as_deref_mut() {
            h.iter_mut().for_each(|x| *x = 0.0);
        }
        let mut sum = 0.0;
        for i in 0..self.bodies {
            for j in i + 1..self.bodies {
                let mut x = [0.0; 3];
                let mut r2 = 0.0;
                for (c, xc) in x.iter_mut().enumerate().take(d) {
                    *xc = q[i * d + c] - q[j * d + c];
                    r2 += *xc * *xc;
                }
                // The same rounding as `value`.
                let w = (r2 * r2 * r2).sqrt().recip();
                sum += w;
                let a = -3.0 * w / r2;
                for c in 0..d {
                    grad[i * d + c] += a * x[c];
                    grad[j * d + c] -= a * x[c];
                }
                if let Some(h) = hess.as_deref_mut() {
                    let b = 15.0 * w / (r2 * r2);
                    for c in 0..d {
                        for e in 0..d {
                            let eye = if c == e { a } else { 0.0 };
                            let wce = eye + b * x[c] * x[e];
                            let (ic, jc, ie, je) = (i * d + c, j * d + c, i * d + e, j * d + e);
                            h[ic * n + ie] += wce;
                            h[jc * n + je] += wce;
                            h[ic * n + je] -= wce;
                            h[jc * n + ie] -= wce;
                        }
                    }
                }
            }
        }
        let g = sum.sqrt().recip();
        let g3 = g * g * g;
        if let Some(h) = hess {
            let g5 = g3 * g * g;
            for a in 0..n {
                for b in 0..n {
                    h[a * n + b] = 0.75 * g5 * grad[a] * grad[b] - 0.5 * g3 * h[a * n + b];
                }
            }
        }
        grad.iter_mut().for_each(|x| *x *= -0.5 * g3);
        g
    }
}

/// A monitor given by a math expression in the coordinates (names as in the problem, the
/// same syntax as Lagrangians, [`crate::expr`]; no `t` and no velocities).
///
/// ```
/// use femvi::adaptive::{ExprMonitor, Monitor};
/// let g = ExprMonitor::new("(x^2 + y^2)^0.75", &["x".into(), "y".into()], &[])?;
/// assert!((g.value(&[3.0, 4.0]) - 5f64.powf(1.5)).abs() < 1e-12);
/// assert!(ExprMonitor::new("x_dot", &["x".into()], &[]).is_err());
/// # Ok::<(), femvi::expr::ExprError>(())
/// ```
#[derive(Debug, Clone)]
pub struct ExprMonitor {
    n: usize,
    program: Program,
}

impl ExprMonitor {
    /// Compiles `source` with the coordinate names and parameter values.
    ///
    /// # Errors
    /// [`ExprError`] as for [`crate::expr::ExprLagrangian::new`] (unknown symbols include
    /// `t` and the velocities).
    pub fn new(source: &str, coordinates: &[String], parameters: &[(String, f64)]) -> Result<Self, ExprError> {
        let program = Program::compile(source, coordinates, parameters)?;
        Ok(Self {
            n: coordinates.len(),
            program,
        })
    }
}

impl Monitor for ExprMonitor {
    fn dim(&self) -> usize {
        self.n
    }
    fn value<D: Scalar>(&self, q: &[D]) -> D {
        let nan = D::from(f64::NAN);
        self.program.eval(|i| q.get(i).copied().unwrap_or(nan))
    }
}
