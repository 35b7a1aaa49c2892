//! Ensembles: N runs of one problem with other initial states and/or parameter values, on a
//! rayon pool. Each member is driven exactly as `femvi run` drives a run (the same integrator,
//! the same energy observer), so a member's numbers are those of the single run bit for bit;
//! a member's failure is its own error and does not stop the others. `femvi ensemble` and the
//! Python package (`femvi.ensemble`) both run through [`run_all`] and write or return what
//! [`Member`] holds.

use crate::problem::Problem;
use crate::record::{write_table, EnergyError, WorkBalance};
use femvi::step::{drive, Observer};
use femvi::{Integrator, Lagrangian, Start};
use rayon::prelude::*;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

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
}

impl Member {
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
        Err(femvi::Error::Step(e)) => return Member::failed(n, problem.grid.t0(), format!("first element: {e}")),
        Err(e) => return Member::failed(n, problem.grid.t0(), e.to_string()),
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
        Err(femvi::Error::Step(e)) => return Member::failed(n, t0, format!("first element: {e}")),
        Err(e) => return Member::failed(n, t0, e.to_string()),
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
fn pool(workers: usize) -> Result<rayon::ThreadPool, String> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(workers)
        .build()
        .map_err(|e| e.to_string())
}

/// Runs members `0..size` of the one problem `problem`, member i from `start(i)` (called once
/// per member; Err: that member fails with the message), on `workers` threads, counting
/// finished members in `done`. When the problem's run is Störmer–Verlet on a mechanical
/// system ([`femvi::ensemble::in_lanes`]), the members go [`femvi::LANES`] at a time in SIMD
/// lanes ([`femvi::ensemble::run_in_lanes`]); otherwise one by one ([`run_member`]). Either
/// way each member's numbers are its single run's, bit for bit. Err: the pool cannot start.
pub fn run_shared(
    problem: &Problem,
    size: usize,
    workers: usize,
    done: &AtomicUsize,
    start: impl Fn(usize) -> Result<Start, String> + Sync,
) -> Result<Vec<Member>, String> {
    let starts: Vec<Result<Start, String>> = (0..size).map(&start).collect();
    let lanes = crate::with_system!(&problem.system, l => in_lanes(l, problem, &starts, workers, done))?;
    if let Some(members) = lanes {
        return Ok(members);
    }
    let n = problem.coordinates.len();
    run_all(size, workers, done, |i| match &starts[i] {
        Ok(s) => run_member(problem, s.clone()),
        Err(e) => Member::failed(n, f64::NAN, e.clone()),
    })
}

/// The members in lanes if the problem's run takes them (Ok(None) otherwise).
fn in_lanes<L: Lagrangian + Clone + Sync>(
    lag: &L,
    problem: &Problem,
    starts: &[Result<Start, String>],
    workers: usize,
    done: &AtomicUsize,
) -> Result<Option<Vec<Member>>, String> {
    let (n, t0) = (lag.dim(), problem.grid.t0());
    if problem.terms.constraints.is_some() || problem.terms.adaptive.is_some() {
        return Ok(None);
    }
    let Some(first) = starts.iter().find_map(|s| s.as_ref().ok()) else {
        return Ok(None);
    };
    let grid = problem.grid.clone();
    let Ok(template) = problem.integrator(lag, &problem.element, grid, first.clone(), problem.energy) else {
        return Ok(None);
    };
    let Some(lanes) = femvi::ensemble::EnsembleLanes::of(&template) else {
        return Ok(None);
    };
    let valid: Vec<Start> = starts.iter().filter_map(|s| s.as_ref().ok().cloned()).collect();
    let counted = |m: usize| {
        done.fetch_add(m, Ordering::Relaxed);
    };
    let mut ends = pool(workers)?.install(|| lanes.run(&valid, &counted)).into_iter();
    let members = starts
        .iter()
        .map(|s| match s {
            Err(e) => {
                done.fetch_add(1, Ordering::Relaxed);
                Member::failed(n, f64::NAN, e.clone())
            }
            Ok(_) => match ends.next() {
                Some(Ok(end)) => Member {
                    final_t: end.t,
                    q: end.q,
                    p: end.p,
                    energy_error: end.energy_error,
                    steps: end.steps,
                    error: end.error.map(|e| e.to_string()),
                    saved_q: vec![],
                    saved_p: vec![],
                },
                Some(Err(femvi::Error::Step(e))) => Member::failed(n, t0, format!("first element: {e}")),
                Some(Err(e)) => Member::failed(n, t0, e.to_string()),
                None => Member::failed(n, t0, "no result for this member".into()),
            },
        })
        .collect();
    Ok(Some(members))
}

/// The column names of an ensemble table: `member`, `final_t`, the coordinates, `p_` and the
/// coordinates, `energy_error`, `steps`.
pub fn columns(coordinates: &[String]) -> Vec<String> {
    let mut c = vec!["member".to_string(), "final_t".to_string()];
    c.extend(coordinates.iter().cloned());
    c.extend(coordinates.iter().map(|x| format!("p_{x}")));
    c.push("energy_error".into());
    c.push("steps".into());
    c
}

/// Writes `ensemble.csv` (the [`columns`] and `error`, numbers in shortest round-trip form)
/// and `ensemble.npy` (the numeric columns, NaN for what a failed member lacks, with
/// `ensemble_columns.txt`) into `dir`.
///
/// # Errors
/// The files cannot be written.
pub fn write(dir: &Path, coordinates: &[String], members: &[Member]) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let cols = columns(coordinates);
    let mut table = Vec::with_capacity(members.len() * cols.len());
    let mut w = csv::Writer::from_path(dir.join("ensemble.csv"))?;
    let mut header = cols.clone();
    header.push("error".into());
    w.write_record(&header)?;
    for (i, m) in members.iter().enumerate() {
        let mut row = vec![i as f64, m.final_t];
        row.extend(&m.q);
        row.extend(&m.p);
        row.push(m.energy_error);
        row.push(m.steps as f64);
        let mut text: Vec<String> = row.iter().map(|x| x.to_string()).collect();
        text[0] = i.to_string();
        text.push(m.error.clone().unwrap_or_default());
        w.write_record(&text)?;
        table.extend(row);
    }
    w.flush()?;
    write_table(
        &dir.join("ensemble.npy"),
        &dir.join("ensemble_columns.txt"),
        &cols,
        &table,
    )
}

/// What `femvi ensemble` was asked for (its options; the doc comments are the `--help` text).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct EnsembleArgs {
    /// Override a value of the problem file for every member (repeatable), e.g.
    /// --set time.end=100.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Initial states: a CSV of rows q0 then p0 (2n numbers; a header row is allowed) or
    /// an (N, 2n) float64 .npy file.
    #[arg(long)]
    pub states: Option<std::path::PathBuf>,
    /// The second half of each state row is v0 instead of p0.
    #[arg(long)]
    pub velocity: bool,
    /// A parameter of the system table's parameters over the members: NAME=LO:HI:N.
    #[arg(long)]
    pub param: Option<String>,
    /// Threads (default: all cores).
    #[arg(long, default_value_t = 0)]
    pub workers: usize,
    /// Output directory (default: the problem's).
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
    /// No progress bar or report.
    #[arg(long)]
    pub quiet: bool,
}

/// Initial states from a CSV (rows of numbers; a first row that is not numbers is a header)
/// or an NPY file (a 2-D float64 array), as one row-major vector and its row count.
///
/// # Errors
/// The file cannot be read, a value is not a number, or the rows do not have `width` numbers.
pub fn read_states(path: &Path, width: usize) -> Result<(Vec<f64>, usize), String> {
    let at = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let values: Vec<f64> = if path.extension().is_some_and(|e| e == "npy") {
        let bytes = crate::bounded::read(path, crate::bounded::Limits::BINARY).map_err(|e| at(&e))?;
        let npy = npyz::NpyFile::new(&bytes[..]).map_err(|e| at(&e))?;
        let shape = npy.shape().to_vec();
        if shape.len() != 2 || shape[1] as usize != width {
            return Err(at(&format!("expected an (N, {width}) array, got shape {shape:?}")));
        }
        npy.into_vec::<f64>().map_err(|e| at(&e))?
    } else {
        let text = crate::bounded::read_to_string(path, crate::bounded::Limits::CSV).map_err(|e| at(&e))?;
        let mut v = Vec::new();
        for (k, line) in text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()) {
            let row: Result<Vec<f64>, _> = line.split(',').map(|x| x.trim().parse::<f64>()).collect();
            match row {
                Ok(r) if r.len() == width => v.extend(r),
                Ok(r) => return Err(at(&format!("line {}: {} numbers, expected {width}", k + 1, r.len()))),
                Err(_) if k == 0 => {} // a header
                Err(e) => return Err(at(&format!("line {}: {e}", k + 1))),
            }
        }
        v
    };
    if values.iter().any(|x| !x.is_finite()) {
        return Err(at(&"initial states must be finite"));
    }
    let rows = values.len() / width.max(1);
    Ok((values, rows))
}

/// `femvi ensemble`: runs the members and writes ensemble.csv/.npy. Ok(true): every member
/// reached the end; Ok(false): some failed (their rows say why). Err: a message and exit code.
pub fn command(path: &Path, args: &EnsembleArgs) -> Result<bool, (String, u8)> {
    let bad = |e: String| (e, crate::BAD_INPUT);
    let problem = crate::problem::load_with(path, &args.set).map_err(|e| bad(e.to_string()))?;
    problem
        .refuse(crate::problem::capabilities::Use::Ensemble, "femvi ensemble")
        .map_err(|e| bad(format!("{}: {e}", path.display())))?;
    let n = problem.coordinates.len();
    let states = match &args.states {
        Some(f) => Some(read_states(f, 2 * n).map_err(bad)?),
        None => None,
    };
    let axis = args
        .param
        .as_deref()
        .map(crate::chaos::Axis::parse)
        .transpose()
        .map_err(bad)?;
    let size = match (&states, &axis) {
        (Some((_, a)), Some(b)) if *a != b.n => {
            return Err(bad(format!("--states has {a} rows but --param gives {} values", b.n)));
        }
        (Some((_, a)), _) => *a,
        (None, Some(b)) => b.n,
        (None, None) => {
            return Err(bad(format!(
                "{}: give --states FILE and/or --param NAME=LO:HI:N",
                path.display()
            )))
        }
    };
    let member_problem = |a: &crate::chaos::Axis, i: usize| -> Result<Problem, String> {
        let mut set = args.set.clone();
        set.push(format!("system.parameters.{}={:?}", a.name, a.value(i)));
        crate::problem::load_with(path, &set).map_err(|e| e.to_string())
    };
    // A parameter that the problem does not have is an input error, found on the first member.
    if let Some(a) = &axis {
        member_problem(a, 0).map_err(bad)?;
    }
    let rows = states.as_ref().map(|(v, _)| v.as_slice());
    let done = AtomicUsize::new(0);
    let member = |i: usize| {
        let owned;
        let p = match &axis {
            Some(a) => match member_problem(a, i) {
                Ok(p) => {
                    owned = p;
                    &owned
                }
                Err(e) => return Member::failed(n, f64::NAN, e),
            },
            None => &problem,
        };
        match start_of(p, rows, i, args.velocity) {
            Ok(start) => run_member(p, start),
            Err(e) => Member::failed(n, f64::NAN, e),
        }
    };
    let members = match &axis {
        None => {
            let start = |i: usize| start_of(&problem, rows, i, args.velocity);
            with_progress(size, args.quiet, &done, || {
                run_shared(&problem, size, args.workers, &done, start)
            })
        }
        Some(_) => with_progress(size, args.quiet, &done, || run_all(size, args.workers, &done, member)),
    }
    .map_err(|e| (e, crate::NUMERICAL))?;
    let dir = args.out.clone().unwrap_or_else(|| problem.directory.clone());
    write(&dir, &problem.coordinates, &members)
        .map_err(|e| (format!("cannot write {}: {e}", dir.display()), crate::BAD_INPUT))?;
    let failed = members.iter().filter(|m| m.error.is_some()).count();
    if !args.quiet {
        println!(
            "{size} members, {failed} failed; wrote {}",
            dir.join("ensemble.csv").display()
        );
    }
    Ok(failed == 0)
}

/// Runs `work` while a progress bar (unless `quiet`) follows `done` out of `size`.
fn with_progress<T: Send>(size: usize, quiet: bool, done: &AtomicUsize, work: impl FnOnce() -> T + Send) -> T {
    if quiet {
        return work();
    }
    let bar = indicatif::ProgressBar::new(size as u64);
    let out = std::thread::scope(|scope| {
        let worker = scope.spawn(work);
        while !worker.is_finished() {
            bar.set_position(done.load(Ordering::Relaxed) as u64);
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        worker.join()
    });
    bar.finish_and_clear();
    match out {
        Ok(t) => t,
        Err(p) => std::panic::resume_unwind(p),
    }
}
