//! Double-double arithmetic (≈ 106-bit significands) for the few tables that must be correct
//! to the last bit of f64: Gauss rules, the fixed-point tables of high-degree elements, and the
//! energy level of adaptive runs (`adaptive/energy.rs`).
//! Hand-written because the `twofloat` crate's division was measured to lose ~1e-16 relative;
//! these error-free transformations (Knuth's two-sum, Dekker's two-product) are exact to
//! ~1e-32.

/// A double-double number hi + lo (|lo| ≤ ulp(hi)/2), with error-free transformations
/// (Knuth's two-sum, Dekker's two-product). Only what the tables need.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Dd {
    pub(crate) hi: f64,
    pub(crate) lo: f64,
}

impl Dd {
    pub(crate) fn new(x: f64) -> Self {
        Dd { hi: x, lo: 0.0 }
    }
    pub(crate) fn two_sum(a: f64, b: f64) -> Self {
        let s = a + b;
        let bb = s - a;
        let e = (a - (s - bb)) + (b - bb);
        Dd { hi: s, lo: e }
    }
    pub(crate) fn quick(a: f64, b: f64) -> Self {
        let s = a + b;
        Dd { hi: s, lo: b - (s - a) }
    }
    pub(crate) fn add(self, o: Dd) -> Dd {
        let s = Dd::two_sum(self.hi, o.hi);
        let t = Dd::two_sum(self.lo, o.lo);
        let s = Dd::quick(s.hi, s.lo + t.hi);
        Dd::quick(s.hi, s.lo + t.lo)
    }
    pub(crate) fn neg(self) -> Dd {
        Dd {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
    pub(crate) fn sub(self, o: Dd) -> Dd {
        self.add(o.neg())
    }
    /// The exact product a·b as hi + lo by Dekker's splitting: plain f64 arithmetic, no fused
    /// multiply-add (which the baseline x86-64 target lacks and emulates in software; the
    /// step-scaled tables are built every step on a variable grid). Exact unless a·b over- or
    /// underflows.
    pub(crate) fn two_prod(a: f64, b: f64) -> Dd {
        const SPLIT: f64 = 134_217_729.0; // 2^27 + 1
        let split = |x: f64| {
            let c = SPLIT * x;
            let hi = c - (c - x);
            (hi, x - hi)
        };
        let p = a * b;
        let (ah, al) = split(a);
        let (bh, bl) = split(b);
        Dd {
            hi: p,
            lo: ((ah * bh - p) + ah * bl + al * bh) + al * bl,
        }
    }
    /// The double-double product, by [`Dd::two_prod`].
    pub(crate) fn mul(self, o: Dd) -> Dd {
        let p = Dd::two_prod(self.hi, o.hi);
        Dd::quick(p.hi, p.lo + (self.hi * o.lo + self.lo * o.hi))
    }
    pub(crate) fn mulf(self, f: f64) -> Dd {
        self.mul(Dd::new(f))
    }
    pub(crate) fn div(self, o: Dd) -> Dd {
        let q1 = self.hi / o.hi;
        let r = self.sub(o.mulf(q1));
        let q2 = r.hi / o.hi;
        let r = r.sub(o.mulf(q2));
        let q3 = r.hi / o.hi;
        Dd::quick(q1, q2).add(Dd::new(q3))
    }
    pub(crate) fn divf(self, f: f64) -> Dd {
        self.div(Dd::new(f))
    }
    /// The square root (one Newton correction of the f64 root; NaN, infinities and zero as
    /// f64 gives them).
    pub(crate) fn sqrt(self) -> Dd {
        let s = self.hi.sqrt();
        if s == 0.0 || !s.is_finite() {
            return Dd::new(s);
        }
        let r = self.sub(Dd::two_prod(s, s));
        Dd::quick(s, r.hi / (2.0 * s))
    }
    /// Rounds to the nearest f64.
    pub(crate) fn round(self) -> f64 {
        self.hi + self.lo
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn dekker_product_is_exact() {
        // (1 + 2^-30)(1 + 2^-29) = 1 + 3·2^-30 + 2^-59: the last term is the rounding error.
        let a = 1.0 + 2f64.powi(-30);
        let b = 1.0 + 2f64.powi(-29);
        let p = super::Dd::two_prod(a, b);
        assert_eq!(p.hi, 1.0 + 3.0 * 2f64.powi(-30));
        assert_eq!(p.lo, 2f64.powi(-59));
        // Against the fused multiply-add product on awkward values.
        for (x, y) in [(0.1, 0.7), (1.0 / 3.0, 3.0e10), (-2.5e-8, 1.2345678901234567)] {
            let q = super::Dd::two_prod(x, y);
            assert_eq!(q.hi, x * y);
            assert_eq!(q.lo, x.mul_add(y, -(x * y)));
        }
    }
}
