//! Members of one problem in SIMD lanes: [`run_shared`] takes them eight at a time through
//! `femvi::ensemble` where the problem's run qualifies (Störmer–Verlet, or the fixed-point
//! step of an element of up to three points, on a mechanical system), and one by one
//! ([`super::run_member`]) otherwise; either way each member is its single run bit for bit.

use super::{pool, run_all, run_member, Member};
use crate::problem::Problem;
use femvi::{Lagrangian, Start};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Runs members `0..size` of the one problem `problem`, member i from `start(i)` (called once
/// per member; Err: that member fails with the message), on `workers` threads, counting
/// finished members in `done`. When the problem's run qualifies
/// ([`femvi::ensemble::in_lanes`]: Störmer–Verlet, or the fixed-point step of an element of
/// up to three points and degree 3, on a mechanical system), the members go [`femvi::LANES`] at a time in SIMD
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
                    body: vec![],
                },
                Some(Err(e)) => Member::not_started(n, t0, &e),
                None => Member::failed(n, t0, "no result for this member".into()),
            },
        })
        .collect();
    Ok(Some(members))
}
