//! The numbering of the optimiser's unknowns, chosen so that the KKT matrix is banded.
//!
//! Nodes are numbered g = 0 … N·s in time (element k has nodes k·s … k·s + s). Each node has
//! its multipliers Λ_g (n), with holonomic constraints its constraint impulses ν_g (mc) and,
//! but for the two ends whose positions are given, its position Q_g (n) and the multipliers
//! κ_g (mc) of g(Q_g) = 0; element k has the controls U_{k,j} (m) at its r quadrature points.
//! The order is Λ_0, ν_0, then per element k: U_k, then for the nodes g = k·s + 1 … k·s + s:
//! Q_g, Λ_g, ν_g, κ_g. An element's unknowns then lie within rm + (2n + 2mc)(s + 1)
//! consecutive indices, which is the bandwidth (plus one) of the KKT matrix. A free end (`free_q` components of the last
//! position, `free_v` of the last velocity left to the optimiser) puts the free components of
//! Q_N before Λ_N, ν_N (and κ_N) and those of the end velocity V after them, followed by the
//! multipliers of the hidden constraints G(q_N) V = 0. The last element then fits the
//! bandwidth as the others do, and V, which only the end terms couple (with Q_N, Λ_N and the
//! hidden multipliers), lies within 3n + 3mc of them, so the bandwidth holds.
//! A free final time is one more unknown after all of these, kept out of the band (a bordered system).

/// Index arithmetic for a mesh of `elements` elements of degree `s` with `r` quadrature
/// points, `n` coordinates, `m` controls and `mc` holonomic constraints.
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
    /// Holonomic constraints.
    pub(super) mc: usize,
    /// Whether the end carries the hidden constraints G(q_N) v_N = 0 (with constraints and
    /// a free end velocity, or a free end position and a given non-zero end velocity).
    pub(super) hidden: bool,
}

impl Layout {
    /// Unknowns of a node between the ends: Q, Λ, ν, κ.
    fn node(&self) -> usize {
        2 * self.n + 2 * self.mc
    }

    /// Unknowns per element: its controls and the nodes after its first.
    fn block(&self) -> usize {
        self.r * self.m + self.s * self.node()
    }

    /// κ at the last node: the constraints on its position, when some of it is free.
    fn end_kappa(&self) -> usize {
        if self.free_q > 0 {
            self.mc
        } else {
            0
        }
    }

    /// The hidden constraints G(q_N) v_N = 0, when the end carries them.
    fn end_hidden(&self) -> usize {
        if self.hidden {
            self.mc
        } else {
            0
        }
    }

    /// Number of banded unknowns (the final time, when free, is not among them).
    pub(super) fn size(&self) -> usize {
        self.end_start() + self.free_q + self.n + self.mc + self.end_kappa() + self.free_v + self.end_hidden()
    }

    /// Lower and upper bandwidth of the KKT matrix.
    pub(super) fn bandwidth(&self) -> usize {
        self.r * self.m + self.node() * (self.s + 1) - 1
    }

    /// Number of nodes, N·s + 1.
    pub(super) fn nodes(&self) -> usize {
        self.elements * self.s + 1
    }

    /// Start of node g's unknowns (g ≥ 1).
    fn node_start(&self, g: usize) -> usize {
        let (k, a) = ((g - 1) / self.s, (g - 1) % self.s + 1);
        self.n + self.mc + k * self.block() + self.r * self.m + (a - 1) * self.node()
    }

    /// Start of the last node's unknowns.
    fn end_start(&self) -> usize {
        self.node_start(self.nodes() - 1)
    }

    /// Index of Q_g's first entry, `None` at the two ends (given positions; the free
    /// components of the last are at [`Layout::end_q`]).
    pub(super) fn q(&self, g: usize) -> Option<usize> {
        (g != 0 && g + 1 != self.nodes()).then(|| self.node_start(g))
    }

    /// Index of the `slot`-th free component of the last position.
    pub(super) fn end_q(&self, slot: usize) -> usize {
        self.end_start() + slot
    }

    /// Index of Λ_g's first entry.
    pub(super) fn lambda(&self, g: usize) -> usize {
        match g {
            0 => 0,
            g if g + 1 == self.nodes() => self.end_start() + self.free_q,
            g => self.node_start(g) + self.n,
        }
    }

    /// Index of the first constraint impulse ν_g (mc entries).
    pub(super) fn nu(&self, g: usize) -> usize {
        self.lambda(g) + self.n
    }

    /// Index of the first multiplier κ_g of g(Q_g) = 0, where Q_g has unknowns.
    pub(super) fn kappa(&self, g: usize) -> Option<usize> {
        let has = self.mc > 0 && g != 0 && (g + 1 != self.nodes() || self.free_q > 0);
        has.then(|| self.nu(g) + self.mc)
    }

    /// Index of the first control at quadrature point j of element k.
    pub(super) fn u(&self, k: usize, j: usize) -> usize {
        self.n + self.mc + k * self.block() + j * self.m
    }

    /// Index of the `slot`-th free component of the end velocity.
    pub(super) fn end_v(&self, slot: usize) -> usize {
        self.end_start() + self.free_q + self.n + self.mc + self.end_kappa() + slot
    }

    /// Index of the first multiplier of the hidden constraints G(q_N) v_N = 0, when some of
    /// the end velocity is free and there are constraints.
    pub(super) fn hidden(&self) -> Option<usize> {
        (self.end_hidden() > 0).then(|| self.end_v(self.free_v))
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
            (1, 1, 1, 1, 3, 0, 0, 0),
            (2, 1, 2, 2, 4, 1, 2, 0),
            (3, 2, 3, 4, 2, 3, 3, 0),
            (1, 2, 1, 2, 1, 1, 0, 0),
            (3, 1, 1, 1, 3, 0, 0, 1),
            (3, 1, 2, 2, 3, 3, 3, 2),
            (2, 1, 3, 3, 2, 1, 0, 1),
            (2, 2, 2, 2, 1, 0, 1, 1),
        ];
        for (n, m, s, r, elements, free_q, free_v, mc) in cases {
            let l = Layout {
                n,
                m,
                s,
                r,
                elements,
                free_q,
                free_v,
                mc,
                hidden: mc > 0 && free_q + free_v > 0,
            };
            let mut seen = vec![0; l.size()];
            let node_vars = |g: usize| {
                let mut v: Vec<usize> = (0..n).map(|i| l.lambda(g) + i).collect();
                v.extend((0..mc).map(|c| l.nu(g) + c));
                if let Some(q) = l.q(g) {
                    v.extend((0..n).map(|i| q + i));
                }
                if let Some(k) = l.kappa(g) {
                    v.extend((0..mc).map(|c| k + c));
                }
                v
            };
            for g in 0..l.nodes() {
                node_vars(g).into_iter().for_each(|i| seen[i] += 1);
            }
            for k in 0..elements {
                let mut idx = vec![];
                for j in 0..r {
                    (0..m).for_each(|c| idx.push(l.u(k, j) + c));
                }
                for g in k * s..=k * s + s {
                    idx.extend(node_vars(g));
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
            if let Some(h) = l.hidden() {
                (0..mc).for_each(|c| seen[h + c] += 1);
            }
            assert!(seen.iter().all(|&c| c == 1), "{seen:?}");
        }
    }
}
