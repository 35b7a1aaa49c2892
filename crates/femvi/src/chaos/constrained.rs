//! The chaos indicators and sensitivities of constrained runs ([`crate::constraints`]): the
//! tangent vectors live in the tangent space of the constrained phase space T*N (dimension
//! 2(n − m)), carried by each step's tangent map (implicit differentiation of the constrained
//! step equations and of the momentum projection) and written in symplectic coordinates of
//! that space (`constraints/chart.rs`), so that MEGNO, FLI and the spectrum are accumulated as
//! for an unconstrained run of n − m degrees of freedom (`drive.rs`, `accumulate.rs`), and a
//! conservative spectrum comes in ± pairs. The run is the one integrator with the
//! constraints' term (`constraints/chaos_run.rs`: the steps of `femvi run`).

use super::accumulate::apply;
use super::drive::{drive, TangentRun};
use super::{initial_vector, ChaosOptions, ChaosReport, FinalNode};
use crate::constraints::{Constraints, Enforcement, ManifoldRun};
use crate::discrete::Element;
use crate::error::{invalid, Result};
use crate::lagrangian::Lagrangian;
use crate::solution::{Problem, SolveOptions};
use nalgebra::DMatrix;

/// [`super::indicators`] for `problem` on the constraint manifold of `constraints` (the steps
/// of [`crate::constraints::solve_constrained_with`] with `enforcement`).
///
/// The tangent vectors have 2(n − m) components: the symplectic coordinates (Uᵀδq, Uᵀδp) of
/// the tangent space of T*N, U an orthonormal basis of ker G(q) (`constraints/chart.rs`). The
/// initial vector (given in (q, p), 2n components, or the default (1, …, 1)) is projected onto
/// that tangent space: its coordinates are (Uᵀδq, Uᵀδp), i.e. the components along range
/// G(q)ᵀ are dropped, and it is normalised there; the spectrum has 2(n − m) exponents.
///
/// # Errors
/// As [`crate::constraints::solve_constrained_with`]; an initial vector of the wrong length,
/// zero, or normal to the manifold.
///
/// # Example
///
/// ```
/// use femvi::chaos::{constrained_indicators, ChaosOptions};
/// use femvi::constraints::Enforcement;
/// use femvi::{models, Element, Problem, SolveOptions, Start};
///
/// // The spherical pendulum (|q| = 1 in space): integrable, so its 4 exponents tend to 0 (like
/// // ln t / t) and ⟨Y⟩ to 2; they sum to 0 up to round-off (the map is symplectic).
/// let (lag, sphere) = models::chain(3, 1, 1.0, 1.0, 1.0)?;
/// let start = Start::Velocity { q: vec![0.6, 0.0, -0.8], v: vec![0.0, 0.7, 0.0] };
/// let problem = Problem::new(lag, start, 0.0, 300.0);
/// let chaos = ChaosOptions { spectrum: true, ..ChaosOptions::default() };
/// let r = constrained_indicators(&problem, &sphere, &Element::with_order(4)?, &SolveOptions::step(0.1), Enforcement::default(), &chaos)?;
/// let s = r.spectrum.unwrap();
/// assert_eq!(s.len(), 4);
/// assert!(s.iter().sum::<f64>().abs() < 1e-10 && s.iter().all(|l| l.abs() < 0.02));
/// assert!((r.last.mean_megno - 2.0).abs() < 0.3);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn constrained_indicators<L: Lagrangian + Sync, C: Constraints + Sync>(
    problem: &Problem<L>,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
    enforcement: Enforcement,
    chaos: &ChaosOptions,
) -> Result<ChaosReport> {
    let run = ManifoldRun::new(problem, constraints, element, (options, enforcement))?;
    indicators_on(run, problem.lagrangian.dim(), chaos)
}

/// The indicators of `run` (n coordinates) from the initial vector of `chaos` projected onto
/// the tangent space of T*N ([`constrained_indicators`]).
pub(super) fn indicators_on<L: Lagrangian + Sync, C: Constraints + Sync>(
    run: ManifoldRun<'_, L, C>,
    n: usize,
    chaos: &ChaosOptions,
) -> Result<ChaosReport> {
    let v = initial_vector(chaos, 2 * n)?;
    let mut u: Vec<f64> = (&run.chart.reduce * DMatrix::from_column_slice(v.len(), 1, &v))
        .iter()
        .copied()
        .collect();
    let len = super::accumulate::norm(&u);
    if len.is_nan() || len <= 1e-12 {
        return Err(invalid(
            "initial tangent vector",
            "has no component along the constraint manifold's phase space",
        ));
    }
    u.iter_mut().for_each(|x| *x /= len);
    let tmp = vec![0.0; u.len()];
    Ok(drive(&mut OnManifold { run, tmp }, u, chaos))
}

/// The sensitivity of the final state of a constrained run to the initial one (row-major
/// 2n×2n in (q, p)): the product of the steps' tangent maps after the derivative of the start
/// projection onto T*N, P₀ = lift ∘ reduce (`constraints/chart.rs`: the identity on the
/// tangent space of T*N, zero on (range Gᵀ)²). For a start direction (δq, δp) with
/// G(q₀) δq = 0 it is the derivative of the run along it (the start momentum being projected
/// onto T*N first, as the run does); `options.max_steps` stops the run after that many steps.
///
/// # Errors
/// As [`crate::constraints::solve_constrained_with`]; a step that fails is an error here.
///
/// # Example
///
/// ```
/// use femvi::chaos::constrained_sensitivity;
/// use femvi::constraints::Enforcement;
/// use femvi::{models, Element, Problem, SolveOptions, Start};
///
/// let (lag, sphere) = models::chain(3, 1, 1.0, 1.0, 1.0)?;
/// let start = Start::Velocity { q: vec![0.6, 0.0, -0.8], v: vec![0.0, 0.7, 0.0] };
/// let problem = Problem::new(lag, start, 0.0, 1.0);
/// let (m, (_, q, _)) = constrained_sensitivity(&problem, &sphere, &Element::with_order(4)?, &SolveOptions::step(0.1), Enforcement::default())?;
/// // Every image is tangent to the sphere at the end: q·δq = 0.
/// for col in 0..6 {
///     let dot: f64 = (0..3).map(|i| q[i] * m[i * 6 + col]).sum();
///     assert!(dot.abs() < 1e-12);
/// }
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn constrained_sensitivity<L: Lagrangian + Sync, C: Constraints + Sync>(
    problem: &Problem<L>,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
    enforcement: Enforcement,
) -> Result<(Vec<f64>, FinalNode)> {
    let run = ManifoldRun::new(problem, constraints, element, (options, enforcement))?;
    sensitivity_of(run)
}

/// The sensitivity of the end of `run` to its start ([`constrained_sensitivity`]).
pub(super) fn sensitivity_of<L: Lagrangian + Sync, C: Constraints + Sync>(
    mut run: ManifoldRun<'_, L, C>,
) -> Result<(Vec<f64>, FinalNode)> {
    let mut w = &run.chart.lift * &run.chart.reduce;
    while run.step()? {
        w = run.ambient_map()? * w;
    }
    let m = w.transpose().iter().copied().collect();
    let (t, q, p) = run.node();
    Ok((m, (t, q.to_vec(), p.to_vec())))
}

/// A constrained run as the chaos loop drives it.
struct OnManifold<'a, L: Lagrangian, C> {
    run: ManifoldRun<'a, L, C>,
    tmp: Vec<f64>,
}

impl<L: Lagrangian, C: Constraints> TangentRun for OnManifold<'_, L, C> {
    fn advance(&mut self) -> Result<bool> {
        self.run.step()
    }
    fn carry(&mut self, vectors: &mut [f64]) -> Result<()> {
        let m = self.run.reduced_map()?;
        // Row-major, as `apply` expects.
        let m: Vec<f64> = m.transpose().iter().copied().collect();
        let d = self.tmp.len();
        apply(&m, d, vectors, &mut self.tmp);
        Ok(())
    }
    fn time(&self) -> f64 {
        self.run.node().0
    }
    fn last_step(&self) -> f64 {
        self.run.last_step()
    }
    fn node(&self) -> FinalNode {
        let (t, q, p) = self.run.node();
        (t, q.to_vec(), p.to_vec())
    }
}
