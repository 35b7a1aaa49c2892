//! Maps of the indicators over a grid of initial conditions or parameters (the familiar
//! MEGNO stability maps), one run per point, in parallel on a pool of `threads` threads
//! (rayon). Each point's result is the one a serial run gives: the runs are independent.

use super::{indicators, ChaosOptions, ChaosReport};
use crate::discrete::Element;
use crate::error::{invalid, Result};
use crate::lagrangian::Lagrangian;
use crate::solution::{Problem, SolveOptions};
use rayon::prelude::*;

/// The indicators of `points` problems, `problem(i)` for i in 0..points, on `threads`
/// threads (0: all cores). Each entry is that point's report or the error that prevented
/// it, so that one bad point does not stop the map.
///
/// # Errors
/// A thread pool that cannot be made.
///
/// # Example
///
/// ```
/// use femvi::chaos::{map, ChaosOptions};
/// use femvi::{models, Element, Problem, SolveOptions, Start};
///
/// // Circular Kepler orbits of radius 1 … 2: all regular.
/// let kepler = models::kepler(1.0)?;
/// let problem = |i: usize| {
///     let r = 1.0 + i as f64 / 3.0;
///     let start = Start::Momentum { q: vec![r, 0.0], p: vec![0.0, r.sqrt().recip()] };
///     Problem::new(kepler.clone(), start, 0.0, 500.0)
/// };
/// let reports = map(4, problem, &Element::with_order(4)?, &SolveOptions::step(0.1), &ChaosOptions::default(), 2)?;
/// for r in &reports {
///     let r = r.as_ref().expect("a regular orbit");
///     assert!((r.last.mean_megno - 2.0).abs() < 0.2);
/// }
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn map<L, F>(
    points: usize,
    problem: F,
    element: &Element,
    options: &SolveOptions,
    chaos: &ChaosOptions,
    threads: usize,
) -> Result<Vec<Result<ChaosReport>>>
where
    L: Lagrangian + Send,
    F: Fn(usize) -> Problem<L> + Sync,
{
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| invalid("thread pool", e.to_string()))?;
    Ok(pool.install(|| {
        (0..points)
            .into_par_iter()
            .map(|i| indicators(&problem(i), element, options, chaos))
            .collect()
    }))
}
