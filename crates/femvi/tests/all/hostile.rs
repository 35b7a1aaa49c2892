//! Hostile inputs: every public library function that takes user data answers with a typed
//! error (or a documented harmless value) instead of panicking, aborting, hanging or
//! allocating without bound. Each test here failed on the code before its fix (a stack
//! overflow, an abort on a failed allocation, a hang or a panic; see the commit messages).

use femvi::expr::ExprLagrangian;
use femvi::{models, Element, Integrator, Lagrangian, Scalar, SolverOptions, Start, TimeGrid};
use std::sync::mpsc;
use std::time::Duration;

/// Runs `f` in a thread with a 256 KiB stack: deep recursion overflows it and aborts the test.
fn on_small_stack<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::Builder::new()
        .stack_size(256 * 1024)
        .spawn(f)
        .unwrap()
        .join()
        .unwrap()
}

/// Runs `f` in a thread and fails if it has not returned within `seconds` (a hang).
fn within<T: Send + 'static>(seconds: u64, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(Duration::from_secs(seconds))
        .unwrap_or_else(|_| panic!("did not return within {seconds} s"))
}

fn x() -> Vec<String> {
    vec!["x".to_string()]
}

/// The circular Kepler orbit of radius 1, over [0, 1] with h = 0.1.
fn circle() -> Start {
    Start::Momentum {
        q: vec![1.0, 0.0],
        p: vec![0.0, 1.0],
    }
}

fn grid() -> TimeGrid {
    TimeGrid::uniform(0.0, 0.1, 1.0).unwrap()
}

// ---- 1. Deep and long expressions --------------------------------------------------------

#[test]
fn deeply_nested_expressions_are_rejected_without_deep_recursion() {
    let sources = [
        format!("{}x{}", "(".repeat(7000), ")".repeat(7000)),
        format!("{}x{}", "sin(".repeat(7000), ")".repeat(7000)),
        format!("{}x", "-".repeat(7000)),
        format!("x{}", "^x".repeat(7000)),
        format!("{}x", "2^-".repeat(7000)),
    ];
    for src in sources {
        let head: String = src.chars().take(12).collect();
        let result = on_small_stack(move || ExprLagrangian::new(&src, &x(), &[]).map(|_| ()));
        let e = result.expect_err(&head);
        assert!(e.message.contains("nested"), "{head}: {}", e.message);
    }
}

#[test]
fn nesting_up_to_the_limit_compiles_on_a_small_stack() {
    use femvi::expr::MAX_NESTING;
    let deep = MAX_NESTING - 1;
    // Each of these opens one level.
    for (open, close) in [("(", ")"), ("sin(", ")"), ("-", ""), ("2^", ""), ("pow(x,", ")")] {
        let src = format!("{}x{}", open.repeat(deep), close.repeat(deep));
        let ok = on_small_stack(move || ExprLagrangian::new(&src, &x(), &[]).map(|_| ()));
        assert!(ok.is_ok(), "{open}: {ok:?}");
        let src = format!("{}x{}", open.repeat(deep + 1), close.repeat(deep + 1));
        let err = on_small_stack(move || ExprLagrangian::new(&src, &x(), &[]).map(|_| ()));
        assert!(err.is_err(), "{open}");
    }
}

#[test]
fn long_sums_and_products_compile_and_evaluate() {
    for (op, want) in [("+", 14_000.0 * 0.5), ("*", 1.0)] {
        let unit = if op == "+" { "x" } else { "(x+0.5)" };
        let src = vec![unit; 14_000].join(op);
        let lag = on_small_stack(move || ExprLagrangian::new(&src, &x(), &[]).unwrap());
        let got: f64 = on_small_stack(move || lag.value(0.0, &[0.5], &[0.0]));
        assert!((got - want).abs() <= 1e-9 * want, "{op}: {got} != {want}");
    }
}

// ---- 2. Large systems: O(n) set-up ------------------------------------------------------

/// Time of `Integrator::new` for `lag` from q at rest (degree 2, the fixed-point solver).
fn setup<L: Lagrangian>(lag: &L, q: Vec<f64>) -> Duration {
    let element = Element::with_order(4).unwrap();
    let grid = TimeGrid::uniform(0.0, 0.01, 1.0).unwrap();
    let start = Start::Velocity {
        v: vec![0.0; q.len()],
        q,
    };
    let clock = std::time::Instant::now();
    Integrator::new(lag, &element, grid, start, SolverOptions::default()).unwrap();
    clock.elapsed()
}

/// A chain of n masses slightly displaced.
fn chain(n: usize) -> Vec<f64> {
    (0..n).map(|i| 1e-3 * ((i * 7919) % 1000) as f64).collect()
}

/// Bodies on a lattice in 3-D (no two at the same place).
fn lattice(bodies: usize) -> Vec<f64> {
    (0..bodies)
        .flat_map(|b| [(b % 10) as f64, ((b / 10) % 10) as f64, (b / 100) as f64])
        .collect()
}

#[test]
fn the_largest_documented_systems_set_up_in_linear_memory() {
    setup(
        &models::fpu(models::MAX_FPU_MASSES, 0.25, 0.0).unwrap(),
        chain(models::MAX_FPU_MASSES),
    );
    let bodies = models::MAX_BODIES;
    setup(&models::n_body(1.0, vec![1.0; bodies], 3).unwrap(), lattice(bodies));
}

/// Set-up times of large systems, one case per process, e.g.
/// `FEMVI_SETUP="fpu 100000" cargo test -p femvi --test all -- --ignored hostile::setup_time --nocapture`.
#[test]
#[ignore]
fn setup_time() {
    let case = std::env::var("FEMVI_SETUP").unwrap_or_else(|_| "fpu 1000".into());
    let (kind, size) = case.split_once(' ').unwrap();
    let size: usize = size.parse().unwrap();
    let elapsed = match kind {
        "fpu" => setup(&models::fpu(size, 0.25, 0.0).unwrap(), chain(size)),
        _ => setup(&models::n_body(1.0, vec![1.0; size], 3).unwrap(), lattice(size)),
    };
    println!("SETUP {kind} {size}: {:.2} ms", 1e3 * elapsed.as_secs_f64());
}

// ---- 3. Time grids ----------------------------------------------------------------------

#[test]
fn counting_a_long_cyclic_grid_does_not_walk_it() {
    let count = within(20, || TimeGrid::steps(0.0, vec![0.5, 0.25], 1e12).unwrap().count());
    // 1e12 / 0.75 = 1 333 333 333 333.33 cycles of two steps, then one shortened step.
    assert!(count.abs_diff(2_666_666_666_667) <= 1, "{count}");
    // Small grids keep their exact count.
    assert_eq!(TimeGrid::steps(0.0, vec![0.1, 0.2], 1.0).unwrap().count(), 7);
}

#[test]
fn steps_that_do_not_move_the_time_are_rejected() {
    // t + h == t at the start.
    assert!(TimeGrid::uniform(1e17, 1.0, 1e17 + 1e6).is_err());
    assert!(TimeGrid::steps(1e17, vec![1.0, 64.0], 1e17 + 1e6).is_err());
    assert!(TimeGrid::steps(-1e17, vec![4.0, 1.0], 0.0).is_err());
    // Only near the end: a list of steps would stand still there (a run would never end).
    let stalls = TimeGrid::steps(0.0, vec![1.0, 2.0], 1e17);
    assert!(stalls.is_err(), "{stalls:?}");
    // Steps that do move it are kept, and a uniform grid, whose nodes t0 + k h are computed
    // from k, only rounds near the end.
    assert!(TimeGrid::uniform(1e15, 1.0, 1e15 + 1e6).is_ok());
    assert!(TimeGrid::steps(1e15, vec![1.0, 2.0], 1e15 + 1e6).is_ok());
    assert!(TimeGrid::uniform(0.0, 1.0, 1e17).is_ok());
}

// ---- 4. Bad arguments -------------------------------------------------------------------

/// A Lagrangian with no coordinate at all.
struct Empty;
impl Lagrangian for Empty {
    fn dim(&self) -> usize {
        0
    }
    fn value<D: Scalar>(&self, t: D, _q: &[D], _v: &[D]) -> D {
        t
    }
}

#[test]
fn zero_dimensional_systems_are_rejected() {
    let element = Element::with_order(2).unwrap();
    for start in [
        Start::Velocity { q: vec![], v: vec![] },
        Start::Momentum { q: vec![], p: vec![] },
        Start::Positions { q0: vec![], q1: vec![] },
    ] {
        let e = Integrator::new(&Empty, &element, grid(), start.clone(), SolverOptions::default()).err();
        assert!(e.is_some(), "{start:?}");
        let fpu = femvi::Mechanical::unit_mass(models::FpuPotential {
            n: 0,
            alpha: 0.0,
            beta: 0.0,
        });
        assert!(Integrator::new(&fpu, &element, grid(), start, SolverOptions::default()).is_err());
    }
    let no_coordinates = ExprLagrangian::new("t", &[], &[]).unwrap();
    let start = Start::Velocity { q: vec![], v: vec![] };
    assert!(Integrator::new(&no_coordinates, &element, grid(), start, SolverOptions::default()).is_err());
}

#[test]
fn model_constructors_reject_bad_parameters() {
    assert!(models::n_body(1.0, vec![1.0, 2.0], 7).is_err());
    assert!(models::n_body(1.0, vec![1.0, 2.0], 0).is_err());
    assert!(models::n_body(f64::NAN, vec![1.0, 2.0], 2).is_err());
    assert!(models::harmonic(1.0, f64::NAN).is_err());
    assert!(models::harmonic(f64::INFINITY, 1.0).is_err());
    assert!(models::pendulum(1.0, f64::NAN, 1.0).is_err());
    assert!(models::pendulum(1.0, 1.0, f64::INFINITY).is_err());
    assert!(models::forced_oscillator(1.0, 1.0, f64::NAN, 1.0).is_err());
    assert!(models::forced_oscillator(1.0, 1.0, 1.0, f64::NEG_INFINITY).is_err());
    assert!(models::DoublePendulum::new(1.0, 1.0, 1.0, f64::NAN, 1.0).is_err());
    assert!(models::DoublePendulum::new(1.0, 0.0, 1.0, 1.0, 1.0).is_err());
    assert!(models::KeplerPotential::new(f64::NAN).is_err());
    assert!(models::FpuPotential::new(0, 0.25, 0.0).is_err());
    assert!(models::FpuPotential::new(8, f64::INFINITY, 0.0).is_err());
    // A potential built by hand with a dimension the force does not handle: NaN, no panic.
    let odd = models::GravityPotential {
        g: 1.0,
        masses: vec![1.0, 1.0],
        dim: 7,
    };
    let mut force = [0.0; 14];
    femvi::Potential::force(&odd, 0.0, &[0.5; 14], &mut force);
    assert!(force.iter().all(|f| f.is_nan()));
}

#[test]
fn model_coordinates_with_short_parameter_lists() {
    for model in ["fpu", "n-body", "nope"] {
        for p in [&[][..], &[f64::NAN, 2.0], &[1e300, 3.0], &[-1.0, 2.0], &[2.5, 2.0]] {
            assert_eq!(models::coordinates(model, p), Vec::<String>::new(), "{model} {p:?}");
            assert!(models::try_coordinates(model, p).is_err(), "{model} {p:?}");
        }
    }
    assert!(models::try_coordinates("n-body", &[2.0, 7.0]).is_err());
    assert!(models::try_coordinates("n-body", &[2.0]).is_err());
    assert_eq!(models::coordinates("harmonic", &[]), ["x"]);
    assert_eq!(models::try_coordinates("fpu", &[2.0]).unwrap(), ["q1", "q2"]);
}

#[test]
fn boundary_value_problems_with_huge_meshes_are_rejected_before_allocating() {
    use femvi::bvp::{line_guess, node_times, solve, BoundaryValues, BvpOptions};
    let lag = models::harmonic(1.0, 1.0).unwrap();
    let element = Element::with_order(4).unwrap();
    for elements in [usize::MAX, usize::MAX / 2, 1 << 40, 1_000_000_000] {
        let bv = BoundaryValues {
            t0: 0.0,
            q0: vec![1.0],
            t1: 1.0,
            q1: vec![0.0],
            elements,
        };
        assert!(node_times(&bv, &element).len() < 1000, "{elements}");
        assert!(line_guess(&bv, &element).len() < 1000, "{elements}");
        assert!(solve(&lag, &element, &bv, &[1.0, 0.5, 0.0], BvpOptions::default()).is_err());
    }
}

#[test]
fn check_rejects_symmetries_that_do_not_fit_the_system() {
    use femvi::diagnostics::{check, Symmetry};
    let kepler = models::kepler(1.0).unwrap();
    let element = Element::with_order(2).unwrap();
    for sym in [
        Symmetry::Rotation(0, 2),
        Symmetry::Rotation(5, 0),
        Symmetry::Rotations(vec![(0, 1), (1, 9)], "bad".into()),
        Symmetry::Translation(vec![1.0]),
        Symmetry::Translation(vec![1.0, 0.0, 0.0]),
        Symmetry::Translation(vec![f64::NAN, 0.0]),
    ] {
        let syms = std::slice::from_ref(&sym);
        let got = check(
            &kepler,
            &element,
            grid(),
            circle(),
            SolverOptions::default(),
            None,
            syms,
        );
        assert!(got.is_err(), "{sym:?}");
        assert!(sym.validate(2).is_err());
        assert!(sym.momentum(&[1.0, 0.0], &[0.0, 1.0]).is_nan());
        let _ = sym.label(&["x".into()]);
    }
}

#[test]
fn element_functions_with_buffers_of_the_wrong_length_do_not_panic() {
    use femvi::ElementWork;
    let lag = models::kepler(1.0).unwrap();
    let el = Element::with_order(4).unwrap();
    let (base, incr) = ([1.0, 0.0], [0.0, 0.0, 0.0, 0.1, 0.0, 0.2]);
    let mut work = ElementWork::new(&el, 2);
    // A gradient buffer, increments and scratch of the wrong sizes.
    let mut short = [0.0; 3];
    let ld = el.gradient_in_place(&lag, 0.0, 0.2, &base, &incr, false, &mut work, &mut short);
    assert!(ld.is_nan());
    let ld = el.gradient_in_place(&lag, 0.0, 0.2, &base, &incr[..4], false, &mut work, &mut [0.0; 6]);
    assert!(ld.is_nan());
    let mut small = ElementWork::new(&Element::with_order(2).unwrap(), 2);
    let ld = el.gradient_in_place(&lag, 0.0, 0.2, &base, &incr, false, &mut small, &mut [0.0; 6]);
    assert!(ld.is_nan());
    let (em, ep) = el.energies(0.2, &small);
    assert!(em.is_nan() && ep.is_nan());
    let e = el.check_buffers(&base, &incr, &small, &[0.0; 6], None).unwrap_err();
    assert!(e.to_string().contains("element work"), "{e}");
    assert!(el.check_buffers(&base, &incr, &work, &short, None).is_err());
    let hessian_fits = |h: &[f64]| el.check_buffers(&base, &incr, &work, &[0.0; 6], Some(h)).is_ok();
    assert!(!hessian_fits(&[0.0; 35]) && hessian_fits(&[0.0; 36]));
    let (ld, grad, hess) = el.full_hessian(&lag, 0.0, 0.2, &base, &incr[..5]);
    assert!(ld.is_nan() && grad.len() == 8 && hess.len() == 64);
    assert!(el.action_generic(&lag, 0.0, 0.2, &incr[..5]).is_nan());
    let mut hess = [0.0; 35];
    let ld = el.hessian_in_place(&lag, 0.0, 0.2, &base, &incr, &mut work, &mut [0.0; 6], &mut hess);
    assert!(ld.is_nan());
    el.points_in_place(0.0, 0.2, &base, &incr[..5], &mut work);
    el.points_in_place(0.0, 0.2, &base, &incr, &mut small);
    let mut vals = [0.0; 7];
    el.basis.values_in_place(0.3, &mut vals);
    el.basis.derivatives_in_place(0.3, &mut vals);
    assert!(el.phi(9, 0).is_nan() && el.dphi(0, 9).is_nan());
}

#[test]
fn band_matrices_check_their_arguments() {
    use femvi::solve::BandMatrix;
    assert!(BandMatrix::zeros(usize::MAX / 2, 1, 1).is_err());
    assert!(BandMatrix::zeros(1 << 40, 1 << 20, 0).is_err());
    let mut band = BandMatrix::zeros(4, 1, 1).unwrap();
    assert!(band.add(3, 0, 1.0).is_err() && band.add(0, 2, 1.0).is_err() && band.add(4, 4, 1.0).is_err());
    assert_eq!(band.get(9, 9), 0.0);
    let mut b = [1.0; 4];
    assert!(band.solve(&mut b).is_err(), "solve before factor");
    for i in 0..4 {
        band.add(i, i, 2.0).unwrap();
    }
    assert!(band.factor());
    assert!(band.solve(&mut [1.0; 3]).is_err());
    band.solve(&mut b).unwrap();
    assert_eq!(b, [0.5; 4]);
}

#[test]
fn huge_elements_rules_and_newton_sizes_are_errors() {
    use femvi::fem::{LagrangeBasis, NodeFamily, QuadratureKind, QuadratureRule};
    use femvi::solve::{newton_dense, DenseNewtonWork};
    let gauss = QuadratureKind::GaussLegendre;
    assert!(within(20, move || QuadratureRule::new(gauss(1_000_000)).is_err()));
    assert!(within(20, || LagrangeBasis::new(1_000_000_000, NodeFamily::Lobatto).is_err()));
    assert!(within(20, || Element::with_order(2_000_000).is_err()));
    assert!(DenseNewtonWork::try_new(usize::MAX / 4).is_err());
    // A work space made for another size is made again, not indexed past its end.
    let mut work = DenseNewtonWork::new(1);
    let mut x = [3.0, 4.0];
    let residual = |x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>| {
        r.iter_mut().zip(x).zip([1.0, 2.0]).for_each(|((r, x), c)| *r = x - c);
        if let Some(j) = jac {
            j.copy_from_slice(&[1.0, 0.0, 0.0, 1.0]);
        }
    };
    let solved = newton_dense(&mut x, 1e-14, 20, |_| 1.0, &mut work, residual);
    assert!(solved.is_ok() && x == [1.0, 2.0], "{solved:?} {x:?}");
    let rule = QuadratureRule {
        kind: gauss(0),
        nodes: vec![],
        weights: vec![],
    };
    assert_eq!(rule.exact_degree(), 0);
}

#[test]
fn elements_changed_after_construction_are_rejected() {
    let lag = models::kepler(1.0).unwrap();
    let corruptions: [fn(&mut Element); 4] = [
        |e| e.rule.weights.truncate(1),
        |e| e.basis.nodes.push(2.0),
        |e| e.basis.degree = 5,
        |e| e.rule.nodes.push(0.5),
    ];
    for corrupt in corruptions {
        let mut element = Element::with_order(4).unwrap();
        corrupt(&mut element);
        assert!(Integrator::new(&lag, &element, grid(), circle(), SolverOptions::default()).is_err());
    }
}

#[test]
fn trajectories_and_defects_with_wrong_sizes() {
    use femvi::diagnostics::{symplecticity_defect, PiecewiseTrajectory};
    let lag = models::kepler(1.0).unwrap();
    let element = Element::with_order(4).unwrap();
    let other = femvi::fem::LagrangeBasis::new(5, femvi::NodeFamily::Equispaced).unwrap();
    let record = |basis, n| {
        let mut it = Integrator::new(&lag, &element, grid(), circle(), SolverOptions::default()).unwrap();
        PiecewiseTrajectory::record(&mut it, basis, n)
    };
    assert!(record(&element.basis, 3).is_err() && record(&other, 2).is_err());
    let traj = record(&element.basis, 2).unwrap();
    let mut out = [0.0; 5];
    traj.eval(0.5, &mut out);
    assert!(out.iter().all(|x| x.is_nan()));
    assert!(traj.l2_distance(usize::MAX, |_, q| q.fill(0.0)).is_finite());
    assert!(symplecticity_defect(&[1.0, 0.0, 0.0], 1).is_nan());
    assert!(symplecticity_defect(&[], usize::MAX).is_nan());
}
