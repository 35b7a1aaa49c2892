//! The fixed-point step across lanes: [`LANES`] members of one run of a mechanical
//! Lagrangian (M = I, V autonomous) whose element is solved by the fixed-point iteration on
//! the stage forces (`step/fixed_point_step.rs`: Y_l = h a_l u + h² Σ_i B_li f(q_k + Y_i),
//! then ΔQ^m = h α_m u + h² Σ_i β_mi f_i and Δp = h Σ_i b_i f_i, DESIGN.md §2), advanced a step
//! at a time together. Every lane does its single run's operations in the same order: the
//! start from the last step's stage forces (`StageStart::plain_table`) or from the initial
//! velocity / the last element's polynomial, the sweeps with the stopping rule of
//! `Judge` (in lanes: `ensemble/judge.rs`), the update with the coefficients' rounding
//! errors as a second sum, and the compensated sums of the node, so each lane has its
//! member's bits.
//!
//! Lanes sweep until the last of them stops; a lane that has stopped keeps the forces of its
//! last sweep (the ones its step is made of) and its later sweeps are not read. A lane whose
//! iteration fails, whose new node is not finite or whose energy there is not finite ends as
//! its single run does, and is not read again. Rules of up to [`MAX_POINTS`] points (the
//! start then never takes the extra force evaluations of `step/start.rs`, which rules of
//! four points and more may) and degrees up to the same.

use super::energy::{end_at, start_failed, Energy};
use super::judge::{LaneJudge, CONTINUE, CONVERGED, NON_FINITE, NOT_CONVERGED, STALLED};
use super::verlet::Starts;
use super::{MemberEnd, GROUPS};
use crate::discrete::Element;
use crate::error::{Error, StepError, StepFailure};
use crate::lagrangian::{Lagrangian, Lanes, LANES};
use crate::step::fixed_point::{FixedPointTables, StepTables};
use crate::step::{SolverOptions, StageStart, TimeGrid, COEFFICIENT_ROUNDING};

/// The most quadrature points (and the highest degree) of an element whose steps go in lanes.
pub(crate) const MAX_POINTS: usize = 3;

/// A value per stage (or element node), coordinate and lane.
type Stages<const N: usize> = [[Lanes; N]; MAX_POINTS];

/// What the fixed-point lanes take from the run besides its Lagrangian and grid.
#[derive(Debug, Clone)]
pub(crate) struct Plan<'a> {
    pub(crate) element: &'a Element,
    pub(crate) opts: SolverOptions,
    pub(crate) tab: FixedPointTables,
}

/// The node of every lane with the compensation terms of its sums (`RunState`).
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Node<const N: usize> {
    q: [Lanes; N],
    cq: [Lanes; N],
    p: [Lanes; N],
    cp: [Lanes; N],
}

/// One group of [`LANES`] members: the node, the iteration's stages and forces, what the
/// next step starts from, the energy tracker and how members ended.
#[repr(C, align(64))]
struct Group<const N: usize> {
    node: Node<N>,
    v0: [Lanes; N],
    /// Stage displacements Y_l, and the positions q_k + Y_l of a sweep.
    y: Stages<N>,
    pos: Stages<N>,
    /// The forces of each lane's last sweep (its step's), and of the sweep under way.
    f: Stages<N>,
    fnew: Stages<N>,
    /// The last accepted step's stage forces (the next start's data).
    data: Stages<N>,
    /// The last element's node increments, nodes 0 … s.
    incr: [[Lanes; N]; MAX_POINTS + 1],
    energy: Energy,
    /// Members still running.
    alive: [bool; LANES],
    ends: Vec<Option<MemberEnd>>,
}

/// The members of `starts` (two groups of [`LANES`]) from t0 to the end of `grid`; one
/// [`MemberEnd`] per lane, as [`super::verlet::run`] gives them. The two groups go through
/// each step together, sweep by sweep, so that the processor overlaps one group's chain of
/// dependent operations with the other's. Inlined into each instruction-set variant
/// (`ensemble/mod.rs`).
#[inline(always)]
pub(super) fn run<L: Lagrangian, const N: usize>(
    lag: &L,
    grid: &TimeGrid,
    plan: &Plan<'_>,
    [s0, s1]: &[Starts<N>; GROUPS],
) -> Vec<MemberEnd> {
    let (el, tab, opts) = (plan.element, &plan.tab, &plan.opts);
    let (deg, r) = (el.degree(), el.points());
    let exact = opts.polish && COEFFICIENT_ROUNDING;
    let t0 = grid.t0();
    let (mut g0, mut g1) = (Group::new(lag, t0, s0), Group::new(lag, t0, s1));
    let mut tables = StepTables::new(deg, r);
    let mut start = StageStart::new(el, N);
    let (mut k, mut t, mut last_h, mut k1) = (0usize, t0, f64::NAN, 1.0);
    let uniform = grid.uniform_rule();
    while g0.running() || g1.running() {
        let next = match &uniform {
            Some(u) => u.next(k1, t),
            None => grid.next(k, t),
        };
        let Some((h, t_next)) = next else { break };
        if tables.h_bits != h.to_bits() {
            tables.build(tab, &el.rule.weights, h);
        }
        let mut stage_t = [0.0; MAX_POINTS];
        for (st, c) in stage_t.iter_mut().zip(&el.rule.nodes) {
            *st = t + c * h;
        }
        let stage_t = &stage_t[..r];
        // The single run's choice (`FixedPointStep::solve`): after an accepted step whose
        // length is within 2× of this one, from its stage forces.
        let rho = if k > 0 { h / last_h } else { f64::NAN };
        if (0.5..=2.0).contains(&rho) {
            let mat = start.plain_table(el, tab, h, last_h);
            g0.start_from_forces(r, &tables.ha, mat);
            g1.start_from_forces(r, &tables.ha, mat);
        } else {
            g0.start_from_guess(el, h, last_h, k > 0);
            g1.start_from_guess(el, h, last_h, k > 0);
        }
        let (mut i0, mut i1) = (g0.iteration(opts), g1.iteration(opts));
        loop {
            let (a0, a1) = (i0.running(), i1.running());
            if !(a0 || a1) {
                break;
            }
            if a0 {
                g0.sweep_judged(lag, &tables, stage_t, &mut i0, (k, t));
            }
            if a1 {
                g1.sweep_judged(lag, &tables, stage_t, &mut i1, (k, t));
            }
        }
        for g in [&mut g0, &mut g1] {
            let (dq, dp) = g.update(&tables, deg, r, exact);
            g.commit(lag, (&dq, &dp), (k, t), t_next);
            g.data = g.f;
        }
        last_h = h;
        k += 1;
        k1 += 1.0;
        t = t_next;
    }
    let mut ends = g0.ends_at((k, t));
    ends.extend(g1.ends_at((k, t)));
    ends
}

/// The fixed-point iteration of one group under way: the stopping rule's memory, the lanes
/// still sweeping, the sweeps so far and each lane's max |q_k| (`RunState::qscale`).
struct Iteration {
    judge: LaneJudge,
    /// 1 for the lanes still sweeping, 0 for the others (numbers, for vector compares).
    active: Lanes,
    sweeps: usize,
    qscale: Lanes,
}

impl Iteration {
    fn running(&self) -> bool {
        self.active.iter().fold(0.0, |a, &b| a + b) > 0.0
    }
}

impl<const N: usize> Group<N> {
    /// Stages from the last step's stage forces: y_l = h a_l u + Σ_j mat_jl w_j
    /// (`StageStart::start` without extra evaluations; `mat` column-major r × r).
    #[inline(always)]
    fn start_from_forces(&mut self, r: usize, ha: &[f64], mat: &[f64]) {
        let u = &self.node.p;
        for (i, &hai) in ha.iter().enumerate().take(r) {
            for c in 0..N {
                // Lanes innermost, so that each line is a vector operation.
                let mut z = [0.0; LANES];
                for l in 0..LANES {
                    z[l] = hai * u[c][l];
                }
                for j in 0..r {
                    let m = mat[j * r + i];
                    for l in 0..LANES {
                        z[l] += m * self.data[j][c][l];
                    }
                }
                self.y[i][c] = z;
            }
        }
    }

    /// Stages from predicted node increments (`Guess::predict`, then
    /// `FixedPointStep::start_from_guess`): X^m = c_m h v0 on the first step, else the last
    /// element's polynomial extrapolated over the new step.
    #[inline(never)]
    fn start_from_guess(&mut self, el: &Element, h: f64, last_h: f64, after_step: bool) {
        let s = el.degree();
        let nodes = &el.basis.nodes;
        let mut x = [[[0.0; LANES]; N]; MAX_POINTS];
        if after_step {
            let rho = h / last_h;
            let mut row = [0.0; MAX_POINTS + 1];
            for m in 1..=s {
                el.basis.values_in_place(1.0 + nodes[m] * rho, &mut row[..=s]);
                for c in 0..N {
                    for l in 0..LANES {
                        let mut acc = 0.0;
                        for (j, w) in row[..=s].iter().enumerate() {
                            acc += w * (self.incr[j][c][l] - self.incr[s][c][l]);
                        }
                        x[m - 1][c][l] = acc;
                    }
                }
            }
        } else {
            for m in 1..=s {
                for c in 0..N {
                    for l in 0..LANES {
                        x[m - 1][c][l] = nodes[m] * h * self.v0[c][l];
                    }
                }
            }
        }
        for i in 0..el.points() {
            for c in 0..N {
                for l in 0..LANES {
                    self.y[i][c][l] = (1..=s).map(|m| el.phi(i, m) * x[m - 1][c][l]).sum();
                }
            }
        }
    }

    /// A group at its start: the start's energy shown to the tracker (a lane whose energy
    /// is not finite ends there).
    fn new<L: Lagrangian>(lag: &L, t0: f64, s: &Starts<N>) -> Self {
        let zero = [[0.0; LANES]; N];
        let mut g = Group {
            node: Node {
                q: s.q,
                cq: zero,
                p: s.p,
                cp: zero,
            },
            v0: s.v,
            y: [zero; MAX_POINTS],
            pos: [zero; MAX_POINTS],
            f: [zero; MAX_POINTS],
            fnew: [zero; MAX_POINTS],
            data: [zero; MAX_POINTS],
            incr: [zero; MAX_POINTS + 1],
            energy: Energy::blank(),
            alive: [true; LANES],
            ends: vec![None; LANES],
        };
        let bad = g.energy.node(lag, t0, &g.node.q, &g.node.p);
        start_failed::<N>(&mut g.ends, &bad, &g.energy, t0);
        g.alive = std::array::from_fn(|l| !bad[l]);
        g
    }

    /// Whether a member of the group is still running.
    fn running(&self) -> bool {
        self.alive.iter().fold(false, |a, &b| a | b)
    }

    /// Every lane's end: the members still running at node (k, t), the others where they
    /// ended.
    fn ends_at(self, at: (usize, f64)) -> Vec<MemberEnd> {
        let Group { node, energy, ends, .. } = self;
        ends.into_iter()
            .enumerate()
            .map(|(l, e)| e.unwrap_or_else(|| end_at(&node.q, &node.p, &energy, l, at)))
            .collect()
    }

    /// The iteration of the step from the current node, before its first sweep.
    #[inline(always)]
    fn iteration(&self, opts: &SolverOptions) -> Iteration {
        // max(m, |q|) as `RunState::qscale` folds it: a select, which vectorises (the same
        // value, m being positive and |q| never −0).
        let mut qscale = [f64::MIN_POSITIVE; LANES];
        for c in 0..N {
            for l in 0..LANES {
                let a = self.node.q[c][l].abs();
                qscale[l] = if a > qscale[l] { a } else { qscale[l] };
            }
        }
        Iteration {
            judge: LaneJudge::new(opts),
            active: self.alive.map(|a| if a { 1.0 } else { 0.0 }),
            sweeps: 0,
            qscale,
        }
    }

    /// One sweep of the lanes still iterating (`FixedPointStep::iterate`), judged: a lane that
    /// stops keeps this sweep's forces; one whose iteration fails ends at node (k, t) with
    /// its single run's error.
    #[inline(always)]
    fn sweep_judged<L: Lagrangian>(
        &mut self,
        lag: &L,
        tables: &StepTables,
        stage_t: &[f64],
        it: &mut Iteration,
        at: (usize, f64),
    ) {
        it.sweeps += 1;
        let (mut delta, mut ymax, probe) = self.sweep(lag, tables, stage_t);
        for l in 0..LANES {
            if probe[l].is_nan() {
                (delta[l], ymax[l]) = (f64::NAN, f64::NAN);
            }
        }
        let verdicts = it.judge.sweep(&delta, &ymax, &it.qscale, it.sweeps);
        // Masks as numbers (1 or 0), so that these loops are vector compares and selects.
        let (mut take, mut fails) = ([0.0; LANES], [0.0; LANES]);
        for l in 0..LANES {
            let (v, a) = (verdicts[l], it.active[l] != 0.0);
            take[l] = if a & (v <= CONVERGED) { 1.0 } else { 0.0 };
            fails[l] = if a & (v > CONVERGED) { 1.0 } else { 0.0 };
            it.active[l] = if a & (v == CONTINUE) { 1.0 } else { 0.0 };
        }
        if fails.iter().fold(0.0, |a, &b| a + b) > 0.0 {
            self.iteration_failed(&fails, &verdicts, &delta, (it.sweeps, at));
        }
        for i in 0..stage_t.len() {
            for c in 0..N {
                for l in 0..LANES {
                    self.f[i][c][l] = if take[l] != 0.0 {
                        self.fnew[i][c][l]
                    } else {
                        self.f[i][c][l]
                    };
                }
            }
        }
    }

    /// The lanes that `fails` marks (1: a lane that was sweeping, whose verdict is a
    /// failure; not one that stopped at an earlier sweep, whose later verdicts are not read)
    /// end at node (k, t) with their single run's error (the change `delta` as its residual,
    /// after `sweeps` sweeps).
    #[inline(never)]
    fn iteration_failed(
        &mut self,
        fails: &Lanes,
        verdicts: &Lanes,
        delta: &Lanes,
        (sweeps, (k, t)): (usize, (usize, f64)),
    ) {
        for l in 0..LANES {
            if fails[l] == 0.0 {
                continue;
            }
            let failure = match verdicts[l] {
                v if v == NON_FINITE => StepFailure::NonFinite,
                v if v == STALLED => StepFailure::Stalled,
                v if v == NOT_CONVERGED => StepFailure::NotConverged,
                _ => continue,
            };
            if self.alive[l] {
                let error = StepError {
                    step: k,
                    t,
                    residual: delta[l],
                    iterations: sweeps,
                    failure,
                };
                self.end(l, (k, t), k, Error::Step(error));
            }
        }
    }

    /// One sweep in every lane (`fixed_point_sweep`): the forces at q_k + Y_l, then
    /// Y_l ← h a_l u + h² Σ_i B_li f_i. Returns per lane the largest |ΔY|, the largest |Y| and
    /// the finiteness probe (Σ Y·0, NaN where a value is not finite).
    #[inline(always)]
    fn sweep<L: Lagrangian>(&mut self, lag: &L, tables: &StepTables, stage_t: &[f64]) -> (Lanes, Lanes, Lanes) {
        let r = stage_t.len();
        for i in 0..r {
            for c in 0..N {
                for l in 0..LANES {
                    self.pos[i][c][l] = self.node.q[c][l] + self.y[i][c][l];
                }
            }
            lag.force_lanes(stage_t[i], &self.pos[i], &mut self.fnew[i]);
        }
        let (ha, h2b) = (&tables.ha, &tables.h2b);
        let (mut delta, mut ymax, mut probe) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        for c in 0..N {
            for (i, &hai) in ha.iter().enumerate().take(r) {
                let mut z = [0.0; LANES];
                for l in 0..LANES {
                    z[l] = hai * self.node.p[c][l];
                }
                for j in 0..r {
                    let m = h2b[j * r + i];
                    for l in 0..LANES {
                        z[l] += m * self.fnew[j][c][l];
                    }
                }
                for l in 0..LANES {
                    let d = (z[l] - self.y[i][c][l]).abs();
                    delta[l] = if d > delta[l] { d } else { delta[l] };
                    ymax[l] = if z[l].abs() > ymax[l] { z[l].abs() } else { ymax[l] };
                    probe[l] += z[l] * 0.0;
                }
                self.y[i][c] = z;
            }
        }
        (delta, ymax, probe)
    }

    /// The node increments ΔQ^m = h α_m u + h² Σ_i β_mi f_i (into `incr`) and the momentum
    /// increment h Σ_i b_i f_i, each with its coefficients' rounding errors as a second sum
    /// when `exact` (`FixedPointStep::update`). Returns (ΔQ^s, Δp).
    #[inline(always)]
    fn update(&mut self, st: &StepTables, s: usize, r: usize, exact: bool) -> ([Lanes; N], [Lanes; N]) {
        // Each sum lanes innermost (a vector operation per term), in the single run's order.
        let affine = |a: f64, m: &[f64], f: &Stages<N>, u: &Lanes, row: usize, c: usize| {
            let mut z = [0.0; LANES];
            for l in 0..LANES {
                z[l] = a * u[l];
            }
            for i in 0..r {
                let mi = m[i * s + row];
                for l in 0..LANES {
                    z[l] += mi * f[i][c][l];
                }
            }
            z
        };
        let weighted = |w: &[f64], f: &Stages<N>, c: usize| {
            let mut z = [0.0; LANES];
            for i in 0..r {
                for l in 0..LANES {
                    z[l] += w[i] * f[i][c][l];
                }
            }
            z
        };
        for row in 0..s {
            for c in 0..N {
                let mut z = affine(st.h_alpha[row], &st.h2_beta, &self.f, &self.node.p[c], row, c);
                if exact {
                    let lo = affine(st.h_alpha_lo[row], &st.h2_beta_lo, &self.f, &self.node.p[c], row, c);
                    for l in 0..LANES {
                        z[l] += lo[l];
                    }
                }
                self.incr[row + 1][c] = z;
            }
        }
        let mut dp = [[0.0; LANES]; N];
        for c in 0..N {
            let mut hi = weighted(&st.hw, &self.f, c);
            if exact {
                let lo = weighted(&st.hw_lo, &self.f, c);
                for l in 0..LANES {
                    hi[l] += lo[l];
                }
            }
            dp[c] = hi;
        }
        (self.incr[s], dp)
    }

    /// Moves every lane to its new node (`RunState::commit`: compensated sums), which the
    /// energy tracker is then shown at (k + 1, t_next). A running lane whose new node is
    /// not finite ends at (k, t) with the step's error; one whose energy there is not finite
    /// ends there too, with the step counted.
    #[inline(always)]
    fn commit<L: Lagrangian>(
        &mut self,
        lag: &L,
        (dq, dp): (&[Lanes; N], &[Lanes; N]),
        (k, t): (usize, f64),
        t_next: f64,
    ) {
        let old = self.node;
        let mut probe = [0.0; LANES];
        for c in 0..N {
            for l in 0..LANES {
                let (q, cq) = (old.q[c][l], old.cq[c][l]);
                let y = dq[c][l] + cq;
                let tq = q + y;
                self.node.cq[c][l] = (q - tq) + y;
                self.node.q[c][l] = tq;
                let (p, cp) = (old.p[c][l], old.cp[c][l]);
                let y = dp[c][l] + cp;
                let tp = p + y;
                self.node.cp[c][l] = (p - tp) + y;
                self.node.p[c][l] = tp;
                probe[l] += tq * 0.0 + tp * 0.0;
            }
        }
        let failed = probe.iter().fold(false, |a, x| a | x.is_nan());
        if failed {
            for (l, x) in probe.iter().enumerate() {
                if x.is_nan() && self.alive[l] {
                    let error = StepError {
                        step: k,
                        t,
                        residual: f64::NAN,
                        iterations: 0,
                        failure: StepFailure::NonFinite,
                    };
                    self.end_from(&old, l, (k, t), k, Error::Step(error));
                }
            }
        }
        let bad = self.energy.node(lag, t_next, &self.node.q, &self.node.p);
        if bad.iter().fold(false, |a, &b| a | b) {
            for (l, &b) in bad.iter().enumerate() {
                if b && self.alive[l] {
                    let error = Error::NonFiniteEnergy { step: k + 1, t: t_next };
                    self.end_from(&old, l, (k, t), k + 1, error);
                }
            }
        }
    }

    /// Lane l ends at the group's current node (k, t) after `steps` steps with `error`.
    fn end(&mut self, l: usize, at: (usize, f64), steps: usize, error: Error) {
        let node = self.node;
        self.end_from(&node, l, at, steps, error);
    }

    /// Lane l ends at `node` (its node (k, t)) after `steps` steps with `error`.
    #[inline(never)]
    fn end_from(&mut self, node: &Node<N>, l: usize, at: (usize, f64), steps: usize, error: Error) {
        let mut e = end_at(&node.q, &node.p, &self.energy, l, at);
        e.steps = steps;
        e.error = Some(error);
        if let Some(slot) = self.ends.get_mut(l) {
            *slot = Some(e);
        }
        if let Some(a) = self.alive.get_mut(l) {
            *a = false;
        }
    }
}
