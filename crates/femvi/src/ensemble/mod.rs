//! Ensembles in SIMD lanes (issue 39 item 2): many runs of one problem (the same Lagrangian,
//! element and time grid) that differ only in their start, taken [`LANES`] at a time, one
//! member per lane of a vector register. A run of L = ½|v|² − V(q) (M = I, V autonomous)
//! qualifies when its steps are Störmer–Verlet (degree 1 with the trapezoid rule, the
//! paper's linear element §2.3; `verlet.rs`; the sizes of [`VERLET_LANE_DIMENSIONS`]) or the
//! fixed-point iteration of an element of up to three quadrature points and degree 3 (the
//! sizes of [`LANE_DIMENSIONS`]; `fixed_point/`, the stage equations of
//! DESIGN.md §2 with the single run's stopping rule in lanes, `judge.rs`): [`run_in_lanes`]
//! then advances [`LANES`] members a step at a time through [`Lagrangian::force_lanes`] and
//! [`Lagrangian::potential_lanes`], with
//! each member's numbers those of its single run ([`crate::step::drive()`] with an
//! [`crate::solution::EnergyTracker`] at every node) bit for bit: the same IEEE operations
//! in the same order, lane by lane. The loop is compiled three times, for AVX-512, AVX2
//! and the baseline instruction set, and the processor's best is taken at run time; no
//! variant contracts a product and a sum into a fused multiply-add (Rust never does), so
//! all three give the same bits. Chunks of [`LANES`] members run in parallel on rayon's
//! current pool (threads × lanes).
//!
//! # Example
//!
//! ```
//! use femvi::ensemble::{in_lanes, run_in_lanes};
//! use femvi::step::{drive, Observer};
//! use femvi::solution::EnergyTracker;
//! use femvi::{models, Element, Integrator, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};
//!
//! let kepler = models::kepler(1.0)?;
//! let verlet = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid)?;
//! let grid = TimeGrid::uniform(0.0, 0.01, 10.0)?;
//! let starts: Vec<Start> = (0..20)
//!     .map(|i| Start::Momentum { q: vec![1.0, 0.0], p: vec![0.0, 0.8 + 0.01 * i as f64] })
//!     .collect();
//! let template = Integrator::new(&kepler, &verlet, grid.clone(), starts[0].clone(), SolverOptions::default())?;
//! assert!(in_lanes(&template));
//! let ends = run_in_lanes(&template, &starts, &|_| {}).expect("Störmer–Verlet on Kepler");
//!
//! // Member 7 against its single run.
//! let mut single = Integrator::new(&kepler, &verlet, grid, starts[7].clone(), SolverOptions::default())?;
//! while single.step()? {}
//! let end = ends[7].as_ref().expect("member 7 starts");
//! assert_eq!(end.q, single.node().q);
//! assert_eq!(end.p, single.node().p);
//! assert_eq!(end.steps, 1000);
//! # Ok::<(), femvi::Error>(())
//! ```

mod energy;
mod fixed_point;
mod judge;
mod verlet;

pub use crate::lagrangian::{Lanes, LANES};

use crate::discrete::Element;
use crate::error::{Error, Result};
use crate::lagrangian::Lagrangian;
use crate::step::fixed_point::FixedPointTables;
use crate::step::initial_node;
use crate::step::SolverOptions;
use crate::step::{Integrator, Start, TimeGrid};
use fixed_point::Plan;
use rayon::prelude::*;
use verlet::Starts;

/// How a member of an ensemble ended: what its single run ends with.
#[derive(Debug, Clone, PartialEq)]
pub struct MemberEnd {
    /// Index of the last node (the steps taken from t0).
    pub k: usize,
    /// Its time.
    pub t: f64,
    /// Positions there.
    pub q: Vec<f64>,
    /// Momenta there, as [`Integrator::node`] gives them.
    pub p: Vec<f64>,
    /// Steps taken.
    pub steps: usize,
    /// The largest relative energy error |H − H0| / |H0| over the nodes, as
    /// [`crate::solution::EnergyTracker`] reports it when shown every node.
    pub energy_error: f64,
    /// The step that failed (a node that is not finite), if any.
    pub error: Option<Error>,
}

/// The numbers of coordinates whose members take the fixed-point step in lanes (each size is
/// a loop compiled for it): up to 6 the carried values stay in registers; 8, 9 and 12 (two or
/// three bodies in the plane or in space, four in the plane) spill some of them.
pub const LANE_DIMENSIONS: [usize; 9] = [1, 2, 3, 4, 5, 6, 8, 9, 12];

/// The numbers of coordinates whose members take Störmer–Verlet steps in lanes: those for
/// which a single run takes the fixed-size loop of `step/explicit.rs` (`fast_explicit` in
/// `step/integrator.rs`), whose operations the lanes repeat; a single run of another size
/// sums the drift in another order, so its lanes would not have its bits.
pub const VERLET_LANE_DIMENSIONS: [usize; 5] = [1, 2, 3, 4, 6];

/// Whether members of the run `template` (an integrator at its start) step in lanes: M = I,
/// L autonomous, and its steps are either Störmer–Verlet ([`Integrator::step`] takes the
/// explicit solver) with n one of [`VERLET_LANE_DIMENSIONS`], or the fixed-point iteration of
/// an element of degree and points at most 3 (Gauss–Legendre of degree 2 or 3, the implicit
/// midpoint rule, …) with n one of [`LANE_DIMENSIONS`]; no force, constraint or energy mode.
/// See the [module](self) for an example.
pub fn in_lanes<L: Lagrangian>(template: &Integrator<'_, L>) -> bool {
    let lag = template.lagrangian();
    let mechanical = lag.mass_matrix().is_some_and(|m| m.is_identity()) && lag.is_autonomous();
    let n = lag.dim();
    let el = template.element();
    // Rules of fewer than `RICH_START_POINTS` points start every step from the last one's
    // stage forces alone, which is what the fixed-point lanes do.
    const _: () = assert!(fixed_point::MAX_POINTS < crate::step::RICH_START_POINTS);
    const _: () = assert!(fixed_point::MAX_POINTS <= crate::step::START_MAX_POINTS);
    let fixed_point = template.plain_fixed_point()
        && el.points() <= fixed_point::MAX_POINTS
        && el.degree() <= fixed_point::MAX_POINTS;
    mechanical
        && ((template.plain_explicit() && VERLET_LANE_DIMENSIONS.contains(&n))
            || (fixed_point && LANE_DIMENSIONS.contains(&n)))
}

/// Runs the members `starts` of the run `template` (its Lagrangian and grid) to the end of
/// the grid, [`LANES`] at a time, chunks in parallel on rayon's current pool; `done(m)` is
/// called as chunks of m members finish (for a progress display). Member i's entry is its
/// [`MemberEnd`], or the error its start gives ([`Integrator::new`]'s: a wrong length, a
/// non-finite number, a start from two positions). None if [`in_lanes`] does not hold. See
/// the [module](self) for an example; [`EnsembleLanes`] is the same with a choice of width,
/// and without holding the template (which is not `Sync`) across the parallel work.
pub fn run_in_lanes<L: Lagrangian + Sync>(
    template: &Integrator<'_, L>,
    starts: &[Start],
    done: &(dyn Fn(usize) + Sync),
) -> Option<Vec<Result<MemberEnd>>> {
    EnsembleLanes::of(template).map(|lanes| lanes.run(starts, done))
}

/// The members of one run in lanes: its Lagrangian and grid, and the compiled width.
///
/// ```
/// use femvi::ensemble::{EnsembleLanes, Width};
/// use femvi::{models, Element, Integrator, SolverOptions, Start, TimeGrid};
/// let hh = models::henon_heiles();
/// let verlet = Element::galerkin(1, femvi::NodeFamily::Equispaced, femvi::QuadratureKind::Trapezoid)?;
/// let grid = TimeGrid::uniform(0.0, 0.05, 5.0)?;
/// let starts: Vec<Start> = (0..9).map(|i| Start::Momentum { q: vec![0.0, 0.1], p: vec![0.05 * i as f64, 0.0] }).collect();
/// let template = Integrator::new(&hh, &verlet, grid, starts[0].clone(), Default::default())?;
/// let lanes = EnsembleLanes::of(&template).expect("Störmer–Verlet on a mechanical system");
/// let portable = lanes.width(Width::Portable).run(&starts, &|_| {});
/// let best = lanes.run(&starts, &|_| {});
/// assert_eq!(portable, best);
/// # Ok::<(), femvi::Error>(())
/// ```
#[derive(Debug)]
pub struct EnsembleLanes<'a, L> {
    lag: &'a L,
    grid: &'a TimeGrid,
    width: Width,
    /// The element and options of a fixed-point run (None: Störmer–Verlet).
    fixed_point: Option<(&'a Element, SolverOptions)>,
}

// References only: copied whatever L is (a derive would ask L: Copy).
impl<L> Clone for EnsembleLanes<'_, L> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<L> Copy for EnsembleLanes<'_, L> {}

impl<'a, L: Lagrangian + Sync> EnsembleLanes<'a, L> {
    /// The lanes of `template`'s run (an integrator at its start), with the widest loop the
    /// processor has; None if [`in_lanes`] does not hold.
    pub fn of(template: &'a Integrator<'_, L>) -> Option<Self> {
        in_lanes(template).then(|| EnsembleLanes {
            lag: template.lagrangian(),
            grid: template.grid(),
            width: Width::Best,
            fixed_point: template
                .plain_fixed_point()
                .then(|| (template.element(), *template.options())),
        })
    }

    /// The same with the loop compiled for `width` (every width gives the same bits).
    pub fn width(self, width: Width) -> Self {
        EnsembleLanes { width, ..self }
    }

    /// Runs the members `starts` as [`run_in_lanes`] does.
    pub fn run(&self, starts: &[Start], done: &(dyn Fn(usize) + Sync)) -> Vec<Result<MemberEnd>> {
        let (lag, grid, width) = (self.lag, self.grid, self.width);
        let plan = match self.fixed_point {
            None => None,
            Some((element, opts)) => match FixedPointTables::new(element) {
                Ok(tab) => Some(Plan { element, opts, tab }),
                // `Integrator::new` built the same tables for the template.
                Err(e) => return starts.iter().map(|_| Err(e.clone())).collect(),
            },
        };
        let plan = plan.as_ref();
        macro_rules! sized {
            ($N:literal) => {
                starts
                    .par_chunks(CHUNK)
                    .flat_map_iter(|chunk| {
                        let ends = chunk_of::<L, $N>(lag, grid, plan, chunk, width);
                        done(chunk.len());
                        ends
                    })
                    .collect()
            };
        }
        match lag.dim() {
            1 => sized!(1),
            2 => sized!(2),
            3 => sized!(3),
            4 => sized!(4),
            5 => sized!(5),
            6 => sized!(6),
            8 => sized!(8),
            9 => sized!(9),
            // `of` admits no other size.
            _ => sized!(12),
        }
    }
}

/// Which compiled variant of the lane loop runs ([`EnsembleLanes::width`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Width {
    /// The widest the processor has.
    Best,
    /// The baseline instruction set (SSE2 on x86-64).
    Portable,
    /// AVX2 (if the processor has it; the portable loop otherwise).
    Avx2,
    /// AVX-512F (if the processor has it; the portable loop otherwise).
    Avx512,
}

/// Groups of [`LANES`] members a loop advances together: two, whose chains of dependent
/// operations the processor overlaps (Kepler, AVX-512, criterion, before members checked
/// their energy: 4.2 ns per member-step with one group, 3.9 with two; with the energy, on
/// the `lanes` binary: three and four groups were no faster than two, four slower, 0.8 s
/// against 0.37 s, from spilled registers).
pub(crate) const GROUPS: usize = 2;

/// Members a loop advances together.
pub(crate) const CHUNK: usize = GROUPS * LANES;

/// A member's start as a node: q0, p0 and v0.
type StartNode = (Vec<f64>, Vec<f64>, Vec<f64>);

/// One chunk of at most [`CHUNK`] members: the starts checked and made into nodes, the
/// lanes of members whose start fails filled with a member that starts (their numbers
/// dropped), and the loop of `width`.
pub(crate) fn chunk_of<L: Lagrangian, const N: usize>(
    lag: &L,
    grid: &TimeGrid,
    plan: Option<&Plan<'_>>,
    chunk: &[Start],
    width: Width,
) -> Vec<Result<MemberEnd>> {
    let t0 = grid.t0();
    let nodes: Vec<Result<StartNode>> = chunk.iter().map(|s| initial_node(lag, t0, s.clone())).collect();
    let Some(fill) = nodes.iter().find_map(|n| n.as_ref().ok()) else {
        // No member of the chunk starts: their errors are all there is.
        return nodes.into_iter().filter_map(Result::err).map(Err).collect();
    };
    let mut s = [(); GROUPS].map(|_| Starts {
        q: [[0.0; LANES]; N],
        p: [[0.0; LANES]; N],
        v: [[0.0; LANES]; N],
    });
    for (m, group) in s.iter_mut().enumerate() {
        for l in 0..LANES {
            let (q, p, v) = match nodes.get(m * LANES + l) {
                Some(Ok(node)) => node,
                _ => fill,
            };
            for i in 0..N {
                group.q[i][l] = q.get(i).copied().unwrap_or(f64::NAN);
                group.p[i][l] = p.get(i).copied().unwrap_or(f64::NAN);
                group.v[i][l] = v.get(i).copied().unwrap_or(f64::NAN);
            }
        }
    }
    let ends = run_width::<L, N>(lag, grid, plan, &s, width);
    nodes
        .into_iter()
        .zip(ends)
        .map(|(node, end)| node.map(|_| end))
        .collect()
}

/// The lane loop (Störmer–Verlet, or the fixed-point step of `plan`) compiled for `width`
/// (or the best the processor has).
fn run_width<L: Lagrangian, const N: usize>(
    lag: &L,
    grid: &TimeGrid,
    plan: Option<&Plan<'_>>,
    s: &[Starts<N>; GROUPS],
    width: Width,
) -> Vec<MemberEnd> {
    #[cfg(target_arch = "x86_64")]
    {
        let avx512 = std::arch::is_x86_feature_detected!("avx512f");
        let avx2 = std::arch::is_x86_feature_detected!("avx2");
        match width {
            // SAFETY: the processor has the instruction set the variant is compiled for.
            Width::Best | Width::Avx512 if avx512 => return unsafe { x86::avx512::<L, N>(lag, grid, plan, s) },
            Width::Best | Width::Avx2 if avx2 => return unsafe { x86::avx2::<L, N>(lag, grid, plan, s) },
            _ => {}
        }
    }
    let _ = width;
    run_loop::<L, N>(lag, grid, plan, s)
}

/// The loop of `plan` (Störmer–Verlet without one), inlined into each instruction-set
/// variant.
#[inline(always)]
fn run_loop<L: Lagrangian, const N: usize>(
    lag: &L,
    grid: &TimeGrid,
    plan: Option<&Plan<'_>>,
    s: &[Starts<N>; GROUPS],
) -> Vec<MemberEnd> {
    match plan {
        None => verlet::run::<L, N, GROUPS>(lag, grid, s),
        Some(plan) => fixed_point::run::<L, N>(lag, grid, plan, s),
    }
}

/// The lane loops compiled with wider vector instructions (the same operations).
#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::fixed_point::Plan;
    use super::verlet::Starts;
    use super::{run_loop, MemberEnd, GROUPS};
    use crate::lagrangian::Lagrangian;
    use crate::step::TimeGrid;

    /// With AVX-512F: a lane loop of eight doubles is one register.
    #[target_feature(enable = "avx512f")]
    pub(super) fn avx512<L: Lagrangian, const N: usize>(
        lag: &L,
        grid: &TimeGrid,
        plan: Option<&Plan<'_>>,
        s: &[Starts<N>; GROUPS],
    ) -> Vec<MemberEnd> {
        run_loop::<L, N>(lag, grid, plan, s)
    }

    /// With AVX2: two registers.
    #[target_feature(enable = "avx2")]
    pub(super) fn avx2<L: Lagrangian, const N: usize>(
        lag: &L,
        grid: &TimeGrid,
        plan: Option<&Plan<'_>>,
        s: &[Starts<N>; GROUPS],
    ) -> Vec<MemberEnd> {
        run_loop::<L, N>(lag, grid, plan, s)
    }
}

#[cfg(test)]
mod tests;
