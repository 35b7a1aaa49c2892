//! The numbering of the unknowns of a boundary value problem in the vector that the Newton
//! iteration solves for, and which unknown each local variable of an element is. Only the
//! unknowns of one element or of two neighbours meet in the Hessian of the action, so the
//! numbering in order of time makes it banded ([`Layout::bandwidth`]).

/// Where the unknowns sit in the solution vector. Fixed mesh: the interior nodal values in
/// order of time. Moving mesh: per element k ≥ 1 the block (t_k, Q_k, internal nodes of
/// element k), after the internal nodes of element 0.
#[derive(Debug, Clone, Copy)]
pub(super) struct Layout {
    pub(super) n: usize,
    pub(super) s: usize,
    pub(super) elements: usize,
    pub(super) moving: bool,
}

impl Layout {
    fn block(&self) -> usize {
        1 + self.s * self.n
    }
    fn offset(&self, k: usize) -> usize {
        (self.s - 1) * self.n + (k - 1) * self.block()
    }
    /// The unknown t_k, if it is one.
    pub(super) fn time(&self, k: usize) -> Option<usize> {
        (self.moving && k >= 1 && k < self.elements).then(|| self.offset(k))
    }
    /// Component c of global node g, if it is an unknown.
    pub(super) fn node(&self, g: usize, c: usize) -> Option<usize> {
        let (n, s) = (self.n, self.s);
        if g == 0 || g == self.elements * s {
            return None;
        }
        if !self.moving {
            return Some((g - 1) * n + c);
        }
        let (k, j) = (g / s, g % s);
        Some(match (k, j) {
            (_, 0) => self.offset(k) + 1 + c,
            (0, _) => (j - 1) * n + c,
            _ => self.offset(k) + 1 + n + (j - 1) * n + c,
        })
    }
    /// The unknown behind local variable `a` of element k, if it is one. The local variables
    /// are, on a moving mesh, (t_k, t_{k+1}, Q^0 … Q^s) and, on a fixed mesh, (Q^0 … Q^s),
    /// each Q^j with its n components.
    pub(super) fn local(&self, k: usize, a: usize) -> Option<usize> {
        let (n, s) = (self.n, self.s);
        let lead = if self.moving { 2 } else { 0 };
        match a {
            0 if self.moving => self.time(k),
            1 if self.moving => self.time(k + 1),
            _ => self.node(k * s + (a - lead) / n, (a - lead) % n),
        }
    }
    pub(super) fn len(&self) -> usize {
        if self.moving {
            (self.s - 1) * self.n + (self.elements - 1) * self.block()
        } else {
            (self.elements * self.s - 1) * self.n
        }
    }
    /// The number of unknowns and of entries of the banded Jacobian (size × (3 bandwidth + 1),
    /// see `BandMatrix::zeros`), or None if they overflow; the arithmetic of [`Layout::len`]
    /// and [`Layout::bandwidth`], checked.
    pub(super) fn checked_size(&self) -> Option<(usize, usize)> {
        let (n, s, big_n) = (self.n, self.s, self.elements);
        let (unknowns, bandwidth) = if self.moving {
            let block = s.checked_mul(n)?.checked_add(1)?;
            let first = s.checked_sub(1)?.checked_mul(n)?;
            let rest = big_n.checked_sub(1)?.checked_mul(block)?;
            (first.checked_add(rest)?, block.checked_add(n)?)
        } else {
            let nodes = big_n.checked_mul(s)?.checked_sub(1)?;
            (nodes.checked_mul(n)?, s.checked_add(1)?.checked_mul(n)?.checked_sub(1)?)
        };
        let width = bandwidth.checked_mul(3)?.checked_add(1)?;
        Some((unknowns, unknowns.max(1).checked_mul(width)?))
    }

    /// Lower (= upper) bandwidth of ∂²S.
    pub(super) fn bandwidth(&self) -> usize {
        if self.moving {
            self.block() + self.n
        } else {
            (self.s + 1) * self.n - 1
        }
    }
}
