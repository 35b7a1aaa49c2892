//! `femvi check` on a problem with rotations: the run of `Integrator::with_rotations_measured`,
//! whose every step's symplecticity defect is measured on T*SO(3) (max |JᵀΩJ − Ω| of the
//! step's Jacobian in canonical coordinates R = R_k exp(ψ̂), p_ψ = dexp_ψ μ; the module docs
//! of `femvi::rotation`), with the energy error and drift over the nodes; the time-reversal
//! test and the Noether momenta of `[symmetries]` are not measured (a note says so).

use super::report::CheckReport;
use crate::problem::Problem;
use femvi::rotation::Rotations;
use femvi::{Integrator, Lagrangian};

/// The report for a problem with rotations; Err carries a message and an exit code.
pub fn check(problem: &Problem, rotations: &Rotations) -> Result<CheckReport, (String, u8)> {
    crate::with_system!(&problem.system, l => check_with(l, problem, rotations))
}

fn check_with<L: Lagrangian + Sync>(
    lag: &L,
    problem: &Problem,
    rotations: &Rotations,
) -> Result<CheckReport, (String, u8)> {
    if !problem.events.is_empty() {
        return Err((
            "[system] rotations are checked without [[events]]".into(),
            crate::BAD_INPUT,
        ));
    }
    let mut it = Integrator::with_rotations_measured(
        lag,
        &problem.element,
        problem.grid.clone(),
        problem.start.clone(),
        problem.options,
        rotations.clone(),
    )
    .map_err(|e| (e.to_string(), crate::BAD_INPUT))?;
    let e0 = it.energy().map_err(|e| (e.to_string(), 1))?;
    let scale = if e0 == 0.0 { 1.0 } else { e0.abs() };
    let (mut t, mut rel) = (vec![it.node().t], vec![0.0]);
    while it.step().map_err(|e| (e.to_string(), 1))? {
        t.push(it.node().t);
        rel.push((it.energy().map_err(|e| (e.to_string(), 1))? - e0) / scale);
    }
    let autonomous = lag.is_autonomous();
    let mut notes = vec![format!(
        "{} rotation(s): the symplecticity defect is measured on T*SO(3) in canonical chart coordinates at every step; time reversal and [symmetries] momenta are not measured",
        rotations.count()
    )];
    if !autonomous {
        notes.push("the Lagrangian depends on time: H is not conserved".into());
    }
    let steps = t.len() - 1;
    Ok(CheckReport {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        steps,
        final_t: it.node().t,
        symplecticity_defect: it.symplecticity_defect(),
        symplecticity_defect_relative: None,
        symplecticity_samples: steps,
        max_rel_energy_error: rel.iter().fold(0.0, |m, x| m.max(x.abs())),
        energy_conserved: autonomous,
        energy_drift: super::constrained::slope(&t, &rel),
        momentum_drift: Default::default(),
        time_reversal_error: None,
        max_rel_discrete_energy_error: None,
        two_form: None,
        notes,
    })
}
