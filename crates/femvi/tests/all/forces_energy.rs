//! Forces in the energy mode (issue 19, item 1; `femvi::forces`, `forces/energy_term.rs`): the
//! discrete energy balance Ẽ_k − Ẽ_0 − W_k at every node (checked for the midpoint element
//! against the hand-derived energies and works of each element), the nodal order against the
//! damped oscillator's closed form, a zero force against the conservative energy-mode run bit
//! for bit, and hostile forces.

use crate::common::{fit_order, Errs};
use femvi::forces::{solve_forced, Force, ForcedSolution, LinearForce};
use femvi::{
    models, solve, Degenerate, Element, EnergyOptions, Error, Lagrangian, Method, NodeFamily, Problem, QuadratureKind,
    Scalar, SolveOptions, Start, StepFailure, Steps,
};

/// The midpoint element (s = 0 here) or degree s with s-point Gauss.
fn element(s: usize) -> Element {
    if s == 0 {
        Element::midpoint()
    } else {
        Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap()
    }
}

/// Energy-mode options from the first step h (steps in [h/1000, 10 h]).
fn energy(h: f64, method: Method) -> SolveOptions {
    let mut o = SolveOptions::step(h);
    o.steps = Steps::Energy {
        step: h,
        options: EnergyOptions::from_step(h),
    };
    o.solver.method = method;
    o
}

fn oscillator(t_end: f64) -> Problem<impl Lagrangian> {
    Problem::new(
        models::harmonic(1.0, 1.0).unwrap(),
        Start::Velocity {
            q: vec![1.0],
            v: vec![0.0],
        },
        0.0,
        t_end,
    )
}

/// x(t), x'(t) of x'' + c x' + x = 0 from x(0) = 1, x'(0) = 0 (underdamped, c < 2).
fn damped(c: f64, t: f64) -> (f64, f64) {
    let g = c / 2.0;
    let wd = (1.0 - g * g).sqrt();
    let b = g / wd;
    let e = (-g * t).exp();
    let (cs, sn) = ((wd * t).cos(), (wd * t).sin());
    let x = e * (cs + b * sn);
    let v = e * (-g * (cs + b * sn) + wd * (b * cs - sn));
    (x, v)
}

fn run(problem: &Problem<impl Lagrangian + Sync>, c: f64, el: &Element, opts: &SolveOptions) -> ForcedSolution {
    solve_forced(problem, &LinearForce::damping(1, c), el, opts).unwrap()
}

/// The midpoint element by hand: L = ½v² − ½x², F = −c v, element [t_k, t_k + h] with
/// v = Δq/h and x_m the midpoint, E⁻ = E⁺ = ½v² + ½x_m², W = −c h v², W⁻ = W⁺ = W/2 (c = ½).
/// So Ẽ_k = E(element k) − W_k/2 = E(element k − 1) + W_{k−1}/2, and Ẽ_k − Ẽ_0 = Σ_{j<k} W_j.
///
/// Under damping the steps grow: Ẽ − H (about |Δz|²/8 for the midpoint rule) stays nearly
/// constant while both decay, so h ∝ Ẽ^(−1/2) (module docs of `forces/energy_term.rs`); the run
/// stops within the step bounds [h0/1000, 10 h0] once Ẽ has decayed about 100-fold.
#[test]
fn midpoint_energy_equation_and_work_by_hand_over_a_long_run() {
    let c = 0.002;
    let (h, t_end) = (0.05, 2000.0);
    let sol = run(&oscillator(t_end), c, &element(0), &energy(h, Method::Newton));
    let s = &sol.solution;
    assert!(s.error.is_none(), "{:?}", s.error);
    assert!(s.steps >= 15000, "steps {}", s.steps);
    let elems: Vec<(f64, f64)> =
        s.t.windows(2)
            .zip(s.q.windows(2))
            .map(|(t, q)| {
                let hk = t[1] - t[0];
                let v = (q[1] - q[0]) / hk;
                let xm = 0.5 * (q[0] + q[1]);
                (0.5 * v * v + 0.5 * xm * xm, -c * hk * v * v)
            })
            .collect();
    let e0 = elems[0].0 - 0.5 * elems[0].1;
    let (mut w, mut worst_eq, mut worst_bal, mut worst_w) = (0.0, 0.0f64, 0.0f64, 0.0f64);
    let mut worst_early = 0.0f64;
    for k in 1..elems.len() {
        let (left, right) = (elems[k - 1].0 + 0.5 * elems[k - 1].1, elems[k].0 - 0.5 * elems[k].1);
        w += elems[k - 1].1;
        worst_eq = worst_eq.max((left - right).abs() / e0);
        if s.t[k] < 10.0 {
            worst_early = worst_early.max((left - right).abs() / e0);
        }
        worst_bal = worst_bal.max((right - e0 - w).abs() / e0);
        worst_w = worst_w.max((sol.work[k] - w).abs() / e0);
    }
    let disc = sol.discrete_balance.unwrap();
    let e_end = *sol.discrete_energy.last().unwrap();
    let n = s.t.len();
    let h_end = s.t[n - 1] - s.t[n - 2];
    eprintln!(
        "midpoint, c = {c}, {} steps: energy equation {worst_eq:.2e} (t < 10: {worst_early:.2e}), balance {worst_bal:.2e}, work column {worst_w:.2e}, library balance {:.2e}; Ẽ from {e0} to {e_end}; last step {h_end} (h0 sqrt(Ẽ0/Ẽ) = {})",
        s.steps,
        disc.max_rel,
        h * (e0 / e_end).sqrt()
    );
    // The energy has decayed by a factor e^-4: the balance is not trivially small.
    assert!(e_end < 0.05 * e0);
    assert!((h_end / (h * (e0 / e_end).sqrt()) - 1.0).abs() < 0.1);
    // h_k recovered here as t_{k+1} − t_k carries ulp(t)/h_k of relative error, about 1e-12
    // near t = 2000: round-off of this check, not of the run. Early on it is 50 times less.
    assert!(worst_early < 1e-13, "{worst_early}");
    assert!(worst_eq < 1e-11 && worst_bal < 1e-11 && worst_w < 1e-13);
    assert!(disc.max_rel < 1e-12);
    assert!((sol.discrete_energy[0] - e0).abs() < 1e-15);
}

/// The library's discrete balance for degrees 1 to 3 over a long run, and H − H0 − W small.
#[test]
fn discrete_energy_balance_to_round_off_for_higher_degrees() {
    for s in 1..=3 {
        let c = 0.01;
        let h = [0.1, 0.2, 0.4][s - 1];
        let sol = run(&oscillator(300.0), c, &element(s), &energy(h, Method::Auto));
        let st = sol.solution.energy_stats.unwrap();
        let disc = sol.discrete_balance.unwrap();
        eprintln!(
            "s = {s}, h0 = {h}: {} steps, h in [{:.4}, {:.4}], degenerate {}, discrete balance {:.2e}, H balance {:.2e}, error {:?}",
            sol.solution.steps,
            st.min_step,
            st.max_step,
            st.degenerate_steps,
            disc.max_rel,
            sol.balance.max_rel,
            sol.solution.error
        );
        assert!(sol.solution.error.is_none());
        assert_eq!(st.degenerate_steps, 0);
        // Ẽ − H = O(h^{2s} Ẽ) stays nearly constant while Ẽ decays: h ∝ Ẽ^(−1/(2s)).
        let (d0, d1) = (sol.discrete_energy[0], *sol.discrete_energy.last().unwrap());
        let predicted = h * (d0 / d1).powf(1.0 / (2.0 * s as f64));
        let n = sol.solution.t.len();
        let h_end = sol.solution.t[n - 1] - sol.solution.t[n - 2];
        eprintln!("s = {s}: last step {h_end:.5}, predicted {predicted:.5}");
        assert!(
            (h_end / predicted - 1.0).abs() < 0.02,
            "s = {s}: {h_end} vs {predicted}"
        );
        assert!(disc.max_rel < 1e-12, "s = {s}: {}", disc.max_rel);
        assert!(sol.balance.max_rel < 1e-2, "s = {s}: {}", sol.balance.max_rel);
    }
}

/// Nodal error max_k |q_k − x(t_k)| + |p_k − x'(t_k)| over [0, 10] against the closed form,
/// fitted over the first step h0.
#[test]
fn nodal_order_against_the_closed_form() {
    let c = 0.3;
    for (s, hs, want) in [
        (1usize, [0.1, 0.05, 0.025, 0.0125], 2.0),
        (2, [0.4, 0.2, 0.1, 0.05], 4.0),
        (3, [0.8, 0.4, 0.2, 0.1], 6.0),
    ] {
        let mut errs = vec![];
        for h in hs {
            let sol = run(&oscillator(10.0), c, &element(s), &energy(h, Method::Auto));
            let so = &sol.solution;
            assert!(so.error.is_none(), "s = {s}, h = {h}: {:?}", so.error);
            let err = (0..so.t.len())
                .map(|i| {
                    let (x, v) = damped(c, so.t[i]);
                    (so.q[i] - x).abs() + (so.p[i] - v).abs()
                })
                .fold(0.0, f64::max);
            errs.push(err);
        }
        let order = fit_order(&hs, &errs);
        eprintln!("s = {s}: errors {} order {order:.2}", Errs(&errs));
        assert!((order - want).abs() < 0.3, "s = {s}: order {order}");
    }
}

/// A zero force gives the conservative energy-mode run (`femvi::solve`, full Newton) bit for
/// bit. The forced steps solve by full Newton whatever the Newton method asked for, so the
/// conservative run they equal is `Method::FullNewton` (`Method::Newton` is the simplified
/// iteration there since issue 15, equal to round-off, not bit for bit).
#[test]
fn zero_force_is_the_conservative_energy_run_bit_for_bit() {
    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    let hh = Problem::new(
        models::henon_heiles(),
        Start::Momentum {
            q: vec![0.1, -0.1],
            p: vec![0.3, 0.2],
        },
        0.0,
        50.0,
    );
    for s in 0..=2 {
        let el = element(s);
        let opts = energy(0.1, Method::FullNewton);
        let forced = solve_forced(&hh, &LinearForce::damping(2, 0.0), &el, &opts).unwrap();
        let plain = solve(&hh, &el, &opts).unwrap();
        let f = &forced.solution;
        assert!(f.error.is_none() && plain.error.is_none());
        assert!(f.steps > 400 && f.steps == plain.steps, "{} {}", f.steps, plain.steps);
        assert_eq!(bits(&f.t), bits(&plain.t), "s = {s}: t");
        assert_eq!(bits(&f.q), bits(&plain.q), "s = {s}: q");
        assert_eq!(bits(&f.p), bits(&plain.p), "s = {s}: p");
        assert_eq!(f.energy_stats, plain.energy_stats, "s = {s}: statistics");
        assert!(forced.work.iter().all(|&w| w == 0.0));
    }
}

/// F = +a v (anti-damping) at rate a.
struct Push(f64);
impl Force for Push {
    fn dim(&self) -> usize {
        1
    }
    fn force<D: Scalar>(&self, _t: D, _q: &[D], v: &[D], out: &mut [D]) {
        out[0] = v[0] * self.0;
    }
}

/// A force that is NaN from t = 1 on.
struct Poison;
impl Force for Poison {
    fn dim(&self) -> usize {
        1
    }
    fn force<D: Scalar>(&self, t: D, _q: &[D], _v: &[D], out: &mut [D]) {
        out[0] = if t.re() >= 1.0 { D::from(f64::NAN) } else { D::from(0.0) };
    }
}

/// A step error naming the step and the time of its node in the solution.
fn step_error(sol: &ForcedSolution) -> femvi::StepError {
    match &sol.solution.error {
        Some(Error::Step(e)) => e.clone(),
        other => panic!("expected a step error, got {other:?}"),
    }
}

#[test]
fn hostile_forces_are_typed_errors_naming_step_and_time() {
    let el = element(1);
    // Strong anti-damping: the work over any admissible step outruns the energy equation.
    let sol = solve_forced(&oscillator(10.0), &Push(40.0), &el, &energy(0.1, Method::Auto)).unwrap();
    let e = step_error(&sol);
    let last = sol.solution.t.len() - 1;
    eprintln!("anti-damping: {e}");
    assert_eq!(e.failure, StepFailure::NoAdmissibleStep);
    assert_eq!(
        (e.step, e.t),
        (*sol.solution.step.last().unwrap(), sol.solution.t[last])
    );
    // The same with the fallback policy: the run goes on with counted degenerate steps.
    let mut opts = energy(0.1, Method::Auto);
    if let Steps::Energy { options, .. } = &mut opts.steps {
        options.on_degenerate = Degenerate::Fixed;
    }
    let sol = solve_forced(&oscillator(1.0), &Push(40.0), &el, &opts).unwrap();
    let st = sol.solution.energy_stats.unwrap();
    eprintln!(
        "anti-damping, fixed fallback: {} degenerate steps, {:?}",
        st.degenerate_steps, sol.solution.error
    );
    assert!(st.degenerate_steps > 0);
    // A force that turns NaN: a typed error at the first step that meets it.
    let sol = solve_forced(&oscillator(10.0), &Poison, &el, &energy(0.1, Method::Auto)).unwrap();
    let e = step_error(&sol);
    eprintln!("NaN force: {e}");
    assert!(e.t < 1.0 && e.t > 0.5, "{e}");
    assert_eq!(e.t, *sol.solution.t.last().unwrap());
    // Bad bounds and a method the forced energy mode does not have: input errors.
    let mut opts = energy(0.1, Method::Auto);
    if let Steps::Energy { options, .. } = &mut opts.steps {
        options.min_step = 0.2;
    }
    let force = LinearForce::damping(1, 0.1);
    assert!(matches!(
        solve_forced(&oscillator(1.0), &force, &el, &opts),
        Err(Error::Invalid { .. })
    ));
    let opts = energy(0.1, Method::FixedPoint);
    assert!(matches!(
        solve_forced(&oscillator(1.0), &force, &el, &opts),
        Err(Error::Invalid { .. })
    ));
}

/// A nonlinear system, the damped pendulum: the discrete balance Ẽ_k − Ẽ_0 − W_k stays at
/// round-off while the nodal balance H_k − H_0 − W_k (H not quadratic) shrinks at order 2s.
#[test]
fn damped_pendulum_discrete_and_nodal_balances() {
    let pend = Problem::new(
        models::pendulum(1.0, 1.0, 1.0).unwrap(),
        Start::Velocity {
            q: vec![1.5],
            v: vec![0.0],
        },
        0.0,
        10.0,
    );
    for (s, hs, want) in [
        (1usize, [0.1, 0.05, 0.025, 0.0125], 2.0),
        (2, [0.2, 0.1, 0.05, 0.025], 4.0),
    ] {
        let mut errs = vec![];
        for h in hs {
            let sol = run(&pend, 0.1, &element(s), &energy(h, Method::Auto));
            assert!(
                sol.solution.error.is_none(),
                "s = {s}, h = {h}: {:?}",
                sol.solution.error
            );
            let disc = sol.discrete_balance.unwrap().max_rel;
            assert!(disc < 1e-13, "s = {s}, h = {h}: discrete balance {disc}");
            errs.push(sol.balance.max_abs);
        }
        let order = fit_order(&hs, &errs);
        eprintln!("pendulum s = {s}: max |H − H0 − W| {} order {order:.2}", Errs(&errs));
        assert!((order - want).abs() < 0.3, "s = {s}: order {order}");
    }
}

/// A time-dependent force and a time-dependent L (a stiffness 1 + 0.3 sin t, a drive
/// 0.5 cos 1.3t, damping 0.2): energy goes up and down, and Ẽ changes by W − h Σ b_i ∂L/∂t,
/// which the reported work includes; the discrete balance stays at round-off.
#[test]
fn driven_oscillator_with_time_dependent_stiffness() {
    use femvi::expr::ExprLagrangian;
    use femvi::forces::{LinearForce, Sum};
    let coords = ["x".to_string()];
    let lag = ExprLagrangian::new("0.5*x_dot^2 - 0.5*(1 + 0.3*sin(t))*x^2", &coords, &[]).unwrap();
    assert!(!lag.is_autonomous());
    let problem = Problem::new(
        lag,
        Start::Velocity {
            q: vec![1.0],
            v: vec![0.0],
        },
        0.0,
        30.0,
    );
    let force = Sum(LinearForce::damping(1, 0.2), LinearForce::drive(vec![0.5], 1.3));
    for (s, h) in [(1, 0.05), (2, 0.2)] {
        let sol = solve_forced(&problem, &force, &element(s), &energy(h, Method::Auto)).unwrap();
        // Degree 2 ends early here: along this orbit the root of the energy equation, whose
        // h-dependence is only O(h⁴), meets a fold (the steps grow fast, then g(h) has no
        // zero). That is a typed error naming the step, and the balance holds up to it.
        match &sol.solution.error {
            None => {}
            Some(Error::Step(e)) if s == 2 && e.failure == StepFailure::NoAdmissibleStep => {
                eprintln!("time-dependent, s = {s}: stopped: {e}")
            }
            Some(e) => panic!("s = {s}: {e}"),
        }
        let disc = sol.discrete_balance.unwrap().max_rel;
        let d = &sol.discrete_energy;
        let rises = d.windows(2).filter(|w| w[1] > w[0]).count();
        eprintln!(
            "time-dependent, s = {s}: {} steps, discrete balance {disc:.2e}, H balance {:.2e}, Ẽ rises at {rises} nodes",
            sol.solution.steps, sol.balance.max_rel
        );
        assert!(disc < 1e-13, "s = {s}: {disc}");
        assert!(rises > 10 && rises < d.len() - 10, "{rises} of {}", d.len());
    }
}
