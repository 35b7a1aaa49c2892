//! Forces in the energy mode as a term of the one integrator (issue 33): the run of
//! `Integrator::with_force_energy` observed by `solve_forced_with` (saveat, dense output,
//! events) gives the nodes of `solve_forced` bit for bit; its saved states, dense output and
//! event times agree with the damped oscillator's closed form; and a run stopped at a
//! checkpoint and restored into a new integrator ends on the same bits as one that was never
//! stopped, with the same discrete energy balance and energy-mode statistics.

use femvi::forces::{solve_forced, solve_forced_with, LinearForce};
use femvi::solution::Event;
use femvi::{
    models, Element, EnergyOptions, Integrator, Lagrangian, NodeFamily, Problem, QuadratureKind, SolveOptions,
    SolverOptions, Start, Steps, TimeGrid,
};

const C: f64 = 0.1;

/// x(t), x'(t) of x'' + C x' + x = 0 from x(0) = 1, x'(0) = 0.
fn damped(t: f64) -> (f64, f64) {
    let g = C / 2.0;
    let wd = (1.0 - g * g).sqrt();
    let b = g / wd;
    let e = (-g * t).exp();
    let (cs, sn) = ((wd * t).cos(), (wd * t).sin());
    (e * (cs + b * sn), e * (-g * (cs + b * sn) + wd * (b * cs - sn)))
}

fn oscillator(t_end: f64) -> Problem<impl Lagrangian + Sync> {
    let start = Start::Velocity {
        q: vec![1.0],
        v: vec![0.0],
    };
    Problem::new(models::harmonic(1.0, 1.0).unwrap(), start, 0.0, t_end)
}

fn energy_options(h: f64) -> SolveOptions {
    let mut o = SolveOptions::step(h);
    o.steps = Steps::Energy {
        step: h,
        options: EnergyOptions::from_step(h),
    };
    o
}

fn gauss(s: usize) -> Element {
    Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap()
}

#[test]
fn observed_run_has_the_nodes_of_solve_forced_and_the_closed_form_between_them() {
    let (problem, el, force) = (oscillator(20.0), gauss(4), LinearForce::damping(1, C));
    let plain = solve_forced(&problem, &force, &el, &energy_options(0.05)).unwrap();
    let mut opts = energy_options(0.05);
    opts.dense = true;
    opts.saveat = (1..40).map(|i| 0.5 * i as f64 + 0.013).collect();
    opts.events = vec![Event::new("x = 0", |_t, q: &[f64], _v: &[f64]| q[0])];
    let sol = solve_forced_with(&problem, &force, &el, &opts, &mut []).unwrap();
    assert!(sol.error.is_none() && plain.solution.error.is_none());
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&sol.t), bits(&plain.solution.t));
    assert_eq!(bits(&sol.q), bits(&plain.solution.q));
    assert_eq!(bits(&sol.p), bits(&plain.solution.p));
    assert_eq!(sol.energy_stats, plain.solution.energy_stats);
    // The steps really vary: the energy equation sets them as the energy decays.
    let st = sol.energy_stats.unwrap();
    assert!(st.max_step > 1.2 * st.min_step, "{st:?}");
    // Saved states against the closed form (degree 4: the element polynomial is O(h^5)).
    assert_eq!(sol.saved.t, opts.saveat);
    for (i, &t) in sol.saved.t.iter().enumerate() {
        let (x, v) = damped(t);
        assert!((sol.saved.q[i] - x).abs() < 1e-6, "q at {t}: {} vs {x}", sol.saved.q[i]);
        assert!((sol.saved.v[i] - v).abs() < 1e-5, "v at {t}: {} vs {v}", sol.saved.v[i]);
    }
    // Every zero of x in [0, 20]: tan(wd t) = −wd / g, t = ((j + 1) π − atan(wd / g)) / wd.
    let (g, wd) = (C / 2.0, (1.0 - C * C / 4.0).sqrt());
    let zeros: Vec<f64> = (0..7)
        .map(|j| ((j + 1) as f64 * std::f64::consts::PI - (wd / g).atan()) / wd)
        .filter(|&t| t < 20.0)
        .collect();
    assert_eq!(sol.events.len(), zeros.len());
    for (e, t) in sol.events.iter().zip(&zeros) {
        assert!((e.t - t).abs() < 1e-6, "event at {} vs {t}", e.t);
    }
    let dense = sol.dense.as_ref().unwrap();
    let mut q = [0.0];
    for t in [0.3, 7.77, 19.9] {
        dense.q_at(t, &mut q).unwrap();
        assert!((q[0] - damped(t).0).abs() < 1e-6);
    }
}

#[test]
fn a_checkpointed_run_resumes_bit_for_bit_with_its_discrete_balance() {
    let (lag, el, force) = (
        models::harmonic(1.0, 1.0).unwrap(),
        gauss(2),
        LinearForce::damping(1, C),
    );
    let make = || {
        let start = Start::Velocity {
            q: vec![1.0],
            v: vec![0.0],
        };
        let grid = TimeGrid::uniform(0.0, 0.05, 30.0).unwrap();
        let energy = EnergyOptions::from_step(0.05);
        Integrator::with_force_energy(&lag, &el, grid, start, SolverOptions::default(), &force, energy).unwrap()
    };
    let mut whole = make();
    while whole.step().unwrap() {}
    let mut first = make();
    for _ in 0..137 {
        assert!(first.step().unwrap());
    }
    let cp = first.checkpoint("damped");
    let mut second = make();
    second.restore(&cp, "damped").unwrap();
    while second.step().unwrap() {}
    let (a, b) = (whole.node(), second.node());
    assert_eq!((a.k, a.t.to_bits()), (b.k, b.t.to_bits()));
    assert_eq!(a.q[0].to_bits(), b.q[0].to_bits());
    assert_eq!(a.p[0].to_bits(), b.p[0].to_bits());
    assert_eq!(whole.work().to_bits(), second.work().to_bits());
    assert_eq!(whole.energy_stats(), second.energy_stats());
    assert_eq!(whole.discrete_balance(), second.discrete_balance());
    assert_eq!(
        whole.discrete_energy().map(f64::to_bits),
        second.discrete_energy().map(f64::to_bits)
    );
    // The balance is round-off and the discrete energy fell by the work.
    let bal = whole.discrete_balance().unwrap();
    assert!(bal.max_rel < 1e-13, "{bal:?}");
    assert!(whole.work() < -0.4);
    // A checkpoint of the conservative energy mode is refused here (another run).
    let start = Start::Velocity {
        q: vec![1.0],
        v: vec![0.0],
    };
    let grid = TimeGrid::uniform(0.0, 0.05, 30.0).unwrap();
    let opts = (SolverOptions::default(), EnergyOptions::from_step(0.05));
    let conservative = Integrator::with_energy(&lag, &el, grid, start, opts.0, opts.1).unwrap();
    assert!(second.restore(&conservative.checkpoint("damped"), "damped").is_err());
}
