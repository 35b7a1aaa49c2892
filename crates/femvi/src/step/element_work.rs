//! The element's evaluation buffers — points, gradient ∂L_d/∂Q and Hessian ∂²L_d/∂Q∂Q — for
//! whatever needs the element's derivatives rather than forces: the Newton solver, the start
//! from (q0, q1), the energy mode's discrete energies and the tangent maps. Made on first use,
//! so that explicit and fixed-point runs never hold the (s+1)n-square Hessian.

use crate::discrete::{Element, ElementWork};
use crate::error::{invalid, Result};

/// The largest (s+1)·n for which the dense element Hessian ((s+1)n)² and Newton's s·n-square
/// Jacobians are allocated: 4 096, about 128 MB for the Hessian and 256 MB for the Jacobians.
pub const MAX_DENSE_NEWTON: usize = 4096;

/// Checks, before anything is allocated, that Newton's dense matrices for `element` in
/// dimension n stay within [`MAX_DENSE_NEWTON`].
///
/// # Errors
/// [`crate::Error::Invalid`] naming the size, the limit and the way out.
pub(crate) fn check_dense_newton(element: &Element, n: usize) -> Result<()> {
    let w = element.nodes().checked_mul(n);
    match w {
        Some(w) if w <= MAX_DENSE_NEWTON => Ok(()),
        _ => Err(invalid(
            "Newton's method",
            format!(
                "an element of {} nodes in dimension {n} needs dense ({}n)^2 Hessians; the limit is (s+1) n <= {MAX_DENSE_NEWTON} (use a mechanical Lagrangian with method = \"fixed-point\", a lower degree or a smaller system)",
                element.nodes(),
                element.nodes(),
            ),
        )),
    }
}

/// Buffers for evaluating one element of dimension n.
#[derive(Debug, Clone)]
pub(crate) struct ElementBuffers {
    pub(crate) ework: ElementWork,
    /// ∂L_d/∂Q, (s+1)n.
    pub(crate) grad: Vec<f64>,
    /// ∂²L_d/∂Q∂Q, row-major ((s+1)n)²; empty until a Hessian is needed.
    hess: Vec<f64>,
}

impl ElementBuffers {
    pub(crate) fn new(element: &Element, n: usize) -> Self {
        Self {
            ework: ElementWork::new(element, n),
            grad: vec![0.0; element.nodes() * n],
            hess: Vec::new(),
        }
    }

    /// The buffers with the Hessian allocated: (work, gradient, Hessian).
    #[inline]
    pub(crate) fn with_hessian(&mut self) -> (&mut ElementWork, &mut [f64], &mut [f64]) {
        let w = self.grad.len();
        if self.hess.len() != w * w {
            self.hess = vec![0.0; w * w];
        }
        (&mut self.ework, &mut self.grad, &mut self.hess)
    }
}

/// Makes the buffers on first use.
#[inline]
pub(crate) fn buffers<'b>(slot: &'b mut Option<ElementBuffers>, element: &Element, n: usize) -> &'b mut ElementBuffers {
    slot.get_or_insert_with(|| ElementBuffers::new(element, n))
}
