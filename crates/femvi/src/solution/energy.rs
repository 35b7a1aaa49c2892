//! The energy at every node of a run and how far it strays: H(t, q, p) = p·v − L by the
//! inverse Legendre transform (each inversion warm-started from the previous node's
//! velocity), the largest relative error |H − H0| / |H0| (|H − H0| where H0 = 0), and for a
//! time-dependent Lagrangian the balance with the continuous law dH/dt = −∂L/∂t: the work
//! W(t) = −∫∂L/∂t dt by the trapezoid rule over the nodes (so itself only second-order accurate
//! in the step) and the largest |H − H0 − W| relative to |H0|.
//!
//! [`super::solve`] tracks it (unless [`super::SolveOptions::track_energy`] is off) and the
//! command and the Python package report the same numbers, bit for bit, from this one place.

use super::dense::ElementEval;
use crate::error::{check_len, invalid, Result};
use crate::fem::LagrangeBasis;
use crate::lagrangian::{hamiltonian, Lagrangian, PointDerivatives};
use crate::slices::copy_short;
use crate::step::{ElementNodes, Start};

/// The energy of one node, as [`EnergyTracker::node`] computed it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct NodeEnergy {
    /// The Hamiltonian H(t, q, p).
    pub h: f64,
    /// Its relative error against the first node's.
    pub rel: f64,
}

/// What the energy did over a run: over every node, whatever was kept, or over the kept nodes
/// only ([`EnergyReport::nodes`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyReport {
    /// Largest |H − H0| / |H0| over the nodes (|H − H0| where H0 = 0).
    pub max_rel_error: f64,
    /// Time-dependent L only: the largest |H − H0 − W| / |H0|, W = −∫∂L/∂t dt.
    pub max_rel_balance: Option<f64>,
    /// The nodes the errors are over ([`super::EnergyNodes::Every`] or
    /// [`super::EnergyNodes::Kept`]).
    pub nodes: super::EnergyNodes,
}

/// The energy balance of a time-dependent Lagrangian.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Balance {
    /// (t, ∂L/∂t) at the last node.
    last: Option<(f64, f64)>,
    work: f64,
    max_rel: f64,
}

/// Computes H at every node it is shown and keeps the largest relative error.
///
/// ```
/// use femvi::solution::EnergyTracker;
/// use femvi::{models, Lagrangian, Start};
/// let lag = models::harmonic(1.0, 1.0)?;
/// let start = Start::Velocity { q: vec![1.0], v: vec![0.0] };
/// let mut tracker = EnergyTracker::new(1, &start, lag.is_autonomous());
/// let e = tracker.node(&lag, 0.0, &[1.0], &[0.0])?;
/// assert_eq!(e.h, 0.5);
/// let e = tracker.node(&lag, 0.1, &[0.0], &[1.1])?; // H = 0.605
/// assert!((e.rel - 0.21).abs() < 1e-12);
/// assert_eq!(tracker.report().max_rel_error, e.rel);
/// # Ok::<(), femvi::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct EnergyTracker {
    /// Velocities of the last Legendre inversion: the next one starts from them.
    v: Vec<f64>,
    work: PointDerivatives,
    e0: f64,
    /// The largest |H − H0| since the start or the last restore: the largest relative error
    /// is this over |H0| (division rounds monotonically, so the quotient of the maximum is the
    /// maximum of the quotients, bit for bit), which saves a division per node.
    max_dev: f64,
    /// The largest relative error restored from a checkpoint (0 otherwise).
    max_rel_floor: f64,
    /// The last node's energy; its `rel` is computed when asked for if `rel_stale`.
    current: NodeEnergy,
    rel_stale: bool,
    balance: Option<Balance>,
    /// What the caller shows it (for the report).
    nodes: super::EnergyNodes,
    /// [`super::EnergyNodes::Kept`]: where an inversion starts.
    end: Option<ElementEnd>,
}

/// The interpolant of an element evaluated at its end: the basis and scratch.
#[derive(Debug, Clone)]
struct ElementEnd {
    basis: LagrangeBasis,
    eval: ElementEval,
    /// q_h(t_end), computed alongside and not used.
    q: Vec<f64>,
}

impl EnergyTracker {
    /// For a system with `dim` coordinates started from `start` (whose velocities, if given,
    /// start the first Legendre inversion); `autonomous` as [`Lagrangian::is_autonomous`].
    pub fn new(dim: usize, start: &Start, autonomous: bool) -> Self {
        let v = match start {
            Start::Velocity { v, .. } if v.len() == dim => v.clone(),
            _ => vec![0.0; dim],
        };
        Self {
            v,
            work: PointDerivatives::new(dim),
            e0: f64::NAN,
            max_dev: 0.0,
            max_rel_floor: 0.0,
            current: NodeEnergy::default(),
            rel_stale: false,
            balance: (!autonomous).then_some(Balance {
                last: None,
                work: 0.0,
                max_rel: 0.0,
            }),
            nodes: super::EnergyNodes::Every,
            end: None,
        }
    }

    /// Says which nodes the caller shows the tracker ([`EnergyReport::nodes`]; by default
    /// [`super::EnergyNodes::Every`]); with [`super::EnergyNodes::Kept`],
    /// [`EnergyTracker::node_after`] starts each inversion from the end velocity of the
    /// element (of basis `basis`) ending on the node.
    pub fn with_nodes(mut self, nodes: super::EnergyNodes, basis: &LagrangeBasis) -> Self {
        self.nodes = nodes;
        self.end = (nodes == super::EnergyNodes::Kept).then(|| ElementEnd {
            basis: basis.clone(),
            eval: ElementEval::new(basis.len()),
            q: vec![0.0; self.v.len()],
        });
        self
    }

    /// The energy at the node (t, q, p), which becomes the current one.
    ///
    /// # Errors
    /// As [`hamiltonian`]: the Legendre transform cannot be inverted there, or the lengths
    /// are not the tracker's dimension.
    ///
    /// Inlined (its rare parts are not), so that a caller's loop over nodes (the command's
    /// explicit fast path) keeps the mechanical case in registers.
    #[inline(always)]
    pub fn node<L: Lagrangian>(&mut self, lag: &L, t: f64, q: &[f64], p: &[f64]) -> Result<NodeEnergy> {
        let n = self.v.len();
        let h = match lag.mass_matrix() {
            // The mechanical case of `hamiltonian` (v = M⁻¹p, H = p·v − L, the same operations
            // in the same order, so the same bits) without its argument checks at every node:
            // the lengths are compared here, and anything else takes the checked route.
            Some(mass) if q.len() == n && p.len() == n && lag.dim() == n && mass.dim() == n && n > 0 => {
                mass.solve(p, &mut self.v);
                let pv: f64 = p.iter().zip(self.v.iter()).map(|(a, b)| a * b).sum();
                pv - lag.value(t, q, &self.v)
            }
            _ => self.general(lag, t, q, p)?,
        };
        if self.e0.is_nan() {
            self.e0 = h;
        }
        // A node whose energy is not finite ends the run (the callers' check): it stays out
        // of the report (a select, not a branch, in this inlined path).
        self.max_dev = self.max_dev.max(if h.is_finite() { (h - self.e0).abs() } else { 0.0 });
        self.current.h = h;
        self.rel_stale = true;
        if self.balance.is_some() && h.is_finite() {
            self.balance_at(lag, t, q, h);
        }
        // The caller that does not read `rel` (the command between written nodes) does not
        // pay its division.
        Ok(self.current())
    }

    /// |H − H0| relative to |H0| (itself where H0 = 0).
    #[inline(always)]
    fn relative(&self, dev: f64) -> f64 {
        if self.e0 != 0.0 {
            dev / self.e0.abs()
        } else {
            dev
        }
    }

    /// H by [`hamiltonian`] (any Lagrangian).
    #[inline(never)]
    fn general<L: Lagrangian>(&mut self, lag: &L, t: f64, q: &[f64], p: &[f64]) -> Result<f64> {
        hamiltonian(lag, t, q, p, &mut self.v, &mut self.work)
    }

    /// Whether [`EnergyTracker::node_lean`] applies to `lag`: an autonomous mechanical
    /// Lagrangian with M = I of the tracker's dimension.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::solution::EnergyTracker;
    /// use femvi::{models, Lagrangian, Start};
    /// let lag = models::kepler(1.0)?;
    /// let start = Start::Momentum { q: vec![1.0, 0.0], p: vec![0.0, 1.0] };
    /// let mut tracker = EnergyTracker::new(2, &start, lag.is_autonomous());
    /// assert!(tracker.lean(&lag));
    /// // H = |p|²/2 − μ/|q| = −1/2 on the circular orbit, as `node` gives it.
    /// let h = tracker.node_lean(&lag, 0.0, &[1.0, 0.0], &[0.0, 1.0]);
    /// assert_eq!(h, Some(-0.5));
    /// assert_eq!(tracker.node(&lag, 0.0, &[1.0, 0.0], &[0.0, 1.0])?.h, -0.5);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn lean<L: Lagrangian>(&self, lag: &L) -> bool {
        let n = self.v.len();
        let identity = lag.mass_matrix().is_some_and(|m| m.is_identity() && m.dim() == n);
        identity && self.balance.is_none() && lag.dim() == n && n > 0
    }

    /// As [`EnergyTracker::node`] for a Lagrangian [`EnergyTracker::lean`] accepted (the
    /// caller checks), with the same operations and bits: H = p·p − L(t, q, p), since
    /// v = M⁻¹p = p. Its code has no call and no error path, so that in a caller's loop over
    /// nodes (the command's explicit fast path) the loop's carried values stay in
    /// registers: the checked [`EnergyTracker::node`] there cost 16 % of a Kepler run, this
    /// 2 %. None (and nothing recorded) if q or p is not of the tracker's dimension. See
    /// [`EnergyTracker::lean`] for an example.
    #[inline(always)]
    pub fn node_lean<L: Lagrangian>(&mut self, lag: &L, t: f64, q: &[f64], p: &[f64]) -> Option<f64> {
        if q.len() != self.v.len() || p.len() != self.v.len() {
            return None;
        }
        // `v` keeps its copy (checkpoints read it), of p's length: a constant in the caller's
        // fast loop, where a copy of `v`'s length would be a call to memcpy; moves for up to
        // four entries where it is not (a loop of its own calling the caller per node).
        if let Some(v) = self.v.get_mut(..p.len()) {
            copy_short(v, p);
        }
        let pv: f64 = p.iter().map(|a| a * a).sum();
        // L(t, q, p) = p·p·½ − V as `Mechanical::value` forms it (its kinetic sum is pv).
        let l = match lag.potential_value(t, q) {
            Some(v) => pv * 0.5 - v,
            None => lag.value(t, q, p),
        };
        let h = pv - l;
        if self.e0.is_nan() {
            self.e0 = h;
        }
        // As in `node`: a non-finite energy stays out of the report.
        self.max_dev = self.max_dev.max(if h.is_finite() { (h - self.e0).abs() } else { 0.0 });
        self.current.h = h;
        self.rel_stale = true;
        Some(h)
    }

    /// The energy balance of a time-dependent L at the node (t, q) with energy h.
    #[inline(never)]
    fn balance_at<L: Lagrangian>(&mut self, lag: &L, t: f64, q: &[f64], h: f64) {
        let Some(b) = self.balance.as_mut() else { return };
        lag.first_derivatives(t, q, &self.v, true, &mut self.work);
        let lt = self.work.l_t();
        if let Some((t0, lt0)) = b.last {
            b.work -= 0.5 * (t - t0) * (lt + lt0);
        }
        b.last = Some((t, lt));
        let scale = if self.e0 != 0.0 { self.e0.abs() } else { 1.0 };
        b.max_rel = b.max_rel.max((h - self.e0 - b.work).abs() / scale);
    }

    /// The energy of the last node shown (zeros before the first).
    #[inline(always)]
    pub fn current(&self) -> NodeEnergy {
        if self.rel_stale {
            NodeEnergy {
                h: self.current.h,
                rel: self.relative((self.current.h - self.e0).abs()),
            }
        } else {
            self.current
        }
    }

    /// [`EnergyTracker::node`] at the node ending the element `el` (None: the first node).
    /// With [`super::EnergyNodes::Kept`] the inverse Legendre transform starts from the
    /// velocity of the element's interpolant at its end ((2.26) differentiated, τ = 1), not
    /// from a node many steps back; otherwise as [`EnergyTracker::node`].
    ///
    /// # Errors
    /// As [`EnergyTracker::node`].
    ///
    /// ```
    /// use femvi::solution::{EnergyNodes, EnergyTracker};
    /// use femvi::step::ElementNodes;
    /// use femvi::{models, Element, Lagrangian, NodeFamily, QuadratureKind, Start};
    /// let rel = models::RelativisticKepler { c: 10.0 };
    /// let e = Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(2))?;
    /// let start = Start::Velocity { q: vec![1.0, 0.0], v: vec![0.0, 0.0] };
    /// let mut tracker = EnergyTracker::new(2, &start, rel.is_autonomous()).with_nodes(EnergyNodes::Kept, &e.basis);
    /// // y(t) = t on [0, 1]: the element ends with velocity (0, 0.9); p = γv, γ = 1/√(1 − |v|²/c²).
    /// let el = ElementNodes { t: 0.0, h: 1.0, base: &[1.0, 0.0], incr: &[0.0, 0.0, 0.0, 0.45, 0.0, 0.9] };
    /// let p = [0.0, 0.9 / (1.0 - 0.0081f64).sqrt()];
    /// tracker.node_after(&rel, Some(el), 1.0, &[1.0, 0.9], &p)?;
    /// assert!((tracker.velocity()[1] - 0.9).abs() < 1e-15);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn node_after<L: Lagrangian>(
        &mut self,
        lag: &L,
        el: Option<ElementNodes<'_>>,
        t: f64,
        q: &[f64],
        p: &[f64],
    ) -> Result<NodeEnergy> {
        if let (Some(end), Some(el)) = (self.end.as_mut(), el) {
            let n = self.v.len();
            if el.base.len() == n && el.incr.len() == end.basis.len() * n && el.h != 0.0 {
                end.eval
                    .eval_at(&end.basis, el.h, el.base, el.incr, 1.0, &mut end.q, &mut self.v);
            }
        }
        self.node(lag, t, q, p)
    }

    /// The velocity at the last node shown (the inverse Legendre transform of its momentum).
    pub fn velocity(&self) -> &[f64] {
        &self.v
    }

    /// The largest errors so far (0 before the first node).
    pub fn report(&self) -> EnergyReport {
        EnergyReport {
            max_rel_error: self.max_rel_floor.max(self.relative(self.max_dev)),
            max_rel_balance: self.balance.map(|b| b.max_rel),
            nodes: self.nodes,
        }
    }

    /// The tracker's whole state as 64-bit words (f64 as bit patterns, so NaN survives), for
    /// checkpoints: restored by [`EnergyTracker::restore_words`], the tracker continues bit for
    /// bit as if it had not stopped.
    pub fn words(&self) -> Vec<u64> {
        let b = self.balance;
        let last = b.and_then(|b| b.last);
        let current = self.current();
        let mut w = vec![
            self.e0.to_bits(),
            self.report().max_rel_error.to_bits(),
            current.h.to_bits(),
            current.rel.to_bits(),
            u64::from(b.is_some()),
            u64::from(last.is_some()),
            last.map_or(0, |l| l.0.to_bits()),
            last.map_or(0, |l| l.1.to_bits()),
            b.map_or(0, |b| b.work.to_bits()),
            b.map_or(0, |b| b.max_rel.to_bits()),
        ];
        w.extend(self.v.iter().map(|x| x.to_bits()));
        w
    }

    /// Restores the state [`EnergyTracker::words`] gave into a tracker of the same dimension
    /// and kind (autonomous or not).
    ///
    /// # Errors
    /// The words have the wrong length or were written by a tracker of the other kind.
    pub fn restore_words(&mut self, words: &[u64]) -> Result<()> {
        check_len("energy tracker state", 10 + self.v.len(), words.len())?;
        let f = |i: usize| f64::from_bits(words[i]);
        if (words[4] == 1) != self.balance.is_some() {
            return Err(invalid(
                "energy tracker state",
                "written for a Lagrangian of the other kind (autonomous or time-dependent)",
            ));
        }
        self.e0 = f(0);
        self.max_rel_floor = f(1);
        self.max_dev = 0.0;
        self.current = NodeEnergy { h: f(2), rel: f(3) };
        self.rel_stale = false;
        if let Some(b) = self.balance.as_mut() {
            b.last = (words[5] == 1).then(|| (f(6), f(7)));
            b.work = f(8);
            b.max_rel = f(9);
        }
        for (x, w) in self.v.iter_mut().zip(&words[10..]) {
            *x = f64::from_bits(*w);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::EnergyTracker;
    use crate::{models, Lagrangian, Start};

    /// xorshift64*, uniform in [−1, 1).
    fn uniform(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }

    /// `node_lean` (L at v = p from p·p and [`Lagrangian::potential_value`]) gives the bits of
    /// `node` (L by [`Lagrangian::value`]) for the M = I models the command's fast loop runs.
    fn lean_equals_checked<L: Lagrangian>(lag: &L, seed: u64) {
        let n = lag.dim();
        let start = Start::Momentum {
            q: vec![0.0; n],
            p: vec![0.0; n],
        };
        let (mut lean, mut checked) = (EnergyTracker::new(n, &start, true), EnergyTracker::new(n, &start, true));
        assert!(lean.lean(lag));
        let mut s = seed;
        for _ in 0..200 {
            // Nearly equal positions: V small against p·p, so that a kinetic sum formed
            // differently (another order) shows in H's last bits.
            let q: Vec<f64> = (0..n).map(|_| 0.5 + 0.01 * uniform(&mut s)).collect();
            let p: Vec<f64> = (0..n).map(|_| 3.0 * uniform(&mut s)).collect();
            let a = lean.node_lean(lag, 0.0, &q, &p).unwrap();
            let b = checked.node(lag, 0.0, &q, &p).unwrap().h;
            assert_eq!(a.to_bits(), b.to_bits(), "{a} vs {b}");
        }
        assert_eq!(lean.report(), checked.report());
    }

    #[test]
    fn the_lean_energy_is_the_checked_one_bit_for_bit() {
        lean_equals_checked(&models::kepler(1.0).unwrap(), 1);
        lean_equals_checked(&models::fpu(37, 0.25, 0.1).unwrap(), 2);
        lean_equals_checked(&models::harmonic(1.0, 1.0).unwrap(), 3);
    }
}
