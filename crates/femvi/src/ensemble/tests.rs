//! Members in lanes against their single runs, bit for bit: every compiled width, Kepler
//! and Hénon–Heiles (hand-written lane code) and a potential with the per-lane default,
//! uniform and variable grids, members that fail mid-run or at their first step, starts that
//! fail, and chunks that are not full.

use super::*;
use crate::solution::EnergyTracker;
use crate::step::fixed_point::FixedPointTables;
use crate::{models, Element, NodeFamily, Potential, QuadratureKind, Scalar, SolverOptions};

fn verlet() -> Element {
    Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).expect("Störmer–Verlet")
}

/// The single run of `start`: stepped to the end (or its failure) with the energy tracker
/// shown every node, as `femvi ensemble` drives a member: a step that fails ends it at the
/// node before; a node whose energy is not finite ends it at the node before that node
/// (`Error::NonFiniteEnergy`, the step to it counted), or with no node at the start.
fn single<L: Lagrangian>(lag: &L, run: &Run<'_>, start: &Start) -> Result<MemberEnd> {
    let (el, grid) = (run.element, run.grid);
    let mut it = Integrator::new(lag, el, grid.clone(), start.clone(), run.opts)?;
    let n = lag.dim();
    let mut tracker = EnergyTracker::new(n, start, lag.is_autonomous());
    let report = |tracker: &EnergyTracker| tracker.report().max_rel_error;
    let node = it.node();
    if !tracker.node(lag, node.t, node.q, node.p)?.h.is_finite() {
        let (k, t) = (0, node.t);
        let error = Some(Error::NonFiniteEnergy { step: k, t });
        let nan = vec![f64::NAN; n];
        return Ok(MemberEnd {
            k,
            t,
            q: nan.clone(),
            p: nan,
            steps: 0,
            energy_error: report(&tracker),
            error,
        });
    }
    let mut good = (node.k, node.t, node.q.to_vec(), node.p.to_vec());
    let error = loop {
        match it.step() {
            Ok(true) => {
                let node = it.node();
                if !tracker.node(lag, node.t, node.q, node.p)?.h.is_finite() {
                    let error = Error::NonFiniteEnergy {
                        step: node.k,
                        t: node.t,
                    };
                    let (k, t, q, p) = good;
                    return Ok(MemberEnd {
                        k,
                        t,
                        q,
                        p,
                        steps: node.k,
                        energy_error: report(&tracker),
                        error: Some(error),
                    });
                }
                good = (node.k, node.t, node.q.to_vec(), node.p.to_vec());
            }
            Ok(false) => break None,
            Err(e) => break Some(e),
        }
    };
    let node = it.node();
    Ok(MemberEnd {
        k: node.k,
        t: node.t,
        q: node.q.to_vec(),
        p: node.p.to_vec(),
        steps: node.k,
        energy_error: report(&tracker),
        error,
    })
}

/// Bit patterns, so that NaN = NaN and 0 ≠ −0.
fn bits(x: &[f64]) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}

/// The run the members share besides their Lagrangian: grid, element and options.
struct Run<'a> {
    grid: &'a TimeGrid,
    element: &'a Element,
    opts: SolverOptions,
}

/// Every member of `starts` in lanes of every width equals its single run bit for bit
/// (Störmer–Verlet); returns how many fail.
fn agree<L: Lagrangian + Sync, const N: usize>(lag: &L, grid: &TimeGrid, starts: &[Start]) -> usize {
    let el = verlet();
    let run = Run {
        grid,
        element: &el,
        opts: SolverOptions::default(),
    };
    agree_on::<L, N>(lag, &run, starts)
}

/// As [`agree`] for any run that goes in lanes.
fn agree_on<L: Lagrangian + Sync, const N: usize>(lag: &L, run: &Run<'_>, starts: &[Start]) -> usize {
    let grid = run.grid;
    let template = Integrator::new(lag, run.element, grid.clone(), starts[0].clone(), run.opts).expect("template");
    assert!(in_lanes(&template), "the run goes in lanes");
    let plan = template.plain_fixed_point().then(|| Plan {
        element: run.element,
        opts: run.opts,
        tab: FixedPointTables::new(run.element).expect("tables"),
    });
    let mut failures = 0;
    for width in [Width::Portable, Width::Avx2, Width::Avx512, Width::Best] {
        let ends: Vec<_> = starts
            .chunks(LANES)
            .flat_map(|c| chunk_of::<L, N>(lag, grid, plan.as_ref(), c, width))
            .collect();
        assert_eq!(ends.len(), starts.len());
        failures = 0;
        for (i, (end, start)) in ends.iter().zip(starts).enumerate() {
            match (end, single(lag, run, start)) {
                (Ok(a), Ok(b)) => {
                    let at = format!("member {i}, {width:?}");
                    assert_eq!((a.k, a.steps, a.t.to_bits()), (b.k, b.steps, b.t.to_bits()), "{at}");
                    assert_eq!(bits(&a.q), bits(&b.q), "{at}: q");
                    assert_eq!(bits(&a.p), bits(&b.p), "{at}: p");
                    assert_eq!(a.energy_error.to_bits(), b.energy_error.to_bits(), "{at}: energy");
                    let msg = |e: &Option<Error>| e.as_ref().map(ToString::to_string);
                    assert_eq!(msg(&a.error), msg(&b.error), "{at}: error");
                    failures += usize::from(a.error.is_some());
                }
                (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "member {i}: start error"),
                (a, b) => panic!("member {i}, {width:?}: lanes {a:?}, single {b:?}"),
            }
        }
    }
    failures
}

fn momentum(q: [f64; 2], p: [f64; 2]) -> Start {
    Start::Momentum {
        q: q.to_vec(),
        p: p.to_vec(),
    }
}

/// 21 Kepler starts at (1, 0) with speeds 0.5 … 1.3, one where r² underflows (the force is not
/// finite at the start: the first step fails, k = 0) and one that is not finite (its start
/// fails).
fn kepler_starts() -> Vec<Start> {
    let mut starts: Vec<Start> = (0..21)
        .map(|i| momentum([1.0, 0.0], [0.0, 0.5 + 0.04 * i as f64]))
        .collect();
    starts.insert(3, momentum([1e-170, 0.0], [-0.0, 1.0]));
    starts.insert(9, momentum([f64::NAN, 0.0], [0.0, 1.0]));
    starts
}

#[test]
fn kepler_members_equal_their_single_runs_on_every_width() {
    let lag = models::kepler(1.0).expect("kepler");
    let grid = TimeGrid::uniform(0.0, 0.01, 20.0).expect("grid");
    let mut starts = kepler_starts();
    // A start of the wrong length.
    starts.insert(
        12,
        Start::Momentum {
            q: vec![1.0],
            p: vec![0.0, 1.0],
        },
    );
    let failed = agree::<_, 2>(&lag, &grid, &starts);
    assert_eq!(failed, 1, "the member that starts at r ≈ 0 fails at its first step");
}

/// 19 Hénon–Heiles starts at (0, 0.1) with energies 0.02 … 0.38, below and above the
/// escape energy 1/6.
fn escapers() -> Vec<Start> {
    (0..19)
        .map(|i| {
            let e = 0.02 + 0.02 * i as f64;
            momentum([0.0, 0.1], [(2.0 * e).sqrt(), 0.0])
        })
        .collect()
}

#[test]
fn henon_heiles_members_that_escape_fail_alone() {
    let lag = models::henon_heiles();
    let grid = TimeGrid::uniform(0.0, 0.05, 200.0).expect("grid");
    // Energies below and above the escape energy 1/6: above it some members leave the well
    // and overflow, mid-run.
    let starts = escapers();
    // They fail mid-run: their energy overflows (x²y, y³) before their node does.
    let failed = agree::<_, 2>(&lag, &grid, &starts);
    assert!(failed >= 2, "{failed} members fail");
    assert!(failed < starts.len() - 4, "{failed} members fail");
}

/// A potential without lane code: the per-lane defaults, on a variable grid, in 3-D.
#[derive(Debug, Clone, Copy)]
struct Anharmonic;

impl Potential for Anharmonic {
    fn dim(&self) -> usize {
        3
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let r2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
        r2 * 0.5 + r2 * r2 * 0.25 + (q[0] * 3.0).sin() * 0.1
    }
}

#[test]
fn the_per_lane_defaults_equal_single_runs_on_a_variable_grid() {
    let lag = crate::Mechanical::unit_mass(Anharmonic);
    let grid = TimeGrid::steps(0.0, vec![0.02, 0.035, 0.01], 15.0).expect("grid");
    let starts: Vec<Start> = (0..11)
        .map(|i| Start::Velocity {
            q: vec![0.3, -0.1 * i as f64, 0.2],
            v: vec![0.1 * i as f64, 0.0, -0.5],
        })
        .collect();
    assert_eq!(agree::<_, 3>(&lag, &grid, &starts), 0);
}

#[test]
fn run_in_lanes_refuses_what_it_does_not_take() {
    let kepler = models::kepler(1.0).expect("kepler");
    let grid = TimeGrid::uniform(0.0, 0.1, 1.0).expect("grid");
    let start = momentum([1.0, 0.0], [0.0, 1.0]);
    // Degree 4: four Gauss points, more than the fixed-point lanes hold.
    let quadratic = Element::with_order(8).expect("element");
    let it = Integrator::new(
        &kepler,
        &quadratic,
        grid.clone(),
        start.clone(),
        SolverOptions::default(),
    )
    .expect("run");
    assert!(!in_lanes(&it));
    assert!(run_in_lanes(&it, std::slice::from_ref(&start), &|_| {}).is_none());
    // A time-dependent potential.
    let driven = crate::Mechanical::unit_mass(Driven);
    let s = Start::Momentum {
        q: vec![0.1],
        p: vec![0.0],
    };
    let el = verlet();
    let it = Integrator::new(&driven, &el, grid, s, SolverOptions::default()).expect("run");
    assert!(it.node().k == 0 && !in_lanes(&it));
}

/// V = ½q² − q sin t: not autonomous.
#[derive(Debug, Clone, Copy)]
struct Driven;

impl Potential for Driven {
    fn dim(&self) -> usize {
        1
    }
    fn value<D: Scalar>(&self, t: D, q: &[D]) -> D {
        q[0] * q[0] * 0.5 - q[0] * t.sin()
    }
}

/// A 2-D expression Lagrangian (mechanical, M = I, no `potential_value`) with a
/// parameterless potential.
fn quartic() -> crate::expr::ExprLagrangian {
    let coords = vec!["x".to_string(), "y".to_string()];
    crate::expr::ExprLagrangian::new(
        "0.5*(x_dot^2 + y_dot^2) - 0.25*(x^2 + y^2)^2 - 0.3*sin(x)*y",
        &coords,
        &[],
    )
    .expect("expression")
}

/// An expression Lagrangian: its compiled force and L itself lane by lane, equal to single
/// runs.
#[test]
fn expression_members_equal_their_single_runs() {
    let lag = quartic();
    let grid = TimeGrid::uniform(0.0, 0.01, 5.0).expect("grid");
    let starts: Vec<Start> = (0..13).map(|i| momentum([1.0, 0.1 * i as f64], [0.0, 0.5])).collect();
    let el = verlet();
    let template = Integrator::new(&lag, &el, grid.clone(), starts[0].clone(), SolverOptions::default()).expect("run");
    assert!(in_lanes(&template));
    assert_eq!(agree::<_, 2>(&lag, &grid, &starts), 0);
    #[cfg(feature = "jit")]
    assert_eq!(lag.ran_in_lanes(), (true, true), "the force and L as code across lanes");
}

/// Kepler and Hénon–Heiles written as expressions (force and L as code across lanes,
/// `expr/native/lanes.rs`): members equal their single runs on every width, those that fail
/// at their start, at their first step or mid-run included.
#[test]
fn expression_kepler_and_henon_heiles_members_equal_their_single_runs() {
    let xy = vec!["x".to_string(), "y".to_string()];
    let kepler =
        crate::expr::ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2)", &xy, &[]).expect("kepler");
    let grid = TimeGrid::uniform(0.0, 0.01, 20.0).expect("grid");
    let starts = kepler_starts();
    assert_eq!(
        agree::<_, 2>(&kepler, &grid, &starts),
        1,
        "the start at r ≈ 0 fails at its first step"
    );
    let hh = crate::expr::ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2) - 0.5*(x^2 + y^2) - x^2*y + y^3/3", &xy, &[])
        .expect("Hénon–Heiles");
    let grid = TimeGrid::uniform(0.0, 0.05, 200.0).expect("grid");
    let failed = agree::<_, 2>(&hh, &grid, &escapers());
    assert!((2..escapers().len() - 4).contains(&failed), "{failed} members fail");
    let el = Element::with_order(4).expect("degree 2");
    let grid = TimeGrid::uniform(0.0, 0.1, 150.0).expect("grid");
    let failed = agree_on::<_, 2>(&hh, &fixed_point_run(&grid, &el, true), &escapers());
    assert!(
        (2..escapers().len() - 4).contains(&failed),
        "{failed} members fail (degree 2)"
    );
    #[cfg(feature = "jit")]
    for lag in [&kepler, &hh] {
        assert_eq!(lag.ran_in_lanes(), (true, true), "the force and L as code across lanes");
    }
}

/// The fixed-point run of `element` (with polish or without).
fn fixed_point_run<'a>(grid: &'a TimeGrid, element: &'a Element, polish: bool) -> Run<'a> {
    let opts = SolverOptions {
        polish,
        ..SolverOptions::default()
    };
    Run { grid, element, opts }
}

/// Kepler with the fixed-point step (Gauss–Legendre of degrees 1 to 3, a Lobatto rule with
/// end points, polish on and off): members in lanes equal single runs, including members
/// whose iteration fails mid-run (a stall, the cap of sweeps) and one whose start fails.
#[test]
fn fixed_point_kepler_members_equal_their_single_runs_on_every_width() {
    let lag = models::kepler(1.0).expect("kepler");
    let grid = TimeGrid::uniform(0.0, 0.05, 15.0).expect("grid");
    let mut starts: Vec<Start> = (0..19)
        .map(|i| momentum([1.0, 0.0], [0.0, 0.5 + 0.04 * i as f64]))
        .collect();
    starts.insert(3, momentum([1e-170, 0.0], [-0.0, 1.0]));
    starts.insert(9, momentum([f64::NAN, 0.0], [0.0, 1.0]));
    let elements = [
        Element::with_order(2).expect("midpoint"),
        Element::with_order(4).expect("degree 2"),
        Element::with_order(6).expect("degree 3"),
        Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::GaussLobatto(3)).expect("Lobatto"),
    ];
    for el in &elements {
        for polish in [true, false] {
            // The start at r ≈ 0 ends there (its energy is not finite). With some elements the
            // iteration fails mid-run on the most eccentric orbits, at h = 0.05 near their
            // pericentre: it stalls, or reaches the cap of sweeps (lanes and single run alike).
            let failed = agree_on::<_, 2>(&lag, &fixed_point_run(&grid, el, polish), &starts);
            assert!(
                failed >= 1,
                "degree {}, polish {polish}: the start at r ≈ 0 fails",
                el.degree()
            );
        }
    }
}

/// Hénon–Heiles at degree 2 (the fixed-point ensemble): members above the escape
/// energy fail mid-run, alone.
#[test]
fn fixed_point_henon_heiles_members_that_escape_fail_alone() {
    let lag = models::henon_heiles();
    let grid = TimeGrid::uniform(0.0, 0.1, 150.0).expect("grid");
    let starts = escapers();
    let el = Element::with_order(4).expect("degree 2");
    let failed = agree_on::<_, 2>(&lag, &fixed_point_run(&grid, &el, true), &starts);
    assert!(failed >= 2, "{failed} members fail");
    assert!(failed < starts.len() - 4, "{failed} members fail");
}

/// A variable grid whose step changes by more than 2× (the start from the last element's
/// polynomial instead of the stage forces), a potential without lane code, in 3-D.
#[test]
fn fixed_point_members_equal_single_runs_on_a_grid_of_jumps() {
    let lag = crate::Mechanical::unit_mass(Anharmonic);
    let grid = TimeGrid::steps(0.0, vec![0.02, 0.05, 0.01, 0.012], 6.0).expect("grid");
    let starts: Vec<Start> = (0..11)
        .map(|i| Start::Velocity {
            q: vec![0.3, -0.1 * i as f64, 0.2],
            v: vec![0.1 * i as f64, 0.0, -0.5],
        })
        .collect();
    for el in [
        Element::with_order(4).expect("degree 2"),
        Element::with_order(6).expect("degree 3"),
    ] {
        assert_eq!(agree_on::<_, 3>(&lag, &fixed_point_run(&grid, &el, true), &starts), 0);
    }
}

/// An expression Lagrangian with the fixed-point step (its compiled forces at all stages
/// in the single run, lane by lane here).
#[test]
fn fixed_point_expression_members_equal_their_single_runs() {
    let lag = quartic();
    let grid = TimeGrid::uniform(0.0, 0.02, 5.0).expect("grid");
    let starts: Vec<Start> = (0..13).map(|i| momentum([1.0, 0.1 * i as f64], [0.0, 0.5])).collect();
    let el = Element::with_order(4).expect("degree 2");
    assert_eq!(agree_on::<_, 2>(&lag, &fixed_point_run(&grid, &el, true), &starts), 0);
}

/// Three unit masses in space (n = 9, a size whose carried values spill from registers) and
/// a chain of five (n = 5), written as expressions: with the fixed-point step, members equal
/// their single runs on every width, one whose start collides (r = 0: its first step fails)
/// included. Störmer–Verlet at these sizes stays member by member (a single run sums the
/// drift in another order there).
#[test]
fn larger_systems_in_lanes_equal_their_single_runs() {
    let names = |prefix: &[&str], bodies: usize| -> Vec<String> {
        (1..=bodies)
            .flat_map(|b| prefix.iter().map(move |c| format!("{c}{b}")))
            .collect()
    };
    let xyz = names(&["x", "y", "z"], 3);
    let kinetic = |coords: &[String]| {
        coords
            .iter()
            .map(|c| format!("{c}_dot^2"))
            .collect::<Vec<_>>()
            .join(" + ")
    };
    let r = |a: usize, b: usize| format!("sqrt((x{a} - x{b})^2 + (y{a} - y{b})^2 + (z{a} - z{b})^2)");
    let three = crate::expr::ExprLagrangian::new(
        &format!(
            "0.5*({}) + 1/{} + 1/{} + 1/{}",
            kinetic(&xyz),
            r(1, 2),
            r(1, 3),
            r(2, 3)
        ),
        &xyz,
        &[],
    )
    .expect("three bodies");
    let start = |i: usize| {
        let s = 0.02 * i as f64;
        Start::Momentum {
            q: vec![1.0, 0.0, 0.0, -0.5, 0.87, 0.1, -0.5, -0.87, -0.1],
            p: vec![0.0, 0.6 + s, 0.0, -0.52, -0.3, 0.05, 0.52, -0.3 - s, -0.05],
        }
    };
    let mut starts: Vec<Start> = (0..17).map(start).collect();
    starts.insert(
        5,
        Start::Momentum {
            q: vec![1.0, 0.0, 0.0, 1.0, 0.0, 0.0, -0.5, -0.87, -0.1],
            p: vec![0.0; 9],
        },
    );
    let el = Element::with_order(4).expect("degree 2");
    let grid = TimeGrid::uniform(0.0, 0.02, 3.0).expect("grid");
    assert_eq!(agree_on::<_, 9>(&three, &fixed_point_run(&grid, &el, true), &starts), 1);
    let trapezoid = verlet();
    let template = Integrator::new(
        &three,
        &trapezoid,
        grid.clone(),
        starts[0].clone(),
        SolverOptions::default(),
    )
    .expect("run");
    assert!(!in_lanes(&template), "Störmer–Verlet at n = 9 goes member by member");
    let chain: Vec<String> = (1..=5).map(|i| format!("x{i}")).collect();
    let springs = "(x2 - x1)^4/4 + (x3 - x2)^4/4 + (x4 - x3)^4/4 + (x5 - x4)^4/4 + x1^2/2 + x5^2/2";
    let fpu = crate::expr::ExprLagrangian::new(&format!("0.5*({}) - ({springs})", kinetic(&chain)), &chain, &[])
        .expect("chain");
    let starts: Vec<Start> = (0..11)
        .map(|i| Start::Momentum {
            q: vec![0.1 * i as f64, 0.0, -0.2, 0.3, 0.0],
            p: vec![0.0, 0.5, 0.0, -0.1, 0.2],
        })
        .collect();
    let el = Element::with_order(6).expect("degree 3");
    assert_eq!(agree_on::<_, 5>(&fpu, &fixed_point_run(&grid, &el, true), &starts), 0);
}
