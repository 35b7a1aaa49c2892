//! Variational equations of the discrete flow, for any Lagrangian: tangent vectors carried
//! through each step by the step's tangent map (implicit differentiation of the step
//! equations, `Integrator::tangent_map`; symplectic because the step is), and the chaos
//! indicators built on them — MEGNO, FLI, the largest Lyapunov exponent and the whole
//! spectrum (`accumulate.rs`) — and the sensitivity of the final state to the initial one
//! and to a parameter of the Lagrangian (`parameter.rs`). Forced runs ([`crate::forces`],
//! `forced.rs`) are runs of the same integrator with its force term, their vectors carried
//! by the forced step's map (`step/term_tangent.rs`); constrained runs on their manifold ([`crate::constraints`],
//! `constrained.rs`), also both at once (`forced_constrained.rs`), have the same indicators,
//! through the loop of `drive.rs`.
//!
//! Cost: one element Hessian by automatic differentiation and one LU of the s·n step
//! Jacobian per step, on top of the step itself.

mod accumulate;
mod constrained;
mod drive;
mod forced;
mod forced_constrained;
mod map;
mod orthonormal;
mod parameter;
mod step_map;

pub use constrained::{constrained_indicators, constrained_sensitivity};
pub use forced::{forced_indicators, forced_sensitivity};
pub use forced_constrained::{forced_constrained_indicators, forced_constrained_sensitivity};
pub use map::map;
pub use parameter::{parameter_sensitivity, Frozen};

use crate::discrete::Element;
use crate::error::{invalid, Error, Result};
use crate::lagrangian::Lagrangian;
use crate::solution::{Problem, SolveOptions, Steps};
use crate::step::Integrator;
use accumulate::norm;
use drive::{drive, TangentRun};
use step_map::ExtendedProduct;

/// What to compute besides MEGNO, FLI and the largest exponent.
#[derive(Debug, Clone, PartialEq)]
pub struct ChaosOptions {
    /// Also the whole Lyapunov spectrum (2n tangent vectors, re-orthonormalised every
    /// `renormalize_every` steps).
    pub spectrum: bool,
    /// Steps between re-orthonormalisations of the spectrum's vectors (≥ 1).
    pub renormalize_every: usize,
    /// Time from the start during which the spectrum's vectors are carried and
    /// re-orthonormalised but their growth is not counted (default 0): the frame first turns
    /// towards the Lyapunov directions, whose transient otherwise biases each exponent by
    /// O(1/T) (and spoils the ± pairing of a Hamiltonian spectrum at finite T).
    pub spectrum_transient: f64,
    /// The initial tangent vector of MEGNO, FLI and the largest exponent, in (q, p) (it is
    /// normalised); default (1, 1, …)/√(2n).
    pub initial_vector: Option<Vec<f64>>,
    /// Record the indicators every this many steps (0: only at the end).
    pub record_every: usize,
}

impl Default for ChaosOptions {
    fn default() -> Self {
        Self {
            spectrum: false,
            renormalize_every: 1,
            spectrum_transient: 0.0,
            initial_vector: None,
            record_every: 0,
        }
    }
}

/// The indicators at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChaosSample {
    /// Time.
    pub t: f64,
    /// MEGNO Y and its mean ⟨Y⟩.
    pub megno: f64,
    /// See `megno`.
    pub mean_megno: f64,
    /// FLI: the largest ln|δ| so far.
    pub fli: f64,
    /// ln|δ| / t: the largest Lyapunov exponent's estimate.
    pub lyapunov: f64,
}

/// The indicators of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct ChaosReport {
    /// Steps taken.
    pub steps: usize,
    /// The indicators at the end.
    pub last: ChaosSample,
    /// The Lyapunov spectrum (largest first), if asked for.
    pub spectrum: Option<Vec<f64>>,
    /// The indicators every `record_every` steps.
    pub series: Vec<ChaosSample>,
    /// The error that stopped the run early, if any (the indicators are those before it).
    pub error: Option<Error>,
    /// The last node reached (t, q, p).
    pub final_node: FinalNode,
}

/// Runs `problem` with `element` (steps and solver from `options`; its outputs are not used)
/// and computes MEGNO, FLI, the largest Lyapunov exponent and, if asked, the spectrum.
///
/// # Errors
/// Bad input as for [`crate::solve()`]; energy mode with a time-dependent Lagrangian; an
/// initial vector of the wrong length or zero.
///
/// In energy mode (time steps as variables, paper §3) the tangent vectors are carried by the
/// (q, p) block of each step's extended map at the run's energy, a symplectic map.
///
/// # Example
///
/// ```
/// use femvi::chaos::{indicators, ChaosOptions};
/// use femvi::{models, Element, Problem, SolveOptions, Start};
///
/// // A circular Kepler orbit: regular, MEGNO tends to 2, the exponent to 0.
/// let start = Start::Momentum { q: vec![1.0, 0.0], p: vec![0.0, 1.0] };
/// let problem = Problem::new(models::kepler(1.0)?, start, 0.0, 2000.0);
/// let report = indicators(&problem, &Element::with_order(4)?, &SolveOptions::step(0.1), &ChaosOptions::default())?;
/// assert!((report.last.mean_megno - 2.0).abs() < 0.1);
/// assert!(report.last.lyapunov.abs() < 0.01);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn indicators<L: Lagrangian>(
    problem: &Problem<L>,
    element: &Element,
    options: &SolveOptions,
    chaos: &ChaosOptions,
) -> Result<ChaosReport> {
    let mut it = integrator(problem, element, options)?;
    indicators_limited(&mut it, chaos, options.max_steps)
}

/// [`indicators`] on an integrator set up by the caller (with steps as parameters), from its
/// current node to the end of its grid; time is counted from that node.
///
/// # Errors
/// An initial vector of the wrong length or zero.
pub fn indicators_on<L: Lagrangian>(it: &mut Integrator<'_, L>, chaos: &ChaosOptions) -> Result<ChaosReport> {
    indicators_limited(it, chaos, None)
}

/// [`indicators_on`], stopping after `max_steps` steps if given.
fn indicators_limited<L: Lagrangian>(
    it: &mut Integrator<'_, L>,
    chaos: &ChaosOptions,
    max_steps: Option<usize>,
) -> Result<ChaosReport> {
    let d = it.tangent_dim();
    let u = initial_vector(chaos, d)?;
    let mut run = PlainRun { it, left: max_steps };
    Ok(drive(&mut run, u, chaos))
}

/// An integrator's run (plain, or with forces), its vectors carried by
/// [`Integrator::tangent_apply`].
struct PlainRun<'r, 'a, L: Lagrangian> {
    it: &'r mut Integrator<'a, L>,
    /// Steps left before `SolveOptions::max_steps` stops the run (None: to the grid's end).
    left: Option<usize>,
}

impl<L: Lagrangian> TangentRun for PlainRun<'_, '_, L> {
    fn advance(&mut self) -> Result<bool> {
        match self.left.as_mut() {
            Some(0) => return Ok(false),
            Some(left) => *left -= 1,
            None => {}
        }
        self.it.step()
    }
    fn carry(&mut self, vectors: &mut [f64]) -> Result<()> {
        self.it.tangent_apply(vectors)
    }
    fn time(&self) -> f64 {
        self.it.node().t
    }
    fn last_step(&self) -> f64 {
        self.it.last_element().map_or(0.0, |e| e.h)
    }
    fn node(&self) -> FinalNode {
        let node = self.it.node();
        (node.t, node.q.to_vec(), node.p.to_vec())
    }
}

/// The last node of a run: (t, q, p).
pub type FinalNode = (f64, Vec<f64>, Vec<f64>);

/// The sensitivity of the final state to the initial one, ∂(q_N, p_N)/∂(q_0, p_0) (row-major
/// 2n×2n), as the product of the step maps, with the final node (t, q, p).
///
/// # Errors
/// As [`indicators`]; a step that fails is an error here (there is no final state).
///
/// `options.max_steps` stops the run after that many steps. In energy mode the derivative
/// follows the discrete energy's dependence on the start (it is fixed by the first element),
/// so it is what central differences of whole runs with the same number of steps measure.
///
/// # Example
///
/// ```
/// use femvi::chaos::sensitivity;
/// use femvi::{models, Element, Problem, SolveOptions, Start};
///
/// // The harmonic oscillator: the flow over time T is the rotation by T.
/// let start = Start::Momentum { q: vec![1.0], p: vec![0.0] };
/// let problem = Problem::new(models::harmonic(1.0, 1.0)?, start, 0.0, 1.0);
/// let (m, _) = sensitivity(&problem, &Element::with_order(8)?, &SolveOptions::step(0.05))?;
/// assert!((m[0] - 1f64.cos()).abs() < 1e-12 && (m[1] - 1f64.sin()).abs() < 1e-12);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn sensitivity<L: Lagrangian>(
    problem: &Problem<L>,
    element: &Element,
    options: &SolveOptions,
) -> Result<(Vec<f64>, FinalNode)> {
    let mut it = integrator(problem, element, options)?;
    sensitivity_on(&mut it, options.max_steps)
}

/// [`sensitivity`] of the run of `it` from its node to the end of its grid (or `max_steps`
/// steps), plain or with forces.
fn sensitivity_on<L: Lagrangian>(
    it: &mut Integrator<'_, L>,
    max_steps: Option<usize>,
) -> Result<(Vec<f64>, FinalNode)> {
    let energy = it.energy_stats().is_some();
    let mut product = ExtendedProduct::new(it.lagrangian().dim(), energy);
    let mut steps = 0;
    while max_steps.is_none_or(|m| steps < m) && it.step()? {
        product.step(it)?;
        steps += 1;
    }
    let node = it.node();
    Ok((product.sensitivity(), (node.t, node.q.to_vec(), node.p.to_vec())))
}

fn integrator<'a, L: Lagrangian>(
    problem: &'a Problem<L>,
    element: &'a Element,
    options: &SolveOptions,
) -> Result<Integrator<'a, L>> {
    let grid = crate::solution::grid(problem, &options.steps)?;
    let (lag, start) = (&problem.lagrangian, problem.start.clone());
    match &options.steps {
        Steps::Energy { options: e, .. } => {
            if !lag.is_autonomous() {
                return Err(invalid(
                    "chaos indicators",
                    "energy mode needs an autonomous Lagrangian (its energy then stays fixed); \
                     use steps as parameters",
                ));
            }
            Integrator::with_energy(lag, element, grid, start, options.solver, *e)
        }
        _ => Integrator::new(lag, element, grid, start, options.solver),
    }
}

fn initial_vector(chaos: &ChaosOptions, d: usize) -> Result<Vec<f64>> {
    let v = match &chaos.initial_vector {
        Some(v) if v.len() != d => {
            return Err(Error::Dimension {
                what: "initial tangent vector".into(),
                expected: d,
                got: v.len(),
            })
        }
        Some(v) => v.clone(),
        None => vec![1.0; d],
    };
    let len = norm(&v);
    if !(len > 0.0 && len.is_finite()) {
        return Err(invalid("initial tangent vector", "must be finite and not zero"));
    }
    Ok(v.iter().map(|x| x / len).collect())
}
