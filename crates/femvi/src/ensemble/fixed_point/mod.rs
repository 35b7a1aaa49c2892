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

mod node;
mod sweep;

use super::energy::{end_at, start_failed, Energy};
use super::judge::LaneJudge;
use super::verlet::Starts;
use super::{MemberEnd, GROUPS};
use crate::discrete::Element;
use crate::error::Error;
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
        // The inner nodes' increments are read only by a start from the last element's
        // polynomial, which the next step takes if its length is not within 2× of this one.
        let after = match &uniform {
            Some(u) => u.next(k1 + 1.0, t_next),
            None => grid.next(k + 1, t_next),
        };
        let inner = after.is_some_and(|(h2, _)| !(0.5..=2.0).contains(&(h2 / h)));
        for g in [&mut g0, &mut g1] {
            let (dq, dp) = g.update(&tables, (deg, r), exact, inner);
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
        let at_start = g.energy.node(lag, t0, &g.node.q, &g.node.p);
        let bad = at_start.bad();
        start_failed::<N>(&mut g.ends, (g.energy, at_start), t0);
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
