//! The Lie-group element as a term of the one integrator ([`crate::step::term`]): each step
//! is solved in the algebra (`step.rs`); the integrator keeps the grid, the node with its
//! compensated sums, the last element (dense output and events on the embedded entries),
//! counters, checkpoints and the driver with its observers. The node's momentum of a
//! rotation block is P = ½ R Π̂, the momentum conjugate to the entries of R of the embedded
//! Lagrangian (module docs of [`super`]); it is set, not summed ([`StepTerm::momentum`]).

use super::action::{element_work, EmbeddedForce, StepData};
use super::body::BodyStep;
use super::body_state::{block, body_momentum, body_states, BodyState};
use super::layout::Rotations;
use super::so3::{exp, hat, mul, Mat3};
use super::step::{Kept, LieStep};
use super::tangent::{defect, jacobian, Solved};
use crate::discrete::Element;
use crate::error::{invalid, Error, Result};
use crate::lagrangian::Lagrangian;
use crate::step::checkpoint::{Reader, Words};
use crate::step::state::{Increments, LastElement, RunState};
use crate::step::term::StepTerm;
use crate::step::SolverOptions;

/// The embedded momentum P = ½ R Π̂ of a body angular momentum Π.
pub(crate) fn embedded_momentum(r: &Mat3<f64>, pi: &[f64; 3]) -> Mat3<f64> {
    mul(r, &hat(pi)).map(|v| 0.5 * v)
}

/// R (3 − RᵀR)/2: one Newton–Schulz step towards the nearest rotation, which takes a matrix
/// ε = |RᵀR − 1| from SO(3) to O(ε²). The step starts from the node's R brought back this
/// way, so that the round-off of the committed sums R_k + (R_k exp(ξ̂) − R_k) does not
/// accumulate over the steps (left alone it grows like a random walk and, through the
/// regularising term of the embedded Lagrangian, biases the momenta by about ε per step).
pub(crate) fn onto_group(r: &Mat3<f64>) -> Mat3<f64> {
    let g = super::so3::mul_tn(r, r);
    let c: Mat3<f64> = std::array::from_fn(|k| if k % 4 == 0 { 1.5 - 0.5 * g[k] } else { -0.5 * g[k] });
    mul(r, &c)
}

/// The term of a run with rotations.
pub(crate) struct RotationTerm<'a, L> {
    pub lag: &'a L,
    pub element: &'a Element,
    pub layout: Rotations,
    pub step: LieStep,
    pub opts: SolverOptions,
    /// Momenta of the node in slots (Π of the rotations, p of the ordinary coordinates).
    mom: Vec<f64>,
    /// The new node's momentum, set after the commit.
    p: Vec<f64>,
    /// The node with its rotations brought back onto SO(3) (`onto_group`).
    q: Vec<f64>,
    /// The degree-1 fixed point of a rigid body (`body.rs`), where it applies.
    body: Option<BodyStep>,
    /// The largest symplecticity defect of the steps so far, if it is measured.
    pub defect: Option<f64>,
    /// The force of a forced run ([`crate::Integrator::with_rotations_and_force`]).
    force: Option<&'a (dyn EmbeddedForce + Sync)>,
    /// The discrete work of the last solved element (0 without a force).
    last_work: f64,
    /// (t_k, h) of the last solved step, None before the first (or after a restore): what
    /// its tangent map ([`StepTerm::chart_tangent`]) is taken at, with `q`, `mom` and the
    /// step's unknowns.
    solved: Option<(f64, f64)>,
}

impl<'a, L: Lagrangian> RotationTerm<'a, L> {
    pub(crate) fn new(
        lag: &'a L,
        element: &'a Element,
        layout: Rotations,
        opts: SolverOptions,
        force: Option<&'a (dyn EmbeddedForce + Sync)>,
    ) -> Self {
        let step = LieStep::new(&layout, element);
        let (ne, n) = (layout.slots(), layout.dim());
        // The degree-1 fixed point is that of the free Lagrangian: a forced run takes Newton.
        let single = layout.offsets() == [0] && n == 9 && force.is_none();
        let body = if single { BodyStep::new(lag, element) } else { None };
        Self {
            lag,
            element,
            layout,
            step,
            opts,
            mom: vec![0.0; ne],
            p: vec![0.0; n],
            q: vec![0.0; n],
            body,
            defect: None,
            force,
            last_work: 0.0,
            solved: None,
        }
    }
}

impl<L: Lagrangian> StepTerm for RotationTerm<'_, L> {
    fn solve(
        &mut self,
        state: &RunState,
        _last: &mut LastElement,
        (h, _t_next): (f64, f64),
        out: &mut Increments,
    ) -> Result<usize> {
        let (s, ne, n, m) = (
            self.element.degree(),
            self.layout.slots(),
            self.layout.dim(),
            self.layout.count(),
        );
        self.q.copy_from_slice(&state.q);
        // The momenta the last step left, if the node's p is still the one it set; the body
        // momenta read back from P = ½ R Π̂ otherwise (the start, or a node set from outside).
        // Reading them back each step would round them twice more per step, with a bias that
        // shows as a drift of |Π| (1.3e-13 over 1000 steps of the free body, 7e-15 carried).
        let carried = state.k > 0
            && self.p.len() == state.p.len()
            && self.p.iter().zip(&state.p).all(|(a, b)| a.to_bits() == b.to_bits());
        if carried {
            self.mom.copy_from_slice(&self.step.end);
        }
        for (r, &o) in self.layout.offsets().iter().enumerate() {
            let rk = onto_group(&block(&state.q, o));
            self.q[o..o + 9].copy_from_slice(&rk);
            if !carried {
                let pi = body_momentum(&rk, &block(&state.p, o));
                self.mom[3 * r..3 * r + 3].copy_from_slice(&pi);
            }
        }
        if !carried {
            for (slot, &c) in self.layout.ordinary().iter().enumerate() {
                self.mom[3 * m + slot] = state.p[c];
            }
        }
        let data = StepData {
            t0: state.t,
            h,
            q: &self.q,
            force: self.force,
        };
        let iterations = match self.body.as_mut() {
            Some(body) => {
                let step = &mut self.step;
                let scale = if step.h_prev > 0.0 { h / step.h_prev } else { 0.0 };
                let mut xi = [step.x[0] * scale, step.x[1] * scale, step.x[2] * scale];
                let (mu, rk) = ([self.mom[0], self.mom[1], self.mom[2]], block(&self.q, 0));
                let (sweeps, next) = body
                    .solve(self.lag, (state.t, h, &rk), &mu, &mut xi, (self.opts, state.k))
                    .map_err(Error::Step)?;
                step.x.copy_from_slice(&xi);
                step.end.copy_from_slice(&next);
                step.h_prev = h;
                sweeps
            }
            None => self
                .step
                .solve(
                    self.lag,
                    self.element,
                    &self.layout,
                    &data,
                    &self.mom,
                    (self.opts, state.k),
                )
                .map_err(Error::Step)?,
        };
        self.solved = Some((state.t, h));
        if self.force.is_some() {
            let data = StepData {
                t0: state.t,
                h,
                q: &self.q,
                force: self.force,
            };
            self.last_work = element_work(self.element, &self.layout, &data, &self.step.x);
        }
        if let Some(worst) = self.defect {
            let data = StepData {
                t0: state.t,
                h,
                q: &self.q,
                force: self.force,
            };
            let solved = Solved {
                data: &data,
                mom: &self.mom,
                x: &self.step.x,
            };
            let d = defect(self.lag, self.element, &self.layout, &solved);
            self.defect = Some(if d.is_nan() { f64::NAN } else { worst.max(d) });
        }
        // The element's nodal increments, row 0 zero.
        out.incr[..n].iter_mut().for_each(|v| *v = 0.0);
        for j in 1..=s {
            let x = &self.step.x[(j - 1) * ne..j * ne];
            let row = &mut out.incr[j * n..(j + 1) * n];
            for (r, &o) in self.layout.offsets().iter().enumerate() {
                let rj = mul(&block(&self.q, o), &exp(&[x[3 * r], x[3 * r + 1], x[3 * r + 2]]));
                for k in 0..9 {
                    row[o + k] = rj[k] - state.q[o + k];
                }
                if j == s {
                    let pi: [f64; 3] = std::array::from_fn(|c| self.step.end[3 * r + c]);
                    self.p[o..o + 9].copy_from_slice(&embedded_momentum(&rj, &pi));
                }
            }
            for (slot, &c) in self.layout.ordinary().iter().enumerate() {
                row[c] = x[3 * m + slot];
                if j == s {
                    self.p[c] = self.step.end[3 * m + slot];
                }
            }
        }
        out.dq.copy_from_slice(&out.incr[s * n..(s + 1) * n]);
        for ((d, a), b) in out.dp.iter_mut().zip(&self.p).zip(&state.p) {
            *d = a - b;
        }
        Ok(iterations)
    }

    fn accepted(&mut self, _n: usize) {}

    fn element_work(&self) -> f64 {
        self.last_work
    }

    fn save(&self, w: &mut Words) {
        w.fs(&self.step.x);
        w.f(self.step.h_prev);
        w.fs(&self.step.end);
        w.fs(&self.p);
        match &self.step.kept {
            Some(kept) => {
                w.b(true);
                w.f(kept.h);
                w.fs(kept.jac.as_slice());
            }
            None => w.b(false),
        }
    }

    fn load(&mut self, r: &mut Reader<'_>, _last: &LastElement) -> Result<()> {
        r.fs(&mut self.step.x)?;
        self.step.h_prev = r.f()?;
        r.fs(&mut self.step.end)?;
        r.fs(&mut self.p)?;
        self.solved = None;
        self.step.kept = if r.b()? {
            let h = r.f()?;
            let m = self.step.x.len();
            let mut jac = nalgebra::DMatrix::zeros(m, m);
            r.fs(jac.as_mut_slice())?;
            Some(Kept::restore(jac, h))
        } else {
            None
        };
        Ok(())
    }

    fn name(&self) -> &'static str {
        "rotations"
    }

    fn works(&self) -> bool {
        self.force.is_some()
    }

    fn momentum(&self) -> Option<&[f64]> {
        Some(&self.p)
    }

    fn defect(&self) -> Option<f64> {
        self.defect
    }

    fn rotations(&self) -> Option<&Rotations> {
        Some(&self.layout)
    }

    fn chart_dim(&self) -> Option<usize> {
        Some(2 * self.layout.slots())
    }

    fn chart_tangent(&mut self) -> Option<Result<nalgebra::DMatrix<f64>>> {
        if self.force.is_some() {
            // The frozen force of the action gives the residual, not the force's derivatives.
            return Some(Err(invalid(
                "tangent map",
                "the tangent map of a forced Lie-group step (the derivatives of the torques in the step's unknowns) is not derived",
            )));
        }
        let Some((t0, h)) = self.solved else {
            return Some(Err(invalid(
                "tangent map",
                "no step has been solved since the start or the restore",
            )));
        };
        let data = StepData {
            t0,
            h,
            q: &self.q,
            force: None,
        };
        let solved = Solved {
            data: &data,
            mom: &self.mom,
            x: &self.step.x,
        };
        let j = jacobian(self.lag, self.element, &self.layout, &solved);
        if j.iter().all(|v| v.is_finite()) {
            Some(Ok(j))
        } else {
            Some(Err(invalid("tangent map", "the linearised Lie-group step is singular")))
        }
    }

    fn rotation_states(&self, t: f64, q: &[f64], p: &[f64]) -> Option<Vec<BodyState>> {
        Some(body_states(self.lag, &self.layout, t, q, p))
    }
}
