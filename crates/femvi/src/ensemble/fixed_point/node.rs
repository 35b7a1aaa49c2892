//! The fixed-point lanes' step around the sweeps: the stages' start (from the last step's
//! stage forces, or from v0 / the last element's polynomial), the update of the node
//! increments and the momentum from the converged forces, and the compensated move to the
//! new node with its energy (`FixedPointStep::update`, `RunState::commit`).

use super::{Group, Stages, MAX_POINTS};
use crate::discrete::Element;
use crate::error::{Error, StepError, StepFailure};
use crate::lagrangian::{Lagrangian, Lanes, LANES};
use crate::step::fixed_point::StepTables;

impl<const N: usize> Group<N> {
    /// Stages from the last step's stage forces: y_l = h a_l u + Σ_j mat_jl w_j
    /// (`StageStart::start` without extra evaluations; `mat` column-major r × r).
    #[inline(always)]
    pub(super) fn start_from_forces(&mut self, r: usize, ha: &[f64], mat: &[f64]) {
        let u = &self.node.p;
        for (i, &hai) in ha.iter().enumerate().take(r) {
            for c in 0..N {
                // Lanes innermost, so that each line is a vector operation.
                let mut z = [0.0; LANES];
                for l in 0..LANES {
                    z[l] = hai * u[c][l];
                }
                for j in 0..r {
                    let m = mat[j * r + i];
                    for l in 0..LANES {
                        z[l] += m * self.data[j][c][l];
                    }
                }
                self.y[i][c] = z;
            }
        }
    }

    /// Stages from predicted node increments (`Guess::predict`, then
    /// `FixedPointStep::start_from_guess`): X^m = c_m h v0 on the first step, else the last
    /// element's polynomial extrapolated over the new step.
    #[inline(never)]
    pub(super) fn start_from_guess(&mut self, el: &Element, h: f64, last_h: f64, after_step: bool) {
        let s = el.degree();
        let nodes = &el.basis.nodes;
        let mut x = [[[0.0; LANES]; N]; MAX_POINTS];
        if after_step {
            let rho = h / last_h;
            let mut row = [0.0; MAX_POINTS + 1];
            for m in 1..=s {
                el.basis.values_in_place(1.0 + nodes[m] * rho, &mut row[..=s]);
                for c in 0..N {
                    for l in 0..LANES {
                        let mut acc = 0.0;
                        for (j, w) in row[..=s].iter().enumerate() {
                            acc += w * (self.incr[j][c][l] - self.incr[s][c][l]);
                        }
                        x[m - 1][c][l] = acc;
                    }
                }
            }
        } else {
            for m in 1..=s {
                for c in 0..N {
                    for l in 0..LANES {
                        x[m - 1][c][l] = nodes[m] * h * self.v0[c][l];
                    }
                }
            }
        }
        for i in 0..el.points() {
            for c in 0..N {
                for l in 0..LANES {
                    self.y[i][c][l] = (1..=s).map(|m| el.phi(i, m) * x[m - 1][c][l]).sum();
                }
            }
        }
    }

    /// The node increments ΔQ^m = h α_m u + h² Σ_i β_mi f_i (into `incr`; the inner nodes
    /// m < s only with `inner`) and the momentum increment h Σ_i b_i f_i, each with its
    /// coefficients' rounding errors as a second sum when `exact` (`FixedPointStep::update`).
    /// Returns (ΔQ^s, Δp).
    #[inline(always)]
    pub(super) fn update(
        &mut self,
        st: &StepTables,
        (s, r): (usize, usize),
        exact: bool,
        inner: bool,
    ) -> ([Lanes; N], [Lanes; N]) {
        // Each sum lanes innermost (a vector operation per term), in the single run's order.
        let affine = |a: f64, m: &[f64], f: &Stages<N>, u: &Lanes, row: usize, c: usize| {
            let mut z = [0.0; LANES];
            for l in 0..LANES {
                z[l] = a * u[l];
            }
            for i in 0..r {
                let mi = m[i * s + row];
                for l in 0..LANES {
                    z[l] += mi * f[i][c][l];
                }
            }
            z
        };
        let weighted = |w: &[f64], f: &Stages<N>, c: usize| {
            let mut z = [0.0; LANES];
            for i in 0..r {
                for l in 0..LANES {
                    z[l] += w[i] * f[i][c][l];
                }
            }
            z
        };
        for row in (if inner { 0 } else { s - 1 })..s {
            for c in 0..N {
                let mut z = affine(st.h_alpha[row], &st.h2_beta, &self.f, &self.node.p[c], row, c);
                if exact {
                    let lo = affine(st.h_alpha_lo[row], &st.h2_beta_lo, &self.f, &self.node.p[c], row, c);
                    for l in 0..LANES {
                        z[l] += lo[l];
                    }
                }
                self.incr[row + 1][c] = z;
            }
        }
        let mut dp = [[0.0; LANES]; N];
        for c in 0..N {
            let mut hi = weighted(&st.hw, &self.f, c);
            if exact {
                let lo = weighted(&st.hw_lo, &self.f, c);
                for l in 0..LANES {
                    hi[l] += lo[l];
                }
            }
            dp[c] = hi;
        }
        (self.incr[s], dp)
    }

    /// Moves every lane to its new node (`RunState::commit`: compensated sums), which the
    /// energy tracker is then shown at (k + 1, t_next). A running lane whose new node is
    /// not finite ends at (k, t) with the step's error; one whose energy there is not finite
    /// ends there too, with the step counted.
    #[inline(always)]
    pub(super) fn commit<L: Lagrangian>(
        &mut self,
        lag: &L,
        (dq, dp): (&[Lanes; N], &[Lanes; N]),
        (k, t): (usize, f64),
        t_next: f64,
    ) {
        let old = self.node;
        let mut probe = [0.0; LANES];
        for c in 0..N {
            for l in 0..LANES {
                let (q, cq) = (old.q[c][l], old.cq[c][l]);
                let y = dq[c][l] + cq;
                let tq = q + y;
                self.node.cq[c][l] = (q - tq) + y;
                self.node.q[c][l] = tq;
                let (p, cp) = (old.p[c][l], old.cp[c][l]);
                let y = dp[c][l] + cp;
                let tp = p + y;
                self.node.cp[c][l] = (p - tp) + y;
                self.node.p[c][l] = tp;
                probe[l] += tq * 0.0 + tp * 0.0;
            }
        }
        let failed = probe.iter().fold(false, |a, x| a | x.is_nan());
        if failed {
            for (l, x) in probe.iter().enumerate() {
                if x.is_nan() && self.alive[l] {
                    let error = StepError {
                        step: k,
                        t,
                        residual: f64::NAN,
                        iterations: 0,
                        failure: StepFailure::NonFinite,
                    };
                    self.end_from(&old, l, (k, t), k, Error::Step(error));
                }
            }
        }
        let hs = self.energy.node(lag, t_next, &self.node.q, &self.node.p);
        if hs.any_bad() {
            let bad = hs.bad();
            for (l, &b) in bad.iter().enumerate() {
                if b && self.alive[l] {
                    let error = Error::NonFiniteEnergy { step: k + 1, t: t_next };
                    self.end_from(&old, l, (k, t), k + 1, error);
                }
            }
        }
    }
}
