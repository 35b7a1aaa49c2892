//! The solution of a constrained boundary value problem at the converged unknowns
//! (`bvp.rs`): the residual and the discrete action, and per element end the position, the
//! momentum (the constrained discrete Legendre transform of the element starting there, of the
//! last element at t_N, projected onto T*N by module `project`), the velocity, the multiplier
//! of the exact flow at that state and the constraint residuals.

use super::bvp_assembly::Assembly;
use super::bvp_newton::inf_norm;
use super::forcing::NodeForce;
use super::jet::ConstraintJet;
use super::layout::Enforcement;
use super::limits::RANK_TOLERANCE;
use super::project::{state_multiplier, Projector};
use super::Constraints;
use crate::bvp::{BvpOptions, BvpSolution};
use crate::discrete::ElementWork;
use crate::error::{Error, Result, StepError};
use crate::lagrangian::Lagrangian;

/// A solved constrained boundary value problem.
#[derive(Debug, Clone, PartialEq)]
pub struct ConstrainedBvpSolution {
    /// Times, positions, momenta (on T*N) at the element ends, all nodal values, the discrete
    /// action, the residual (max over all equations: node rows, constraints, interior
    /// constraint rows) and the Newton iterations.
    pub solution: BvpSolution,
    /// Number of constraints m.
    pub m: usize,
    /// Velocities at the element ends (those of the projected momenta), row-major (N+1)×n.
    pub v: Vec<f64>,
    /// The multipliers λ of the exact flow at each element end state (as the initial value
    /// run reports them; −G(q)ᵀλ is the constraint force), row-major (N+1)×m.
    pub multipliers: Vec<f64>,
    /// The node multipliers ν_1 … ν_{N−1} of the augmented action (impulses: −G(q_k)ᵀν_k is
    /// the constraint impulse at q_k; for degree 1, ν_k ≈ h λ; for higher degrees the
    /// interior multipliers of the elements carry most of the constraint force), row-major
    /// (N−1)×m.
    pub impulses: Vec<f64>,
    /// ‖g(q)‖∞ at each element end.
    pub residual: Vec<f64>,
    /// ‖G(q) v‖∞ (the hidden constraint) at each element end.
    pub hidden_residual: Vec<f64>,
    /// Largest ‖g(q)‖∞ over the element ends.
    pub max_residual: f64,
    /// Where the constraints were enforced inside the elements.
    pub enforcement: Enforcement,
}

/// The solution at the unknowns `x`: residual, action, and per element end the position, the
/// projected momentum, the velocity, the multiplier and the residuals.
pub(super) fn finish<L: Lagrangian, C: Constraints>(
    asm: &mut Assembly<'_, L, C>,
    x: &[f64],
    iterations: usize,
    options: BvpOptions,
) -> Result<ConstrainedBvpSolution> {
    let mut r = vec![0.0; x.len()];
    asm.eval(x, &mut r, None);
    let residual_norm = inf_norm(&r);
    let (n, m, s, big_n) = (asm.num.n, asm.num.m, asm.num.s, asm.num.elements);
    let h = asm.bv.step();
    let times: Vec<f64> = (0..=big_n)
        .map(|k| {
            if k == big_n {
                asm.bv.t1
            } else {
                asm.bv.t0 + k as f64 * h
            }
        })
        .collect();
    let mut q = Vec::with_capacity((big_n + 1) * n);
    let mut p_tilde = vec![0.0; (big_n + 1) * n];
    let mut secant = vec![0.0; (big_n + 1) * n];
    let (mut work, mut grad) = (ElementWork::new(asm.element, n), vec![0.0; (s + 1) * n]);
    let mut incr = vec![0.0; (s + 1) * n];
    let mut action = 0.0;
    for k in 0..big_n {
        asm.eval_element(k, x, false);
        let (g0, g1) = (k * s * n, (k + 1) * s * n);
        let (base, ends) = (&asm.nodes[g0..g0 + n], &asm.nodes[g1..g1 + n]);
        q.extend_from_slice(base);
        for a in 0..n {
            p_tilde[k * n + a] = -asm.sys.res[a];
            secant[k * n + a] = (ends[a] - base[a]) / h;
        }
        if k + 1 == big_n {
            q.extend_from_slice(ends);
            p_tilde[big_n * n..].copy_from_slice(asm.sys.momentum_before_projection());
            secant.copy_within(k * n..(k + 1) * n, big_n * n);
        }
        for (i, d) in incr.iter_mut().enumerate() {
            *d = asm.nodes[g0 + i] - base[i % n];
        }
        action += asm
            .element
            .gradient_in_place(asm.lag, times[k], h, base, &incr, false, &mut work, &mut grad);
    }
    let mut out = ConstrainedBvpSolution {
        solution: BvpSolution {
            times,
            q,
            p: vec![0.0; (big_n + 1) * n],
            nodes: asm.nodes.clone(),
            action,
            residual_norm,
            // Set by the caller from the Jacobian's norm.
            scaled_residual: f64::NAN,
            newton_iterations: iterations,
        },
        m,
        v: secant,
        multipliers: Vec::with_capacity((big_n + 1) * m),
        impulses: (1..big_n)
            .flat_map(|k| (0..m).map(move |l| (k, l)))
            .map(|(k, l)| x[asm.num.nu(k, l)] / h)
            .collect(),
        residual: Vec::with_capacity(big_n + 1),
        hidden_residual: Vec::with_capacity(big_n + 1),
        max_residual: 0.0,
        enforcement: Enforcement::default(),
    };
    project_ends(asm.lag, asm.con, asm.force, &mut out, &p_tilde, options)?;
    Ok(out)
}

/// Projects the momenta `p_tilde` at the element ends onto T*N (velocities from the secant
/// guesses in `out.v`) and fills the multipliers (those of the flow under `force`, if any) and
/// residuals of `out`.
fn project_ends<L: Lagrangian, C: Constraints>(
    lag: &L,
    con: &C,
    force: Option<&dyn NodeForce>,
    out: &mut ConstrainedBvpSolution,
    p_tilde: &[f64],
    options: BvpOptions,
) -> Result<()> {
    let (n, m) = (con.dim(), con.count());
    let mut jet = ConstraintJet::new(m, n);
    let mut projector = Projector::new(n, m);
    let mut f = vec![0.0; n];
    let sol = &mut out.solution;
    for (k, &t) in sol.times.iter().enumerate() {
        let q = &sol.q[k * n..(k + 1) * n];
        jet.eval(con, q, true);
        if jet.conditioning() <= RANK_TOLERANCE {
            return Err(Error::SingularConstraints {
                step: k,
                t,
                ratio: jet.conditioning(),
            });
        }
        let v = &mut out.v[k * n..(k + 1) * n];
        projector
            .project(
                lag,
                &jet,
                t,
                q,
                &p_tilde[k * n..(k + 1) * n],
                v,
                &mut sol.p[k * n..(k + 1) * n],
                options.tolerance,
                options.max_iterations,
            )
            .map_err(|f| {
                Error::Step(StepError {
                    step: k,
                    t,
                    residual: f.residual,
                    iterations: f.iterations,
                    failure: f.failure,
                })
            })?;
        let hidden = (0..m)
            .map(|l| (0..n).map(|a| jet.jac[l * n + a] * v[a]).sum::<f64>().abs())
            .fold(0.0f64, f64::max);
        out.residual.push(jet.residual());
        out.hidden_residual.push(hidden);
        out.max_residual = out.max_residual.max(jet.residual());
        let f = force.map(|force| {
            force.at(t, q, v, &mut f);
            &f[..]
        });
        out.multipliers.extend(state_multiplier(lag, &jet, (t, q, v), f));
    }
    Ok(())
}
