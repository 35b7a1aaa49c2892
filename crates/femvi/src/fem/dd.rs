//! Double-double arithmetic (≈ 106-bit significands) for the few tables that must be correct
//! to the last bit of f64: Gauss rules and the fixed-point tables of high-degree elements.
//! Hand-written because the `twofloat` crate's division was measured to lose ~1e-16 relative;
//! these error-free transformations (Knuth's two-sum, an FMA two-product) are exact to ~1e-32.

/// A double-double number hi + lo (|lo| ≤ ulp(hi)/2), with error-free transformations
/// (Knuth's two-sum, a fused multiply-add two-product). Only what the tables need.
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
    pub(crate) fn mul(self, o: Dd) -> Dd {
        let p = self.hi * o.hi;
        let e = self.hi.mul_add(o.hi, -p);
        Dd::quick(p, e + (self.hi * o.lo + self.lo * o.hi))
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
    /// Rounds to the nearest f64.
    pub(crate) fn round(self) -> f64 {
        self.hi + self.lo
    }
}
