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
    /// Newton iterations (Jacobian factorisations).
    pub newton_iterations: usize,
}

/// Where the unknowns sit in the solution vector. Fixed mesh: the interior nodal values in
/// order of time. Moving mesh: per element k ≥ 1 the block (t_k, Q_k, internal nodes of
/// element k), after the internal nodes of element 0.
#[derive(Debug, Clone, Copy)]
struct Layout {
    n: usize,
    s: usize,
    elements: usize,
    moving: bool,
}

impl Layout {
    fn block(&self) -> usize {
        1 + self.s * self.n
    }
    fn offset(&self, k: usize) -> usize {
        (self.s - 1) * self.n + (k - 1) * self.block()
    }
    /// The unknown t_k, if it is one.
    fn time(&self, k: usize) -> Option<usize> {
        (self.moving && k >= 1 && k < self.elements).then(|| self.offset(k))
    }
    /// Component c of global node g, if it is an unknown.
    fn node(&self, g: usize, c: usize) -> Option<usize> {
        let (n, s) = (self.n, self.s);
        if g == 0 || g == self.elements * s {
            return None;
        }
        if !self.moving {
            return Some((g - 1) * n + c);
        }
        let (k, j) = (g / s, g % s);
        Some(match (k, j) {
            (_, 0) => self.offset(k) + 1 + c,
            (0, _) => (j - 1) * n + c,
            _ => self.offset(k) + 1 + n + (j - 1) * n + c,
        })
    }
    fn len(&self) -> usize {
        if self.moving {
            (self.s - 1) * self.n + (self.elements - 1) * self.block()
        } else {
            (self.elements * self.s - 1) * self.n
        }
    }
    /// Lower (= upper) bandwidth of ∂²S.
    fn bandwidth(&self) -> usize {
        if self.moving {
            self.block() + self.n
        } else {
            (self.s + 1) * self.n - 1
        }
    }
}

struct Assembly<'a, L: Lagrangian> {
    lag: &'a L,
    element: &'a Element,
    bv: &'a BoundaryValues,
    layout: Layout,
    n: usize,
    work: ElementWork,
    /// All global nodal values and all element end times, unpacked from the unknowns.
    nodes: Vec<f64>,
    times: Vec<f64>,
    base: Vec<f64>,
    incr: Vec<f64>,
    grad: Vec<f64>,
    hess: Vec<f64>,
}

impl<L: Lagrangian> Assembly<'_, L> {
    /// Writes the unknowns `x` into `nodes` and (moving mesh) `times`. Returns the first
    /// element whose step is not positive, if any.
    fn unpack(&mut self, x: &[f64]) -> Option<usize> {
        let (n, s, big_n) = (self.n, self.element.degree(), self.bv.elements);
        for g in 1..big_n * s {
            for c in 0..n {
                if let Some(i) = self.layout.node(g, c) {
                    self.nodes[g * n + c] = x[i];
                }
            }
        }
        for k in 1..big_n {
            if let Some(i) = self.layout.time(k) {
                self.times[k] = x[i];
            }
        }
        // A step that is not positive, or NaN.
        (0..big_n).find(|&k| (self.times[k + 1] - self.times[k]).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater))
    }

    /// The step of element k: exact for the uniform mesh (not a difference of times).
    fn step(&self, k: usize) -> f64 {
        if self.layout.moving {
            self.times[k + 1] - self.times[k]
        } else {
            self.bv.step()
        }
    }

    /// Nodal values of element k into `base`, `incr`.
    fn load(&mut self, k: usize) {
        let (n, s) = (self.n, self.element.degree());
        let g0 = k * s;
        self.base.copy_from_slice(&self.nodes[g0 * n..(g0 + 1) * n]);
        for j in 0..=s {
            for c in 0..n {
                self.incr[j * n + c] = self.nodes[(g0 + j) * n + c] - self.base[c];
            }
        }
    }

    /// Residual ∂S/∂x (and the Jacobian into `band` if given) at the unknowns `x`; the action,
    /// or Err(k) if element k has a step that is not positive (a folded mesh).
    fn eval(&mut self, x: &[f64], r: &mut [f64], mut band: Option<&mut BandMatrix>) -> std::result::Result<f64, usize> {
        if let Some(k) = self.unpack(x) {
            return Err(k);
        }
        let (n, s) = (self.n, self.element.degree());
        let moving = self.layout.moving;
        r.iter_mut().for_each(|v| *v = 0.0);
        if let Some(b) = band.as_deref_mut() {
            b.clear();
        }
        let mut action = 0.0;
        // Local variables: moving mesh (t_k, t_{k+1}, Q^0 … Q^s), fixed mesh (Q^0 … Q^s).
        let lead = if moving { 2 } else { 0 };
        let m = lead + (s + 1) * n;
        for k in 0..self.bv.elements {
            self.load(k);
            let (tk, h) = (self.times[k], self.step(k));
            let layout = self.layout;
            let index = |a: usize| -> Option<usize> {
                match a {
                    0 if moving => layout.time(k),
                    1 if moving => layout.time(k + 1),
                    _ => layout.node(k * s + (a - lead) / n, (a - lead) % n),
                }
            };
            match band.as_deref_mut() {
                Some(b) if moving => {
                    let (value, grad, hess) = self.element.full_hessian(self.lag, tk, h, &self.base, &self.incr);
                    action += value;
                    for a in 0..m {
                        let Some(row) = index(a) else { continue };
                        r[row] += grad[a];
                        for c in 0..m {
                            if let Some(col) = index(c) {
                                b.add(row, col, hess[a * m + c]);
                            }
                        }
                    }
                }
                Some(b) => {
                    action += self.element.hessian_in_place(
                        self.lag,
                        tk,
                        h,
                        &self.base,
                        &self.incr,
                        &mut self.work,
                        &mut self.grad,
                        &mut self.hess,
                    );
                    let w = (s + 1) * n;
                    for a in 0..w {
                        let Some(row) = index(a) else { continue };
                        r[row] += self.grad[a];
                        for c in 0..w {
                            if let Some(col) = index(c) {
                                b.add(row, col, self.hess[a * w + c]);
                            }
                        }
                    }
                }
                None => {
                    action += self.element.gradient_in_place(
                        self.lag,
                        tk,
                        h,
                        &self.base,
                        &self.incr,
                        moving,
                        &mut self.work,
                        &mut self.grad,
                    );
                    for a in lead..m {
                        if let Some(row) = index(a) {
                            r[row] += self.grad[a - lead];
                        }
                    }
                    if moving {
                        // ∂L_d/∂t_k = E⁻, ∂L_d/∂t_{k+1} = −E⁺.
                        let (e_minus, e_plus) = self.element.energies(h, &self.work);
                        if let Some(row) = index(0) {
                            r[row] += e_minus;
                        }
                        if let Some(row) = index(1) {
                            r[row] -= e_plus;
                        }
                    }
                }
            }
        }
        Ok(action)
    }
}

fn inf_norm(x: &[f64]) -> f64 {
    x.iter()
        .fold(0.0f64, |m, v| if v.is_nan() { f64::NAN } else { m.max(v.abs()) })
}

/// Newton's method with a backtracking line search on ∂S = 0 over the unknowns `x`, with the
/// banded Jacobian. `rel(x, dx)` is the size of a correction relative to the unknowns. Returns
/// the iterations taken.
fn newton<L: Lagrangian>(
    asm: &mut Assembly<'_, L>,
    x: &mut Vec<f64>,
    options: BvpOptions,
    rel: impl Fn(&[f64], &[f64]) -> f64,
) -> Result<usize> {
    let unknowns = x.len();
    // Where a failure is reported: element k's start on the uniform mesh.
    let (t0, h) = (asm.bv.t0, asm.bv.step());
    let fail = |failure, residual, iterations, step: usize| {
        Error::Step(StepError {
            step,
            t: t0 + step as f64 * h,
            residual,
            iterations,
            failure,
        })
    };
    let folded = |k: usize, residual, iterations| fail(StepFailure::MeshFolded, residual, iterations, k);
    let mut r = vec![0.0; unknowns];
    let mut r_trial = vec![0.0; unknowns];
    let mut trial = x.clone();
    let mut dx = vec![0.0; unknowns];
    let bw = asm.layout.bandwidth();
    let mut band = BandMatrix::zeros(unknowns.max(1), bw, bw);
    let mut iterations = 0;
    if unknowns == 0 {
        return Ok(0);
    }
    loop {
        iterations += 1;
        if let Err(k) = asm.eval(x, &mut r, Some(&mut band)) {
            return Err(folded(k, f64::NAN, iterations));
        }
        let rnorm = inf_norm(&r);
        if !rnorm.is_finite() {
            return Err(fail(StepFailure::NonFinite, rnorm, iterations, 0));
        }
        if rnorm == 0.0 {
            return Ok(iterations);
        }
        if !band.factor() {
            return Err(fail(StepFailure::Singular, rnorm, iterations, 0));
        }
        dx.iter_mut().zip(&r).for_each(|(d, v)| *d = -v);
        band.solve(&mut dx);
        if !inf_norm(&dx).is_finite() {
            return Err(fail(StepFailure::NonFinite, rnorm, iterations, 0));
        }
        let size = rel(x, &dx);
        let small = size <= options.tolerance;
        let r2: f64 = r.iter().map(|v| v * v).sum();
        let mut lambda = 1.0;
        let mut last_fold = None;
        loop {
            trial
                .iter_mut()
                .zip(x.iter().zip(&dx))
                .for_each(|(t, (a, d))| *t = a + lambda * d);
            let ok = match asm.eval(&trial, &mut r_trial, None) {
                Ok(_) => {
                    let t2: f64 = r_trial.iter().map(|v| v * v).sum();
                    small || (t2.is_finite() && t2 <= (1.0 - 1e-4 * lambda) * r2)
                }
                Err(k) => {
                    last_fold = Some(k);
                    false
                }
            };
            if ok {
                break;
            }
            lambda *= 0.5;
            if lambda < 1.0 / 1024.0 {
                if size <= 1e3 * options.tolerance && last_fold.is_none() {
                    lambda = 1.0;
                    trial
                        .iter_mut()
                        .zip(x.iter().zip(&dx))
                        .for_each(|(t, (a, d))| *t = a + d);
                    break;
                }
                return Err(match last_fold {
                    Some(k) => folded(k, rnorm, iterations),
                    None => fail(StepFailure::Stalled, rnorm, iterations, 0),
                });
            }
        }
        std::mem::swap(x, &mut trial);
        if small || lambda * size <= options.tolerance {
            return Ok(iterations);
        }
        if iterations >= options.max_iterations {
            let residual = match asm.eval(x, &mut r, None) {
                Ok(_) => inf_norm(&r),
                Err(_) => f64::NAN,
            };
            return Err(fail(StepFailure::NotConverged, residual, iterations, 0));
        }
    }
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
    let big_n = bv.elements;
    let h = bv.step();
    let uniform: Vec<f64> = (0..=big_n)
        .map(|k| if k == big_n { bv.t1 } else { bv.t0 + k as f64 * h })
        .collect();
    let fixed = Layout {
        n,
        s,
        elements: big_n,
        moving: false,
    };
    let mut asm = Assembly {
        lag,
        element,
        bv,
        layout: fixed,
        n,
        work: ElementWork::new(element, n),
        nodes: nodes.clone(),
        times: uniform.clone(),
        base: vec![0.0; n],
        incr: vec![0.0; (s + 1) * n],
        grad: vec![0.0; (s + 1) * n],
        hess: vec![0.0; ((s + 1) * n).pow(2)],
    };
    // The fixed uniform mesh first.
    let qscale = |x: &[f64]| {
        inf_norm(x)
            .max(inf_norm(&bv.q0))
            .max(inf_norm(&bv.q1))
            .max(f64::MIN_POSITIVE)
    };
    let mut x: Vec<f64> = nodes[n..(globals - 1) * n].to_vec();
    let mut iterations = newton(&mut asm, &mut x, options, |x, dx| inf_norm(dx) / qscale(x))?;
    if options.moving_mesh && big_n > 1 {
        // Then the moving mesh, from that solution.
        let moving = Layout { moving: true, ..fixed };
        asm.unpack(&x);
        let mut y = vec![0.0; moving.len()];
        let mut is_time = vec![false; moving.len()];
        for g in 1..big_n * s {
            for c in 0..n {
                if let Some(i) = moving.node(g, c) {
                    y[i] = asm.nodes[g * n + c];
                }
            }
        }
        for k in 1..big_n {
            if let Some(i) = moving.time(k) {
                y[i] = uniform[k];
                is_time[i] = true;
            }
        }
        asm.layout = moving;
        let tscale = bv.t0.abs().max(bv.t1.abs()).max(bv.t1 - bv.t0);
        let rel = |x: &[f64], dx: &[f64]| {
            // The nodal values' scale, as for the fixed mesh, over the entries that are not times.
            let qmax = x.iter().zip(&is_time).filter(|(_, t)| !**t).fold(0.0f64, |m, (v, _)| {
                if v.is_nan() {
                    f64::NAN
                } else {
                    m.max(v.abs())
                }
            });
            let qs = qscale(&[qmax]);
            dx.iter()
                .zip(&is_time)
                .map(|(d, &t)| d.abs() / if t { tscale } else { qs })
                .fold(0.0f64, |m, v| if v.is_nan() { f64::NAN } else { m.max(v) })
        };
        iterations += newton(&mut asm, &mut y, options, rel)?;
        x = y;
    }
    let mut r = vec![0.0; asm.layout.len()];
    let action = match asm.eval(&x, &mut r, None) {
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
    // Discrete Legendre transforms at the element ends.
    let mut q = vec![0.0; (big_n + 1) * n];
    let mut p = vec![0.0; (big_n + 1) * n];
    for k in 0..big_n {
        asm.load(k);
        let h = asm.step(k);
        element.gradient_in_place(
            lag,
            times[k],
            h,
            &asm.base,
            &asm.incr,
            false,
            &mut asm.work,
            &mut asm.grad,
        );
        q[k * n..(k + 1) * n].copy_from_slice(&asm.base);
        for c in 0..n {
            p[k * n + c] = -asm.grad[c];
            if k + 1 == big_n {
                p[big_n * n + c] = asm.grad[s * n + c];
            }
        }
    }
    q[big_n * n..].copy_from_slice(&bv.q1);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::{NodeFamily, QuadratureKind};

    /// The assembled Jacobian of the moving-mesh system (hyper-dual numbers over times and
    /// nodes) is the derivative of its residual (gradient and discrete energies), by central
    /// differences, at a point off the solution with an uneven mesh.
    #[test]
    fn moving_mesh_jacobian_is_the_derivative_of_the_residual() {
        let lag = crate::models::pendulum(1.0, 1.0, 1.0).unwrap();
        let elements = [
            Element::midpoint(),
            Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(2)).unwrap(),
            Element::galerkin(3, NodeFamily::Lobatto, QuadratureKind::GaussLobatto(4)).unwrap(),
        ];
        for element in &elements {
            let bv = BoundaryValues {
                t0: 0.0,
                q0: vec![1.0],
                t1: 3.0,
                q1: vec![-0.5],
                elements: 4,
            };
            let s = element.degree();
            let layout = Layout {
                n: 1,
                s,
                elements: 4,
                moving: true,
            };
            let mut asm = Assembly {
                lag: &lag,
                element,
                bv: &bv,
                layout,
                n: 1,
                work: ElementWork::new(element, 1),
                nodes: line_guess(&bv, element),
                times: vec![0.0, 0.7, 1.5, 2.2, 3.0],
                base: vec![0.0; 1],
                incr: vec![0.0; s + 1],
                grad: vec![0.0; s + 1],
                hess: vec![0.0; (s + 1) * (s + 1)],
            };
            let len = layout.len();
            let mut x = vec![0.0; len];
            for g in 1..4 * s {
                x[layout.node(g, 0).unwrap()] = asm.nodes[g] + 0.1 * (g as f64).sin();
            }
            for k in 1..4 {
                x[layout.time(k).unwrap()] = asm.times[k];
            }
            let bw = layout.bandwidth();
            let mut band = BandMatrix::zeros(len, bw, bw);
            let mut r = vec![0.0; len];
            asm.eval(&x, &mut r, Some(&mut band)).unwrap();
            let (mut rp, mut rm) = (vec![0.0; len], vec![0.0; len]);
            let d = 1e-6;
            for i in 0..len {
                let mut xp = x.clone();
                xp[i] += d;
                asm.eval(&xp, &mut rp, None).unwrap();
                let mut xm = x.clone();
                xm[i] -= d;
                asm.eval(&xm, &mut rm, None).unwrap();
                for row in 0..len {
                    let fd = (rp[row] - rm[row]) / (2.0 * d);
                    let jac = band.get(row, i);
                    assert!(
                        (fd - jac).abs() < 1e-6 * (1.0 + jac.abs()),
                        "degree {s}: J[{row}][{i}] = {jac} but the difference quotient is {fd}"
                    );
                }
            }
        }
    }
}
