//! The discrete forces of an element (Marsden–West 2001, §3.2), the virtual work of F over
//! the element with its own quadrature and basis:
//!
//!   F_d^j = h Σ_i b_i F(t_k + c_i h, q_h(c_i), q̇_h(c_i)) ℓ_j(c_i),
//!
//! over any scalar, with the element's work h Σ_i b_i F·q̇_h(c_i); and their Jacobian in the
//! nodal values by forward-mode dual numbers (one pass per nodal value).

use super::Force;
use crate::discrete::Element;
use crate::lagrangian::Scalar;
use num_dual::Dual64;

/// The discrete forces F_d^0 … F_d^s of the element [t0, t0 + h] whose nodal values are
/// `base` + `incr[j]` (incr row-major (s+1)×n), into `out` ((s+1)·n entries); returns the
/// element's work h Σ_i b_i F(c_i)·q̇_h(c_i). NaN (in `out` and the work) unless the lengths
/// fit the element and the force's dimension n = `base.len()`.
///
/// # Example
///
/// ```
/// use femvi::forces::{element_forces, LinearForce};
/// use femvi::Element;
///
/// // A constant force f on a linear element of step h: F_d = (h f/2, h f/2), work f Δq.
/// let element = Element::with_order(2)?;
/// let f = LinearForce::drive(vec![3.0], 0.0);
/// let mut fd = [0.0f64; 2];
/// let work = element_forces(&element, &f, 0.0, 0.5, &[1.0], &[0.0, 0.2], &mut fd);
/// assert!((fd[0] - 0.75).abs() < 1e-15 && (fd[1] - 0.75).abs() < 1e-15);
/// assert!((work - 0.6).abs() < 1e-15);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn element_forces<D: Scalar, F: Force>(
    element: &Element,
    force: &F,
    t0: f64,
    h: f64,
    base: &[f64],
    incr: &[D],
    out: &mut [D],
) -> D {
    let (n, w) = (base.len(), element.nodes());
    let size = n.checked_mul(w);
    if force.dim() != n || size != Some(incr.len()) || size != Some(out.len()) {
        out.iter_mut().for_each(|o| *o = D::from(f64::NAN));
        return D::from(f64::NAN);
    }
    // Called at every solver iteration: small systems use stack buffers, larger ones allocate.
    if n <= STACK {
        let mut buf = [D::from(0.0); 3 * STACK];
        let (q, rest) = buf.split_at_mut(STACK);
        let (v, f) = rest.split_at_mut(STACK);
        accumulate(
            element,
            force,
            (t0, h),
            base,
            incr,
            out,
            (&mut q[..n], &mut v[..n], &mut f[..n]),
        )
    } else {
        let mut buf = vec![D::from(0.0); 3 * n];
        let (q, rest) = buf.split_at_mut(n);
        let (v, f) = rest.split_at_mut(n);
        accumulate(element, force, (t0, h), base, incr, out, (q, v, f))
    }
}

/// Largest n (and, for the Jacobian, 4n nodal values) evaluated from stack buffers.
const STACK: usize = 16;

/// The sums of [`element_forces`] with the point buffers (q, v, F) given.
fn accumulate<D: Scalar, F: Force>(
    element: &Element,
    force: &F,
    (t0, h): (f64, f64),
    base: &[f64],
    incr: &[D],
    out: &mut [D],
    (q, v, f): (&mut [D], &mut [D], &mut [D]),
) -> D {
    let (n, w) = (base.len(), element.nodes());
    out.iter_mut().for_each(|o| *o = D::from(0.0));
    let mut work = D::from(0.0);
    for i in 0..element.points() {
        for c in 0..n {
            q[c] = D::from(base[c]);
            v[c] = D::from(0.0);
        }
        for j in 0..w {
            let (a, d) = (element.phi(i, j), element.dphi(i, j) / h);
            for c in 0..n {
                q[c] += incr[j * n + c] * a;
                v[c] += incr[j * n + c] * d;
            }
        }
        let t = t0 + element.rule.nodes[i] * h;
        force.force(D::from(t), q, v, f);
        let bh = element.rule.weights[i] * h;
        for c in 0..n {
            work += f[c] * v[c] * bh;
        }
        for j in 0..w {
            let a = bh * element.phi(i, j);
            for c in 0..n {
                out[j * n + c] += f[c] * a;
            }
        }
    }
    work
}

/// [`element_forces`] in f64 with its Jacobian ∂F_d^j_c/∂Q^m_e into `jac` (row-major, w×w
/// for w = (s+1)·n), by one dual-number pass per nodal value; returns the work. NaN if the
/// lengths do not fit.
///
/// ```
/// use femvi::forces::{element_forces_jacobian, LinearForce};
/// use femvi::Element;
///
/// // F = −c v on a linear element: F_d^j = −(c/2)(Q^1 − Q^0), so ∂F_d^j/∂Q^1 = −c/2.
/// let element = Element::with_order(2)?;
/// let (mut fd, mut jac) = ([0.0; 2], [0.0; 4]);
/// element_forces_jacobian(&element, &LinearForce::damping(1, 0.4), 0.0, 0.1, &[0.0], &[0.0, 0.3], &mut fd, &mut jac);
/// assert!(jac.iter().zip([0.2, -0.2, 0.2, -0.2]).all(|(a, b)| (a - b).abs() < 1e-15));
/// # Ok::<(), femvi::Error>(())
/// ```
#[allow(clippy::too_many_arguments)]
pub fn element_forces_jacobian<F: Force>(
    element: &Element,
    force: &F,
    t0: f64,
    h: f64,
    base: &[f64],
    incr: &[f64],
    out: &mut [f64],
    jac: &mut [f64],
) -> f64 {
    let w = incr.len();
    if w.checked_mul(w) != Some(jac.len()) {
        jac.iter_mut().for_each(|x| *x = f64::NAN);
        out.iter_mut().for_each(|x| *x = f64::NAN);
        return f64::NAN;
    }
    let work = element_forces(element, force, t0, h, base, incr, out);
    let (mut xs, mut fs) = ([Dual64::from(0.0); 4 * STACK], [Dual64::from(0.0); 4 * STACK]);
    let (mut xh, mut fh);
    let (xd, fd) = if w <= 4 * STACK {
        (&mut xs[..w], &mut fs[..w])
    } else {
        (xh, fh) = (vec![Dual64::from(0.0); w], vec![Dual64::from(0.0); w]);
        (&mut xh[..], &mut fh[..])
    };
    xd.iter_mut().zip(incr).for_each(|(d, &x)| *d = Dual64::from(x));
    for b in 0..w {
        xd[b].eps = 1.0;
        element_forces(element, force, t0, h, base, xd, fd);
        xd[b].eps = 0.0;
        for (a, f) in fd.iter().enumerate() {
            jac[a * w + b] = f.eps;
        }
    }
    work
}
