//! Size checks of an element's buffers, so that the in-place evaluations of `discrete.rs`
//! never index past a caller's buffer: [`Element::check_buffers`] (a typed error, for callers
//! to run once before a loop) and the O(r) test the evaluations run on every call (NaN
//! results on a misfit, no panic). Also the consistency of an element whose public fields
//! (basis, rule) were changed after construction.

use super::{Element, ElementWork};
use crate::error::{check_len, invalid, Error, Result};

impl Element {
    /// Checks buffers for [`Element::points_in_place`], [`Element::gradient_in_place`] and
    /// (with `hess`) [`Element::hessian_in_place`] in dimension n = `base.len()`: `incr` and
    /// `grad` of (s+1)·n entries, `hess` of ((s+1)·n)², and `work` made by
    /// [`ElementWork::new`] for this element and n. The evaluations run the same test on every
    /// call and answer NaN when it fails; this names the buffer at fault.
    ///
    /// # Errors
    /// [`Error::Dimension`] naming the first buffer of the wrong size, or
    /// [`Error::Invalid`] for n = 0.
    pub fn check_buffers(
        &self,
        base: &[f64],
        incr: &[f64],
        work: &ElementWork,
        grad: &[f64],
        hess: Option<&[f64]>,
    ) -> Result<()> {
        let n = base.len();
        if n == 0 {
            return Err(invalid("element buffers", "dimension 0: base is empty"));
        }
        let too_big = || invalid("element buffers", format!("dimension {n} is too large"));
        let dim = self.nodes().checked_mul(n).ok_or_else(too_big)?;
        check_len("nodal increments", dim, incr.len())?;
        check_len("gradient", dim, grad.len())?;
        if let Some(hess) = hess {
            check_len("Hessian", dim.checked_mul(dim).ok_or_else(too_big)?, hess.len())?;
        }
        check_len("element work (dimension)", n, work.n)?;
        if !work.fits(self.points(), n) {
            return Err(Error::Dimension {
                what: "element work (quadrature points)".into(),
                expected: self.points(),
                got: work.pts.len(),
            });
        }
        Ok(())
    }

    /// Whether the evaluations can run in dimension n with these increments and work space.
    pub(super) fn fits(&self, n: usize, incr: &[f64], work: &ElementWork) -> bool {
        n > 0 && work.n == n && self.nodes().checked_mul(n) == Some(incr.len()) && work.fits(self.points(), n)
    }

    /// Checks that the basis, the rule and the tabulated values agree (they do for an element
    /// built by this module; its public fields could have been changed since).
    pub(super) fn check_consistent(&self) -> Result<()> {
        let (w, r) = (self.nodes(), self.points());
        let basis_ok = self.basis.degree >= 1 && self.basis.nodes.len() == w;
        let rule_ok = r >= 1 && self.rule.weights.len() == r;
        let tables_ok = self.phi.len() == r * w && self.dphi.len() == r * w;
        if basis_ok && rule_ok && tables_ok {
            Ok(())
        } else {
            Err(invalid(
                "element",
                "its basis, quadrature rule and tables disagree (a public field was changed after construction); build it again",
            ))
        }
    }
}

impl ElementWork {
    /// Whether the work space holds r points in dimension n (each point's derivative buffers
    /// for n too).
    pub(super) fn fits(&self, r: usize, n: usize) -> bool {
        let rn = r.checked_mul(n);
        self.n == n
            && self.tc.len() == r
            && rn == Some(self.qc.len())
            && rn == Some(self.vc.len())
            && self.pts.len() == r
            && self.pts.iter().all(|p| p.dim() == n && p.grad.len() == p.width())
    }

    /// Sets the points to NaN (after a call with buffers that do not fit).
    pub(super) fn poison(&mut self) {
        for x in self.tc.iter_mut().chain(self.qc.iter_mut()).chain(self.vc.iter_mut()) {
            *x = f64::NAN;
        }
    }
}
