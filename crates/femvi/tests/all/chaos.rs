//! Variational equations and chaos indicators: the propagated tangent map against central
//! finite differences of whole runs (a mechanical and a velocity-dependent Lagrangian), its
//! symplecticity over 10⁴ steps, MEGNO → 2 on regular orbits (Kepler, Hénon–Heiles), MEGNO's
//! slope λ/2 on a chaotic Hénon–Heiles orbit against the exponent from the QR method, and the
//! spectrum's ± pairs.

use femvi::chaos::{indicators, sensitivity, ChaosOptions};
use femvi::expr::ExprLagrangian;
use femvi::{models, solve, Element, EnergyOptions, Lagrangian, Problem, SolveOptions, Start, Steps};

fn final_state<L: Lagrangian + Clone>(
    problem: &Problem<L>,
    el: &Element,
    options: &SolveOptions,
    q: Vec<f64>,
    p: Vec<f64>,
) -> Vec<f64> {
    let perturbed = Problem::new(
        problem.lagrangian.clone(),
        Start::Momentum { q, p },
        problem.t0,
        problem.t_end,
    );
    let options = SolveOptions {
        every: 0,
        ..options.clone()
    };
    let sol = solve(&perturbed, el, &options).unwrap();
    assert!(sol.error.is_none());
    let last = sol.len() - 1;
    [sol.q_row(last).unwrap(), sol.p_row(last).unwrap()].concat()
}

/// max |M − M_fd| / max |M| with M_fd by central differences (step eps) of whole runs:
/// second order, or with `fourth` the five-point stencil (error O(eps⁴)), which lets a larger
/// eps keep the runs' rounding noise (~noise/eps) small.
fn fd_difference_with<L: Lagrangian + Clone>(
    problem: &Problem<L>,
    el: &Element,
    options: &SolveOptions,
    eps: f64,
    fourth: bool,
) -> f64 {
    let Start::Momentum { q, p } = problem.start.clone() else {
        panic!("momentum start")
    };
    let n = q.len();
    let (m, _) = sensitivity(problem, el, options).unwrap();
    let d = 2 * n;
    let (mut worst, mut size) = (0.0f64, 0.0f64);
    for j in 0..d {
        let shifted = |sign: f64| {
            let (mut q, mut p) = (q.clone(), p.clone());
            if j < n {
                q[j] += sign * eps;
            } else {
                p[j - n] += sign * eps;
            }
            final_state(problem, el, options, q, p)
        };
        let (plus, minus) = (shifted(1.0), shifted(-1.0));
        let far = fourth.then(|| (shifted(2.0), shifted(-2.0)));
        for i in 0..d {
            let fd = match &far {
                Some((plus2, minus2)) => (8.0 * (plus[i] - minus[i]) - (plus2[i] - minus2[i])) / (12.0 * eps),
                None => (plus[i] - minus[i]) / (2.0 * eps),
            };
            worst = worst.max((m[i * d + j] - fd).abs());
            size = size.max(m[i * d + j].abs());
        }
    }
    worst / size
}

fn fd_difference<L: Lagrangian + Clone>(problem: &Problem<L>, el: &Element, options: &SolveOptions, eps: f64) -> f64 {
    fd_difference_with(problem, el, options, eps, false)
}

#[test]
fn tangent_maps_agree_with_finite_differences_of_whole_runs() {
    // Hénon–Heiles (mechanical: fixed point), 1000 steps.
    let hh = Problem::new(
        models::henon_heiles(),
        Start::Momentum {
            q: vec![0.1, -0.05],
            p: vec![0.2, 0.3],
        },
        0.0,
        50.0,
    );
    let rel = fd_difference(&hh, &Element::with_order(6).unwrap(), &SolveOptions::step(0.05), 1e-6);
    eprintln!("Hénon–Heiles: relative difference {rel:.2e}");
    assert!(rel <= 1e-7, "{rel:e}");
    // A charge in a magnetic field in a Kepler well (velocity-dependent: Newton), 1000 steps.
    let coords = ["x".to_string(), "y".to_string()];
    let magnetic = ExprLagrangian::new(
        "0.5*(x_dot^2 + y_dot^2) + 0.5*b*(x*y_dot - y*x_dot) + 1/sqrt(x^2 + y^2)",
        &coords,
        &[("b".into(), 0.7)],
    )
    .unwrap();
    let mg = Problem::new(
        magnetic,
        Start::Momentum {
            q: vec![0.8, 0.0],
            p: vec![0.0, 1.3],
        },
        0.0,
        20.0,
    );
    let rel = fd_difference(&mg, &Element::with_order(4).unwrap(), &SolveOptions::step(0.02), 1e-6);
    eprintln!("magnetic: relative difference {rel:.2e}");
    assert!(rel <= 1e-7, "{rel:e}");
}

/// Energy mode: exactly 1000 steps (max_steps; the span is longer), so that the perturbed runs
/// take as many steps as the tangent product; the carried energy follows the start.
fn energy_options(h: f64) -> SolveOptions {
    SolveOptions {
        steps: Steps::Energy {
            step: h,
            options: EnergyOptions::from_step(h),
        },
        max_steps: Some(1000),
        ..SolveOptions::step(h)
    }
}

fn hh_energy_problem() -> Problem<femvi::Mechanical<models::HenonHeilesPotential>> {
    Problem::new(
        models::henon_heiles(),
        Start::Momentum {
            q: vec![0.1, -0.05],
            p: vec![0.2, 0.3],
        },
        0.0,
        1e3,
    )
}

#[test]
fn energy_mode_tangent_maps_agree_with_finite_differences_of_whole_runs() {
    // Hénon–Heiles, 1000 steps near h = 0.1. Degree 1 (Element::with_order(2)): the five-point
    // stencil at eps = 1e-4 measured 1.5e-9 (plain central differences reach only ~2e-7: the
    // map's curvature at eps ≥ 1e-5, the runs' rounding noise below).
    let hh = hh_energy_problem();
    let options = energy_options(0.1);
    let rel = fd_difference_with(&hh, &Element::with_order(2).unwrap(), &options, 1e-4, true);
    eprintln!("Hénon–Heiles, energy mode, degree 1: relative difference {rel:.2e}");
    assert!(rel <= 1e-7, "{rel:e}");
    let (_, (t, _, _)) = sensitivity(&hh, &Element::with_order(2).unwrap(), &options).unwrap();
    assert!(t > 90.0 && t < 120.0, "1000 steps near h = 0.1: t = {t}");
}

#[test]
fn energy_mode_degree_two_tangent_maps_agree_to_the_runs_own_precision() {
    // Degree 2 (Element::with_order(4)) at h = 0.1: the discrete energy's slope in h is
    // g_h ≈ 2e-6, so each step's h is fixed by the energy equation only to ~ε|E|/g_h ≈ 1e-11
    // and a whole run only to ~1e-8 in time (fixed-point and Newton runs end 5e-9 apart).
    // Finite differences and the map itself are then defined to ~2e-6 (the map's curvature
    // ~1e3 times that spread). Measured: five-point stencil at eps = 3e-4, 2.0e-6; the maps of
    // a fixed-point and a Newton run differ by 2e-6 relative. Before the vectors were carried
    // by solves (`Integrator::extended_tangent_apply`) instead of products with the assembled
    // maps, whose entries of size 1/g_h ≈ 5e5 cost digits, the map was off by 1.8e-2 and the
    // two solvers' maps differed by 0.5 %.
    let hh = hh_energy_problem();
    let el = Element::with_order(4).unwrap();
    let options = energy_options(0.1);
    let rel = fd_difference_with(&hh, &el, &options, 3e-4, true);
    eprintln!("Hénon–Heiles, energy mode, degree 2: relative difference {rel:.2e}");
    assert!(rel <= 2e-5, "{rel:e}");
    let newton = SolveOptions {
        solver: femvi::SolverOptions {
            method: femvi::Method::Newton,
            ..options.solver
        },
        ..options.clone()
    };
    let (a, _) = sensitivity(&hh, &el, &options).unwrap();
    let (b, _) = sensitivity(&hh, &el, &newton).unwrap();
    let size = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let diff = a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) / size;
    eprintln!("fixed point against Newton: relative difference {diff:.2e}");
    assert!(diff <= 2e-5, "{diff:e}");
}

#[test]
fn energy_mode_megno_tends_to_two_on_a_regular_orbit() {
    // A circular Kepler orbit, degree 1, steps near 0.05: regular, ⟨Y⟩ → 2 and λ → 0.
    let start = Start::Momentum {
        q: vec![1.0, 0.0],
        p: vec![0.0, 1.0],
    };
    let problem = Problem::new(models::kepler(1.0).unwrap(), start, 0.0, 2000.0);
    let options = SolveOptions {
        max_steps: None,
        ..energy_options(0.05)
    };
    let report = indicators(
        &problem,
        &Element::with_order(2).unwrap(),
        &options,
        &ChaosOptions::default(),
    )
    .unwrap();
    eprintln!(
        "energy mode Kepler: ⟨Y⟩ = {}, λ = {}",
        report.last.mean_megno, report.last.lyapunov
    );
    assert!(report.error.is_none());
    assert!((report.last.mean_megno - 2.0).abs() < 0.05, "{:?}", report.last);
    assert!(report.last.lyapunov.abs() < 0.01);
}

/// (max |MᵀJM − J|, max |M|) of the whole-run tangent map.
fn whole_run_defect(h: f64, t_end: f64) -> (f64, f64) {
    let hh = Problem::new(
        models::henon_heiles(),
        Start::Momentum {
            q: vec![0.1, -0.05],
            p: vec![0.2, 0.3],
        },
        0.0,
        t_end,
    );
    let (m, _) = sensitivity(&hh, &Element::with_order(4).unwrap(), &SolveOptions::step(h)).unwrap();
    let (d, n) = (4, 2);
    // MᵀJM − J with J = [[0, I], [−I, 0]].
    let j = |a: usize, b: usize| -> f64 {
        if a < n && b == a + n {
            1.0
        } else if a >= n && b + n == a {
            -1.0
        } else {
            0.0
        }
    };
    let (mut worst, mut size) = (0.0f64, 0.0f64);
    for a in 0..d {
        for b in 0..d {
            let mut s = 0.0;
            for k in 0..d {
                for l in 0..d {
                    s += m[k * d + a] * j(k, l) * m[l * d + b];
                }
            }
            worst = worst.max((s - j(a, b)).abs());
            size = size.max(m[a * d + b].abs());
        }
    }
    (worst, size)
}

#[test]
fn the_propagated_tangent_map_is_symplectic() {
    // 10⁴ steps of h = 0.01: the map grows to |M| ≈ 5 (shear of a regular orbit) and the
    // defect stays below 1e-12.
    let (worst, size) = whole_run_defect(0.01, 100.0);
    eprintln!("h = 0.01, 10^4 steps: defect {worst:.2e} (max |M| {size:.1})");
    assert!(worst <= 1e-12, "{worst:e}");
    // 10⁴ steps of h = 0.1 (t = 1000): |M| ≈ 55, and the rounding of the stored product (each
    // step ~ε|M|² in MᵀJM) sets the scale: the defect relative to |M|² stays at round-off.
    let (worst, size) = whole_run_defect(0.1, 1000.0);
    eprintln!("h = 0.1, 10^4 steps: defect {worst:.2e} (max |M| {size:.1})");
    assert!(worst <= 1e-12 * size.max(1.0).powi(2), "{worst:e}");
}

#[test]
fn megno_tends_to_two_on_regular_orbits() {
    let period = 2.0 * std::f64::consts::PI;
    let e: f64 = 0.3;
    let kepler = Problem::new(
        models::kepler(1.0).unwrap(),
        Start::Momentum {
            q: vec![1.0 - e, 0.0],
            p: vec![0.0, ((1.0 + e) / (1.0 - e)).sqrt()],
        },
        0.0,
        1e4 * period,
    );
    let el = Element::with_order(4).unwrap();
    let r = indicators(
        &kepler,
        &el,
        &SolveOptions::step(period / 40.0),
        &ChaosOptions::default(),
    )
    .unwrap();
    eprintln!(
        "Kepler: <Y> = {:.5}, lambda = {:.2e}",
        r.last.mean_megno, r.last.lyapunov
    );
    assert!((r.last.mean_megno - 2.0).abs() <= 0.02, "{}", r.last.mean_megno);
    // A regular Hénon–Heiles orbit (E = 1/12), 10⁴ periods of ~2π.
    let hh = Problem::new(
        models::henon_heiles(),
        Start::Momentum {
            q: vec![0.0, 0.1],
            p: vec![0.39, 0.0],
        },
        0.0,
        1e4 * period,
    );
    let r = indicators(&hh, &el, &SolveOptions::step(0.2), &ChaosOptions::default()).unwrap();
    eprintln!("Hénon–Heiles regular: <Y> = {:.5}", r.last.mean_megno);
    assert!((r.last.mean_megno - 2.0).abs() <= 0.02, "{}", r.last.mean_megno);
}

/// Least-squares slope of y against x.
fn slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    sxy / sxx
}

#[test]
fn megno_grows_with_half_the_lyapunov_exponent_on_a_chaotic_orbit() {
    // Hénon–Heiles at E = 1/6 from (0, −0.1) with p_y = 0: in the chaotic sea.
    let (y0, energy): (f64, f64) = (-0.1, 1.0 / 6.0);
    let v = 0.5 * y0 * y0 - y0.powi(3) / 3.0;
    let hh = Problem::new(
        models::henon_heiles(),
        Start::Momentum {
            q: vec![0.0, y0],
            p: vec![(2.0 * (energy - v)).sqrt(), 0.0],
        },
        0.0,
        T_CHAOS,
    );
    let chaos = ChaosOptions {
        spectrum: true,
        renormalize_every: 10,
        record_every: 100,
        ..ChaosOptions::default()
    };
    let r = indicators(&hh, &Element::with_order(4).unwrap(), &SolveOptions::step(0.1), &chaos).unwrap();
    let spectrum = r.spectrum.clone().unwrap();
    let lambda = spectrum[0];
    // ⟨Y⟩ ≈ λ t / 2 + c: its slope over the second half of the run.
    let half: Vec<_> = r.series.iter().filter(|s| s.t >= 0.5 * T_CHAOS).collect();
    let (t, y): (Vec<f64>, Vec<f64>) = half.iter().map(|s| (s.t, s.mean_megno)).unzip();
    let k = slope(&t, &y);
    eprintln!(
        "chaotic: lambda (QR) {lambda:.5}, 2 x MEGNO slope {:.5}, spectrum {spectrum:?}",
        2.0 * k
    );
    assert!(lambda > 0.01, "not chaotic: {lambda}");
    assert!((2.0 * k / lambda - 1.0).abs() <= 0.05, "{} against {lambda}", 2.0 * k);
    // A Hamiltonian spectrum comes in ± pairs: their sum is zero exactly (det M = 1) up to
    // round-off; counted from the start, each pair's sum goes like 1/T (the initial frame's
    // transient; see the next test for the spectrum counted after a transient).
    let total: f64 = spectrum.iter().sum();
    assert!(total.abs() <= 1e-6, "{spectrum:?}");
    for i in 0..2 {
        assert!((spectrum[i] + spectrum[3 - i]).abs() <= 2.0 / T_CHAOS, "{spectrum:?}");
    }
}

/// Counted after a transient (the frame first turns to the Lyapunov directions), the
/// spectrum of the chaotic Hénon–Heiles orbit comes in ± pairs to round-off, not only like 1/T.
#[test]
fn the_spectrum_after_a_transient_comes_in_plus_minus_pairs() {
    let (y0, energy): (f64, f64) = (-0.1, 1.0 / 6.0);
    let v = 0.5 * y0 * y0 - y0.powi(3) / 3.0;
    let start = Start::Momentum {
        q: vec![0.0, y0],
        p: vec![(2.0 * (energy - v)).sqrt(), 0.0],
    };
    let hh = Problem::new(models::henon_heiles(), start, 0.0, 1e4);
    let el = Element::with_order(4).unwrap();
    let mut sums = vec![];
    for transient in [0.0, 1e3] {
        let chaos = ChaosOptions {
            spectrum: true,
            renormalize_every: 10,
            spectrum_transient: transient,
            ..ChaosOptions::default()
        };
        let s = indicators(&hh, &el, &SolveOptions::step(0.1), &chaos)
            .unwrap()
            .spectrum
            .unwrap();
        eprintln!(
            "transient {transient}: spectrum {s:?}, pair sums {:.2e} {:.2e}",
            s[0] + s[3],
            s[1] + s[2]
        );
        assert!(s[0] > 0.05, "chaotic: {s:?}");
        sums.push(((s[0] + s[3]).abs(), (s[1] + s[2]).abs()));
    }
    // From the start: the transient's 1/T bias (about 1e-4 at T = 1e4); after it: round-off.
    assert!(sums[0].0 > 1e-5, "{sums:?}");
    assert!(sums[1].0 <= 1e-12 && sums[1].1 <= 1e-12, "{sums:?}");
}

/// Length of the chaotic run.
const T_CHAOS: f64 = 5e4;

#[test]
fn a_map_gives_each_point_the_serial_result() {
    let problem = |i: usize| {
        let x = -0.3 + 0.1 * i as f64;
        let py = (0.25 - x * x).sqrt();
        Problem::new(
            models::henon_heiles(),
            Start::Momentum {
                q: vec![x, 0.0],
                p: vec![0.0, py],
            },
            0.0,
            100.0,
        )
    };
    let (el, options, chaos) = (
        Element::with_order(4).unwrap(),
        SolveOptions::step(0.2),
        ChaosOptions::default(),
    );
    let parallel = femvi::chaos::map(7, problem, &el, &options, &chaos, 2).unwrap();
    for (i, p) in parallel.iter().enumerate() {
        let serial = indicators(&problem(i), &el, &options, &chaos).unwrap();
        assert_eq!(p.as_ref().unwrap(), &serial, "point {i}");
    }
}

/// d(q_N, p_N)/dθ against central differences of whole runs at θ ± 1e-6 (1000 steps), for a
/// mechanical parameter (g of a pendulum) and one in a velocity-dependent term (the field b
/// of a charge in a Kepler well).
#[test]
fn parameter_sensitivities_agree_with_finite_differences_of_whole_runs() {
    use femvi::chaos::{parameter_sensitivity, Frozen};
    fn check(source: &str, coords: &[&str], theta: f64, start: (Vec<f64>, Vec<f64>), h: f64, order: usize) -> f64 {
        let coords: Vec<String> = coords.iter().map(|c| c.to_string()).collect();
        let aug = ExprLagrangian::new(source, &coords, &[]).unwrap();
        let (q, p) = start;
        let problem = Problem::new(
            aug,
            Start::Momentum {
                q: q.clone(),
                p: p.clone(),
            },
            0.0,
            1000.0 * h,
        );
        let el = Element::with_order(order).unwrap();
        let options = SolveOptions::step(h);
        let (d, _) = parameter_sensitivity(&problem, theta, &el, &options).unwrap();
        let run = |th: f64| {
            let lag = Frozen::new(&problem.lagrangian, th).unwrap();
            let pr = Problem::new(
                lag,
                Start::Momentum {
                    q: q.clone(),
                    p: p.clone(),
                },
                0.0,
                1000.0 * h,
            );
            let sol = solve(
                &pr,
                &el,
                &SolveOptions {
                    every: 0,
                    ..options.clone()
                },
            )
            .unwrap();
            assert!(sol.error.is_none());
            let last = sol.len() - 1;
            [sol.q_row(last).unwrap(), sol.p_row(last).unwrap()].concat()
        };
        let eps = 1e-6;
        let (plus, minus) = (run(theta + eps), run(theta - eps));
        let size = d.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        let worst = d
            .iter()
            .zip(plus.iter().zip(&minus))
            .map(|(x, (a, b))| (x - (a - b) / (2.0 * eps)).abs())
            .fold(0.0f64, f64::max);
        worst / size
    }
    let pend = check(
        "0.5*x_dot^2 + g*cos(x)",
        &["x", "g"],
        9.81,
        (vec![1.0], vec![0.0]),
        0.01,
        4,
    );
    eprintln!("pendulum, d/dg: relative difference {pend:.2e}");
    assert!(pend <= 1e-7, "{pend:e}");
    let mag = check(
        "0.5*(x_dot^2 + y_dot^2) + 0.5*b*(x*y_dot - y*x_dot) + 1/sqrt(x^2 + y^2)",
        &["x", "y", "b"],
        0.7,
        (vec![0.8, 0.0], vec![0.0, 1.3]),
        0.02,
        4,
    );
    eprintln!("magnetic, d/db: relative difference {mag:.2e}");
    assert!(mag <= 1e-7, "{mag:e}");
}

/// The harmonic oscillator q'' = −k q from (q0, p0): dq(T)/dk and dp(T)/dk in closed form,
/// against the order-8 element (its error in q is O(h⁸), and so is that of the derivative).
#[test]
fn a_parameter_sensitivity_matches_the_closed_form() {
    use femvi::chaos::parameter_sensitivity;
    let coords = ["x".to_string(), "k".to_string()];
    let aug = ExprLagrangian::new("0.5*x_dot^2 - 0.5*k*x^2", &coords, &[]).unwrap();
    let (q0, p0, k, t) = (0.7, -0.4, 2.0f64, 10.0);
    let problem = Problem::new(
        aug,
        Start::Momentum {
            q: vec![q0],
            p: vec![p0],
        },
        0.0,
        t,
    );
    // Measured |error| of dp/dk: 1.3e-11 (h = 0.05), 1.5e-12 (0.04), 1.3e-10 (0.02), 6.0e-10
    // (0.01): below h = 0.04 it grows with the number of steps (presumably round-off and
    // the solver tolerance of the run), not with h⁸.
    let (d, _) =
        parameter_sensitivity(&problem, k, &Element::with_order(8).unwrap(), &SolveOptions::step(0.02)).unwrap();
    // q = q0 cos wt + (p0/w) sin wt, p = −q0 w sin wt + p0 cos wt, w = √k, dw/dk = 1/(2w).
    let w = k.sqrt();
    let (c, s) = ((w * t).cos(), (w * t).sin());
    let dq_dw = -q0 * t * s - p0 / (w * w) * s + p0 / w * t * c;
    let dp_dw = -q0 * s - q0 * w * t * c - p0 * t * s;
    let (dq, dp) = (dq_dw / (2.0 * w), dp_dw / (2.0 * w));
    eprintln!(
        "closed form: dq/dk {dq:.12} (femvi {:.12}), dp/dk {dp:.12} (femvi {:.12})",
        d[0], d[1]
    );
    assert!(
        (d[0] - dq).abs() < 1e-9 && (d[1] - dp).abs() < 1e-9,
        "{d:?} vs ({dq}, {dp})"
    );
}
