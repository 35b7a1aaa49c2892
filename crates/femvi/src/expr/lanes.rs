//! An expression Lagrangian across SIMD lanes (issue 39 item 2): its compiled force and
//! value evaluated at [`LANES`] points at once by machine code that works on the lanes
//! themselves (`native/lanes.rs`), for [`Lagrangian::force_lanes`] and
//! [`Lagrangian::value_lanes`], so that an ensemble of an expression from a problem file
//! runs in lanes as the built-in models do. The code is compiled at the first call (most
//! runs never ask for it) and gives each lane the scalar code's bits; without it (no `jit`
//! feature, a host Cranelift does not support, a force without a tape) the lanes are
//! evaluated one by one, with the same bits.

use super::ExprLagrangian;
use crate::lagrangian::{force_per_lane, lagrangian_per_lane, Lanes};
#[cfg(feature = "jit")]
use crate::lagrangian::{Lagrangian, LANES};

/// The lanes' machine code of one expression Lagrangian, each compiled at its first use.
#[derive(Debug, Clone, Default)]
pub(super) struct LanesCode {
    #[cfg(feature = "jit")]
    force: std::sync::OnceLock<Option<std::sync::Arc<super::native::Native>>>,
    #[cfg(feature = "jit")]
    value: std::sync::OnceLock<Option<std::sync::Arc<super::native::Native>>>,
}

impl ExprLagrangian {
    /// [`Lagrangian::force_lanes`]: the force tape's code across lanes where it compiles.
    pub(super) fn force_in_lanes(&self, t: f64, q: &[Lanes], out: &mut [Lanes]) {
        #[cfg(feature = "jit")]
        if let Some(tape) = &self.fast.force {
            let code = self
                .lanes
                .force
                .get_or_init(|| super::native::compile_lanes(tape).map(std::sync::Arc::new));
            if code.as_ref().is_some_and(|code| code.call_lanes(t, q, &[], out)) {
                return;
            }
        }
        force_per_lane(self, t, q, out);
    }

    /// [`Lagrangian::value_lanes`]: the value program's code across lanes where it compiles.
    pub(super) fn value_in_lanes(&self, t: f64, q: &[Lanes], v: &[Lanes]) -> Lanes {
        #[cfg(feature = "jit")]
        {
            let n = self.dim();
            let code = self
                .lanes
                .value
                .get_or_init(|| super::native::compile_program_lanes(self.program.ops(), n).map(std::sync::Arc::new));
            let mut out = [0.0; LANES];
            if code
                .as_ref()
                .is_some_and(|code| code.call_lanes(t, q, v, std::slice::from_mut(&mut out)))
            {
                return out;
            }
        }
        lagrangian_per_lane(self, t, q, v)
    }

    /// Whether the force and the value have run as code across lanes (tests: the lanes of
    /// an ensemble took it, not the per-lane defaults).
    #[cfg(all(test, feature = "jit"))]
    pub(crate) fn ran_in_lanes(&self) -> (bool, bool) {
        let compiled = |c: &std::sync::OnceLock<Option<std::sync::Arc<super::native::Native>>>| {
            c.get().is_some_and(Option::is_some)
        };
        (compiled(&self.lanes.force), compiled(&self.lanes.value))
    }
}
