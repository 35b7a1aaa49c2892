//! Two-point boundary value problems by the discrete variational principle (paper §2, after
//! (2.1), and (2.26): "the original variational problem reduces to the extremum problem of the
//! function (2.26)"): with q(t_0) = A and q(t_N) = B fixed, every other nodal value of the
//! piecewise polynomial (element end nodes and internal nodes) is unknown, and ∂S/∂Q = 0 for
//! S = Σ_k L_d(w_k) is solved by Newton's method. The Jacobian, the Hessian of S, is block
//! banded (one element wide) and is factorised by a banded LU, so an iteration costs O(N).
//!
//! With a moving mesh ([`BvpOptions::moving_mesh`], T. D. Lee's discrete mechanics) the interior
//! element end times t_1 … t_{N−1} are unknowns too, and ∂S/∂t_k = 0 joins: the discrete
//! energy equations (3.3), E_k⁺ of element k − 1 equal to E_k⁻ of element k. The Jacobian
//! (by hyper-dual numbers over times and nodes, [`Element::full_hessian`]) stays banded.
//!
//! This file holds the problem and its solution and [`solve`], which runs the stages; the
//! numbering of the unknowns is in `layout.rs`, the action with its gradient and banded
//! Hessian in `eval.rs`, the Newton iteration in `newton.rs` and the moving mesh in
//! `moving.rs`.

mod eval;
mod layout;
mod moving;
mod newton;

pub(crate) use newton::band_inf_norm;

use crate::discrete::Element;
use crate::error::{check_len, invalid, Error, Result, StepError, StepFailure};
use crate::lagrangian::Lagrangian;
use eval::Assembly;
use layout::Layout;
use newton::{inf_norm, newton};

/// The most numbers the banded Jacobian of a boundary value problem may hold (2²⁸, 2 GiB):
/// [`solve`] rejects a larger problem before allocating anything, and [`node_times`] and
/// [`line_guess`] return nothing for a mesh of more nodal values.
pub const MAX_JACOBIAN_ENTRIES: usize = 1 << 28;

/// The data of a two-point boundary value problem on a uniform mesh of elements.
#[derive(Debug, Clone, PartialEq)]
pub struct BoundaryValues {
    /// Start time.
    pub t0: f64,
    /// q(t0).
    pub q0: Vec<f64>,
    /// End time.
    pub t1: f64,
    /// q(t1).
    pub q1: Vec<f64>,
    /// Number of elements N.
    pub elements: usize,
}

impl BoundaryValues {
    /// Checks the data against a dimension.
    ///
    /// # Errors
    /// Dimension 0, wrong lengths, non-finite values, t1 ≤ t0 or no element.
    pub fn validate(&self, n: usize) -> Result<()> {
        if n == 0 {
            return Err(invalid("dimension", "the system has no coordinates (dimension 0)"));
        }
        check_len("boundary q0", n, self.q0.len())?;
        check_len("boundary q1", n, self.q1.len())?;
        if self.q0.iter().chain(&self.q1).any(|x| !x.is_finite()) || !self.t0.is_finite() || !self.t1.is_finite() {
            return Err(invalid("boundary values", "all values must be finite"));
        }
        if self.t1 <= self.t0 {
            return Err(invalid(
                "boundary times",
                format!("t1 = {} is not after t0 = {}", self.t1, self.t0),
            ));
        }
        if self.elements == 0 {
            return Err(invalid("elements", "at least one element is needed"));
        }
        Ok(())
    }

    /// Step h of the uniform mesh.
    pub fn step(&self) -> f64 {
        (self.t1 - self.t0) / self.elements as f64
    }
}

/// The number of global nodes, N·s + 1, if their `n` values each fit the limit
/// [`MAX_JACOBIAN_ENTRIES`].
fn global_nodes(bv: &BoundaryValues, element: &Element, n: usize) -> Option<usize> {
    let globals = bv.elements.checked_mul(element.degree())?.checked_add(1)?;
    (globals.checked_mul(n)? <= MAX_JACOBIAN_ENTRIES).then_some(globals)
}

/// Times of all global nodes (element ends and internal nodes), in order: N·s + 1 of them
/// (none if they would be more than [`MAX_JACOBIAN_ENTRIES`]).
pub fn node_times(bv: &BoundaryValues, element: &Element) -> Vec<f64> {
    let (s, h) = (element.degree(), bv.step());
    let Some(globals) = global_nodes(bv, element, 1) else {
        return Vec::new();
    };
    let mut t = Vec::with_capacity(globals);
    for k in 0..bv.elements {
        let tk = bv.t0 + k as f64 * h;
        for tau in element.basis.nodes.iter().take(s) {
            t.push(tk + tau * h);
        }
    }
    t.push(bv.t1);
    t
}

/// The straight line between the boundary values at every global node (row-major by node);
/// none if the nodal values would be more than [`MAX_JACOBIAN_ENTRIES`].
pub fn line_guess(bv: &BoundaryValues, element: &Element) -> Vec<f64> {
    if global_nodes(bv, element, bv.q0.len()).is_none() {
        return Vec::new();
    }
    let span = bv.t1 - bv.t0;
    node_times(bv, element)
        .iter()
        .flat_map(|t| {
            let a = (t - bv.t0) / span;
            bv.q0
                .iter()
                .zip(&bv.q1)
                .map(move |(x, y)| x + a * (y - x))
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Tolerance and iteration cap of the Newton iteration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BvpOptions {
    /// Relative tolerance on the Newton corrections (relative to the largest |Q|).
    pub tolerance: f64,
    /// Iteration cap.
    pub max_iterations: usize,
    /// Whether the interior element end times are unknowns (a moving mesh, solved after the
    /// fixed uniform mesh, from its solution). A mesh that folds (t_k not increasing) is the
    /// typed error [`StepFailure::MeshFolded`].
    pub moving_mesh: bool,
}

impl Default for BvpOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-14,
            max_iterations: 50,
            moving_mesh: false,
        }
    }
}

/// A solved boundary value problem.
#[derive(Debug, Clone, PartialEq)]
pub struct BvpSolution {
    /// Element end times t_0 … t_N.
    pub times: Vec<f64>,
    /// q at t_0 … t_N, row-major (N+1)×n.
    pub q: Vec<f64>,
    /// Momenta at t_0 … t_N from the discrete Legendre transforms, row-major (N+1)×n.
    pub p: Vec<f64>,
    /// All global nodal values (internal nodes included), row-major (N·s+1)×n.
    pub nodes: Vec<f64>,
    /// The discrete action S.
    pub action: f64,
    /// max |∂S/∂Q| over the unknowns at the solution.
    pub residual_norm: f64,
    /// The scaled residual η = max|∂S/∂Q| / (‖J‖∞ · max|Q|) at the solution, with J the
    /// Hessian of the action last assembled (on a moving mesh the unknowns' scale is the larger
    /// of max|Q| and the time span): the relative change of the unknowns that would explain
    /// the residual, independent of the number of elements. Round-off makes `residual_norm`
    /// grow like N (about ε·max|Q|·‖J‖, and ‖J‖ grows like 1/h); η stays near ε. Newton's
    /// method on the fixed mesh stops at η ≤ `tolerance` once its corrections stop shrinking
    /// (on a moving mesh η is reported only).
    pub scaled_residual: f64,
    /// Newton iterations (Jacobian factorisations).
    pub newton_iterations: usize,
}

/// Solves the boundary value problem from the initial guess `guess` (all global nodal values,
/// row-major (N·s+1)×n, e.g. [`line_guess`]; its end values are replaced by q0 and q1).
///
/// # Errors
/// Invalid data (also a problem whose Jacobian would hold more than
/// [`MAX_JACOBIAN_ENTRIES`] numbers), or a Newton iteration that fails (singular Jacobian,
/// non-finite values, a line search that cannot decrease the residual, the iteration cap): a
/// [`StepError`] whose `residual` is the residual norm reached.
pub fn solve<L: Lagrangian>(
    lag: &L,
    element: &Element,
    bv: &BoundaryValues,
    guess: &[f64],
    options: BvpOptions,
) -> Result<BvpSolution> {
    solve_with_term(lag, element, bv, guess, options, None)
}

/// Terms added to an element's gradient ∂L_d/∂Q (and its Hessian) in the nodal equations: the
/// discrete forces of [`crate::forces`]. Fixed meshes only.
pub(crate) trait ElementTerm {
    /// Adds the term of the element [t0, t0 + h] with nodal values `base` + `incr` to `grad`
    /// and, if given, its derivative in the nodal values to `hess` (row-major, as the
    /// element's Hessian).
    fn add(&self, t0: f64, h: f64, base: &[f64], incr: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>);
}

/// [`solve`] with `term` added to every element's equations (and to the discrete Legendre
/// transforms of the end values).
pub(crate) fn solve_with_term<L: Lagrangian>(
    lag: &L,
    element: &Element,
    bv: &BoundaryValues,
    guess: &[f64],
    options: BvpOptions,
    term: Option<&dyn ElementTerm>,
) -> Result<BvpSolution> {
    let n = lag.dim();
    bv.validate(n)?;
    element.check_nondegenerate()?;
    check_size(n, element, bv, options.moving_mesh)?;
    let nodes = initial_nodes(n, element, bv, guess)?;
    let uniform = uniform_times(bv);
    let mut x: Vec<f64> = nodes[n..nodes.len() - n].to_vec();
    let mut asm = Assembly::new(lag, element, bv, nodes, uniform.clone(), term);
    // The fixed uniform mesh first.
    let fixed = newton(
        &mut asm,
        &mut x,
        options,
        |x, dx| inf_norm(dx) / qscale(bv, x),
        |x| qscale(bv, x),
        true,
    )?;
    let (mut iterations, mut scale) = (fixed.iterations, fixed.jacobian_norm * qscale(bv, &x));
    if options.moving_mesh && bv.elements > 1 {
        // Then the moving mesh, from that solution.
        let (y, more) = moving::solve_moving(&mut asm, &x, &uniform, options)?;
        iterations += more.iterations;
        let tscale = bv.t0.abs().max(bv.t1.abs()).max(bv.t1 - bv.t0);
        scale = more.jacobian_norm * qscale(bv, &y).max(tscale);
        x = y;
    }
    finish(&mut asm, &x, iterations, scale)
}

/// Checks that the problem's Jacobian (on the moving mesh too, if asked for) fits
/// [`MAX_JACOBIAN_ENTRIES`].
fn check_size(n: usize, element: &Element, bv: &BoundaryValues, moving: bool) -> Result<()> {
    let s = element.degree();
    let layouts = [false, moving && bv.elements > 1].map(|moving| Layout {
        n,
        s,
        elements: bv.elements,
        moving,
    });
    for layout in layouts {
        match layout.checked_size() {
            Some((_, entries)) if entries <= MAX_JACOBIAN_ENTRIES => {}
            _ => {
                return Err(invalid(
                    "elements",
                    format!(
                        "{} elements of degree {s} in dimension {n}: the Jacobian would hold more than {MAX_JACOBIAN_ENTRIES} numbers",
                        bv.elements
                    ),
                ))
            }
        }
    }
    Ok(())
}

/// Returns the guess (checked) with its end values replaced by q0 and q1; the data were
/// checked by [`solve`].
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

/// Element end times t_0 … t_N of the uniform mesh, t_N = t1 exactly.
fn uniform_times(bv: &BoundaryValues) -> Vec<f64> {
    let (big_n, h) = (bv.elements, bv.step());
    (0..=big_n)
        .map(|k| if k == big_n { bv.t1 } else { bv.t0 + k as f64 * h })
        .collect()
}

/// The scale of the nodal values `x` and the boundary values, against which Newton
/// corrections are measured.
fn qscale(bv: &BoundaryValues, x: &[f64]) -> f64 {
    inf_norm(x)
        .max(inf_norm(&bv.q0))
        .max(inf_norm(&bv.q1))
        .max(f64::MIN_POSITIVE)
}

/// The solution at the unknowns `x`: action, residual (also divided by `scale`, ‖J‖∞ times
/// the unknowns' scale) and the values at the element ends.
fn finish<L: Lagrangian>(asm: &mut Assembly<'_, L>, x: &[f64], iterations: usize, scale: f64) -> Result<BvpSolution> {
    let mut r = vec![0.0; asm.layout.len()];
    let action = match asm.eval(x, &mut r, None) {
        Ok(a) => a,
        Err(k) => {
            return Err(Error::Step(StepError {
                step: k,
                t: asm.times[k],
                residual: f64::NAN,
                iterations,
                failure: StepFailure::MeshFolded,
            }))
        }
    };
    let residual_norm = inf_norm(&r);
    let nodes = asm.nodes.clone();
    let times = asm.times.clone();
    let (q, p) = end_values(asm);
    Ok(BvpSolution {
        times,
        q,
        p,
        nodes,
        action,
        residual_norm,
        scaled_residual: residual_norm / scale,
        newton_iterations: iterations,
    })
}

/// q and p at the element ends t_0 … t_N (row-major (N+1)×n) by the discrete Legendre
/// transforms: p_k = −∂L_d/∂q_k of element k, and p_N = ∂L_d/∂q_N of the last element.
fn end_values<L: Lagrangian>(asm: &mut Assembly<'_, L>) -> (Vec<f64>, Vec<f64>) {
    let (n, s, big_n) = (asm.n, asm.element.degree(), asm.bv.elements);
    let mut q = vec![0.0; (big_n + 1) * n];
    let mut p = vec![0.0; (big_n + 1) * n];
    for k in 0..big_n {
        asm.load(k);
        let h = asm.step(k);
        asm.element.gradient_in_place(
            asm.lag,
            asm.times[k],
            h,
            &asm.base,
            &asm.incr,
            false,
            &mut asm.work,
            &mut asm.grad,
        );
        if let Some(term) = asm.term {
            term.add(asm.times[k], h, &asm.base, &asm.incr, &mut asm.grad, None);
        }
        q[k * n..(k + 1) * n].copy_from_slice(&asm.base);
        for c in 0..n {
            p[k * n + c] = -asm.grad[c];
            if k + 1 == big_n {
                p[big_n * n + c] = asm.grad[s * n + c];
            }
        }
    }
    q[big_n * n..].copy_from_slice(&asm.bv.q1);
    (q, p)
}
