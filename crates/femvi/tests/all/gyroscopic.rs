//! The gyroscopic fixed point (issue 15): L = ½vᵀMv + A(t, q)·v − V(t, q) solved without
//! Hessians (step/gyroscopic/mod.rs). Structure detection in expressions and the compiled A and
//! ∂L/∂q against automatic differentiation; whole runs against Newton's method on the same
//! equations (Arenstorf in the rotating frame, a charge in a uniform magnetic field), as
//! expressions and as Rust Lagrangians; and the order 2s against the closed-form solution
//! of the charge in a harmonic trap.

use femvi::expr::ExprLagrangian;
use femvi::lagrangian::PointDerivatives;
use femvi::{Element, Integrator, Lagrangian, MassMatrix, Method, Scalar, SolverOptions, Start, TimeGrid};

/// A small deterministic generator (xorshift), uniform in [lo, hi).
struct Rng(u64);
impl Rng {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }
}

fn names(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

const ARENSTORF: &str = "0.5*(x_dot^2 + y_dot^2) + x*y_dot - y*x_dot + 0.5*(x^2 + y^2) \
    + (1 - mu)/sqrt((x + mu)^2 + y^2) + mu/sqrt((x - 1 + mu)^2 + y^2)";
const MAGNETIC: &str = "0.5*(x_dot^2 + y_dot^2) + 0.5*b*(x*y_dot - y*x_dot) - 0.5*(x^2 + y^2)";

fn arenstorf() -> ExprLagrangian {
    ExprLagrangian::new(ARENSTORF, &names(&["x", "y"]), &[("mu".into(), 0.012277471)]).unwrap()
}

fn magnetic_expr(b: f64) -> ExprLagrangian {
    ExprLagrangian::new(MAGNETIC, &names(&["x", "y"]), &[("b".into(), b)]).unwrap()
}

/// The charge in a harmonic trap with a uniform field b as a Rust Lagrangian that declares
/// its gyroscopic parts: A = ½b(−y, x), ∂L/∂q = ½b(v_y, −v_x) − q; with `by_ad` it keeps the
/// trait's default parts (from automatic differentiation).
struct TrappedCharge {
    b: f64,
    mass: MassMatrix,
    by_ad: bool,
}

impl TrappedCharge {
    fn new(b: f64, by_ad: bool) -> Self {
        Self {
            b,
            mass: MassMatrix::identity(2),
            by_ad,
        }
    }
}

impl Lagrangian for TrappedCharge {
    fn dim(&self) -> usize {
        2
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
        let kinetic = (v[0] * v[0] + v[1] * v[1]) * 0.5;
        let magnetic = (q[0] * v[1] - q[1] * v[0]) * (0.5 * self.b);
        kinetic + magnetic - (q[0] * q[0] + q[1] * q[1]) * 0.5
    }
    fn gyroscopic_mass(&self) -> Option<&MassMatrix> {
        Some(&self.mass)
    }
    fn gyroscopic_terms(&self, t: &[f64], q: &[f64], v: &[f64], out: &mut [f64]) {
        if self.by_ad {
            return femvi_default_terms(self, t, q, v, out);
        }
        let hb = 0.5 * self.b;
        for ((q, v), o) in q.chunks_exact(2).zip(v.chunks_exact(2)).zip(out.chunks_exact_mut(4)) {
            o[0] = -hb * q[1];
            o[1] = hb * q[0];
            o[2] = hb * v[1] - q[0];
            o[3] = -hb * v[0] - q[1];
        }
    }
}

/// The trait's default `gyroscopic_terms`, reached through a wrapper that does not override it.
fn femvi_default_terms(lag: &TrappedCharge, t: &[f64], q: &[f64], v: &[f64], out: &mut [f64]) {
    struct Plain<'a>(&'a TrappedCharge);
    impl Lagrangian for Plain<'_> {
        fn dim(&self) -> usize {
            2
        }
        fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
            self.0.value(t, q, v)
        }
        fn gyroscopic_mass(&self) -> Option<&MassMatrix> {
            Some(&self.0.mass)
        }
    }
    Plain(lag).gyroscopic_terms(t, q, v, out)
}

#[test]
fn gyroscopic_expressions_are_detected_and_their_parts_agree_with_automatic_differentiation() {
    let xy = names(&["x", "y"]);
    let p = [("b".to_string(), 0.7), ("mu".to_string(), 0.3)];
    let cases = [
        ARENSTORF,
        MAGNETIC,
        // A time-dependent field, a dense mass and a field that is not a gradient.
        "0.5*(2*x_dot^2 + x_dot*y_dot + y_dot^2) + sin(t)*x^2*y_dot - exp(-y)*x_dot - cos(x*y)",
        "x_dot^2 + y_dot^2 + (x_dot + y_dot*t)*b*x*y - 1/sqrt(x^2 + y^2 + 1)",
    ];
    let mut rng = Rng(0x5EED);
    for src in cases {
        let lag = ExprLagrangian::new(src, &xy, &p).unwrap();
        assert!(!lag.is_mechanical(), "{src}");
        let m = lag.gyroscopic_mass().unwrap_or_else(|| panic!("{src}: not gyroscopic"));
        for _ in 0..50 {
            let t = [rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)];
            let q: Vec<f64> = (0..4).map(|_| rng.uniform(0.2, 1.5)).collect();
            let v: Vec<f64> = (0..4).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let mut out = [f64::NAN; 8];
            lag.gyroscopic_terms(&t, &q, &v, &mut out);
            for j in 0..2 {
                let (qj, vj) = (&q[2 * j..2 * j + 2], &v[2 * j..2 * j + 2]);
                let mut ad = PointDerivatives::new(2);
                ad.second_by_ad(&lag, t[j], qj, vj, false);
                // M = ∂²L/∂v², A = ∂L/∂v − Mv, g = ∂L/∂q.
                let mut mv = [0.0; 2];
                m.apply(vj, &mut mv);
                let want = [ad.l_v()[0] - mv[0], ad.l_v()[1] - mv[1], ad.l_q()[0], ad.l_q()[1]];
                let scale = want.iter().chain(ad.l_v()).fold(1e-300f64, |s, x| s.max(x.abs()));
                for (got, want) in out[4 * j..4 * j + 4].iter().zip(want) {
                    assert!((got - want).abs() <= 1e-14 * scale, "{src}: {got} vs {want}");
                }
                for a in 0..2 {
                    for b in 0..2 {
                        let h = ad.h(3 + a, 3 + b);
                        assert!((m.get(a, b).unwrap() - h).abs() <= 1e-14 * h.abs().max(1.0), "{src}");
                    }
                }
            }
        }
    }
    for src in [
        // A singular, an indefinite and a q-dependent quadratic part: not gyroscopic.
        "0.5*x_dot^2 + y*y_dot - x",
        "0.5*(x_dot^2 - y_dot^2) + x*y_dot",
        "0.5*(x_dot^2 + (1 + x^2)*y_dot^2) + x*y_dot - y",
        // Mechanical (no linear term) and not polynomial in v.
        "0.5*(x_dot^2 + y_dot^2) - x*y",
        "-sqrt(1 - x_dot^2 - y_dot^2) + x*y_dot",
    ] {
        let lag = ExprLagrangian::new(src, &xy, &p).unwrap();
        assert!(lag.gyroscopic_mass().is_none(), "{src}");
    }
}

/// Final (q, p) of a uniform run with `method`, and the mean iterations per step.
fn run<L: Lagrangian>(lag: &L, el: &Element, h: f64, steps: usize, start: Start, method: Method) -> (Vec<f64>, f64) {
    let grid = TimeGrid::uniform(0.0, h, h * steps as f64).unwrap();
    let opts = SolverOptions {
        method,
        ..Default::default()
    };
    let mut it = Integrator::new(lag, el, grid, start, opts).unwrap();
    while it.advance(usize::MAX).unwrap() > 0 {}
    let node = it.node();
    (
        node.q.iter().chain(node.p.iter()).copied().collect(),
        it.mean_iterations(),
    )
}

/// max |a − b| / max |b|.
fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    a.iter().zip(b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) / scale
}

#[test]
fn the_gyroscopic_fixed_point_agrees_with_newton() {
    // Arenstorf from its periodic orbit's start (0.006 from the Moon, the fastest part) and
    // the trapped charge, degrees 1 to 4 with Gauss points, Auto (the gyroscopic fixed point)
    // against Newton on the same element equations: both solve to round-off.
    let are = arenstorf();
    let are_start = || Start::Velocity {
        q: vec![0.994, 0.0],
        v: vec![0.0, -2.001_585_106_379_082_4],
    };
    let charge_start = || Start::Velocity {
        q: vec![1.0, 0.0],
        v: vec![0.0, 0.3],
    };
    let (expr, rust, rust_ad) = (
        magnetic_expr(3.0),
        TrappedCharge::new(3.0, false),
        TrappedCharge::new(3.0, true),
    );
    for s in 1..=4 {
        let el = Element::with_order(2 * s).unwrap();
        let (a, sweeps) = run(&are, &el, 2e-4, 1000, are_start(), Method::Auto);
        let (b, newton) = run(&are, &el, 2e-4, 1000, are_start(), Method::Newton);
        let d = rel_diff(&a, &b);
        eprintln!("arenstorf degree {s}: {d:.1e} ({sweeps:.2} sweeps, {newton:.2} Newton iterations)");
        assert!(d <= 1e-13, "arenstorf degree {s}: {a:?} vs {b:?}");
        let (b, _) = run(&rust, &el, 0.05, 400, charge_start(), Method::Newton);
        for (name, a) in [
            ("expression", run(&expr, &el, 0.05, 400, charge_start(), Method::Auto)),
            ("rust", run(&rust, &el, 0.05, 400, charge_start(), Method::Auto)),
            (
                "rust, default parts",
                run(&rust_ad, &el, 0.05, 400, charge_start(), Method::Auto),
            ),
        ] {
            let d = rel_diff(&a.0, &b);
            eprintln!("magnetic {name} degree {s}: {d:.1e} ({:.2} sweeps)", a.1);
            assert!(d <= 1e-13, "magnetic {name} degree {s}: {:?} vs {b:?}", a.0);
        }
    }
}

/// The exact position of the trapped charge at t (z = x + iy solves z'' = −i b z' − z, so
/// z = c₊ e^{iω₊t} + c₋ e^{iω₋t} with ω² + bω − 1 = 0).
fn trapped_exact(b: f64, q0: [f64; 2], v0: [f64; 2], t: f64) -> [f64; 2] {
    let d = (b * b + 4.0).sqrt();
    let (wp, wm) = ((-b + d) / 2.0, (-b - d) / 2.0);
    // c₊ = (w0 − iω₋ z0) / (i(ω₊ − ω₋)), c₋ = z0 − c₊; complex numbers as (re, im).
    let (z0, w0) = ((q0[0], q0[1]), (v0[0], v0[1]));
    let num = (w0.0 + wm * z0.1, w0.1 - wm * z0.0);
    let cp = (num.1 / (wp - wm), -num.0 / (wp - wm));
    let cm = (z0.0 - cp.0, z0.1 - cp.1);
    let rot = |c: (f64, f64), w: f64| {
        let (co, si) = ((w * t).cos(), (w * t).sin());
        (c.0 * co - c.1 * si, c.0 * si + c.1 * co)
    };
    let (a, bb) = (rot(cp, wp), rot(cm, wm));
    [a.0 + bb.0, a.1 + bb.1]
}

#[test]
fn the_gyroscopic_fixed_point_keeps_order_2s() {
    // Position errors at T = 8 against the closed form, for h, h/2, h/4: the fitted order is
    // the Gauss element's 2s.
    let (b, q0, v0, end) = (3.0, [1.0, 0.0], [0.0, 0.3], 8.0);
    let exact = trapped_exact(b, q0, v0, end);
    let lag = TrappedCharge::new(b, false);
    for (s, h0) in [(1, 0.04), (2, 0.1), (3, 0.2), (4, 0.4)] {
        let el = Element::with_order(2 * s).unwrap();
        let mut pts = vec![];
        for k in 0..3 {
            let h = h0 / f64::from(1 << k);
            let start = Start::Velocity {
                q: q0.to_vec(),
                v: v0.to_vec(),
            };
            let (state, _) = run(&lag, &el, h, (end / h).round() as usize, start, Method::Auto);
            let e = (state[0] - exact[0]).hypot(state[1] - exact[1]);
            pts.push((h.ln(), e.ln()));
        }
        let mx = pts.iter().map(|p| p.0).sum::<f64>() / 3.0;
        let my = pts.iter().map(|p| p.1).sum::<f64>() / 3.0;
        let slope = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
            / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
        let errors: Vec<f64> = pts.iter().map(|p| p.1.exp()).collect();
        eprintln!("degree {s}: errors {errors:?}, fitted order {slope:.2}");
        assert!((slope - 2.0 * s as f64).abs() <= 0.3, "degree {s}: order {slope}");
    }
}

#[test]
fn a_restored_gyroscopic_run_continues_bit_for_bit() {
    // The start of each step depends on the last steps' terms: a checkpoint carries them.
    let are = arenstorf();
    let el = Element::with_order(6).unwrap();
    let new = || {
        let start = Start::Velocity {
            q: vec![0.994, 0.0],
            v: vec![0.0, -2.001_585_106_379_082_4],
        };
        let grid = TimeGrid::uniform(0.0, 1e-3, 0.3).unwrap();
        // Stopped at a loose tolerance, the result depends on where the iteration started.
        let opts = SolverOptions {
            tolerance: 1e-9,
            polish: false,
            ..Default::default()
        };
        Integrator::new(&are, &el, grid, start, opts).unwrap()
    };
    let mut whole = new();
    while whole.step().unwrap() {}
    let mut first = new();
    first.advance(137).unwrap();
    let saved = first.checkpoint("arenstorf");
    let mut resumed = new();
    resumed.restore(&saved, "arenstorf").unwrap();
    while resumed.step().unwrap() {}
    let bits = |it: &Integrator<'_, ExprLagrangian>| -> Vec<u64> {
        let node = it.node();
        node.q.iter().chain(node.p.iter()).map(|x| x.to_bits()).collect()
    };
    assert_eq!(bits(&resumed), bits(&whole));
}

#[test]
fn energy_mode_runs_on_the_gyroscopic_fixed_point_as_on_newton() {
    // Steps as variables (the trial steps of the energy search solve the same node again and
    // again): the gyroscopic fixed point and Newton reach the same nodes up to the search's
    // amplification of round-off: the mechanical fixed point and Newton on Kepler (degree 2,
    // h = 0.01, t = 5, measured) end 7.6e-9 apart in energy mode, against ~1e-14 with fixed
    // steps; here 1.9e-8 after 100 steps.
    let lag = magnetic_expr(3.0);
    let el = Element::with_order(4).unwrap();
    let go = |method, tolerance| {
        let start = Start::Velocity {
            q: vec![1.0, 0.0],
            v: vec![0.0, 0.3],
        };
        let grid = TimeGrid::uniform(0.0, 0.05, 5.0).unwrap();
        let opts = SolverOptions {
            method,
            tolerance,
            ..Default::default()
        };
        let energy = femvi::EnergyOptions::from_step(0.05);
        let mut it = Integrator::with_energy(&lag, &el, grid, start, opts, energy).unwrap();
        while it.step().unwrap() {}
        let node = it.node();
        let mut out: Vec<f64> = node.q.iter().chain(node.p.iter()).copied().collect();
        out.push(node.t);
        out
    };
    let (a, b) = (go(Method::Auto, 1e-14), go(Method::Newton, 1e-14));
    // Both solvers polish to round-off: a looser tolerance changes neither run.
    assert_eq!(go(Method::Auto, 1e-12), a);
    assert_eq!(go(Method::Newton, 1e-12), b);
    let d = rel_diff(&a, &b);
    eprintln!("energy mode, gyroscopic vs Newton: {d:.1e}");
    assert!(d <= 1e-7, "{a:?} vs {b:?}");
}
