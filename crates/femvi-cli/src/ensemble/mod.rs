//! Ensembles: N runs of one problem with other initial states and/or parameter values, on a
//! rayon pool. Each member is driven exactly as `femvi run` drives a run (the same integrator,
//! the same energy observer), so a member's numbers are those of the single run bit for bit;
//! a member's failure is its own error and does not stop the others. `femvi ensemble` and the
//! Python package (`femvi.ensemble`) both run through [`run_all`] and write or return what
//! [`Member`] holds.

use crate::problem::Problem;
use crate::record::{EnergyError, WorkBalance};
use femvi::step::{drive, Observer};
use femvi::{Integrator, Lagrangian, Start};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

mod command;
mod lanes;

pub use command::{columns, command, read_states, write, EnsembleArgs};
pub use lanes::run_shared;

/// What one member ends with.
#[derive(Debug, Clone, PartialEq)]
pub struct Member {
    /// Time of the last node.
    pub final_t: f64,
    /// Positions there (NaN if the member never started).
    pub q: Vec<f64>,
    /// Momenta there.
    pub p: Vec<f64>,
    /// Largest relative energy error over its nodes; with `[forces]` that of the energy
    /// balance, max |H − H0 − W| / |H0|.
    pub energy_error: f64,
    /// Steps taken.
    pub steps: usize,
    /// The error that stopped it, if any.
    pub error: Option<String>,
    /// q at the requested times ([`run_member_saving`]), row after row; NaN for the times
    /// the member did not reach.
    pub saved_q: Vec<f64>,
    /// p at the requested times.
    pub saved_p: Vec<f64>,
    /// For each rotation of the problem, the body angular velocity w and momentum Π at the
    /// last node ([`with_body`]; empty before, and without rotations).
    pub body: Vec<f64>,
}

/// `m` with its [`Member::body`] set from its last node, for a problem with rotations (as
/// `femvi run` writes them: each rotation's w, then Π; NaN where the node is not known or its
/// velocity cannot be recovered).
pub fn with_body(problem: &Problem, m: Member) -> Member {
    if problem.terms.rotations.is_none() {
        return m;
    }
    crate::with_system!(&problem.system, l => body_of(l, problem, m))
}

fn body_of<L: Lagrangian>(lag: &L, problem: &Problem, mut m: Member) -> Member {
    if let Some(layout) = &problem.terms.rotations {
        let states = femvi::rotation::body_states(lag, layout, m.final_t, &m.q, &m.p);
        m.body = states.iter().flat_map(|b| b.w.iter().chain(&b.pi).copied()).collect();
    }
    m
}

impl Member {
    /// A member whose run could not be made at t0 (its start was refused, or the first
    /// element of a start from two positions failed: "first element: …").
    pub fn not_started(n: usize, t0: f64, error: &femvi::Error) -> Self {
        let why = match error {
            femvi::Error::Step(e) => format!("first element: {e}"),
            e => e.to_string(),
        };
        Member::failed(n, t0, why)
    }

    /// A member that did not start.
    pub fn failed(n: usize, t: f64, error: String) -> Self {
        Member {
            final_t: t,
            q: vec![f64::NAN; n],
            p: vec![f64::NAN; n],
            energy_error: f64::NAN,
            steps: 0,
            error: Some(error),
            saved_q: vec![],
            saved_p: vec![],
            body: vec![],
        }
    }
}

/// Drives `problem` from `start` to its end (or its first failure), as `femvi run` does.
pub fn run_member(problem: &Problem, start: Start) -> Member {
    crate::with_system!(&problem.system, l => drive_member(l, problem, start))
}

fn drive_member<L: Lagrangian + Clone + Sync>(lag: &L, problem: &Problem, start: Start) -> Member {
    let n = lag.dim();
    if let Some(constraints) = &problem.terms.constraints {
        return constrained_member(lag, problem, start, constraints);
    }
    if let Some(settings) = &problem.terms.adaptive {
        return adaptive_member(lag, problem, start, settings, &[]);
    }
    let mut energy = Balanced::new(problem, EnergyError::new(n, &start, lag.is_autonomous()));
    let made = problem.integrator(lag, &problem.element, problem.grid.clone(), start, problem.energy);
    let mut it = match made {
        Ok(it) => it,
        Err(e) => return Member::not_started(n, problem.grid.t0(), &e),
    };
    let report = drive(&mut it, &mut [&mut energy]);
    let node = it.node();
    // A node whose energy is not finite ends the member before it, as it ends a run.
    let (final_t, q, p) = match (&report.error, &energy.good) {
        (Some(femvi::Error::NonFiniteEnergy { .. }), Some(g)) => (g.0, g.1.clone(), g.2.clone()),
        (Some(femvi::Error::NonFiniteEnergy { .. }), None) => (problem.grid.t0(), vec![f64::NAN; n], vec![f64::NAN; n]),
        _ => (node.t, node.q.to_vec(), node.p.to_vec()),
    };
    Member {
        final_t,
        q,
        p,
        energy_error: energy.max_rel(),
        steps: report.steps,
        error: report.error.map(|e| e.to_string()),
        saved_q: vec![],
        saved_p: vec![],
        body: vec![],
    }
}

/// A member of a problem with `[constraints]`: the constrained run `femvi run` makes
/// (`crate::constrained::solve`, with the force if any) from `start`, its final node; the
/// energy error over the kept nodes as `femvi run`'s summary has it, or with forces the
/// energy balance's over every node.
fn constrained_member<L: Lagrangian + Clone + Sync>(
    lag: &L,
    problem: &Problem,
    start: Start,
    constraints: &(femvi::constraints::ExprConstraints, femvi::constraints::Enforcement),
) -> Member {
    let (n, t0) = (lag.dim(), problem.grid.t0());
    let solved = match &problem.terms.force {
        None => crate::constrained::solve(lag, problem, start, constraints).map(|r| (r.solution, None)),
        Some(f) => crate::constrained::solve_forced(lag, problem, start, constraints, f)
            .map(|r| (r.constrained.solution, Some(r.balance.max_rel))),
    };
    let (sol, balance) = match solved {
        Ok(s) => s,
        Err(e) => return Member::failed(n, t0, e),
    };
    let last = sol.len().saturating_sub(1);
    let e0 = sol.energy.first().copied().unwrap_or(f64::NAN);
    let scale = if e0 == 0.0 { 1.0 } else { e0.abs() };
    let energy = sol.energy.iter().fold(0.0f64, |m, h| m.max((h - e0).abs() / scale));
    Member {
        final_t: sol.t.get(last).copied().unwrap_or(t0),
        q: sol.q_row(last).map_or_else(|| vec![f64::NAN; n], <[f64]>::to_vec),
        p: sol.p_row(last).map_or_else(|| vec![f64::NAN; n], <[f64]>::to_vec),
        energy_error: balance.unwrap_or(energy),
        steps: sol.steps,
        error: sol.error.map(|e| e.to_string()),
        saved_q: vec![],
        saved_p: vec![],
        body: vec![],
    }
}

/// A member of a problem in `[time] mode = "adaptive"`: the adaptive run `femvi run` makes
/// (`crate::adaptive::solve_problem`, the file's monitor and `every`) from `start`, its final
/// node, the energy error over the kept nodes as summary.json has it, and the states at
/// `saveat`.
fn adaptive_member<L: Lagrangian + Clone>(
    lag: &L,
    problem: &Problem,
    start: Start,
    settings: &crate::adaptive::AdaptiveTime,
    saveat: &[f64],
) -> Member {
    let (n, t0) = (lag.dim(), problem.grid.t0());
    let p = femvi::Problem::new(lag.clone(), start, t0, problem.grid.end());
    let sol = match crate::adaptive::solve_problem(&p, problem, settings, problem.every, saveat.to_vec(), vec![]) {
        Ok(sol) => sol,
        Err(e) => return Member::failed(n, t0, e),
    };
    let last = sol.t.len().saturating_sub(1);
    let row = |v: &[f64]| {
        v.get(last * n..(last + 1) * n)
            .map_or_else(|| vec![f64::NAN; n], <[f64]>::to_vec)
    };
    let (saved_q, saved_p) = saved(&sol.saved, n, saveat.len());
    Member {
        final_t: sol.t.get(last).copied().unwrap_or(t0),
        q: row(&sol.q),
        p: row(&sol.p),
        energy_error: crate::adaptive::max_rel_energy_error(&sol),
        steps: sol.steps,
        error: sol.error.map(|e| e.to_string()),
        saved_q,
        saved_p,
        body: vec![],
    }
}

/// q and p at the first `times` times of `saved` (the prefix a run reached), NaN after.
fn saved(saved: &femvi::solution::Saved, n: usize, times: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut q, mut p) = (vec![f64::NAN; times * n], vec![f64::NAN; times * n]);
    let reached = saved.t.len().min(times) * n;
    q[..reached].copy_from_slice(&saved.q[..reached]);
    p[..reached].copy_from_slice(&saved.p[..reached]);
    (q, p)
}

/// [`run_member`] that also reports q and p at the times `saveat` (increasing, inside the
/// span), through the library's recorder (`solve_on`, the same integrator and energy tracker,
/// so the final state and energy error are [`run_member`]'s bit for bit).
pub fn run_member_saving(problem: &Problem, start: Start, saveat: &[f64]) -> Member {
    crate::with_system!(&problem.system, l => solve_member(l, problem, start, saveat))
}

fn solve_member<L: Lagrangian + Clone + Sync>(lag: &L, problem: &Problem, start: Start, saveat: &[f64]) -> Member {
    let n = lag.dim();
    let (t0, end) = (problem.grid.t0(), problem.grid.end());
    if let Some(settings) = &problem.terms.adaptive {
        return adaptive_member(lag, problem, start, settings, saveat);
    }
    if problem.terms.constraints.is_some() {
        // Refused by the capability table (saveat with constraints); never run without them.
        let why = crate::problem::capabilities::Use::SaveatOrDense;
        let e = problem.refuse(why, "femvi.ensemble").err().unwrap_or_default();
        return Member::failed(n, t0, e);
    }
    let mut balance = Balanced::new(problem, EnergyError::new(n, &start, lag.is_autonomous()));
    let p = femvi::Problem::new(lag.clone(), start, t0, end);
    let options = femvi::SolveOptions {
        steps: problem.steps.clone(),
        solver: problem.options,
        every: 0,
        saveat: saveat.to_vec(),
        track_energy: true,
        // A member keeps its first and last nodes only; its energy error is over every node,
        // as `run_member`'s.
        energy_nodes: femvi::solution::EnergyNodes::Every,
        ..femvi::SolveOptions::step(1.0)
    };
    // The one integrator of the problem's terms (forces, rotations), through the library's
    // recorder.
    let (grid, el) = (problem.grid.clone(), &problem.element);
    let solved = problem
        .integrator(&p.lagrangian, el, grid, p.start.clone(), problem.energy)
        .and_then(|mut it| femvi::solution::solve_on(&mut it, &p, el, &options, &mut [&mut balance]));
    let sol = match solved {
        Ok(sol) => sol,
        Err(e) => return Member::not_started(n, t0, &e),
    };
    let energy_error = match balance.balance {
        Some(b) => b.max_rel(),
        None => sol.energy_report.map_or(f64::NAN, |r| r.max_rel_error),
    };
    let last = sol.len().saturating_sub(1);
    let (saved_q, saved_p) = saved(&sol.saved, n, saveat.len());
    Member {
        final_t: sol.t.get(last).copied().unwrap_or(t0),
        q: sol.q_row(last).map_or_else(|| vec![f64::NAN; n], <[f64]>::to_vec),
        p: sol.p_row(last).map_or_else(|| vec![f64::NAN; n], <[f64]>::to_vec),
        energy_error,
        steps: sol.steps,
        error: sol.error.map(|e| e.to_string()),
        saved_q,
        saved_p,
        body: vec![],
    }
}

/// The energy observer of a member, and with `[forces]` the energy balance H − H0 = W over
/// every node (as `femvi run`'s summary has it), which is then the member's energy error. A
/// node whose energy is not finite stops the member with [`femvi::Error::NonFiniteEnergy`]
/// (as it stops `femvi run` and `femvi.solve`); the member then ends on the node before it,
/// which `good` keeps.
struct Balanced {
    energy: EnergyError,
    balance: Option<WorkBalance>,
    /// The last node with a finite energy: (t, q, p).
    good: Option<(f64, Vec<f64>, Vec<f64>)>,
}

impl Balanced {
    fn new(problem: &Problem, energy: EnergyError) -> Self {
        let balance = problem.terms.force.is_some().then(WorkBalance::default);
        Balanced {
            energy,
            balance,
            good: None,
        }
    }

    /// The balance's largest relative error with forces, else the energy's.
    fn max_rel(&self) -> f64 {
        self.balance.map_or_else(|| self.energy.max_rel(), |b| b.max_rel())
    }
}

impl<L: Lagrangian> Observer<L> for Balanced {
    fn node(&mut self, it: &Integrator<'_, L>, last: bool) -> femvi::Result<()> {
        self.energy.node(it, last)?;
        let (h, node) = (self.energy.current().get().h, it.node());
        if !h.is_finite() {
            return Err(femvi::Error::NonFiniteEnergy {
                step: node.k,
                t: node.t,
            });
        }
        if let Some(b) = self.balance.as_mut() {
            b.at(h, it.work());
        }
        match self.good.as_mut() {
            Some((t, q, p)) => {
                *t = node.t;
                q.copy_from_slice(node.q);
                p.copy_from_slice(node.p);
            }
            None => self.good = Some((node.t, node.q.to_vec(), node.p.to_vec())),
        }
        Ok(())
    }
}

/// The start of member i: row i of `states` (rows of 2n numbers) as (q, p), or (q, v) with
/// `velocity`; the problem's own start without `states`. Err: the row does not exist.
pub fn start_of(problem: &Problem, states: Option<&[f64]>, i: usize, velocity: bool) -> Result<Start, String> {
    let n = problem.coordinates.len();
    let Some(s) = states else {
        return Ok(problem.start.clone());
    };
    let row = s
        .get(i * 2 * n..(i + 1) * 2 * n)
        .ok_or_else(|| format!("initial state {i} is missing (rows of 2n = {} numbers)", 2 * n))?;
    let (q, x) = (row[..n].to_vec(), row[n..].to_vec());
    Ok(if velocity {
        Start::Velocity { q, v: x }
    } else {
        Start::Momentum { q, p: x }
    })
}

/// Runs members `0..size` (member i is `member(i)`) on `workers` threads (0: all cores),
/// counting finished members in `done` (for a progress display). Err: the pool cannot start.
pub fn run_all(
    size: usize,
    workers: usize,
    done: &AtomicUsize,
    member: impl Fn(usize) -> Member + Sync,
) -> Result<Vec<Member>, String> {
    Ok(pool(workers)?.install(|| {
        (0..size)
            .into_par_iter()
            .map(|i| {
                let m = member(i);
                done.fetch_add(1, Ordering::Relaxed);
                m
            })
            .collect()
    }))
}

/// A rayon pool of `workers` threads (0: all cores).
pub(crate) fn pool(workers: usize) -> Result<rayon::ThreadPool, String> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(workers)
        .build()
        .map_err(|e| e.to_string())
}
