//! The chaos indicators and the sensitivities of forced runs ([`crate::forces`]: discrete
//! Lagrange–d'Alembert): tangent vectors carried by the forced step's tangent map (implicit
//! differentiation of the forced step equations, `forces/tangent.rs`), accumulated as for a
//! conservative run (`drive.rs`, `accumulate.rs`). The forced flow is not symplectic: a
//! dissipative run's spectrum sums to the mean of ln det of the step maps per unit time (for
//! linear damping −c v on a mass m, −c/m), not to 0.

use super::drive::{drive, TangentRun};
use super::{initial_vector, ChaosOptions, ChaosReport, FinalNode};
use crate::discrete::Element;
use crate::error::Result;
use crate::forces::{Force, ForcedTangentRun};
use crate::lagrangian::Lagrangian;
use crate::solution::{Problem, SolveOptions};

/// [`super::indicators`] for `problem` under the non-conservative force `force`: MEGNO, FLI,
/// the largest Lyapunov exponent and, if asked, the spectrum of the forced discrete flow.
///
/// The steps are those of [`crate::forces::solve_forced`] with `Method::Newton` (for a force
/// independent of v, `solve_forced` by default takes the fixed point, equal to round-off); each
/// step's tangent map comes from one more element Hessian, force Jacobian and LU of the s n
/// Newton matrix at the converged step (`forces/tangent.rs`).
///
/// # Errors
/// As [`crate::forces::solve_forced`]; an initial vector of the wrong length or zero.
///
/// # Example
///
/// ```
/// use femvi::chaos::{forced_indicators, ChaosOptions};
/// use femvi::forces::LinearForce;
/// use femvi::{models, Element, Problem, SolveOptions, Start};
///
/// // The damped oscillator x'' = −x − 0.2 x': both exponents are −0.1, their sum −c/m = −0.2
/// // (here to the method's O(h⁴) error in ln det of the step).
/// let problem = Problem::new(models::harmonic(1.0, 1.0)?, Start::Momentum { q: vec![1.0], p: vec![0.0] }, 0.0, 200.0);
/// let chaos = ChaosOptions { spectrum: true, ..ChaosOptions::default() };
/// let force = LinearForce::damping(1, 0.2);
/// let r = forced_indicators(&problem, &force, &Element::with_order(4)?, &SolveOptions::step(0.1), &chaos)?;
/// let s = r.spectrum.unwrap();
/// assert!((s[0] + s[1] + 0.2).abs() < 1e-6);
/// assert!((r.last.lyapunov + 0.1).abs() < 0.01);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn forced_indicators<L: Lagrangian, F: Force>(
    problem: &Problem<L>,
    force: &F,
    element: &Element,
    options: &SolveOptions,
    chaos: &ChaosOptions,
) -> Result<ChaosReport> {
    let run = ForcedTangentRun::new(problem, force, element, options)?;
    let u = initial_vector(chaos, 2 * problem.lagrangian.dim())?;
    Ok(drive(&mut Forced { run, all: vec![] }, u, chaos))
}

/// The sensitivity of the final state of a forced run to the initial one,
/// ∂(q_N, p_N)/∂(q_0, p_0) (row-major 2n×2n), with the final node; as
/// [`super::sensitivity`] (`options.max_steps` stops the run after that many steps).
///
/// # Errors
/// As [`crate::forces::solve_forced`]; a step that fails is an error here.
///
/// # Example
///
/// ```
/// use femvi::chaos::forced_sensitivity;
/// use femvi::forces::LinearForce;
/// use femvi::{models, Element, Problem, SolveOptions, Start};
///
/// // Linear damping: det of the flow over time T is e^{−cT/m} (to the method's error).
/// let problem = Problem::new(models::harmonic(1.0, 1.0)?, Start::Momentum { q: vec![1.0], p: vec![0.0] }, 0.0, 2.0);
/// let (m, _) = forced_sensitivity(&problem, &LinearForce::damping(1, 0.3), &Element::with_order(6)?, &SolveOptions::step(0.1))?;
/// assert!((m[0] * m[3] - m[1] * m[2] - (-0.6f64).exp()).abs() < 1e-9);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn forced_sensitivity<L: Lagrangian, F: Force>(
    problem: &Problem<L>,
    force: &F,
    element: &Element,
    options: &SolveOptions,
) -> Result<(Vec<f64>, FinalNode)> {
    let mut run = ForcedTangentRun::new(problem, force, element, options)?;
    let d = 2 * problem.lagrangian.dim();
    // The start directions as columns (column-major).
    let mut w: Vec<f64> = (0..d * d).map(|i| if i % d == i / d { 1.0 } else { 0.0 }).collect();
    while run.step()? {
        run.carry(&mut w)?;
    }
    let (t, q, p) = run.node();
    let m = (0..d * d).map(|i| w[(i % d) * d + i / d]).collect();
    Ok((m, (t, q.to_vec(), p.to_vec())))
}

/// A forced run as the chaos loop drives it: `u` and `w` carried together (one Hessian and
/// one LU per step).
struct Forced<'a, L, F> {
    run: ForcedTangentRun<'a, L, F>,
    all: Vec<f64>,
}

impl<L: Lagrangian, F: Force> TangentRun for Forced<'_, L, F> {
    fn advance(&mut self) -> Result<bool> {
        self.run.step()
    }
    fn carry(&mut self, u: &mut [f64], w: &mut [f64]) -> Result<()> {
        if w.is_empty() {
            return self.run.carry(u);
        }
        self.all.clear();
        self.all.extend_from_slice(u);
        self.all.extend_from_slice(w);
        self.run.carry(&mut self.all)?;
        let (a, b) = self.all.split_at(u.len());
        u.copy_from_slice(a);
        w.copy_from_slice(b);
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
