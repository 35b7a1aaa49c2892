//! Tangent maps and chaos indicators of forced and constrained runs: the propagated tangent
//! vectors against central finite differences of whole runs (a damped, driven Duffing
//! oscillator; the spherical pendulum and the planar double pendulum in Cartesian
//! coordinates, perturbed along the manifold), the symplecticity of the propagated tangent
//! vectors on the manifold, the ± pairs of a constrained conservative spectrum, MEGNO → 2 on
//! the regular spherical pendulum and its slope λ/2 on the chaotic double pendulum, and the
//! damped oscillator's spectrum against its closed form.

use femvi::chaos::{
    constrained_indicators, constrained_sensitivity, forced_indicators, forced_sensitivity, ChaosOptions,
};
use femvi::constraints::{solve_constrained, Enforcement};
use femvi::expr::ExprLagrangian;
use femvi::forces::{solve_forced, ExprForces, LinearForce};
use femvi::{models, Element, Lagrangian, Problem, SolveOptions, Start};

use crate::common::tangent_fd::{fd_difference, last_state, manifold_directions, unit_vectors};

/// The last node (q, p) of a solution.
fn duffing() -> (Problem<ExprLagrangian>, ExprForces) {
    let coords = vec!["x".to_string()];
    let params = [
        ("a".to_string(), -1.0),
        ("b".to_string(), 1.0),
        ("d".to_string(), 0.15),
        ("g".to_string(), 0.3),
        ("w".to_string(), 1.2),
    ];
    let lag = ExprLagrangian::new("0.5*x_dot^2 - 0.5*a*x^2 - 0.25*b*x^4", &coords, &params).unwrap();
    let force = ExprForces::new(&["-d*x_dot + g*cos(w*t)"], &coords, &params).unwrap();
    let start = Start::Momentum {
        q: vec![1.2],
        p: vec![0.1],
    };
    (Problem::new(lag, start, 0.0, 20.0), force)
}

#[test]
fn forced_tangent_maps_agree_with_finite_differences_of_whole_runs() {
    // The damped, driven Duffing oscillator x'' + δx' − x + x³ = γ cos ωt, 1000 steps.
    let (problem, force) = duffing();
    let (el, options) = (Element::with_order(4).unwrap(), SolveOptions::step(0.02));
    let (m, _) = forced_sensitivity(&problem, &force, &el, &options).unwrap();
    let run = |q: Vec<f64>, p: Vec<f64>| {
        let perturbed = Problem::new(problem.lagrangian.clone(), Start::Momentum { q, p }, 0.0, 20.0);
        let opts = SolveOptions {
            every: 0,
            ..options.clone()
        };
        last_state(&solve_forced(&perturbed, &force, &el, &opts).unwrap().solution)
    };
    // The difference is the central difference's own O(eps²) error: 1.6e-8 at eps = 1e-5,
    // 2.1e-10 at 1e-6 (measured).
    let rel = fd_difference(&m, (&[1.2], &[0.1]), &unit_vectors(2), 1e-6, run);
    eprintln!("Duffing (forced): relative difference {rel:.2e}");
    assert!(rel <= 1e-7, "{rel:e}");
}

/// The double pendulum in the plane (unit masses and rods, g = 1) at angles θ1, θ2 from the
/// downward vertical, at rest: (q, tangent vectors ∂q/∂θ1, ∂q/∂θ2).
fn double_pendulum(th1: f64, th2: f64) -> (Vec<f64>, [Vec<f64>; 2]) {
    let (s1, c1, s2, c2) = (th1.sin(), th1.cos(), th2.sin(), th2.cos());
    let q = vec![s1, -c1, s1 + s2, -c1 - c2];
    (q, [vec![c1, s1, c1, s1], vec![0.0, 0.0, c2, s2]])
}

/// The constrained whole-run map against central differences. The perturbed starts
/// q0 ± ε δq (G δq = 0) leave the manifold by the same O(ε²) for both signs (the curvature
/// term ½ε² g''(δq, δq)), within the start tolerance; the run projects the start momentum onto
/// T*N and the first step returns to the manifold, so the run is a smooth map of the start and
/// the common O(ε²) offset cancels in the central difference (error O(ε²)).
fn constrained_fd<L: Lagrangian + Clone + Sync, C: femvi::constraints::Constraints + Sync>(
    problem: &Problem<L>,
    con: &C,
    el: &Element,
    options: &SolveOptions,
    dq: &[Vec<f64>],
) -> f64 {
    let Start::Momentum { q, p } = problem.start.clone() else {
        panic!("momentum start")
    };
    let (m, _) = constrained_sensitivity(problem, con, el, options, Enforcement::default()).unwrap();
    let run = |q: Vec<f64>, p: Vec<f64>| {
        let perturbed = Problem::new(
            problem.lagrangian.clone(),
            Start::Momentum { q, p },
            problem.t0,
            problem.t_end,
        );
        let opts = SolveOptions {
            every: 0,
            ..options.clone()
        };
        last_state(&solve_constrained(&perturbed, con, el, &opts).unwrap().solution)
    };
    fd_difference(&m, (&q, &p), &manifold_directions(dq), 1e-6, run)
}

#[test]
fn constrained_tangent_maps_agree_with_finite_differences_of_whole_runs() {
    // The spherical pendulum, 1000 steps.
    let (lag, sphere) = models::chain(3, 1, 1.0, 1.0, 1.0).unwrap();
    let start = Start::Momentum {
        q: vec![0.6, 0.0, -0.8],
        p: vec![0.0, 0.7, 0.0],
    };
    let problem = Problem::new(lag, start, 0.0, 50.0);
    let dq = [vec![0.0, 1.0, 0.0], vec![0.8, 0.0, 0.6]];
    let rel = constrained_fd(
        &problem,
        &sphere,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.05),
        &dq,
    );
    eprintln!("spherical pendulum: relative difference {rel:.2e}");
    assert!(rel <= 1e-7, "{rel:e}");
    // The double pendulum in Cartesian coordinates (regular, small swings), 1000 steps.
    let (lag, rods) = models::chain(2, 2, 1.0, 1.0, 1.0).unwrap();
    let (q, dq) = double_pendulum(0.3, -0.2);
    let problem = Problem::new(lag, Start::Momentum { q, p: vec![0.0; 4] }, 0.0, 20.0);
    let rel = constrained_fd(
        &problem,
        &rods,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.02),
        &dq,
    );
    eprintln!("double pendulum: relative difference {rel:.2e}");
    assert!(rel <= 1e-7, "{rel:e}");
}

/// ω(a, b) = a_q·b_p − a_p·b_q.
fn omega(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() / 2;
    (0..n).map(|i| a[i] * b[n + i] - a[n + i] * b[i]).sum()
}

#[test]
fn the_propagated_tangent_vectors_are_symplectic_on_the_manifold() {
    // The double pendulum, 10⁴ steps: 2(n − m) = 4 start directions along the manifold
    // (δq tangent, or δp = M δq tangent). For G δq_a = G δq_b = 0 the start projection keeps
    // ω(a, b) (it adds Gᵀμ to δp), so ω(M a, M b) = ω(a, b) if the steps are symplectic.
    for (th1, th2) in [(0.3, -0.2), (0.8, -0.5)] {
        let (worst, size) = manifold_defect(th1, th2);
        eprintln!("double pendulum ({th1}, {th2}), 10^4 steps: symplecticity defect {worst:.2e} (max |M| {size:.1})");
        // The map grows by shear (|M| ≈ 21 and 38) and the rounding of the stored product
        // (~ε|M|² per step in ω(Ma, Mb)) sets the scale: the defect relative to |M|² stays at
        // round-off (5.4e-12 and 8.5e-11 absolute, about 1e-14 and 6e-14 relative, measured).
        assert!(worst <= 1e-12 * size.max(1.0).powi(2), "{worst:e}");
    }
}

/// (max |ω(Ma, Mb) − ω(a, b)|, max |M|) of the double pendulum's whole-run map over 10⁴ steps.
fn manifold_defect(th1: f64, th2: f64) -> (f64, f64) {
    let (lag, rods) = models::chain(2, 2, 1.0, 1.0, 1.0).unwrap();
    let (q, dq) = double_pendulum(th1, th2);
    let problem = Problem::new(lag, Start::Momentum { q, p: vec![0.0; 4] }, 0.0, 100.0);
    let options = SolveOptions::step(0.01);
    let (m, _) = constrained_sensitivity(
        &problem,
        &rods,
        &Element::with_order(4).unwrap(),
        &options,
        Enforcement::default(),
    )
    .unwrap();
    let mut dirs: Vec<Vec<f64>> = dq.iter().map(|v| [v.clone(), vec![0.0; 4]].concat()).collect();
    dirs.extend(dq.iter().map(|v| [vec![0.0; 4], v.clone()].concat()));
    let image: Vec<Vec<f64>> = dirs
        .iter()
        .map(|v| (0..8).map(|i| (0..8).map(|j| m[i * 8 + j] * v[j]).sum()).collect())
        .collect();
    let size = m.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let mut worst = 0.0f64;
    for a in 0..4 {
        for b in 0..4 {
            worst = worst.max((omega(&image[a], &image[b]) - omega(&dirs[a], &dirs[b])).abs());
        }
    }
    (worst, size)
}

fn chaotic_double_pendulum(t_end: f64) -> (Problem<femvi::Mechanical<models::UniformGravity>>, models::Chain) {
    let (lag, rods) = models::chain(2, 2, 1.0, 1.0, 1.0).unwrap();
    let (q, _) = double_pendulum(2.0, 2.5);
    (
        Problem::new(lag, Start::Momentum { q, p: vec![0.0; 4] }, 0.0, t_end),
        rods,
    )
}

#[test]
fn a_constrained_conservative_spectrum_comes_in_plus_minus_pairs_and_megno_grows_with_half_of_it() {
    // The chaotic double pendulum: 2 degrees of freedom on the manifold, 4 exponents.
    let (problem, rods) = chaotic_double_pendulum(2000.0);
    let chaos = ChaosOptions {
        spectrum: true,
        renormalize_every: 10,
        spectrum_transient: 200.0,
        record_every: 100,
        ..ChaosOptions::default()
    };
    let r = constrained_indicators(
        &problem,
        &rods,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.02),
        Enforcement::default(),
        &chaos,
    )
    .unwrap();
    assert!(r.error.is_none(), "{:?}", r.error);
    let s = r.spectrum.unwrap();
    eprintln!(
        "double pendulum spectrum {s:?}, pair sums {:.2e} {:.2e}",
        s[0] + s[3],
        s[1] + s[2]
    );
    assert_eq!(s.len(), 4);
    assert!(s[0] > 0.1, "not chaotic: {s:?}");
    assert!((s[0] + s[3]).abs() <= 1e-6 && (s[1] + s[2]).abs() <= 1e-6, "{s:?}");
    // MEGNO: ⟨Y⟩ ≈ λt/2 + c, its slope over the second half against λ from the QR method.
    let half: Vec<_> = r.series.iter().filter(|x| x.t >= 1000.0).collect();
    let (t, y): (Vec<f64>, Vec<f64>) = half.iter().map(|x| (x.t, x.mean_megno)).unzip();
    let k = slope(&t, &y);
    eprintln!(
        "double pendulum: lambda (QR) {:.5}, 2 x MEGNO slope {:.5}",
        s[0],
        2.0 * k
    );
    assert!((2.0 * k / s[0] - 1.0).abs() <= 0.05, "{} against {}", 2.0 * k, s[0]);
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
fn megno_tends_to_two_on_the_regular_spherical_pendulum() {
    let (lag, sphere) = models::chain(3, 1, 1.0, 1.0, 1.0).unwrap();
    let start = Start::Momentum {
        q: vec![0.6, 0.0, -0.8],
        p: vec![0.0, 0.7, 0.0],
    };
    let problem = Problem::new(lag, start, 0.0, 2e4);
    let r = constrained_indicators(
        &problem,
        &sphere,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.2),
        Enforcement::default(),
        &ChaosOptions::default(),
    )
    .unwrap();
    eprintln!(
        "spherical pendulum: <Y> = {:.5}, lambda = {:.2e}",
        r.last.mean_megno, r.last.lyapunov
    );
    assert!(r.error.is_none());
    assert!((r.last.mean_megno - 2.0).abs() <= 0.02, "{}", r.last.mean_megno);
}

#[test]
fn the_damped_oscillator_spectrum_is_the_closed_form() {
    // m x'' + c x' + k x = 0: exponents Re(−c/2m ± √((c/2m)² − k/m)), sum −c/m (the trace).
    let el = Element::with_order(4).unwrap();
    // The discrete flow's ln det per unit time differs from −c/m by the method's O(h^2s)
    // error (1.6e-6 at h = 0.05 for the overdamped case, where h|λ| = 0.14): h = 0.02.
    for (m, k, c) in [(1.0, 1.0, 0.2), (2.0, 1.0, 6.0)] {
        let start = Start::Momentum {
            q: vec![1.0],
            p: vec![0.0],
        };
        let problem = Problem::new(models::harmonic(m, k).unwrap(), start, 0.0, 500.0);
        let chaos = ChaosOptions {
            spectrum: true,
            spectrum_transient: 50.0,
            ..ChaosOptions::default()
        };
        let r = forced_indicators(
            &problem,
            &LinearForce::damping(1, c),
            &el,
            &SolveOptions::step(0.02),
            &chaos,
        )
        .unwrap();
        let s = r.spectrum.unwrap();
        let (a, disc) = (-c / (2.0 * m), (c / (2.0 * m)).powi(2) - k / m);
        let root = disc.max(0.0).sqrt();
        let sum = s[0] + s[1];
        eprintln!(
            "damped m {m} k {k} c {c}: spectrum {s:?} (closed form {} {}), sum error {:.2e}",
            a + root,
            a - root,
            sum + c / m
        );
        assert!((sum + c / m).abs() <= 1e-6, "{s:?}");
        // Each exponent: the frame's transient and, underdamped, the rotation bias them by O(1/T).
        assert!(
            (s[0] - (a + root)).abs() <= 1e-2 && (s[1] - (a - root)).abs() <= 1e-2,
            "{s:?}"
        );
    }
}

/// The one integrator's tangent map of a forced step (issue 33: `Integrator::tangent_map`
/// with a force term, which it used to refuse) against central differences of single steps,
/// whichever solver took the step: the Duffing oscillator's velocity-dependent friction takes
/// Newton; a force of t and q alone on this mechanical L the fixed point, whose map must agree
/// with the one the same step taken by Newton gives.
#[test]
fn the_integrators_tangent_map_of_a_forced_step_is_that_of_the_step() {
    use femvi::{Integrator, Method, SolverOptions, TimeGrid};
    let (problem, friction) = duffing();
    let coords = vec!["x".to_string()];
    let drive = ExprForces::new(&["0.3*cos(1.2*t) - 0.2*x^3"], &coords, &[]).unwrap();
    let el = Element::with_order(4).unwrap();
    let lag = &problem.lagrangian;
    let (q0, p0, h, t0) = (1.2, 0.1, 0.05, 0.37);
    fn one_step<F: femvi::forces::Force + Sync>(
        lag: &ExprLagrangian,
        el: &Element,
        force: &F,
        method: Method,
        (t0, h, q, p): (f64, f64, f64, f64),
    ) -> (Vec<f64>, Vec<f64>) {
        let grid = TimeGrid::uniform(t0, h, t0 + h).unwrap();
        let start = Start::Momentum { q: vec![q], p: vec![p] };
        let opts = SolverOptions {
            method,
            ..SolverOptions::default()
        };
        let mut it = Integrator::with_force(lag, el, grid, start, opts, force).unwrap();
        assert!(it.step().unwrap());
        let m = it.tangent_map().unwrap();
        let node = it.node();
        (m, vec![node.q[0], node.p[0]])
    }
    for (name, method) in [
        ("friction, Newton", Method::Auto),
        ("drive", Method::Auto),
        ("drive, Newton", Method::Newton),
    ] {
        let map = |q: f64, p: f64| {
            if name.starts_with("friction") {
                one_step(lag, &el, &friction, method, (t0, h, q, p))
            } else {
                one_step(lag, &el, &drive, method, (t0, h, q, p))
            }
        };
        let (m, _) = map(q0, p0);
        let eps = 1e-6;
        let mut worst = 0.0f64;
        for col in 0..2 {
            let (dq, dp) = if col == 0 { (eps, 0.0) } else { (0.0, eps) };
            let (_, plus) = map(q0 + dq, p0 + dp);
            let (_, minus) = map(q0 - dq, p0 - dp);
            for row in 0..2 {
                let fd = (plus[row] - minus[row]) / (2.0 * eps);
                worst = worst.max((m[row * 2 + col] - fd).abs());
            }
        }
        eprintln!("{name}: max |map − central difference| = {worst:.2e}");
        // Central differences at eps = 1e-6 carry O(eps²) ≈ 1e-12 truncation and
        // O(1e-16/eps) ≈ 1e-10 rounding.
        assert!(worst < 1e-8, "{name}: {worst:e}");
        // Not the unforced map: the friction changes the determinant (e^{-δh} to O(h⁵)).
        if name.starts_with("friction") {
            let det = m[0] * m[3] - m[1] * m[2];
            assert!((det - (-0.15 * h).exp()).abs() < 1e-7, "det {det}");
        }
    }
    // The fixed point's step map equals Newton's to the solvers' tolerance.
    let (a, _) = one_step(lag, &el, &drive, Method::Auto, (t0, h, q0, p0));
    let (b, _) = one_step(lag, &el, &drive, Method::Newton, (t0, h, q0, p0));
    let diff = a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(diff < 1e-12, "fixed point against Newton: {diff:e}");
}
