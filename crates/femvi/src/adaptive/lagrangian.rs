//! The time-transformed Lagrangian of the Poincaré transformation (issue 21; DESIGN.md §4;
//! Hairer, Lubich, Wanner, *Geometric Numerical Integration*, §VIII.2): for an autonomous
//! L(q, v), a monitor g(q) > 0, fictitious time s with dt/ds = g(q) and q' = dq/ds,
//!
//!   L_g(q, q') = g(q) · ( L(q, q'/g(q)) + E₀ ),   E₀ = H(q₀, p₀).
//!
//! Its momentum is ∂L_g/∂q' = ∂L/∂v (the physical momentum, unchanged) and its Hamiltonian is
//! K = g(q)(H(q, p) − E₀): on K = 0 its flow is the physical flow reparametrised by s. Any
//! femvi element integrates L_g with fixed steps in s; the map (q, p) ↦ (q, p) per step is
//! symplectic, and the steps in t follow g.
//!
//! For a mechanical L = ½vᵀMv − V(q), L_g = ½q'ᵀMq'/g − g(V − E₀) has the position-dependent
//! mass matrix M/g, so the step goes through Newton; `derivatives.rs` gives it hand-coded
//! first and second derivatives from V's force and force Jacobian and g's derivatives, in
//! place of automatic differentiation of the whole of L_g. Asked for, the gyroscopic fixed
//! point solves it without Hessians: L_g declares M as its gyroscopic mass with the divisor
//! g ([`Lagrangian::gyroscopic_divisor`]), the momentum Mq'/g split as Mq'/d + A
//! (`step/gyroscopic/divided.rs`).

use super::derivatives;
use super::monitor::Monitor;
use crate::error::{check_len, invalid, Result};
use crate::lagrangian::{Lagrangian, MassMatrix, PointDerivatives, Scalar};

/// L_g(q, q') = g(q)·(L(q, q'/g(q)) + E₀) for an autonomous L (the module documentation).
///
/// # Example
///
/// ```
/// use femvi::adaptive::{KeplerMonitor, TimeTransformed};
/// use femvi::lagrangian::PointDerivatives;
/// use femvi::{models, Lagrangian};
///
/// let lg = TimeTransformed::new(models::kepler(1.0)?, KeplerMonitor, -0.5)?;
/// // The momentum is the physical one: ∂L_g/∂q' = ∂L/∂v with v = q'/g.
/// let (q, qs) = ([2.0, 0.0], [0.3, 0.4]);
/// let g = 2f64.powf(1.5);
/// let mut d = PointDerivatives::new(2);
/// lg.first_derivatives(0.0, &q, &qs, false, &mut d);
/// assert!((d.l_v()[0] - 0.3 / g).abs() < 1e-15 && (d.l_v()[1] - 0.4 / g).abs() < 1e-15);
/// # Ok::<(), femvi::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct TimeTransformed<L, G> {
    lag: L,
    monitor: G,
    e0: f64,
    /// Hand-coded derivatives (mechanical L, unless switched off).
    fast: bool,
}

impl<L: Lagrangian, G: Monitor> TimeTransformed<L, G> {
    /// L_g for `lag`, `monitor` and the energy level `e0` (H at the start).
    ///
    /// # Errors
    /// A non-autonomous L ([`Error::Invalid`](crate::Error::Invalid): extend the state by (t,
    /// p_t) first), a monitor of another dimension, or `e0` not finite.
    pub fn new(lag: L, monitor: G, e0: f64) -> Result<Self> {
        if !lag.is_autonomous() {
            return Err(invalid(
                "adaptive steps",
                "the time transformation needs an autonomous Lagrangian (L must not depend on t)",
            ));
        }
        if monitor.dim() != 0 {
            check_len("monitor", lag.dim(), monitor.dim())?;
        }
        if !e0.is_finite() {
            return Err(invalid(
                "adaptive steps",
                format!("the energy level E0 = {e0} is not finite"),
            ));
        }
        let fast = lag.mass_matrix().is_some();
        Ok(Self { lag, monitor, e0, fast })
    }

    /// The same L_g with its derivatives by automatic differentiation of [`Lagrangian::value`]
    /// even for a mechanical L (to measure the hand-coded path against; results agree to
    /// round-off, not bit for bit).
    ///
    /// ```
    /// use femvi::adaptive::{KeplerMonitor, TimeTransformed};
    /// let lg = TimeTransformed::new(femvi::models::kepler(1.0)?, KeplerMonitor, -0.5)?.by_ad();
    /// assert!(!lg.is_fast());
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn by_ad(mut self) -> Self {
        self.fast = false;
        self
    }

    /// Whether the derivatives are hand-coded (mechanical L).
    pub fn is_fast(&self) -> bool {
        self.fast
    }

    /// The physical Lagrangian L.
    pub fn inner(&self) -> &L {
        &self.lag
    }

    /// The monitor g.
    pub fn monitor(&self) -> &G {
        &self.monitor
    }

    /// The energy level E₀.
    pub fn e0(&self) -> f64 {
        self.e0
    }
}

impl<L: Lagrangian, G: Monitor> Lagrangian for TimeTransformed<L, G> {
    fn dim(&self) -> usize {
        self.lag.dim()
    }

    fn is_autonomous(&self) -> bool {
        true
    }

    fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        let g = self.monitor.value(q);
        let n = v.len();
        let mut fixed = [D::from(0.0); 16];
        let mut heap = Vec::new();
        let w: &mut [D] = if n <= 16 {
            &mut fixed[..n]
        } else {
            heap.resize(n, D::from(0.0));
            &mut heap
        };
        let inv = g.recip();
        for (wi, &vi) in w.iter_mut().zip(v) {
            *wi = vi * inv;
        }
        g * (self.lag.value(t, q, w) + self.e0)
    }

    /// With hand-coded derivatives (a mechanical L), M: the steps take the gyroscopic fixed
    /// point with the divisor g(q_k) ([`Lagrangian::gyroscopic_divisor`]).
    fn gyroscopic_mass(&self) -> Option<&MassMatrix> {
        if self.fast {
            self.lag.mass_matrix()
        } else {
            None
        }
    }

    fn gyroscopic_divisor(&self, _t: f64, q: &[f64]) -> f64 {
        self.monitor.value(q)
    }

    fn gyroscopic_terms_divided(&self, d: f64, t: &[f64], q: &[f64], v: &[f64], out: &mut [f64]) {
        derivatives::gyroscopic_terms(self, d, t, q, v, out);
    }

    fn first_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        if self.fast && !with_t {
            derivatives::first(self, t, q, v, out);
        } else {
            out.first_by_ad(self, t, q, v, with_t);
        }
    }

    fn second_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        if self.fast && !with_t {
            derivatives::second(self, t, q, v, out);
        } else {
            out.second_by_ad(self, t, q, v, with_t);
        }
    }
}
