//! Mesh refinement: the same optimal control problem solved on coarser meshes first, each
//! optimum the start of the next (issue 36, item 5). The coarse solution is carried over as a
//! [`Guess`]: its positions at the element end nodes and its controls at the quadrature
//! points, both interpolated linearly onto the next mesh, and its t1 as the next free t1's
//! start. A coarse stage that does not converge still hands on its best iterate; its
//! outcome is in [`Optimum::stages`].

use super::{ControlProblem, Controls, FinalTime, Guess, OptimizeOptions, Optimum, Stage};
use crate::discrete::Element;
use crate::error::{invalid, Result};
use crate::lagrangian::Lagrangian;

/// One solve of a problem on its own mesh.
type Solve<L, C> = fn(&L, &C, &Element, &ControlProblem, &OptimizeOptions) -> Result<Optimum>;

/// Solves on `options.coarse` meshes, then on the problem's, each from the previous optimum.
pub(super) fn solve_refined<L: Lagrangian + ?Sized, C: Controls>(
    lag: &L,
    controls: &C,
    element: &Element,
    problem: &ControlProblem,
    options: &OptimizeOptions,
    solve: Solve<L, C>,
) -> Result<Optimum> {
    let meshes: Vec<usize> = options.coarse.iter().copied().chain([problem.elements]).collect();
    if meshes.windows(2).any(|w| w[0] == 0 || w[0] >= w[1]) {
        return Err(invalid(
            "coarse meshes",
            format!(
                "{:?} must increase, from at least one element, below the problem's {}",
                options.coarse, problem.elements
            ),
        ));
    }
    let mut stage_options = OptimizeOptions {
        coarse: Vec::new(),
        ..options.clone()
    };
    let mut stage_problem = problem.clone();
    let mut stages = Vec::new();
    for &elements in &options.coarse {
        stage_problem.elements = elements;
        let o = solve(lag, controls, element, &stage_problem, &stage_options)?;
        stages.push(Stage {
            elements,
            iterations: o.iterations,
            objective: o.objective,
            converged: o.error.is_none(),
        });
        stage_options.guess = Some(guess_from(&o, controls.controls()));
        if let FinalTime::Free { min, max, .. } = problem.t1 {
            // Strictly inside the bounds, as a free t1's start must be.
            let margin = 1e-3 * (max - min);
            stage_problem.t1 = FinalTime::Free {
                min,
                max,
                guess: o.t1.clamp(min + margin, max - margin),
            };
        }
    }
    stage_problem.elements = problem.elements;
    let mut best = solve(lag, controls, element, &stage_problem, &stage_options)?;
    best.stages = stages;
    Ok(best)
}

/// An optimum as a guess: rows at the union of its node and control times, positions
/// interpolated between the nodes and controls between the quadrature points (held
/// beyond the first and last).
pub(super) fn guess_from(o: &Optimum, m: usize) -> Guess {
    let n = if o.t.is_empty() { 0 } else { o.q.len() / o.t.len() };
    let mut t: Vec<f64> = o.t.iter().chain(&o.control_t).copied().collect();
    t.sort_by(f64::total_cmp);
    t.dedup();
    let (mut q, mut u) = (Vec::with_capacity(t.len() * n), Vec::with_capacity(t.len() * m));
    let (mut row_q, mut row_u) = (vec![0.0; n], vec![0.0; m]);
    for &s in &t {
        super::start::interpolate(&o.t, &o.q, n, s, &mut row_q);
        super::start::interpolate(&o.control_t, &o.u, m, s, &mut row_u);
        q.extend_from_slice(&row_q);
        u.extend_from_slice(&row_u);
    }
    Guess { t, q, u: Some(u) }
}
