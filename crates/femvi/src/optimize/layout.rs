//! The numbering of the optimiser's unknowns, chosen so that the KKT matrix is banded.
//!
//! Nodes are numbered g = 0 … N·s in time (element k has nodes k·s … k·s + s). Each node has
//! its multipliers Λ_g (n) and, but for the two ends whose positions are given, its position
//! Q_g (n); element k has the controls U_{k,j} (m) at its r quadrature points. The order is
//! Λ_0, then per element k: U_k, then for the nodes g = k·s + 1 … k·s + s: Q_g, Λ_g. An
//! element's unknowns then lie within rm + 2n(s + 1) consecutive indices, which is the
//! bandwidth (plus one) of the KKT matrix. A free end (`free_q` components of the last
//! position, `free_v` of the last velocity left to the optimiser) puts the free components of
//! Q_N before Λ_N and those of the end velocity V after it. The last element then spans
//! rm + 2ns + n + free_q ≤ rm + 2n(s + 1) indices, and V, which only the end term couples
//! (with Q_N and Λ_N), lies within free_q + n + free_v ≤ 3n of them, so the bandwidth holds.
//! A free final time is one more unknown after all of these, kept out of the band (a bordered system).

/// Index arithmetic for a mesh of `elements` elements of degree `s` with `r` quadrature
/// points, `n` coordinates and `m` controls.
#[derive(Debug, Clone, Copy)]
pub(super) struct Layout {
    pub(super) n: usize,
    pub(super) m: usize,
    pub(super) s: usize,
    pub(super) r: usize,
    pub(super) elements: usize,
    /// Free components of the last position.
    pub(super) free_q: usize,
    /// Free components of the last velocity.
    pub(super) free_v: usize,
}

impl Layout {
    /// Unknowns per element: its controls and, per node after its first, Q and Λ.
    fn block(&self) -> usize {
        self.r * self.m + 2 * self.n * self.s
    }

    /// Number of banded unknowns (the final time, when free, is not among them).
    pub(super) fn size(&self) -> usize {
        self.elements * self.block() + self.free_q + self.free_v
    }

    /// Lower and upper bandwidth of the KKT matrix.
    pub(super) fn bandwidth(&self) -> usize {
        self.r * self.m + 2 * self.n * (self.s + 1) - 1
    }

    /// Number of nodes, N·s + 1.
    pub(super) fn nodes(&self) -> usize {
        self.elements * self.s + 1
    }

    /// Start of node g's Q followed by its Λ (g ≥ 1); the last node has only its free
    /// components of Q.
    fn node_start(&self, g: usize) -> usize {
        let (k, a) = ((g - 1) / self.s, (g - 1) % self.s + 1);
        self.n + k * self.block() + self.r * self.m + (a - 1) * 2 * self.n
    }

    /// Index of Q_g's first entry, `None` at the two ends (given positions; the free
    /// components of the last are at [`Layout::end_q`]).
    pub(super) fn q(&self, g: usize) -> Option<usize> {
        (g != 0 && g + 1 != self.nodes()).then(|| self.node_start(g))
    }

    /// Index of the `slot`-th free component of the last position.
    pub(super) fn end_q(&self, slot: usize) -> usize {
        self.node_start(self.nodes() - 1) + slot
    }

    /// Index of the `slot`-th free component of the end velocity.
    pub(super) fn end_v(&self, slot: usize) -> usize {
        self.node_start(self.nodes() - 1) + self.free_q + self.n + slot
    }

    /// Index of Λ_g's first entry.
    pub(super) fn lambda(&self, g: usize) -> usize {
        match g {
            0 => 0,
            g if g + 1 == self.nodes() => self.node_start(g) + self.free_q,
            g => self.node_start(g) + self.n,
        }
    }

    /// Index of the first control at quadrature point j of element k.
    pub(super) fn u(&self, k: usize, j: usize) -> usize {
        self.n + k * self.block() + j * self.m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every unknown has exactly one index, all indices are used, and each element's
    /// unknowns fit within the bandwidth.
    #[test]
    fn numbering_is_a_bijection_within_the_band() {
        let cases = [
            (1, 1, 1, 1, 3, 0, 0),
            (2, 1, 2, 2, 4, 1, 2),
            (3, 2, 3, 4, 2, 3, 3),
            (1, 2, 1, 2, 1, 1, 0),
        ];
        for (n, m, s, r, elements, free_q, free_v) in cases {
            let l = Layout {
                n,
                m,
                s,
                r,
                elements,
                free_q,
                free_v,
            };
            let mut seen = vec![0; l.size()];
            for g in 0..l.nodes() {
                for i in 0..n {
                    seen[l.lambda(g) + i] += 1;
                    if let Some(q) = l.q(g) {
                        seen[q + i] += 1;
                    }
                }
            }
            for k in 0..elements {
                let mut idx = vec![];
                for j in 0..r {
                    (0..m).for_each(|c| idx.push(l.u(k, j) + c));
                }
                for g in k * s..=k * s + s {
                    (0..n).for_each(|i| idx.push(l.lambda(g) + i));
                    if let Some(q) = l.q(g) {
                        (0..n).for_each(|i| idx.push(q + i));
                    }
                }
                if k + 1 == elements {
                    (0..free_q).for_each(|c| idx.push(l.end_q(c)));
                }
                let (lo, hi) = (idx.iter().min().unwrap(), idx.iter().max().unwrap());
                assert!(hi - lo <= l.bandwidth(), "element {k} spans {}", hi - lo);
                // The end term couples q_N, Λ_N and v_N only.
                let last = l.lambda(l.nodes() - 1);
                let end = (0..free_q)
                    .map(|c| l.end_q(c))
                    .chain(last..last + n)
                    .chain((0..free_v).map(|c| l.end_v(c)));
                let (lo, hi) = (end.clone().min().unwrap(), end.max().unwrap());
                assert!(hi - lo <= l.bandwidth(), "the end term spans {}", hi - lo);
                for j in 0..r {
                    (0..m).for_each(|c| seen[l.u(k, j) + c] += 1);
                }
            }
            (0..free_q).for_each(|c| seen[l.end_q(c)] += 1);
            (0..free_v).for_each(|c| seen[l.end_v(c)] += 1);
            assert!(seen.iter().all(|&c| c == 1), "{seen:?}");
        }
    }
}
