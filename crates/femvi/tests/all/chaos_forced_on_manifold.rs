//! Tangent maps and chaos indicators of constrained runs under non-conservative forces
//! (`femvi::chaos::forced_constrained_indicators` / `forced_constrained_sensitivity`): the
//! whole-run map against central finite differences of `solve_constrained_forced` runs
//! perturbed along the manifold, the nodes of the indicator run against that solver's, and the
//! spectrum of the damped spherical pendulum against its closed form.

use femvi::chaos::{forced_constrained_indicators, forced_constrained_sensitivity, ChaosOptions};
use femvi::constraints::{solve_constrained_forced, Enforcement};
use femvi::expr::ExprLagrangian;
use femvi::forces::{ExprForces, LinearForce};
use femvi::{models, Element, Problem, SolveOptions, Start};

use crate::common::tangent_fd::{fd_difference, last_state, manifold_directions};

/// The spherical pendulum (unit mass, rod and g) from q = (0.6, 0, −0.8) with momentum p.
fn sphere_problem(p: Vec<f64>, t_end: f64) -> Problem<femvi::Mechanical<models::UniformGravity>> {
    let (lag, _) = models::chain(3, 1, 1.0, 1.0, 1.0).unwrap();
    let start = Start::Momentum {
        q: vec![0.6, 0.0, -0.8],
        p,
    };
    Problem::new(lag, start, 0.0, t_end)
}

#[test]
fn forced_constrained_tangent_maps_agree_with_finite_differences_of_whole_runs() {
    // Friction and a periodic push along x (a force that depends on t, q̇ and not on a
    // potential), 400 steps.
    let (_, sphere) = models::chain(3, 1, 1.0, 1.0, 1.0).unwrap();
    let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    let force = ExprForces::new(
        &["-0.3*x_dot + 0.2*cos(1.3*t)", "-0.3*y_dot", "-0.3*z_dot*(1 + x^2)"],
        &xyz,
        &[],
    )
    .unwrap();
    let problem = sphere_problem(vec![0.0, 0.7, 0.0], 20.0);
    let (el, options) = (Element::with_order(4).unwrap(), SolveOptions::step(0.05));
    let (m, _) =
        forced_constrained_sensitivity(&problem, &force, &sphere, &el, &options, Enforcement::default()).unwrap();
    let run = |q: Vec<f64>, p: Vec<f64>| {
        let perturbed = Problem::new(problem.lagrangian.clone(), Start::Momentum { q, p }, 0.0, 20.0);
        let opts = SolveOptions {
            every: 0,
            ..options.clone()
        };
        let r = solve_constrained_forced(&perturbed, &force, &sphere, &el, &opts, Enforcement::default()).unwrap();
        last_state(&r.constrained.solution)
    };
    // As tests/all/chaos_forced_constrained.rs: starts q0 ± ε δq with G δq = 0 (off the sphere by
    // the same O(ε²) for both signs, which cancels), the central difference's error O(ε²).
    let dirs = manifold_directions(&[vec![0.0, 1.0, 0.0], vec![0.8, 0.0, 0.6]]);
    // Measured 7.5e-9, 2.4e-9 and 6.8e-10 at ε = 3e-7, 1e-6 and 3e-6: the runs' round-off
    // over ε (over 1000 steps it was 2.1e-7 at 1e-6); ε = 1e-5 leaves the start tolerance.
    let rel = fd_difference(&m, (&[0.6, 0.0, -0.8], &[0.0, 0.7, 0.0]), &dirs, 1e-6, run);
    eprintln!("forced spherical pendulum: relative difference {rel:.2e}");
    assert!(rel <= 1e-7, "{rel:e}");
    // Without the forces' derivatives the map would be the conservative one's: far off.
    let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - z", &xyz, &[]).unwrap();
    let as_expr = Problem::new(lag, problem.start.clone(), 0.0, 20.0);
    let zero = ExprForces::new(&["0", "0", "0"], &xyz, &[]).unwrap();
    let (m0, _) =
        forced_constrained_sensitivity(&as_expr, &zero, &sphere, &el, &options, Enforcement::default()).unwrap();
    let size = m.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let off = m.iter().zip(&m0).fold(0.0f64, |a, (x, y)| a.max((x - y).abs())) / size;
    assert!(off > 1e-2, "{off:e}");
}

#[test]
fn the_indicator_run_takes_the_forced_solvers_nodes() {
    let (_, sphere) = models::chain(3, 1, 1.0, 1.0, 1.0).unwrap();
    let problem = sphere_problem(vec![0.0, 0.7, 0.0], 20.0);
    let (el, options) = (Element::with_order(4).unwrap(), SolveOptions::step(0.05));
    let friction = LinearForce::damping(3, 0.3);
    let r = forced_constrained_indicators(
        &problem,
        &friction,
        &sphere,
        &el,
        &options,
        Enforcement::default(),
        &ChaosOptions::default(),
    )
    .unwrap();
    let run = solve_constrained_forced(&problem, &friction, &sphere, &el, &options, Enforcement::default()).unwrap();
    let sol = &run.constrained.solution;
    let last = sol.len() - 1;
    let (t, q, p) = &r.final_node;
    assert_eq!(r.steps, sol.steps);
    assert_eq!(*t, sol.t[last]);
    assert_eq!(&q[..], sol.q_row(last).unwrap());
    assert_eq!(&p[..], sol.p_row(last).unwrap());
}

#[test]
fn the_damped_spherical_pendulum_spectrum_is_the_closed_form() {
    // Friction −c q̇ on the sphere: in canonical coordinates of T*N it is −c p (p = g(θ)θ̇ for
    // L = ½θ̇ᵀg θ̇ − V), so the flow contracts volume at the rate 2c (two momenta) and the four
    // exponents sum to −2c; the orbit settles at the bottom, where the linearised motion is
    // two damped oscillators ẍ + c ẋ + x = 0, so each exponent tends to −c/2 (underdamped).
    let (_, sphere) = models::chain(3, 1, 1.0, 1.0, 1.0).unwrap();
    let c = 0.4;
    let problem = sphere_problem(vec![0.0, 0.7, 0.0], 400.0);
    let chaos = ChaosOptions {
        spectrum: true,
        spectrum_transient: 50.0,
        ..ChaosOptions::default()
    };
    let r = forced_constrained_indicators(
        &problem,
        &LinearForce::damping(3, c),
        &sphere,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.02),
        Enforcement::default(),
        &chaos,
    )
    .unwrap();
    let s = r.spectrum.unwrap();
    let sum: f64 = s.iter().sum();
    eprintln!(
        "damped spherical pendulum c {c}: spectrum {s:?}, sum error {:.2e}",
        sum + 2.0 * c
    );
    assert_eq!(s.len(), 4);
    assert!((sum + 2.0 * c).abs() <= 1e-6, "{s:?}");
    assert!(s.iter().all(|l| (l + c / 2.0).abs() <= 1e-2), "{s:?}");
}
