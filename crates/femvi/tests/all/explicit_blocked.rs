//! Explicit steps of long chains in blocks of space and time (`step/explicit_blocked.rs`,
//! issue 15): `Integrator::advance` on a Lagrangian with a local force and n ≥ 2¹⁵ takes
//! its steps in tiles. Its nodes, last element and checkpoint (the carried force and its
//! slot included) must be those of `step()`, bit for bit, for any split of a run into calls,
//! on uniform and variable grids, for radius 1 (the FPUT chain) and radius 2 with a
//! time-dependent force (a chain with second-neighbour springs, below); a run that overflows
//! must fail at the step where `step()` fails, with the same state left behind, its force
//! never shown a non-finite position. And `force_range` must give the bits of `force` on every
//! range, the chain's force the bits it had before `force_range`.

use crate::common::snapshot::{bits, chain_start, snapshot, verlet, Snapshot};
use femvi::{models, Integrator, Lagrangian, Mechanical, Potential, Scalar, SolverOptions, Start, TimeGrid};
use std::ops::Range;

/// Longer than the blocked loop's threshold (2¹⁵) and not a multiple of its tile.
const N: usize = 40_000;

/// A chain with nearest- and second-neighbour springs (fixed ends), stiffness modulated in
/// time: V = (1 + ε sin t) Σ (½ d₁² + ¼ d₁⁴) + c Σ ½ d₂², d₁ = q_{i+1} − q_i, d₂ = q_{i+2} − q_i.
/// Its force has radius 2.
struct SecondNeighbour {
    n: usize,
    eps: f64,
    c: f64,
}

impl SecondNeighbour {
    fn at(q: &[f64], i: isize) -> f64 {
        usize::try_from(i).ok().and_then(|i| q.get(i)).copied().unwrap_or(0.0)
    }
}

impl Potential for SecondNeighbour {
    fn dim(&self) -> usize {
        self.n
    }
    fn value<D: Scalar>(&self, t: D, q: &[D]) -> D {
        let at = |i: isize| {
            usize::try_from(i)
                .ok()
                .and_then(|i| q.get(i))
                .copied()
                .unwrap_or(D::from(0.0))
        };
        let mut v1 = D::from(0.0);
        let mut v2 = D::from(0.0);
        for i in -1..self.n as isize {
            let d = at(i + 1) - at(i);
            v1 += d * d * 0.5 + d * d * d * d * 0.25;
        }
        for i in -2..self.n as isize {
            let d = at(i + 2) - at(i);
            v2 += d * d * 0.5;
        }
        v1 * (t.sin() * self.eps + 1.0) + v2 * self.c
    }
    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        self.force_range(t, q, 0..self.n, out);
    }
    fn force_radius(&self) -> Option<usize> {
        Some(2)
    }
    fn force_range(&self, t: f64, q: &[f64], range: Range<usize>, out: &mut [f64]) -> bool {
        let s = 1.0 + self.eps * t.sin();
        let dv = |d: f64| d + d * d * d;
        for (i, o) in range.zip(out.iter_mut()) {
            let i = i as isize;
            let x = Self::at(q, i);
            let near = dv(Self::at(q, i + 1) - x) - dv(x - Self::at(q, i - 1));
            let far = (Self::at(q, i + 2) - x) - (x - Self::at(q, i - 2));
            *o = s * near + self.c * far;
        }
        true
    }
}

/// An on-site potential V = Σ (½ q_i² + ¼ q_i⁴): a force of radius 0.
struct OnSite(usize);

impl Potential for OnSite {
    fn dim(&self) -> usize {
        self.0
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q.iter()
            .fold(D::from(0.0), |v, &x| v + x * x * 0.5 + x * x * x * x * 0.25)
    }
    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        self.force_range(t, q, 0..self.0, out);
    }
    fn force_radius(&self) -> Option<usize> {
        Some(0)
    }
    fn force_range(&self, _t: f64, q: &[f64], range: Range<usize>, out: &mut [f64]) -> bool {
        for (x, o) in q[range].iter().zip(out.iter_mut()) {
            *o = -(x + x * x * x);
        }
        true
    }
}

/// The FPUT chain with a force that asserts that the positions it reads are finite (as
/// `step()` never shows it others), and optionally without `force_range` (a radius declared
/// alone: no blocked steps).
struct Checked {
    chain: femvi::models::FpuPotential,
    parts: bool,
}

impl Potential for Checked {
    fn dim(&self) -> usize {
        self.chain.n
    }
    fn value<D: Scalar>(&self, t: D, q: &[D]) -> D {
        self.chain.value(t, q)
    }
    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        assert!(
            q.iter().all(|x| x.is_finite()),
            "the force was shown a non-finite position"
        );
        self.chain.force(t, q, out);
    }
    fn force_radius(&self) -> Option<usize> {
        Some(1)
    }
    fn force_range(&self, t: f64, q: &[f64], range: Range<usize>, out: &mut [f64]) -> bool {
        let seen = &q[range.start.saturating_sub(1)..(range.end + 1).min(q.len())];
        assert!(
            seen.iter().all(|x| x.is_finite()),
            "the force was shown a non-finite position"
        );
        self.parts && self.chain.force_range(t, q, range, out)
    }
}

/// The snapshots after the nodes `at` (increasing) of a run by `step()`, and its error if it
/// failed (then the last snapshot is the state it left).
fn by_step<L: Lagrangian>(lag: &L, grid: &TimeGrid, start: &Start, at: &[usize]) -> (Vec<Snapshot>, Option<String>) {
    let el = verlet();
    let mut it = Integrator::new(lag, &el, grid.clone(), start.clone(), SolverOptions::default()).unwrap();
    let mut all = vec![];
    loop {
        match it.step() {
            Ok(true) if at.contains(&it.node().k) => all.push(snapshot(&it)),
            Ok(true) => {}
            Ok(false) => return (all, None),
            Err(e) => return failed(all, &it, e),
        }
    }
}

/// The snapshots of a run that failed with `e`: the state the failure left in place of its
/// last good node's (which `by_step` took before the failing step, and a call of `advance`
/// that fails on its first step ended on).
fn failed<L: Lagrangian>(
    mut all: Vec<Snapshot>,
    it: &Integrator<'_, L>,
    e: femvi::Error,
) -> (Vec<Snapshot>, Option<String>) {
    let snap = snapshot(it);
    if all.last().is_some_and(|s| s.0 == snap.0) {
        all.pop();
    }
    all.push(snap);
    (all, Some(e.to_string()))
}

/// The same run by `advance` in calls of `chunk` steps: the snapshots after each call, and
/// the error.
fn by_chunks<L: Lagrangian>(lag: &L, grid: &TimeGrid, start: &Start, chunk: usize) -> (Vec<Snapshot>, Option<String>) {
    let el = verlet();
    let mut it = Integrator::new(lag, &el, grid.clone(), start.clone(), SolverOptions::default()).unwrap();
    let mut all = vec![];
    loop {
        match it.advance(chunk) {
            Ok(0) => return (all, None),
            Ok(_) => all.push(snapshot(&it)),
            Err(e) => return failed(all, &it, e),
        }
    }
}

/// Compares calls of each chunk size with `step()` at the nodes the calls end on.
fn check<L: Lagrangian>(lag: &L, grid: &TimeGrid, start: &Start, chunks: &[usize]) -> Option<String> {
    let mut error = None;
    for &chunk in chunks {
        let (got, e) = by_chunks(lag, grid, start, chunk);
        let ends: Vec<usize> = got.iter().map(|s| s.0).collect();
        let (want, e_step) = by_step(lag, grid, start, &ends);
        assert_eq!(e, e_step, "chunk {chunk}");
        assert_eq!(got.len(), want.len(), "chunk {chunk}");
        for (g, w) in got.iter().zip(&want) {
            assert!(g == w, "chunk {chunk}: node {} differs from step()", g.0);
        }
        error = e;
    }
    error
}

#[test]
fn blocked_steps_are_the_steps_of_step_bit_for_bit() {
    let chain = models::fpu(N, 0.25, 0.1).unwrap();
    let short = TimeGrid::uniform(0.0, 0.1, 4.0).unwrap();
    let variable = TimeGrid::steps(0.0, vec![0.1, 0.17, 0.06], 4.0).unwrap();
    // Calls of one band or less (64 steps a band), on 40 and 36 steps.
    for grid in [&short, &variable] {
        assert_eq!(check(&chain, grid, &chain_start(N), &[3, 18, 35, 1000]), None);
    }
    // Calls of several bands, and around a band's length, on 200 steps; a chain whose last
    // tile is empty at the first steps of a band (40 950 = 10 tiles of 4 096 less 10).
    let long = TimeGrid::uniform(0.0, 0.1, 20.0).unwrap();
    assert_eq!(
        check(&chain, &long, &chain_start(N), &[63, 64, 65, 66, 129, 1000]),
        None
    );
    let ragged = models::fpu(40_950, 0.25, 0.0).unwrap();
    assert_eq!(check(&ragged, &long, &chain_start(40_950), &[1000]), None);
    // Radius 2 with a time-dependent force, and radius 0.
    let wide = Mechanical::unit_mass(SecondNeighbour {
        n: N + 3,
        eps: 0.3,
        c: 0.2,
    });
    assert_eq!(check(&wide, &variable, &chain_start(N + 3), &[7, 1000]), None);
    let long_variable = TimeGrid::steps(0.0, vec![0.1, 0.17, 0.06], 15.0).unwrap();
    assert_eq!(check(&wide, &long_variable, &chain_start(N + 3), &[100]), None);
    let onsite = Mechanical::unit_mass(OnSite(N));
    assert_eq!(check(&onsite, &long, &chain_start(N), &[150]), None);
    // A radius without `force_range`: the whole steps, the same bits.
    let alone = Mechanical::unit_mass(Checked {
        chain: femvi::models::FpuPotential::new(N, 0.25, 0.0).unwrap(),
        parts: false,
    });
    assert_eq!(check(&alone, &short, &chain_start(N), &[1000]), None);
}

#[test]
fn a_blocked_run_that_overflows_fails_where_step_fails() {
    // A chain thrown hard with a cubic force and a long step: it overflows at step 139, in
    // the third band of a long call. The force asserts that it never sees the non-finite
    // positions (the blocked loop stops at the first non-finite node, as `step()` does).
    // Calls that end on the failing step (70 + 69, 139: the call's last step, out of
    // place, after blocked ones) and that run past it.
    let potential = Checked {
        chain: femvi::models::FpuPotential::new(N, 0.0, 10.0).unwrap(),
        parts: true,
    };
    let chain = Mechanical::unit_mass(potential);
    let v = (0..N).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
    let start = Start::Velocity { q: vec![0.0; N], v };
    let grid = TimeGrid::uniform(0.0, 0.2, 1000.0).unwrap();
    let error = check(&chain, &grid, &start, &[70, 139, 1000]);
    assert!(error.is_some_and(|e| e.contains("finite") && e.contains("step 139")));
}

#[test]
fn force_range_gives_the_bits_of_force_on_every_range() {
    let chain = models::fpu(9, 0.25, 0.1).unwrap();
    let wide = Mechanical::unit_mass(SecondNeighbour { n: 9, eps: 0.3, c: 0.2 });
    let q: Vec<f64> = (0..9).map(|i| (1.7 * i as f64).sin()).collect();
    let mut all = [0.0; 9];
    let mut ad = [0.0; 9];
    for lag in [&chain as &dyn ForceOf, &wide] {
        lag.whole(&q, &mut all);
        for from in 0..=9 {
            for to in from..=9 {
                let mut part = vec![f64::NAN; to - from];
                lag.part(&q, from..to, &mut part);
                assert_eq!(bits(&part), bits(&all[from..to]), "{from}..{to}");
            }
        }
    }
    // The hand-coded forces are the gradients of their potentials (automatic
    // differentiation of the value), to rounding.
    wide.potential.force(0.7, &q, &mut all);
    Potential::force(&AdOnly(&wide.potential), 0.7, &q, &mut ad);
    close(&all, &ad);
    chain.potential.force(0.7, &q, &mut all);
    Potential::force(&AdOnly(&chain.potential), 0.7, &q, &mut ad);
    close(&all, &ad);
}

fn close(a: &[f64], b: &[f64]) {
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() <= 1e-14 * (1.0 + y.abs()), "{x} {y}");
    }
}

/// The FPUT force as the chain computed it before `force_range` (bond forces from the ends
/// inward, one branch per bond): the present one must give its bits.
fn fpu_force_before(n: usize, alpha: f64, beta: f64, q: &[f64]) -> Vec<f64> {
    let dv = |d: f64| d + alpha * d * d + beta * d * d * d;
    let bond = |i: usize| {
        let left = if i == 0 { 0.0 } else { q[i - 1] };
        let right = if i == n { 0.0 } else { q[i] };
        right - left
    };
    let mut out = vec![0.0; n];
    let mut prev = dv(bond(0));
    for (i, o) in out.iter_mut().enumerate() {
        let next = dv(bond(i + 1));
        *o = next - prev;
        prev = next;
    }
    out
}

#[test]
fn the_chain_force_keeps_its_bits() {
    for n in 1..=12 {
        for seed in 0..4 {
            let q: Vec<f64> = (0..n)
                .map(|i| (0.9 * (i + 7 * seed) as f64).sin() * 10f64.powi(seed as i32 - 2))
                .collect();
            let chain = models::fpu(n, 0.25, 0.7).unwrap();
            let mut out = vec![f64::NAN; n];
            chain.force(0.0, &q, &mut out);
            assert_eq!(bits(&out), bits(&fpu_force_before(n, 0.25, 0.7, &q)), "n = {n}");
        }
    }
}

/// A potential with the default (automatic differentiation) force.
struct AdOnly<'a, P>(&'a P);

impl<P: Potential> Potential for AdOnly<'_, P> {
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn value<D: Scalar>(&self, t: D, q: &[D]) -> D {
        self.0.value(t, q)
    }
}

/// `force` and `force_range` of a Lagrangian at t = 0.7, object-safe for the loop above.
trait ForceOf {
    fn whole(&self, q: &[f64], out: &mut [f64]);
    fn part(&self, q: &[f64], range: Range<usize>, out: &mut [f64]);
}

impl<L: Lagrangian> ForceOf for L {
    fn whole(&self, q: &[f64], out: &mut [f64]) {
        self.force(0.7, q, out);
    }
    fn part(&self, q: &[f64], range: Range<usize>, out: &mut [f64]) {
        assert!(self.force_range(0.7, q, range, out));
    }
}
