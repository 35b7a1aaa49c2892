//! Constrained two-point boundary value problems: q(t_0) = A and q(t_N) = B on the constraint
//! manifold N = {g = 0}, the augmented discrete action stationary over the interior nodal
//! values and the multipliers (Marsden–West 2001, §3.5, the constrained discrete
//! Hamilton principle; the unconstrained case is paper (2.26), [`crate::bvp`]).
//!
//! With the element's constraint layout of the initial value problem ([`Enforcement`], module
//! `layout`), the augmented action is
//!
//!   S^aug = Σ_k [L_d(w_k) − Σ_i ω_i Λ_k(y_i)·g(y_i)] − Σ_{0<k<N} ν_k·g(q_k),
//!
//! and its stationarity reads, at every interior element end node q_k,
//! D_s L_d(w_{k−1}) + D_0 L_d(w_k) − (interior constraint forces of both elements) −
//! G(q_k)ᵀν_k = 0 and g(q_k) = 0; at every internal node the node rows of the step
//! (module `step`); and per element the interior constraint equations Σ_i ω_i Ψ_ic g(y_i) = 0.
//! This is the sum of the equations of two consecutive initial value steps with
//! ν_k = λ̂_k + μ̂_{k−1} (the two halves that the hidden constraint splits): a trajectory of
//! [`super::solve_constrained`] solves it, and conversely. The end momenta are the
//! constrained discrete Legendre transforms, p_0 = −∂L_d^aug/∂Q^0 of the first element and
//! p_N = ∂L_d^aug/∂Q^s of the last, projected onto T*N with the hidden constraint as in the
//! initial value problem (module `project`); the momenta at the interior element ends are
//! those of element k's start, projected likewise. So the run of the initial value problem
//! from (q_0, p_0) reproduces the solution.
//!
//! Newton's method with the exact Jacobian on a banded numbering (`bvp_assembly.rs`,
//! `bvp_newton.rs`): O(N) per iteration.

use super::bvp_assembly::{Assembly, Numbering};
use super::bvp_finish::finish;
pub use super::bvp_finish::ConstrainedBvpSolution;
use super::bvp_newton::{inf_norm, newton};
use super::forcing::NodeForce;
use super::jet::ConstraintJet;
use super::layout::{Enforcement, Layout};
use super::limits::{MAX_COORDINATES, RANK_TOLERANCE, START_TOLERANCE};
use super::Constraints;
use crate::bvp::{BoundaryValues, BvpOptions, MAX_JACOBIAN_ENTRIES};
use crate::discrete::Element;
use crate::error::{check_len, invalid, Error, Result, StepError};
use crate::lagrangian::Lagrangian;
use crate::solve::{BandMatrix, NewtonFailure};

/// [`solve_constrained_bvp_with`] with the default [`Enforcement`] (that of
/// [`super::solve_constrained`]).
///
/// # Errors
/// As [`solve_constrained_bvp_with`].
///
/// # Example
///
/// A geodesic on the unit sphere (a free particle with |q| = 1) from the equator to the pole
/// in time π/2: a quarter of a great circle at unit speed.
///
/// ```
/// use femvi::bvp::{line_guess, BoundaryValues, BvpOptions};
/// use femvi::constraints::solve_constrained_bvp;
/// use femvi::{models, Element};
///
/// let (lag, sphere) = models::chain(3, 1, 1.0, 0.0, 1.0)?;
/// let half_pi = std::f64::consts::FRAC_PI_2;
/// let bv = BoundaryValues { t0: 0.0, q0: vec![1.0, 0.0, 0.0], t1: half_pi, q1: vec![0.0, 0.0, 1.0], elements: 8 };
/// let element = Element::with_order(4)?;
/// let sol = solve_constrained_bvp(&lag, &sphere, &element, &bv, &line_guess(&bv, &element), BvpOptions::default())?;
/// assert!(sol.solution.residual_norm < 1e-12 && sol.max_residual < 1e-13);
/// // The middle node is at 45 degrees (exactly, by symmetry); the start momentum points to
/// // the pole with unit length (to O(h⁴)).
/// let mid = &sol.solution.q[4 * 3..5 * 3];
/// assert!((mid[0] - 0.5f64.sqrt()).abs() < 1e-15 && (mid[2] - 0.5f64.sqrt()).abs() < 1e-15);
/// assert!((sol.solution.p[2] - 1.0).abs() < 1e-4);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn solve_constrained_bvp<L: Lagrangian, C: Constraints>(
    lag: &L,
    constraints: &C,
    element: &Element,
    bv: &BoundaryValues,
    guess: &[f64],
    options: BvpOptions,
) -> Result<ConstrainedBvpSolution> {
    solve_constrained_bvp_with(lag, constraints, element, bv, guess, options, Enforcement::default())
}

/// Solves the constrained boundary value problem (the module documentation) from the
/// initial guess `guess` (all global nodal values, row-major (N·s+1)×n, as for
/// [`crate::bvp::solve`]; its end values are replaced by q0 and q1; the multipliers start at
/// zero).
///
/// # Errors
/// [`Error::Dimension`] if the constraints, the Lagrangian, the boundary values or the guess
/// disagree on sizes; [`Error::Invalid`] for m ≥ n or n > [`MAX_COORDINATES`], boundary values
/// off the manifold (naming the residual), a moving mesh, a Jacobian of more than
/// [`MAX_JACOBIAN_ENTRIES`] numbers, or invalid data (as [`crate::bvp::solve`]);
/// [`Error::SingularConstraints`] if G is singular at an end or at a node where Newton's
/// system became singular; [`Error::Step`] for a Newton iteration that fails otherwise
/// (singular, non-finite, stalled, the iteration cap), with the residual reached.
pub fn solve_constrained_bvp_with<L: Lagrangian, C: Constraints>(
    lag: &L,
    constraints: &C,
    element: &Element,
    bv: &BoundaryValues,
    guess: &[f64],
    options: BvpOptions,
    enforcement: Enforcement,
) -> Result<ConstrainedBvpSolution> {
    let problem = BvpParts {
        lag,
        con: constraints,
        element,
        bv,
        force: None,
    };
    solve_parts(&problem, guess, options, enforcement)
}

/// The data of a constrained boundary value problem, with the force whose discrete forces are
/// added to each element's node rows (and whose value enters the multipliers at the ends).
pub(super) struct BvpParts<'a, L, C> {
    pub lag: &'a L,
    pub con: &'a C,
    pub element: &'a Element,
    pub bv: &'a BoundaryValues,
    pub force: Option<&'a dyn NodeForce>,
}

/// [`solve_constrained_bvp_with`] on `problem`.
pub(super) fn solve_parts<L: Lagrangian, C: Constraints>(
    problem: &BvpParts<'_, L, C>,
    guess: &[f64],
    options: BvpOptions,
    enforcement: Enforcement,
) -> Result<ConstrainedBvpSolution> {
    let (lag, constraints, element, bv) = (problem.lag, problem.con, problem.element, problem.bv);
    let (n, m) = (lag.dim(), constraints.count());
    check_len("constraints' coordinates", n, constraints.dim())?;
    if n > MAX_COORDINATES || m >= n.max(1) {
        return Err(invalid(
            "constraints",
            format!("need fewer constraints than coordinates and at most {MAX_COORDINATES} coordinates, got {m} constraints on {n}"),
        ));
    }
    bv.validate(n)?;
    element.check_nondegenerate()?;
    if options.moving_mesh {
        return Err(invalid(
            "moving mesh",
            "not supported with constraints (use a fixed mesh)",
        ));
    }
    let sites = Layout::new(element, enforcement)?;
    let num = Numbering {
        n,
        m,
        s: element.degree(),
        sites: sites.sites,
        elements: bv.elements,
    };
    let (len, bw) = checked_size(&num)?;
    check_ends(constraints, bv)?;
    let nodes = initial_nodes(n, element, bv, guess)?;
    let mut x = vec![0.0; len];
    for k in 0..bv.elements {
        for j in 1..=num.s {
            for a in 0..n {
                if let Some(i) = num.node(k, j, a) {
                    x[i] = nodes[(k * num.s + j) * n + a];
                }
            }
        }
    }
    let floor = inf_norm(&bv.q0).max(inf_norm(&bv.q1));
    let mut asm = Assembly::new(lag, constraints, element, bv, sites, nodes);
    asm.force = problem.force;
    let mut band = BandMatrix::zeros(len.max(1), bw, bw)?;
    let mut jacobian_norm = f64::NAN;
    let iterations = newton(
        &mut asm,
        &mut band,
        &mut x,
        options.tolerance,
        options.max_iterations,
        floor,
        &mut jacobian_norm,
    )
    .map_err(|f| newton_error(&mut asm, &x, f))?;
    let mut out = finish(&mut asm, &x, iterations, options)?;
    // η = ‖r‖∞ / (‖J‖∞·max|x|), as the unconstrained solver reports it (its round-off floor
    // does not grow with N); reported only: this Newton stops on its corrections.
    let scale = inf_norm(&x).max(floor).max(f64::MIN_POSITIVE);
    out.solution.scaled_residual = out.solution.residual_norm / (jacobian_norm * scale);
    out.enforcement = enforcement;
    Ok(out)
}

/// The number of unknowns and the bandwidth, if the Jacobian and the nodal values fit
/// [`MAX_JACOBIAN_ENTRIES`].
fn checked_size(num: &Numbering) -> Result<(usize, usize)> {
    let fits = num.checked_size().and_then(|(len, bw)| {
        let entries = len.max(1).checked_mul(bw.checked_mul(3)?.checked_add(1)?)?;
        let values = num.elements.checked_mul(num.s)?.checked_add(1)?.checked_mul(num.n)?;
        (entries <= MAX_JACOBIAN_ENTRIES && values <= MAX_JACOBIAN_ENTRIES).then_some((len, bw))
    });
    fits.ok_or_else(|| {
        invalid(
            "elements",
            format!(
                "{} elements of degree {} with {} coordinates and {} constraints: the Jacobian would hold more than {MAX_JACOBIAN_ENTRIES} numbers",
                num.elements, num.s, num.n, num.m
            ),
        )
    })
}

/// Both ends on the manifold (within [`START_TOLERANCE`] · max(1, ‖q‖∞²)) with a regular G.
fn check_ends<C: Constraints>(con: &C, bv: &BoundaryValues) -> Result<()> {
    let mut jet = ConstraintJet::new(con.count(), con.dim());
    for (what, q, step, t) in [
        ("boundary q0", &bv.q0, 0, bv.t0),
        ("boundary q1", &bv.q1, bv.elements, bv.t1),
    ] {
        jet.eval(con, q, false);
        let qmax = inf_norm(q).max(1.0);
        let within = jet.residual() <= START_TOLERANCE * qmax * qmax;
        if !within {
            return Err(invalid(
                what,
                format!(
                    "violates the constraints: max |g| = {:.3e} (tolerance {START_TOLERANCE:.1e} * max(1, |q|^2))",
                    jet.residual()
                ),
            ));
        }
        if jet.conditioning() <= RANK_TOLERANCE {
            return Err(Error::SingularConstraints {
                step,
                t,
                ratio: jet.conditioning(),
            });
        }
    }
    Ok(())
}

/// The guess (checked) with its end values replaced by q0 and q1.
fn initial_nodes(n: usize, element: &Element, bv: &BoundaryValues, guess: &[f64]) -> Result<Vec<f64>> {
    let globals = bv.elements * element.degree() + 1;
    check_len("initial guess", globals * n, guess.len())?;
    if guess.iter().any(|x| !x.is_finite()) {
        return Err(invalid("initial guess", "contains a non-finite value"));
    }
    let mut nodes = guess.to_vec();
    nodes[..n].copy_from_slice(&bv.q0);
    nodes[(globals - 1) * n..].copy_from_slice(&bv.q1);
    Ok(nodes)
}

/// The typed error of a failed Newton iteration: a singular constraint Jacobian at the first
/// element end where G is singular, if the system was singular there, else a step error.
fn newton_error<L: Lagrangian, C: Constraints>(asm: &mut Assembly<'_, L, C>, x: &[f64], f: NewtonFailure) -> Error {
    let (n, s, h) = (asm.num.n, asm.num.s, asm.bv.step());
    if f.failure == crate::error::StepFailure::Singular {
        asm.unpack(x);
        let mut jet = ConstraintJet::new(asm.num.m, n);
        for k in 1..asm.num.elements {
            jet.eval(asm.con, &asm.nodes[k * s * n..(k * s + 1) * n], false);
            if jet.conditioning() <= RANK_TOLERANCE {
                return Error::SingularConstraints {
                    step: k,
                    t: asm.bv.t0 + k as f64 * h,
                    ratio: jet.conditioning(),
                };
            }
        }
    }
    Error::Step(StepError {
        step: 0,
        t: asm.bv.t0,
        residual: f.residual,
        iterations: f.iterations,
        failure: f.failure,
    })
}
