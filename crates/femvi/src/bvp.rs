//! Two-point boundary value problems by the discrete variational principle (paper §2, after
//! (2.1), and (2.26): "the original variational problem reduces to the extremum problem of the
//! function (2.26)"): with q(t_0) = A and q(t_N) = B fixed, every other nodal value of the
//! piecewise polynomial (element end nodes and internal nodes) is unknown, and ∂S/∂Q = 0 for
//! S = Σ_k L_d(w_k) is solved by Newton's method. The Jacobian, the Hessian of S, is block
//! banded (one element wide) and is factorised by a banded LU, so an iteration costs O(N).

use crate::discrete::{Element, ElementWork};
use crate::error::{check_len, invalid, Error, Result, StepError, StepFailure};
use crate::lagrangian::Lagrangian;
use crate::solve::BandMatrix;

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
    /// Wrong lengths, non-finite values, t1 ≤ t0 or no element.
    pub fn validate(&self, n: usize) -> Result<()> {
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

/// Times of all global nodes (element ends and internal nodes), in order: N·s + 1 of them.
pub fn node_times(bv: &BoundaryValues, element: &Element) -> Vec<f64> {
    let (s, h) = (element.degree(), bv.step());
    let mut t = Vec::with_capacity(bv.elements * s + 1);
    for k in 0..bv.elements {
        let tk = bv.t0 + k as f64 * h;
        for j in 0..s {
            t.push(tk + element.basis.nodes[j] * h);
        }
    }
    t.push(bv.t1);
    t
}

/// The straight line between the boundary values at every global node (row-major by node).
pub fn line_guess(bv: &BoundaryValues, element: &Element) -> Vec<f64> {
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
}

impl Default for BvpOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-14,
            max_iterations: 50,
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
    /// Newton iterations (Jacobian factorisations).
    pub newton_iterations: usize,
}

struct Assembly<'a, L: Lagrangian> {
    lag: &'a L,
    element: &'a Element,
    bv: &'a BoundaryValues,
    n: usize,
    work: ElementWork,
    base: Vec<f64>,
    incr: Vec<f64>,
    grad: Vec<f64>,
    hess: Vec<f64>,
}

impl<L: Lagrangian> Assembly<'_, L> {
    /// Residual ∂S/∂Q over the interior nodes (and the Jacobian into `band` if given);
    /// returns the action.
    fn eval(&mut self, nodes: &[f64], r: &mut [f64], mut band: Option<&mut BandMatrix>) -> f64 {
        let (n, s) = (self.n, self.element.degree());
        let last = self.bv.elements * s;
        let h = self.bv.step();
        let w = (s + 1) * n;
        r.iter_mut().for_each(|x| *x = 0.0);
        if let Some(b) = band.as_deref_mut() {
            b.clear();
        }
        let mut action = 0.0;
        for k in 0..self.bv.elements {
            let g0 = k * s;
            self.base.copy_from_slice(&nodes[g0 * n..(g0 + 1) * n]);
            for j in 0..=s {
                for c in 0..n {
                    self.incr[j * n + c] = nodes[(g0 + j) * n + c] - self.base[c];
                }
            }
            let tk = self.bv.t0 + k as f64 * h;
            action += match band {
                Some(_) => self.element.hessian_in_place(
                    self.lag,
                    tk,
                    h,
                    &self.base,
                    &self.incr,
                    &mut self.work,
                    &mut self.grad,
                    &mut self.hess,
                ),
                None => self.element.gradient_in_place(
                    self.lag,
                    tk,
                    h,
                    &self.base,
                    &self.incr,
                    false,
                    &mut self.work,
                    &mut self.grad,
                ),
            };
            for j in 0..=s {
                let g = g0 + j;
                if g == 0 || g == last {
                    continue;
                }
                for c in 0..n {
                    let row = (g - 1) * n + c;
                    r[row] += self.grad[j * n + c];
                    if let Some(b) = band.as_deref_mut() {
                        for m in 0..=s {
                            let g2 = g0 + m;
                            if g2 == 0 || g2 == last {
                                continue;
                            }
                            for e in 0..n {
                                b.add(row, (g2 - 1) * n + e, self.hess[(j * n + c) * w + m * n + e]);
                            }
                        }
                    }
                }
            }
        }
        action
    }
}

fn inf_norm(x: &[f64]) -> f64 {
    x.iter()
        .fold(0.0f64, |m, v| if v.is_nan() { f64::NAN } else { m.max(v.abs()) })
}

/// Solves the boundary value problem from the initial guess `guess` (all global nodal values,
/// row-major (N·s+1)×n, e.g. [`line_guess`]; its end values are replaced by q0 and q1).
///
/// # Errors
/// Invalid data, or a Newton iteration that fails (singular Jacobian, non-finite values, a
/// line search that cannot decrease the residual, the iteration cap): a [`StepError`] whose
/// `residual` is the residual norm reached.
pub fn solve<L: Lagrangian>(
    lag: &L,
    element: &Element,
    bv: &BoundaryValues,
    guess: &[f64],
    options: BvpOptions,
) -> Result<BvpSolution> {
    let n = lag.dim();
    bv.validate(n)?;
    element.check_nondegenerate()?;
    let s = element.degree();
    let globals = bv.elements * s + 1;
    check_len("initial guess", globals * n, guess.len())?;
    if guess.iter().any(|x| !x.is_finite()) {
        return Err(invalid("initial guess", "contains a non-finite value"));
    }
    let mut nodes = guess.to_vec();
    nodes[..n].copy_from_slice(&bv.q0);
    nodes[(globals - 1) * n..].copy_from_slice(&bv.q1);
    let unknowns = (globals - 2) * n;
    let band_width = (s + 1) * n - 1;
    let mut asm = Assembly {
        lag,
        element,
        bv,
        n,
        work: ElementWork::new(element, n),
        base: vec![0.0; n],
        incr: vec![0.0; (s + 1) * n],
        grad: vec![0.0; (s + 1) * n],
        hess: vec![0.0; ((s + 1) * n).pow(2)],
    };
    let fail = |failure, residual, iterations| {
        Error::Step(StepError {
            step: 0,
            t: bv.t0,
            residual,
            iterations,
            failure,
        })
    };
    let mut r = vec![0.0; unknowns];
    let mut r_trial = vec![0.0; unknowns];
    let mut trial = nodes.clone();
    let mut dx = vec![0.0; unknowns];
    let mut band = BandMatrix::zeros(unknowns.max(1), band_width, band_width);
    let mut iterations = 0;
    let mut action = 0.0;
    if unknowns > 0 {
        loop {
            iterations += 1;
            asm.eval(&nodes, &mut r, Some(&mut band));
            let rnorm = inf_norm(&r);
            if !rnorm.is_finite() {
                return Err(fail(StepFailure::NonFinite, rnorm, iterations));
            }
            if rnorm == 0.0 {
                break;
            }
            if !band.factor() {
                return Err(fail(StepFailure::Singular, rnorm, iterations));
            }
            dx.iter_mut().zip(&r).for_each(|(d, v)| *d = -v);
            band.solve(&mut dx);
            let dnorm = inf_norm(&dx);
            if !dnorm.is_finite() {
                return Err(fail(StepFailure::NonFinite, rnorm, iterations));
            }
            let scale = inf_norm(&nodes).max(f64::MIN_POSITIVE);
            let small = dnorm <= options.tolerance * scale;
            let r2: f64 = r.iter().map(|v| v * v).sum();
            let mut lambda = 1.0;
            loop {
                trial.copy_from_slice(&nodes);
                for (i, d) in dx.iter().enumerate() {
                    trial[n + i] += lambda * d;
                }
                asm.eval(&trial, &mut r_trial, None);
                let t2: f64 = r_trial.iter().map(|v| v * v).sum();
                if small || (t2.is_finite() && t2 <= (1.0 - 1e-4 * lambda) * r2) {
                    break;
                }
                lambda *= 0.5;
                if lambda < 1.0 / 1024.0 {
                    if dnorm <= 1e3 * options.tolerance * scale {
                        lambda = 1.0;
                        trial.copy_from_slice(&nodes);
                        for (i, d) in dx.iter().enumerate() {
                            trial[n + i] += d;
                        }
                        break;
                    }
                    return Err(fail(StepFailure::Stalled, rnorm, iterations));
                }
            }
            std::mem::swap(&mut nodes, &mut trial);
            if small || lambda * dnorm <= options.tolerance * scale {
                break;
            }
            if iterations >= options.max_iterations {
                asm.eval(&nodes, &mut r, None);
                return Err(fail(StepFailure::NotConverged, inf_norm(&r), iterations));
            }
        }
    }
    action += asm.eval(&nodes, &mut r, None);
    let residual_norm = inf_norm(&r);
    // Discrete Legendre transforms at the element ends.
    let (h, big_n) = (bv.step(), bv.elements);
    let mut q = vec![0.0; (big_n + 1) * n];
    let mut p = vec![0.0; (big_n + 1) * n];
    for k in 0..big_n {
        let g0 = k * s;
        asm.base.copy_from_slice(&nodes[g0 * n..(g0 + 1) * n]);
        for j in 0..=s {
            for c in 0..n {
                asm.incr[j * n + c] = nodes[(g0 + j) * n + c] - asm.base[c];
            }
        }
        let tk = bv.t0 + k as f64 * h;
        element.gradient_in_place(lag, tk, h, &asm.base, &asm.incr, false, &mut asm.work, &mut asm.grad);
        q[k * n..(k + 1) * n].copy_from_slice(&asm.base);
        for c in 0..n {
            p[k * n + c] = -asm.grad[c];
            if k + 1 == big_n {
                p[big_n * n + c] = asm.grad[s * n + c];
            }
        }
    }
    q[big_n * n..].copy_from_slice(&bv.q1);
    let times = (0..=big_n)
        .map(|k| if k == big_n { bv.t1 } else { bv.t0 + k as f64 * h })
        .collect();
    Ok(BvpSolution {
        times,
        q,
        p,
        nodes,
        action,
        residual_norm,
        newton_iterations: iterations,
    })
}
