//! Bit-for-bit guard for refactors: the final states of runs covering every solver (explicit
//! through `step` and through `advance`, fixed point polished and not, Newton), energy mode,
//! boundary value problems (fixed and moving mesh), variable steps, the three kinds of start,
//! non-unit masses and tangent maps. The expected bit patterns in `golden/final_states.txt`
//! were produced by the code before the step pipeline was reshaped (commit 1575325's
//! integrator); a refactor must reproduce them exactly. To regenerate after a deliberate
//! change of results: `FEMVI_GOLDEN_WRITE=1 cargo test -p femvi --test all -- golden::`, and say so in
//! the commit message.

use femvi::adaptive::{KeplerMonitor, TimeTransformed};
use femvi::bvp::{line_guess, solve, BoundaryValues, BvpOptions};
use femvi::expr::ExprLagrangian;
use femvi::{
    models, Element, EnergyOptions, Integrator, Lagrangian, Method, NodeFamily, QuadratureKind, SolverOptions, Start,
    TimeGrid,
};

fn gauss(s: usize) -> Element {
    Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap()
}

fn trapezoid() -> Element {
    Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap()
}

fn opts(method: Method) -> SolverOptions {
    SolverOptions {
        method,
        ..SolverOptions::default()
    }
}

/// Bits of the final node, the mean iteration count and (energy mode) the statistics.
fn finish<L: Lagrangian>(it: &Integrator<L>) -> Vec<u64> {
    let node = it.node();
    let mut out = vec![node.k as u64, node.t.to_bits()];
    out.extend(node.q.iter().chain(node.p).map(|x| x.to_bits()));
    out.push(it.mean_iterations().to_bits());
    if let Some(st) = it.energy_stats() {
        out.extend([st.energy, st.min_step, st.max_step, st.max_rel_residual].map(f64::to_bits));
        out.push(st.degenerate_steps as u64);
    }
    out
}

fn run_steps<L: Lagrangian>(mut it: Integrator<L>) -> Vec<u64> {
    while it.step().unwrap() {}
    finish(&it)
}

fn run_advance<L: Lagrangian>(mut it: Integrator<L>, chunk: usize) -> Vec<u64> {
    while it.advance(chunk).unwrap() > 0 {}
    finish(&it)
}

fn kepler_start() -> Start {
    Start::Velocity {
        q: vec![0.4, 0.0],
        v: vec![0.0, 2.0],
    }
}

/// Runs steps and then the tangent map of the last one: its bits after the state's.
fn with_tangent<L: Lagrangian>(mut it: Integrator<L>, energy: bool) -> Vec<u64> {
    while it.step().unwrap() {}
    let mut out = finish(&it);
    let map = if energy {
        it.extended_tangent_map().unwrap()
    } else {
        it.tangent_map().unwrap()
    };
    out.extend(map.iter().map(|x| x.to_bits()));
    out
}

fn new<'a, L: Lagrangian>(
    lag: &'a L,
    el: &'a Element,
    grid: TimeGrid,
    start: Start,
    o: SolverOptions,
) -> Integrator<'a, L> {
    Integrator::new(lag, el, grid, start, o).unwrap()
}

fn energy<'a, L: Lagrangian>(lag: &'a L, el: &'a Element, start: Start, h: f64, end: f64) -> Integrator<'a, L> {
    let grid = TimeGrid::uniform(0.0, h, end).unwrap();
    Integrator::with_energy(
        lag,
        el,
        grid,
        start,
        SolverOptions::default(),
        EnergyOptions::from_step(h),
    )
    .unwrap()
}

fn runs() -> Vec<(&'static str, Vec<u64>)> {
    let mut out = vec![];
    explicit_runs(&mut out);
    fixed_point_runs(&mut out);
    more_runs(&mut out);
    out
}

/// Explicit steps through step() and advance(), cyclic steps, a generic size.
fn explicit_runs(out: &mut Vec<(&'static str, Vec<u64>)>) {
    let kep = models::kepler(1.0).unwrap();
    let heavy = models::harmonic(2.5, 3.0).unwrap();
    let fpu = models::fpu(8, 0.25, 0.0).unwrap();
    let t3 = trapezoid();
    let uni = |h: f64, end: f64| TimeGrid::uniform(0.0, h, end).unwrap();
    let cyc = |steps: Vec<f64>, end: f64| TimeGrid::steps(0.0, steps, end).unwrap();
    out.push((
        "kepler explicit step()",
        run_steps(new(&kep, &t3, uni(0.01, 20.0), kepler_start(), opts(Method::Auto))),
    ));
    out.push((
        "kepler explicit advance(37)",
        run_advance(new(&kep, &t3, uni(0.01, 20.0), kepler_start(), opts(Method::Auto)), 37),
    ));
    out.push((
        "heavy harmonic explicit cyclic steps",
        run_advance(
            Integrator::new(
                &heavy,
                &t3,
                cyc(vec![0.05, 0.07, 0.03], 30.0),
                Start::Momentum {
                    q: vec![1.0],
                    p: vec![0.3],
                },
                opts(Method::Explicit),
            )
            .unwrap(),
            1000,
        ),
    ));
    let fpu_start = Start::Velocity {
        q: (0..8).map(|i| 0.1 * (i as f64 + 1.0).sin()).collect(),
        v: vec![0.0; 8],
    };
    out.push((
        "fpu8 explicit generic size",
        run_advance(
            new(&fpu, &t3, uni(0.05, 10.0), fpu_start.clone(), opts(Method::Auto)),
            100,
        ),
    ));
}

/// The fixed-point solver.
fn fixed_point_runs(out: &mut Vec<(&'static str, Vec<u64>)>) {
    let kep = models::kepler(1.0).unwrap();
    let pend = models::pendulum(1.0, 9.81, 1.0).unwrap();
    let hh = models::henon_heiles();
    let fpu = models::fpu(8, 0.25, 0.0).unwrap();
    let (t4, t2, t1) = (gauss(3), gauss(2), gauss(4));
    let uni = |h: f64, end: f64| TimeGrid::uniform(0.0, h, end).unwrap();
    let cyc = |steps: Vec<f64>, end: f64| TimeGrid::steps(0.0, steps, end).unwrap();
    let pend_start = || Start::Velocity {
        q: vec![1.2],
        v: vec![0.0],
    };
    let fpu_start = Start::Velocity {
        q: (0..8).map(|i| 0.1 * (i as f64 + 1.0).sin()).collect(),
        v: vec![0.0; 8],
    };
    out.push((
        "pendulum fixed point degree 3",
        run_steps(new(&pend, &t4, uni(0.1, 20.0), pend_start(), opts(Method::Auto))),
    ));
    let deg6 = gauss(6);
    out.push((
        "pendulum fixed point degree 6 unpolished",
        run_steps(new(
            &pend,
            &deg6,
            uni(0.4, 40.0),
            pend_start(),
            SolverOptions {
                tolerance: 1e-10,
                polish: false,
                ..SolverOptions::default()
            },
        )),
    ));
    out.push((
        "kepler fixed point degree 4 cyclic steps",
        run_advance(
            new(
                &kep,
                &t1,
                cyc(vec![0.05, 0.08, 0.06], 30.0),
                kepler_start(),
                opts(Method::FixedPoint),
            ),
            50,
        ),
    ));
    out.push((
        "henon-heiles fixed point degree 2 momentum start",
        run_steps(new(
            &hh,
            &t2,
            uni(0.05, 50.0),
            Start::Momentum {
                q: vec![0.1, -0.2],
                p: vec![0.3, 0.1],
            },
            opts(Method::Auto),
        )),
    ));
    out.push((
        "fpu8 fixed point degree 2 generic size",
        run_steps(new(&fpu, &t2, uni(0.1, 10.0), fpu_start, opts(Method::Auto))),
    ));
}

fn more_runs(out: &mut Vec<(&'static str, Vec<u64>)>) {
    let kep = models::kepler(1.0).unwrap();
    let pend = models::pendulum(1.0, 9.81, 1.0).unwrap();
    let heavy = models::harmonic(2.5, 3.0).unwrap();
    let coords = vec!["x".to_string(), "y".to_string()];
    // A charge in a magnetic field B = b (velocity-dependent) in a Kepler well, by Newton
    // (`Method::Auto` takes the gyroscopic fixed point since issue 15; this run keeps Newton).
    let magnetic = ExprLagrangian::new(
        "0.5*(x_dot^2 + y_dot^2) + 0.5*b*(x*y_dot - y*x_dot) + 1/sqrt(x^2 + y^2)",
        &coords,
        &[("b".into(), 0.7)],
    )
    .unwrap();
    let (t4, t2) = (gauss(3), gauss(2));
    let uni = |h: f64, end: f64| TimeGrid::uniform(0.0, h, end).unwrap();
    let cyc = |steps: Vec<f64>, end: f64| TimeGrid::steps(0.0, steps, end).unwrap();
    let heavy_lob = Element::galerkin(3, NodeFamily::Lobatto, QuadratureKind::GaussLobatto(4)).unwrap();
    out.push((
        "heavy harmonic fixed point lobatto 3",
        run_steps(new(
            &heavy,
            &heavy_lob,
            uni(0.2, 20.0),
            Start::Velocity {
                q: vec![1.0],
                v: vec![0.0],
            },
            opts(Method::Auto),
        )),
    ));
    out.push((
        "kepler newton degree 2",
        run_steps(new(&kep, &t2, uni(0.05, 10.0), kepler_start(), opts(Method::Newton))),
    ));
    out.push((
        "magnetic expression newton degree 3 cyclic",
        run_steps(new(
            &magnetic,
            &t4,
            cyc(vec![0.05, 0.04], 8.0),
            kepler_start(),
            opts(Method::Newton),
        )),
    ));
    out.push((
        "pendulum (q0, q1) fixed point degree 2",
        run_steps(new(
            &pend,
            &t2,
            uni(0.05, 10.0),
            Start::Positions {
                q0: vec![1.0],
                q1: vec![0.99],
            },
            opts(Method::Auto),
        )),
    ));
    out.push((
        "kepler (q0, q1) newton midpoint",
        run_steps(new(
            &kep,
            &Element::midpoint(),
            uni(0.01, 5.0),
            Start::Positions {
                q0: vec![0.4, 0.0],
                q1: vec![0.3999, 0.02],
            },
            opts(Method::Newton),
        )),
    ));
    energy_runs(out);
    bvp_runs(out);
}

/// Energy mode, and the tangent maps of three kinds of steps.
fn energy_runs(out: &mut Vec<(&'static str, Vec<u64>)>) {
    let kep = models::kepler(1.0).unwrap();
    let pend = models::pendulum(1.0, 9.81, 1.0).unwrap();
    let (t4, t2) = (gauss(3), gauss(2));
    let uni = |h: f64, end: f64| TimeGrid::uniform(0.0, h, end).unwrap();
    let pend_start = || Start::Velocity {
        q: vec![1.2],
        v: vec![0.0],
    };
    let mid = Element::midpoint();
    out.push((
        "pendulum energy mode midpoint",
        run_steps(energy(&pend, &mid, pend_start(), 0.05, 10.0)),
    ));
    out.push((
        "kepler energy mode degree 1 gauss (q0, q1)",
        run_steps(energy(
            &kep,
            &gauss(1),
            Start::Positions {
                q0: vec![0.4, 0.0],
                q1: vec![0.3999, 0.02],
            },
            0.01,
            5.0,
        )),
    ));
    out.push((
        "pendulum fixed point degree 3 tangent map",
        with_tangent(new(&pend, &t4, uni(0.1, 3.0), pend_start(), opts(Method::Auto)), false),
    ));
    out.push((
        "kepler newton degree 2 tangent map",
        with_tangent(
            new(&kep, &t2, uni(0.05, 3.0), kepler_start(), opts(Method::Newton)),
            false,
        ),
    ));
    out.push((
        "pendulum energy mode extended tangent map",
        with_tangent(energy(&pend, &mid, pend_start(), 0.05, 3.0), true),
    ));
}

/// Boundary value problems, fixed and moving mesh.
fn bvp_runs(out: &mut Vec<(&'static str, Vec<u64>)>) {
    let pend = models::pendulum(1.0, 9.81, 1.0).unwrap();
    for (label, moving, el) in [
        ("pendulum bvp degree 2", false, gauss(2)),
        ("pendulum bvp moving mesh midpoint", true, Element::midpoint()),
    ] {
        let bv = BoundaryValues {
            t0: 0.0,
            q0: vec![0.3],
            t1: 2.0,
            q1: vec![-0.2],
            elements: 40,
        };
        let options = BvpOptions {
            moving_mesh: moving,
            ..BvpOptions::default()
        };
        let sol = solve(&pend, &el, &bv, &line_guess(&bv, &el), options).unwrap();
        let mut bits: Vec<u64> = sol
            .times
            .iter()
            .chain(&sol.q)
            .chain(&sol.p)
            .map(|x| x.to_bits())
            .collect();
        bits.push(sol.action.to_bits());
        bits.push(sol.newton_iterations as u64);
        out.push((label, bits));
    }
}

/// The runs' bits as text: each run's name, then its bits in hex, four to a line.
pub(crate) fn render(runs: &[(&str, Vec<u64>)]) -> String {
    let mut s = String::new();
    for (name, bits) in runs {
        s.push_str(name);
        s.push('\n');
        for chunk in bits.chunks(4) {
            let line: Vec<String> = chunk.iter().map(|b| format!("{b:016x}")).collect();
            s.push_str("  ");
            s.push_str(&line.join(" "));
            s.push('\n');
        }
    }
    s
}

/// Compares `runs` (at least `min_runs` of them) with the bits stored in `path`, line by line
/// naming the run that differs; with `FEMVI_GOLDEN_WRITE` set, writes them there instead.
pub(crate) fn compare_or_write(path: &str, runs: &[(&str, Vec<u64>)], min_runs: usize) {
    let got = render(runs);
    if std::env::var_os("FEMVI_GOLDEN_WRITE").is_some() {
        std::fs::write(path, &got).unwrap();
        return;
    }
    let want = std::fs::read_to_string(path).unwrap();
    assert!(runs.len() >= min_runs, "{} runs", runs.len());
    let mut run = "";
    for (g, w) in got.lines().zip(want.lines()) {
        if !w.starts_with(' ') {
            run = w;
        }
        assert_eq!(g, w, "run '{run}' differs from the stored bits");
    }
    assert_eq!(got.lines().count(), want.lines().count(), "number of lines");
}

#[test]
fn final_states_are_bit_identical_to_the_stored_ones() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden/final_states.txt");
    compare_or_write(path, &runs(), 12);
}

/// Runs `make()` whole, and again stopped after each of `stops` steps, checkpointed (through
/// JSON) and restored into a fresh integrator; the final states must be identical. Returns
/// the number of resumed runs.
fn resume<'a, L: Lagrangian + 'a>(make: impl Fn() -> Integrator<'a, L>, stops: &[usize]) -> usize {
    let mut whole = make();
    while whole.step().unwrap() {}
    let want = finish(&whole);
    for &stop in stops {
        let mut first = make();
        assert_eq!(first.advance(stop).unwrap(), stop);
        let json = serde_json::to_string(&first.checkpoint("golden")).unwrap();
        let mut resumed = make();
        resumed
            .restore(&serde_json::from_str(&json).unwrap(), "golden")
            .unwrap();
        while resumed.step().unwrap() {}
        assert_eq!(finish(&resumed), want, "stopped at {stop}");
    }
    stops.len()
}

/// A run stopped at a node and restored from its checkpoint (serialised to JSON and read
/// back) continues bit for bit as the uninterrupted run, for every solver and energy mode, at
/// many stopping points.
#[test]
fn checkpoints_resume_bit_for_bit() {
    let kep = models::kepler(1.0).unwrap();
    let pend = models::pendulum(1.0, 9.81, 1.0).unwrap();
    let (trap, deg2, deg6, mid) = (trapezoid(), gauss(2), gauss(6), Element::midpoint());
    let mut checked = 0;
    let uni = |h: f64, end: f64| TimeGrid::uniform(0.0, h, end).unwrap();
    let pend_start = || Start::Velocity {
        q: vec![1.2],
        v: vec![0.0],
    };
    checked += resume(
        || new(&kep, &trap, uni(0.01, 5.0), kepler_start(), opts(Method::Auto)),
        &[1, 2, 3, 77, 250, 499],
    );
    checked += resume(
        || new(&pend, &deg6, uni(0.4, 40.0), pend_start(), opts(Method::Auto)),
        &[1, 2, 5, 50, 99],
    );
    let q1 = || Start::Positions {
        q0: vec![1.0],
        q1: vec![0.99],
    };
    checked += resume(
        || new(&pend, &deg2, uni(0.05, 5.0), q1(), opts(Method::Auto)),
        &[1, 2, 3, 40],
    );
    checked += resume(
        || new(&pend, &deg2, uni(0.05, 3.0), pend_start(), opts(Method::Newton)),
        &[1, 2, 17, 59],
    );
    checked += resume(|| energy(&pend, &mid, pend_start(), 0.05, 5.0), &[1, 2, 3, 33, 90]);
    // Adaptive steps by the fixed point with a varying divisor: its divisor-free history of
    // terms (`step/gyroscopic/divided.rs`) is in the checkpoint.
    let lg = TimeTransformed::new(models::kepler(1.0).unwrap(), KeplerMonitor, -0.5).unwrap();
    let ecc = || Start::Momentum {
        q: vec![0.1, 0.0],
        p: vec![0.0, 19f64.sqrt()],
    };
    checked += resume(
        || new(&lg, &deg6, uni(0.1, 30.0), ecc(), opts(Method::FixedPoint)),
        &[1, 2, 3, 100, 250],
    );
    assert!(checked >= 25, "{checked} resumed runs");
}

#[test]
fn checkpoints_of_other_runs_are_refused() {
    let pend = models::pendulum(1.0, 9.81, 1.0).unwrap();
    let (deg2, deg3) = (gauss(2), gauss(3));
    let start = || Start::Velocity {
        q: vec![1.2],
        v: vec![0.0],
    };
    let grid = || TimeGrid::uniform(0.0, 0.1, 5.0).unwrap();
    let mut a = new(&pend, &deg2, grid(), start(), opts(Method::Auto));
    a.advance(5).unwrap();
    let saved = a.checkpoint("p");
    let mut other_element = new(&pend, &deg3, grid(), start(), opts(Method::Auto));
    assert!(other_element.restore(&saved, "p").is_err());
    let mut other_grid = new(
        &pend,
        &deg2,
        TimeGrid::uniform(0.0, 0.2, 5.0).unwrap(),
        start(),
        opts(Method::Auto),
    );
    assert!(other_grid.restore(&saved, "p").is_err());
    let mut same = new(&pend, &deg2, grid(), start(), opts(Method::Auto));
    assert!(same.restore(&saved, "q").is_err(), "another tag");
    let mut damaged = saved.clone();
    damaged.words.pop();
    assert!(same.restore(&damaged, "p").is_err(), "truncated");
    assert_eq!(same.node().k, 0, "unchanged after a refusal");
    let mut old = saved.clone();
    old.version = "0.0.1".into();
    assert!(same.restore(&old, "p").is_err(), "another version");
    same.restore(&saved, "p").unwrap();
    assert_eq!(same.node().k, 5);
}
