//! Bit-for-bit guard for the "one model, one step, one run" refactor (forces, constraints and
//! adaptive steps as terms of one model; one run loop): the final states of the runs that
//! `golden.rs` does not cover, each through the public entry point a user calls. The expected
//! bits are in `golden/terms.txt` (the hex of `f64::to_bits`, and of counts and indices,
//! four to a line, as in `golden/final_states.txt`); a refactor must reproduce them exactly. To
//! regenerate after a deliberate change of results:
//! `FEMVI_GOLDEN_WRITE=1 cargo test -p femvi --test all -- golden_terms::`, and say so in
//! the commit message.
//!
//! What a run pins: the last kept node (step index, t, q, p, v, H), the steps taken, the mean
//! solver iterations, whether it stopped early, and whatever else the entry point reports:
//!
//! - forced runs (`forces::solve_forced`): Newton for a velocity-dependent force (linear
//!   damping; a Rayleigh dissipation plus a drive from expressions, `Sum`, on a driven
//!   Duffing oscillator; a damped pendulum with `Method::Newton` and a step limit), the
//!   fixed point for forces F(t, q) (driven Duffing with a position-dependent force; the
//!   driven oscillator on cyclic steps, degree 4), and the energy mode (midpoint by Newton,
//!   degree 2 by `Method::Auto`): with the discrete work W, the balance, and in the energy
//!   mode the discrete energy, its balance and the energy-mode statistics;
//! - constrained runs (`constraints::solve_constrained_with`) of the spherical pendulum in
//!   Cartesian coordinates: RATTLE (degree 1, trapezoid), every `Enforcement` (`Weak`,
//!   `Ends`, `Nodes` with Gauss and with Lobatto elements, `Points`), degree 4 Gauss, the
//!   planar double pendulum (two constraints), `every`: with the multipliers, the
//!   residuals ‖g‖ and ‖G v‖ of the last node, the largest residual and the start projection;
//!   these by dense Newton (`Method::Newton`, pinned when `Method::Auto` began to take the
//!   fixed point of `constraints/shake/mod.rs` on degrees ≥ 2: their bits did not change), and
//!   the weak degree-2, degree-4 Gauss and double-pendulum runs again by that fixed point
//!   (`Method::Auto`, entries "…, fixed point", added with it);
//! - forced and constrained (`constraints::solve_constrained_forced`): friction with a drive
//!   (degree 2, `Weak`) and friction alone (degree 3, `Nodes`), with W and the balance;
//! - adaptive steps (`solve_adaptive`, Kepler e = 0.9, three periods): degree 2 by the fixed
//!   point with a varying divisor (issue 39); degree 2 with full
//!   Newton, `saveat` and pericentre/apocentre events; degree 1 with the simplified Newton;
//!   an expression monitor with derivatives by automatic differentiation, degree 3: with
//!   the fictitious and physical clocks (s, t), E₀, the saved states and the events;
//! - chaos indicators (`chaos`): Hénon–Heiles in its chaotic sea (spectrum, series),
//!   Kepler in the energy mode, `forced_indicators` (driven Duffing),
//!   `constrained_indicators` (spherical pendulum; dense Newton, and the fixed point as
//!   "…, fixed point"), `forced_constrained_indicators`, and the
//!   whole-run sensitivities `forced_sensitivity` and `constrained_sensitivity`: MEGNO,
//!   ⟨Y⟩, FLI, λ at the end, the spectrum, the recorded series and the final node;
//! - boundary value problems, both stacks: `forces::solve_forced_bvp` (the plain stack with a
//!   force term: damped oscillator, Rayleigh plus drive on a pendulum), `bvp::solve` of a
//!   velocity-dependent expression Lagrangian (the plain ones are in `golden.rs`),
//!   `constraints::solve_constrained_bvp` (geodesic on the sphere; spherical pendulum with
//!   `Weak` and `Nodes`) and `solve_constrained_forced_bvp` (fed the ends of a forced
//!   constrained run): times, q and p at every node, the action, the residual, the Newton
//!   iterations and, constrained, v, the multipliers, the impulses and the residuals.

use femvi::adaptive::{solve_adaptive, AdaptiveOptions, AdaptiveSolution, ExprMonitor, KeplerMonitor};
use femvi::bvp::{line_guess, solve as solve_bvp, BoundaryValues, BvpOptions, BvpSolution};
use femvi::chaos::{
    constrained_indicators, constrained_sensitivity, forced_constrained_indicators, forced_indicators,
    forced_sensitivity, indicators, ChaosOptions, ChaosReport, FinalNode,
};
use femvi::constraints::{
    solve_constrained_bvp, solve_constrained_bvp_with, solve_constrained_forced, solve_constrained_forced_bvp,
    solve_constrained_with, ConstrainedBvpSolution, ConstrainedSolution, Enforcement, ForcedConstrainedSolution,
};
use femvi::expr::ExprLagrangian;
use femvi::forces::{solve_forced, solve_forced_bvp, ExprForces, ForcedSolution, LinearForce, Rayleigh, Sum};
use femvi::solution::{Direction, Event};
use femvi::{
    models, Element, EnergyOptions, EnergyStats, Method, NodeFamily, Problem, QuadratureKind, Solution, SolveOptions,
    Start, Steps,
};
use std::f64::consts::PI;

const G: f64 = 9.81;

type Runs = Vec<(&'static str, Vec<u64>)>;

/// The bits of one run, in the order pushed.
#[derive(Default)]
struct Bits(Vec<u64>);

impl Bits {
    fn f(&mut self, x: f64) -> &mut Self {
        self.0.push(x.to_bits());
        self
    }
    fn fs(&mut self, xs: &[f64]) -> &mut Self {
        self.0.extend(xs.iter().map(|x| x.to_bits()));
        self
    }
    fn u(&mut self, k: usize) -> &mut Self {
        self.0.push(k as u64);
        self
    }
    fn stats(&mut self, st: &Option<EnergyStats>) -> &mut Self {
        if let Some(st) = st {
            self.fs(&[st.energy, st.min_step, st.max_step, st.max_rel_residual]);
            self.u(st.degenerate_steps);
        }
        self
    }
    /// The last kept node of a solution and the run's statistics; the run must not have
    /// failed.
    fn solution(&mut self, s: &Solution) -> &mut Self {
        assert!(s.error.is_none(), "{:?}", s.error);
        let (i, n) = (s.len() - 1, s.n);
        self.u(s.step[i]).f(s.t[i]);
        self.fs(&s.q[i * n..(i + 1) * n]);
        self.fs(&s.p[i * n..(i + 1) * n]);
        self.fs(&s.v[i * n..(i + 1) * n]);
        self.f(s.energy[i]);
        self.u(s.len()).u(s.steps).f(s.mean_iterations).u(s.stopped as usize);
        self.stats(&s.energy_stats);
        if let Some(r) = &s.energy_report {
            self.f(r.max_rel_error);
            if let Some(b) = r.max_rel_balance {
                self.f(b);
            }
        }
        self
    }
    fn forced(&mut self, f: &ForcedSolution) -> &mut Self {
        self.solution(&f.solution);
        self.f(*f.work.last().unwrap()).u(f.work.len());
        self.f(f.balance.max_abs).f(f.balance.max_rel);
        if let Some(e) = f.discrete_energy.last() {
            self.f(*e);
        }
        if let Some(b) = f.discrete_balance {
            self.f(b.max_abs).f(b.max_rel);
        }
        self
    }
    fn constrained(&mut self, c: &ConstrainedSolution) -> &mut Self {
        self.solution(&c.solution);
        let (i, m) = (c.solution.len() - 1, c.m);
        self.u(m).fs(&c.multipliers[i * m..(i + 1) * m]);
        self.f(c.residual[i]).f(c.hidden_residual[i]);
        self.f(c.max_residual).f(c.start_projection)
    }
    fn adaptive(&mut self, a: &AdaptiveSolution) -> &mut Self {
        assert!(a.error.is_none(), "{:?}", a.error);
        let (i, n) = (a.t.len() - 1, a.n);
        self.f(a.e0).u(a.t.len()).f(a.s[i]).f(a.t[i]);
        self.fs(&a.q[i * n..(i + 1) * n]);
        self.fs(&a.p[i * n..(i + 1) * n]);
        self.fs(&a.v[i * n..(i + 1) * n]);
        self.f(a.energy[i])
            .u(a.steps)
            .f(a.mean_iterations)
            .u(a.stopped as usize);
        self.fs(&a.saved.t).fs(&a.saved.q).fs(&a.saved.v).fs(&a.saved.p);
        self.u(a.events.len());
        for e in &a.events {
            self.u(e.event).u(e.step).f(e.t).fs(&e.q).fs(&e.v).fs(&e.p);
        }
        self
    }
    fn node(&mut self, (t, q, p): &FinalNode) -> &mut Self {
        self.f(*t).fs(q).fs(p)
    }
    fn chaos(&mut self, r: &ChaosReport) -> &mut Self {
        assert!(r.error.is_none(), "{:?}", r.error);
        let l = &r.last;
        self.u(r.steps).fs(&[l.t, l.megno, l.mean_megno, l.fli, l.lyapunov]);
        if let Some(s) = &r.spectrum {
            self.fs(s);
        }
        self.u(r.series.len());
        for s in &r.series {
            self.fs(&[s.t, s.megno, s.mean_megno, s.fli, s.lyapunov]);
        }
        self.node(&r.final_node)
    }
    fn bvp(&mut self, b: &BvpSolution) -> &mut Self {
        self.fs(&b.times).fs(&b.q).fs(&b.p).f(b.action).f(b.residual_norm);
        self.u(b.newton_iterations)
    }
    fn constrained_bvp(&mut self, c: &ConstrainedBvpSolution) -> &mut Self {
        self.bvp(&c.solution).u(c.m).fs(&c.v).fs(&c.multipliers).fs(&c.impulses);
        self.fs(&c.residual).fs(&c.hidden_residual).f(c.max_residual)
    }
    fn done(&mut self) -> Vec<u64> {
        std::mem::take(&mut self.0)
    }
}

fn names(xs: &[&str]) -> Vec<String> {
    xs.iter().map(|s| s.to_string()).collect()
}

fn params(xs: &[(&str, f64)]) -> Vec<(String, f64)> {
    xs.iter().map(|(k, v)| (k.to_string(), *v)).collect()
}

fn with_method(mut o: SolveOptions, method: Method) -> SolveOptions {
    o.solver.method = method;
    o
}

fn energy_steps(h: f64, method: Method) -> SolveOptions {
    let o = SolveOptions {
        steps: Steps::Energy {
            step: h,
            options: EnergyOptions::from_step(h),
        },
        ..SolveOptions::step(h)
    };
    with_method(o, method)
}

fn oscillator(t_end: f64) -> Problem<femvi::Mechanical<models::HarmonicPotential>> {
    let start = Start::Velocity {
        q: vec![1.0],
        v: vec![0.0],
    };
    Problem::new(models::harmonic(1.0, 1.0).unwrap(), start, 0.0, t_end)
}

/// The Duffing oscillator x'' − x + x³ = F (a double well), from x = 1.2, p = 0.1.
fn duffing(t_end: f64) -> Problem<ExprLagrangian> {
    let lag = ExprLagrangian::new("0.5*x_dot^2 + 0.5*x^2 - 0.25*x^4", &names(&["x"]), &[]).unwrap();
    let start = Start::Momentum {
        q: vec![1.2],
        p: vec![0.1],
    };
    Problem::new(lag, start, 0.0, t_end)
}

/// Friction −0.15 x' (a Rayleigh function) and the drive 0.3 cos(1.2 t) (an expression).
fn duffing_force() -> Sum<Rayleigh, ExprForces> {
    let x = names(&["x"]);
    let rayleigh = Rayleigh::new("0.5*d*x_dot^2", &x, &params(&[("d", 0.15)])).unwrap();
    let drive = ExprForces::new(&["g*cos(w*t)"], &x, &params(&[("g", 0.3), ("w", 1.2)])).unwrap();
    Sum(rayleigh, drive)
}

fn sphere_start(theta: f64, phidot: f64) -> Start {
    Start::Velocity {
        q: vec![theta.sin(), 0.0, -theta.cos()],
        v: vec![0.0, theta.sin() * phidot, 0.0],
    }
}

fn trapezoid() -> Element {
    Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap()
}

fn order(k: usize) -> Element {
    Element::with_order(k).unwrap()
}

/// Friction −c v and a horizontal drive f0 cos(w t) along x on the sphere.
fn sphere_damped_driven() -> ExprForces {
    let p = params(&[("c", 0.4), ("f0", 1.5), ("w", 2.3)]);
    ExprForces::new(
        &["-c*x_dot + f0*cos(w*t)", "-c*y_dot", "-c*z_dot"],
        &names(&["x", "y", "z"]),
        &p,
    )
    .unwrap()
}

fn runs() -> Runs {
    let mut out = vec![];
    forced_runs(&mut out);
    constrained_runs(&mut out);
    adaptive_runs(&mut out);
    chaos_runs(&mut out);
    bvp_runs(&mut out);
    out
}

/// `solve_forced`: Newton, fixed point, energy mode.
fn forced_runs(out: &mut Runs) {
    let mut b = Bits::default();
    let damping = LinearForce::damping(1, 0.3);
    let sol = solve_forced(&oscillator(20.0), &damping, &order(4), &SolveOptions::step(0.05)).unwrap();
    out.push(("forced newton: damped oscillator degree 2", b.forced(&sol).done()));

    let sol = solve_forced(&duffing(20.0), &duffing_force(), &order(6), &SolveOptions::step(0.05)).unwrap();
    out.push((
        "forced newton: duffing rayleigh + drive degree 3",
        b.forced(&sol).done(),
    ));

    let pendulum = Problem::new(
        models::pendulum(1.0, G, 1.0).unwrap(),
        Start::Velocity {
            q: vec![2.5],
            v: vec![0.0],
        },
        0.0,
        20.0,
    );
    let friction = Rayleigh::new("0.25*th_dot^2 + 0.05*th_dot^4", &names(&["th"]), &[]).unwrap();
    let o = SolveOptions {
        every: 7,
        max_steps: Some(300),
        ..with_method(SolveOptions::step(0.04), Method::Newton)
    };
    let sol = solve_forced(&pendulum, &friction, &order(2), &o).unwrap();
    out.push((
        "forced newton: damped pendulum degree 1 every 7, max_steps 300",
        b.forced(&sol).done(),
    ));

    let position_force = ExprForces::new(
        &["g*cos(w*t) + e*x^2"],
        &names(&["x"]),
        &params(&[("g", 0.3), ("w", 1.2), ("e", 0.1)]),
    )
    .unwrap();
    let sol = solve_forced(&duffing(30.0), &position_force, &order(4), &SolveOptions::step(0.1)).unwrap();
    out.push(("forced fixed point: duffing F(t, x) degree 2", b.forced(&sol).done()));

    let drive = LinearForce::drive(vec![0.5], 1.7);
    let cyclic = SolveOptions {
        steps: Steps::Cycle(vec![0.2, 0.3, 0.25]),
        ..SolveOptions::step(0.2)
    };
    let sol = solve_forced(&oscillator(30.0), &drive, &order(8), &cyclic).unwrap();
    out.push((
        "forced fixed point: driven oscillator degree 4 cyclic",
        b.forced(&sol).done(),
    ));

    let light = LinearForce::damping(1, 0.01);
    let sol = solve_forced(
        &oscillator(30.0),
        &light,
        &Element::midpoint(),
        &energy_steps(0.05, Method::Newton),
    )
    .unwrap();
    out.push(("forced energy mode: damped oscillator midpoint", b.forced(&sol).done()));
    let sol = solve_forced(&oscillator(60.0), &light, &order(4), &energy_steps(0.2, Method::Auto)).unwrap();
    out.push(("forced energy mode: damped oscillator degree 2", b.forced(&sol).done()));
}

/// `solve_constrained_with` (each enforcement, RATTLE, degree 4) and
/// `solve_constrained_forced`.
fn constrained_runs(out: &mut Runs) {
    let mut b = Bits::default();
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    let sph = |t_end: f64| Problem::new(lag.clone(), sphere_start(1.0, 2.0), 0.0, t_end);
    let tilted = Problem::new(
        lag.clone(),
        Start::Velocity {
            q: vec![0.6, 0.0, -0.8],
            v: vec![0.3, 1.5, 0.225],
        },
        0.0,
        4.0,
    );
    // h = 2⁻⁷, 512 steps: RATTLE.
    let h = 0.0078125;
    let run = solve_constrained_with(
        &tilted,
        &sphere,
        &trapezoid(),
        &SolveOptions::step(h),
        Enforcement::Ends,
    )
    .unwrap();
    out.push(("constrained: rattle (degree 1 trapezoid)", b.constrained(&run).done()));
    let lobatto = Element::galerkin(3, NodeFamily::Lobatto, QuadratureKind::GaussLobatto(4)).unwrap();
    let cases: [(&'static str, Element, Enforcement); 5] = [
        ("constrained: weak degree 2", order(4), Enforcement::Weak),
        ("constrained: ends degree 2", order(4), Enforcement::Ends),
        ("constrained: nodes degree 3", order(6), Enforcement::Nodes),
        ("constrained: nodes lobatto degree 3", lobatto, Enforcement::Nodes),
        ("constrained: points degree 3", order(6), Enforcement::Points),
    ];
    // The dense Newton path, pinned by `Method::Newton` since `Method::Auto` takes the
    // fixed-point steps of `constraints/shake/mod.rs` on these elements (pinned below).
    let newton = |h| with_method(SolveOptions::step(h), Method::Newton);
    for (name, el, enforcement) in cases {
        let run = solve_constrained_with(&sph(4.0), &sphere, &el, &newton(0.04), enforcement).unwrap();
        out.push((name, b.constrained(&run).done()));
    }
    let every = SolveOptions {
        every: 9,
        ..newton(0.05)
    };
    let run = solve_constrained_with(&sph(5.0), &sphere, &order(8), &every, Enforcement::Weak).unwrap();
    out.push(("constrained: degree 4 gauss every 9", b.constrained(&run).done()));
    let run = solve_constrained_with(
        &sph(4.0),
        &sphere,
        &order(4),
        &SolveOptions::step(0.04),
        Enforcement::Weak,
    )
    .unwrap();
    out.push(("constrained: weak degree 2, fixed point", b.constrained(&run).done()));
    let every = SolveOptions {
        every: 9,
        ..SolveOptions::step(0.05)
    };
    let run = solve_constrained_with(&sph(5.0), &sphere, &order(8), &every, Enforcement::Weak).unwrap();
    out.push((
        "constrained: degree 4 gauss every 9, fixed point",
        b.constrained(&run).done(),
    ));

    let (lag2, rods) = models::chain(2, 2, 1.0, G, 1.0).unwrap();
    let (a, c): (f64, f64) = (0.5, 1.2);
    let start = Start::Velocity {
        q: vec![a.sin(), -a.cos(), a.sin() + c.sin(), -a.cos() - c.cos()],
        v: vec![0.0; 4],
    };
    let double = Problem::new(lag2, start, 0.0, 3.0);
    let run = solve_constrained_with(&double, &rods, &order(4), &newton(0.02), Enforcement::Weak).unwrap();
    out.push(("constrained: double pendulum weak degree 2", b.constrained(&run).done()));
    let run = solve_constrained_with(&double, &rods, &order(4), &SolveOptions::step(0.02), Enforcement::Weak).unwrap();
    out.push((
        "constrained: double pendulum weak degree 2, fixed point",
        b.constrained(&run).done(),
    ));

    let forced = |run: &ForcedConstrainedSolution, b: &mut Bits| {
        b.constrained(&run.constrained);
        b.f(*run.work.last().unwrap()).u(run.work.len());
        b.f(run.balance.max_abs).f(run.balance.max_rel).done()
    };
    let run = solve_constrained_forced(
        &sph(3.0),
        &sphere_damped_driven(),
        &sphere,
        &order(4),
        &SolveOptions::step(0.02),
        Enforcement::Weak,
    )
    .unwrap();
    out.push((
        "forced + constrained: friction and drive weak degree 2",
        forced(&run, &mut b),
    ));
    let run = solve_constrained_forced(
        &tilted,
        &LinearForce::damping(3, 0.5),
        &sphere,
        &order(6),
        &SolveOptions::step(0.05),
        Enforcement::Nodes,
    )
    .unwrap();
    out.push(("forced + constrained: friction nodes degree 3", forced(&run, &mut b)));
}

/// `solve_adaptive` on Kepler e = 0.9 over three periods, with its physical clock.
fn adaptive_runs(out: &mut Runs) {
    let mut b = Bits::default();
    let e: f64 = 0.9;
    let start = Start::Momentum {
        q: vec![1.0 - e, 0.0],
        p: vec![0.0, ((1.0 + e) / (1.0 - e)).sqrt()],
    };
    let problem = Problem::new(models::kepler(1.0).unwrap(), start, 0.0, 3.0 * 2.0 * PI);
    let options = AdaptiveOptions {
        every: 0,
        saveat: vec![1.0, PI, 7.5, 15.0],
        events: vec![
            Event::new("pericentre", |_, q, _| q[1]).direction(Direction::Rising),
            Event::new("apocentre", |_, q, _| q[1]).direction(Direction::Falling),
        ],
        ..AdaptiveOptions::step(0.05)
    };
    let sol = solve_adaptive(&problem, KeplerMonitor, &order(4), &options).unwrap();
    out.push((
        "adaptive: kepler e 0.9 degree 2 full newton, saveat, events",
        b.adaptive(&sol).done(),
    ));
    let mut options = AdaptiveOptions {
        every: 100,
        ..AdaptiveOptions::step(0.01)
    };
    options.solver.method = Method::Newton;
    let sol = solve_adaptive(&problem, KeplerMonitor, &order(2), &options).unwrap();
    out.push((
        "adaptive: kepler e 0.9 degree 1 simplified newton",
        b.adaptive(&sol).done(),
    ));
    // The fixed point with the divisor g at the element's midpoint (issue 39).
    let mut options = AdaptiveOptions {
        every: 0,
        saveat: vec![1.0, PI, 7.5, 15.0],
        ..AdaptiveOptions::step(0.05)
    };
    options.solver.method = Method::FixedPoint;
    let sol = solve_adaptive(&problem, KeplerMonitor, &order(4), &options).unwrap();
    out.push((
        "adaptive: kepler e 0.9 degree 2 fixed point, saveat",
        b.adaptive(&sol).done(),
    ));
    let monitor = ExprMonitor::new("(x^2 + y^2)^0.75", &names(&["x", "y"]), &[]).unwrap();
    let options = AdaptiveOptions {
        every: 0,
        hand_derivatives: false,
        ..AdaptiveOptions::step(0.1)
    };
    let sol = solve_adaptive(&problem, monitor, &order(6), &options).unwrap();
    out.push((
        "adaptive: kepler e 0.9 degree 3 expression monitor by AD",
        b.adaptive(&sol).done(),
    ));
}

/// `chaos`: indicators of plain (fixed steps and energy mode), forced, constrained and forced
/// constrained runs, and two whole-run sensitivities.
fn chaos_runs(out: &mut Runs) {
    let mut b = Bits::default();
    // Hénon–Heiles at E = 1/6 from (0, −0.1), p_y = 0: in the chaotic sea.
    let (y0, energy): (f64, f64) = (-0.1, 1.0 / 6.0);
    let v = 0.5 * y0 * y0 - y0.powi(3) / 3.0;
    let hh = Problem::new(
        models::henon_heiles(),
        Start::Momentum {
            q: vec![0.0, y0],
            p: vec![(2.0 * (energy - v)).sqrt(), 0.0],
        },
        0.0,
        200.0,
    );
    let spectrum = ChaosOptions {
        spectrum: true,
        renormalize_every: 10,
        record_every: 500,
        ..ChaosOptions::default()
    };
    let r = indicators(&hh, &order(4), &SolveOptions::step(0.1), &spectrum).unwrap();
    out.push(("chaos: henon-heiles chaotic degree 2 spectrum", b.chaos(&r).done()));
    // The same at degree 1 with the trapezoid rule (Störmer–Verlet: the mechanical tangent's
    // one ordered pass), and the FPU chain (prepared products) at degrees 1 and 2.
    let verlet = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    let r = indicators(&hh, &verlet, &SolveOptions::step(0.05), &spectrum).unwrap();
    out.push((
        "chaos: henon-heiles chaotic degree 1 trapezoid spectrum",
        b.chaos(&r).done(),
    ));
    let fpu = Problem::new(
        models::fpu(8, 0.25, 1.0).unwrap(),
        Start::Momentum {
            q: (0..8).map(|i| 0.3 * (i as f64 + 1.0).sin()).collect(),
            p: vec![0.0; 8],
        },
        0.0,
        50.0,
    );
    for (name, element) in [
        ("chaos: fpu 8 degree 1 trapezoid spectrum", &verlet),
        ("chaos: fpu 8 degree 2 spectrum", &order(4)),
    ] {
        let r = indicators(&fpu, element, &SolveOptions::step(0.05), &spectrum).unwrap();
        out.push((name, b.chaos(&r).done()));
    }

    let circular = Problem::new(
        models::kepler(1.0).unwrap(),
        Start::Momentum {
            q: vec![1.0, 0.0],
            p: vec![0.0, 1.0],
        },
        0.0,
        100.0,
    );
    let r = indicators(
        &circular,
        &order(2),
        &energy_steps(0.05, Method::Auto),
        &ChaosOptions::default(),
    )
    .unwrap();
    out.push(("chaos: kepler energy mode degree 1", b.chaos(&r).done()));

    let forced_opts = ChaosOptions {
        spectrum: true,
        record_every: 250,
        ..ChaosOptions::default()
    };
    let r = forced_indicators(
        &duffing(20.0),
        &duffing_force(),
        &order(4),
        &SolveOptions::step(0.02),
        &forced_opts,
    )
    .unwrap();
    out.push(("chaos: forced duffing degree 2 spectrum", b.chaos(&r).done()));

    let (lag, sphere) = models::chain(3, 1, 1.0, 1.0, 1.0).unwrap();
    let sph = |t_end: f64| {
        let start = Start::Velocity {
            q: vec![0.6, 0.0, -0.8],
            v: vec![0.0, 0.7, 0.0],
        };
        Problem::new(lag.clone(), start, 0.0, t_end)
    };
    // Dense Newton steps pinned (`Method::Auto` takes the fixed point of
    // `constraints/shake/mod.rs`, pinned after).
    let newton = with_method(SolveOptions::step(0.1), Method::Newton);
    let r = constrained_indicators(&sph(50.0), &sphere, &order(4), &newton, Enforcement::Weak, &forced_opts).unwrap();
    out.push((
        "chaos: constrained spherical pendulum degree 2 spectrum",
        b.chaos(&r).done(),
    ));
    let r = constrained_indicators(
        &sph(50.0),
        &sphere,
        &order(4),
        &SolveOptions::step(0.1),
        Enforcement::Weak,
        &forced_opts,
    )
    .unwrap();
    out.push((
        "chaos: constrained spherical pendulum degree 2 spectrum, fixed point",
        b.chaos(&r).done(),
    ));
    let r = forced_constrained_indicators(
        &sph(50.0),
        &LinearForce::damping(3, 0.4),
        &sphere,
        &order(4),
        &SolveOptions::step(0.1),
        Enforcement::Weak,
        &ChaosOptions::default(),
    )
    .unwrap();
    out.push((
        "chaos: forced constrained spherical pendulum degree 2",
        b.chaos(&r).done(),
    ));

    let (m, node) = forced_sensitivity(&duffing(5.0), &duffing_force(), &order(4), &SolveOptions::step(0.05)).unwrap();
    out.push((
        "chaos: forced sensitivity duffing degree 2",
        b.fs(&m).node(&node).done(),
    ));
    let (m, node) = constrained_sensitivity(&sph(2.0), &sphere, &order(4), &newton, Enforcement::Weak).unwrap();
    out.push((
        "chaos: constrained sensitivity spherical pendulum degree 2",
        b.fs(&m).node(&node).done(),
    ));
}

/// Both boundary-value stacks: the plain one (with a force term, and a velocity-dependent
/// Lagrangian) and the constrained one (with and without forces).
fn bvp_runs(out: &mut Runs) {
    let mut b = Bits::default();
    let bv1 = |q0: f64, q1: f64, t1: f64, elements: usize| BoundaryValues {
        t0: 0.0,
        q0: vec![q0],
        t1,
        q1: vec![q1],
        elements,
    };
    let el = order(4);
    let bv = bv1(1.0, 0.0, 2.0, 20);
    let osc = models::harmonic(1.0, 1.0).unwrap();
    let sol = solve_forced_bvp(
        &osc,
        &LinearForce::damping(1, 0.5),
        &el,
        &bv,
        &line_guess(&bv, &el),
        BvpOptions::default(),
    )
    .unwrap();
    out.push(("bvp forced: damped oscillator degree 2", b.bvp(&sol).done()));

    let el = order(6);
    let bv = bv1(0.3, -0.2, 2.0, 16);
    let pend = models::pendulum(1.0, G, 1.0).unwrap();
    let th = names(&["th"]);
    let force = Sum(
        Rayleigh::new("0.5*c*th_dot^2", &th, &params(&[("c", 0.3)])).unwrap(),
        ExprForces::new(&["0.8*sin(1.5*t)"], &th, &[]).unwrap(),
    );
    let sol = solve_forced_bvp(&pend, &force, &el, &bv, &line_guess(&bv, &el), BvpOptions::default()).unwrap();
    out.push(("bvp forced: pendulum rayleigh + drive degree 3", b.bvp(&sol).done()));

    let magnetic = ExprLagrangian::new(
        "0.5*(x_dot^2 + y_dot^2) + 0.5*b*(x*y_dot - y*x_dot) - 0.5*(x^2 + y^2)",
        &names(&["x", "y"]),
        &params(&[("b", 0.7)]),
    )
    .unwrap();
    let bv = BoundaryValues {
        t0: 0.0,
        q0: vec![1.0, 0.0],
        t1: 1.5,
        q1: vec![0.2, 0.7],
        elements: 12,
    };
    let el = order(4);
    let sol = solve_bvp(&magnetic, &el, &bv, &line_guess(&bv, &el), BvpOptions::default()).unwrap();
    out.push(("bvp plain: magnetic expression degree 2", b.bvp(&sol).done()));

    let unit = |v: [f64; 3]| {
        let r = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v.map(|x| x / r).to_vec()
    };
    let bv3 = |q0: Vec<f64>, q1: Vec<f64>, t1: f64, elements: usize| BoundaryValues {
        t0: 0.0,
        q0,
        t1,
        q1,
        elements,
    };
    let (free, sphere0) = models::chain(3, 1, 1.0, 0.0, 1.0).unwrap();
    let bv = bv3(unit([1.0, 0.2, -0.3]), unit([-0.2, 0.9, 0.4]), 2.0, 8);
    let sol = solve_constrained_bvp(&free, &sphere0, &el, &bv, &line_guess(&bv, &el), BvpOptions::default()).unwrap();
    out.push((
        "bvp constrained: geodesic on the sphere degree 2",
        b.constrained_bvp(&sol).done(),
    ));

    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    // The ends of an initial value run of degree 4 from θ = 1, swinging sideways, t = 1.
    let th: f64 = 1.0;
    let start = Start::Velocity {
        q: vec![th.sin(), 0.0, -th.cos()],
        v: vec![0.5 * th.cos(), 1.5, 0.5 * th.sin()],
    };
    let ivp = solve_constrained_with(
        &Problem::new(lag.clone(), start, 0.0, 1.0),
        &sphere,
        &order(8),
        &with_method(SolveOptions::step(0.025), Method::Newton),
        Enforcement::Weak,
    )
    .unwrap();
    let iq = &ivp.solution.q;
    let bv = bv3(iq[..3].to_vec(), iq[iq.len() - 3..].to_vec(), 1.0, 20);
    for (name, el, enforcement) in [
        (
            "bvp constrained: spherical pendulum weak degree 2",
            order(4),
            Enforcement::Weak,
        ),
        (
            "bvp constrained: spherical pendulum nodes degree 3",
            order(6),
            Enforcement::Nodes,
        ),
    ] {
        let sol = solve_constrained_bvp_with(
            &lag,
            &sphere,
            &el,
            &bv,
            &line_guess(&bv, &el),
            BvpOptions::default(),
            enforcement,
        )
        .unwrap();
        out.push((name, b.constrained_bvp(&sol).done()));
    }

    // The forced constrained boundary value problem between the ends of a forced run.
    let force = sphere_damped_driven();
    let (h, steps) = (0.01, 40);
    let run = solve_constrained_forced(
        &Problem::new(lag.clone(), sphere_start(1.0, 2.0), 0.0, h * steps as f64),
        &force,
        &sphere,
        &el,
        &SolveOptions::step(h),
        Enforcement::Weak,
    )
    .unwrap();
    let s = &run.constrained.solution;
    let last = s.len() - 1;
    let bv = bv3(
        s.q_row(0).unwrap().to_vec(),
        s.q_row(last).unwrap().to_vec(),
        s.t[last],
        steps,
    );
    let sol = solve_constrained_forced_bvp(
        &lag,
        &force,
        &sphere,
        &el,
        &bv,
        &line_guess(&bv, &el),
        BvpOptions::default(),
        Enforcement::Weak,
    )
    .unwrap();
    out.push((
        "bvp constrained forced: friction and drive weak degree 2",
        b.constrained_bvp(&sol).done(),
    ));
}

#[test]
fn final_states_of_forced_constrained_adaptive_chaos_and_bvp_runs_are_bit_identical() {
    let all = runs();
    let mut seen = std::collections::HashSet::new();
    assert!(all.iter().all(|(name, _)| seen.insert(*name)), "run names are unique");
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden/terms.txt");
    super::golden::compare_or_write(path, &all, 30);
}
