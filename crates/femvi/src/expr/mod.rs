//! Lagrangians from math expressions, for problem files: coordinates by name, the velocity of
//! `x` is `x_dot`, time `t`, named parameters, the constant `pi`; `+ - * / ^`, unary minus,
//! parentheses and the functions sin cos tan exp ln (log) sqrt abs sinh cosh tanh asin acos
//! atan atan2 pow min max. The expression is compiled once into a
//! postfix program with constants folded, evaluated generically over num-dual scalars for its
//! value. At load it is also differentiated symbolically (`dag.rs`: a graph with shared
//! subexpressions and light simplification; `fast.rs`): gradient and Hessian are evaluated from
//! flat f64 tapes (`tape.rs`), equal to automatic differentiation up to rounding, and an
//! expression of the form L = ½vᵀMv − V(t, q) with constant positive definite M
//! (`structure.rs`) reports M and a compiled force −∂V/∂q, so the fixed-point and explicit
//! solvers apply to it as to the built-in models. Expressions too large for the budgets keep
//! automatic differentiation. With the `jit` feature (default) every tape, and the f64 value,
//! also runs as machine code (`native/`, Cranelift), bit for bit the interpreter's results;
//! the force and the value are compiled once more, at their first use, for SIMD lanes of
//! ensemble members (`lanes.rs`, `native/lanes.rs`).
//!
//! Hostile input is safe: sums and products of any length compile and evaluate without
//! recursion (`parse.rs` emits postfix items, `compile.rs` folds them in one loop), and
//! nesting (parentheses, calls, signs, powers) deeper than [`MAX_NESTING`] levels is an
//! [`ExprError`], so the parser's recursion stays within a small stack.
//!
//! Hand-written: expression crates evaluate in f64 only, and we need both generic evaluation
//! and errors that point at the offending character.

mod compile;
mod dag;
mod diff;
mod fast;
mod jacobian;
mod lanes;
#[cfg(feature = "jit")]
mod native;
mod parse;
mod program;
mod structure;
mod tape;

pub(crate) use jacobian::JacobianTape;
pub use parse::{ExprError, MAX_NESTING};
pub use program::Program;

use crate::lagrangian::{Lagrangian, Lanes, MassMatrix, PointDerivatives, Scalar};
use fast::Fast;

/// A Lagrangian given by a math expression in t, the coordinates and their `_dot` velocities.
#[derive(Debug, Clone)]
pub struct ExprLagrangian {
    coordinates: Vec<String>,
    program: Program,
    fast: Box<Fast>,
    autonomous: bool,
    /// The tape of the force's directional derivative, compiled at its first use (tangent
    /// maps of systems above `JACOBIAN_MAX_DIM`; most runs never ask for it).
    force_derivative: std::sync::OnceLock<Option<tape::Tape>>,
    /// The force and value across SIMD lanes, compiled at their first use (ensembles).
    #[cfg_attr(not(feature = "jit"), allow(dead_code))]
    lanes: lanes::LanesCode,
}

impl ExprLagrangian {
    /// Compiles `source` with the given coordinate names and parameter values.
    ///
    /// # Errors
    /// [`ExprError`] with the position of a syntax error, an unknown symbol, a wrong number of
    /// function arguments, nesting deeper than [`MAX_NESTING`], or a name clash among t, the
    /// coordinates, their velocities and the parameters.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::expr::ExprLagrangian;
    /// use femvi::Lagrangian;
    ///
    /// let coords = ["theta".to_string()];
    /// let lag = ExprLagrangian::new("0.5*l^2*theta_dot^2 + g*l*cos(theta)", &coords, &[("g".into(), 9.81), ("l".into(), 2.0)])?;
    /// // L(t, θ = 0, θ̇ = 1) = ½ l² + g l.
    /// let l: f64 = lag.value(0.0, &[0.0], &[1.0]);
    /// assert!((l - (2.0 + 9.81 * 2.0)).abs() < 1e-12);
    /// assert!(ExprLagrangian::new("theta_dot^2 +", &coords, &[]).is_err());
    /// # Ok::<(), femvi::expr::ExprError>(())
    /// ```
    pub fn new(source: &str, coordinates: &[String], parameters: &[(String, f64)]) -> Result<Self, ExprError> {
        let mut vars = vec!["t".to_string()];
        vars.extend(coordinates.iter().cloned());
        vars.extend(coordinates.iter().map(|c| format!("{c}_dot")));
        let mut seen = std::collections::HashSet::with_capacity(vars.len());
        if let Some(twice) = vars.iter().find(|v| !seen.insert(v.as_str())) {
            return Err(ExprError::at(
                source,
                0,
                format!(
                    "the name '{twice}' is given twice (t, the coordinates and their _dot velocities must all differ)"
                ),
            ));
        }
        let program = Program::compile(source, &vars, parameters)?;
        let fast = Box::new(Fast::new(&program, coordinates.len()));
        Ok(Self {
            coordinates: coordinates.to_vec(),
            autonomous: !program.uses_variable(0),
            program,
            fast,
            force_derivative: std::sync::OnceLock::new(),
            lanes: lanes::LanesCode::default(),
        })
    }

    /// Coordinate names.
    pub fn coordinates(&self) -> &[String] {
        &self.coordinates
    }

    /// Whether the expression mentions `t`.
    pub fn depends_on_time(&self) -> bool {
        !self.autonomous
    }

    /// Whether the expression was recognised as mechanical, L = ½vᵀMv − V(t, q) with a
    /// constant positive definite M (then [`Lagrangian::mass_matrix`] returns M and the
    /// fixed-point and explicit solvers apply).
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::expr::ExprLagrangian;
    /// use femvi::Lagrangian;
    ///
    /// let xy = ["x".to_string(), "y".to_string()];
    /// let kepler = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2)", &xy, &[])?;
    /// assert!(kepler.is_mechanical());
    /// assert_eq!(kepler.mass_matrix().and_then(|m| m.get(1, 1)), Some(1.0));
    /// // A magnetic field adds a term linear in the velocities: not mechanical.
    /// let magnetic = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2) + x*y_dot", &xy, &[])?;
    /// assert!(!magnetic.is_mechanical());
    /// # Ok::<(), femvi::expr::ExprError>(())
    /// ```
    pub fn is_mechanical(&self) -> bool {
        self.fast.mass.is_some()
    }

    /// Whether first and second derivatives come from compiled symbolic tapes rather than
    /// automatic differentiation (false only for expressions too large to differentiate
    /// symbolically within the budgets).
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::expr::ExprLagrangian;
    ///
    /// let lag = ExprLagrangian::new("-sqrt(1 - x_dot^2) - 1/x", &["x".to_string()], &[])?;
    /// assert_eq!(lag.has_compiled_derivatives(), (true, true));
    /// assert!(!lag.is_mechanical());
    /// # Ok::<(), femvi::expr::ExprError>(())
    /// ```
    pub fn has_compiled_derivatives(&self) -> (bool, bool) {
        (self.fast.first.is_some(), self.fast.second.is_some())
    }
}

impl Lagrangian for ExprLagrangian {
    fn dim(&self) -> usize {
        self.coordinates.len()
    }

    fn is_autonomous(&self) -> bool {
        self.autonomous
    }

    fn mass_matrix(&self) -> Option<&MassMatrix> {
        self.fast.mass.as_ref()
    }

    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        if let Some(tape) = &self.fast.force {
            return tape.eval(t, q, &[], |i, x| {
                if let Some(o) = out.get_mut(i) {
                    *o = x;
                }
            });
        }
        let n = self.dim();
        let mut d = PointDerivatives::new(n);
        self.first_derivatives(t, q, &vec![0.0; n], false, &mut d);
        out.iter_mut().zip(d.l_q()).for_each(|(o, f)| *o = *f);
    }

    fn force_lanes(&self, t: f64, q: &[Lanes], out: &mut [Lanes]) {
        self.force_in_lanes(t, q, out);
    }

    fn value_lanes(&self, t: f64, q: &[Lanes], v: &[Lanes]) -> Lanes {
        self.value_in_lanes(t, q, v)
    }

    fn forces(&self, t: &[f64], q: &[f64], out: &mut [f64]) {
        match &self.fast.force {
            Some(tape) => tape.eval_points(t, q, &[], out),
            None => {
                let n = self.dim();
                if n == 0 {
                    return;
                }
                for ((&ti, qi), oi) in t.iter().zip(q.chunks_exact(n)).zip(out.chunks_exact_mut(n)) {
                    self.force(ti, qi, oi);
                }
            }
        }
    }

    /// By a tape of (∂f/∂q)·dq compiled from the expression at the first call, for a
    /// mechanical expression; the default (hyper-dual passes) otherwise.
    fn force_derivative(&self, t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
        let n = self.dim();
        if self.fast.mass.is_some() && q.len() == n && dq.len() == n {
            let tape = self
                .force_derivative
                .get_or_init(|| fast::force_derivative_tape(&self.program, n));
            if let Some(tape) = tape {
                return tape.eval(t, q, dq, |i, x| {
                    if let Some(o) = out.get_mut(i) {
                        *o = x;
                    }
                });
            }
        }
        crate::lagrangian::force_derivative_by_ad(self, t, q, dq, out);
    }

    /// From the compiled Hessian (its q block at v = 0), for a mechanical expression whose
    /// Hessian tape was built; false otherwise.
    fn force_jacobian(&self, t: f64, q: &[f64], out: &mut [f64]) -> bool {
        let n = self.dim();
        let (Some(tape), Some(_)) = (&self.fast.second, &self.fast.mass) else {
            return false;
        };
        if q.len() != n || out.len() != n * n {
            return false;
        }
        // The q block of the Hessian at v = 0, read straight from the tape's outputs (no
        // scratch: this runs at every stage of every step of a tangent map).
        let (stack, heap);
        let zeros: &[f64] = if n <= 32 {
            stack = [0.0; 32];
            &stack[..n]
        } else {
            heap = vec![0.0; n];
            &heap
        };
        hessian_outputs(tape, (t, q, zeros), 2 * n + 1, |entry| {
            if let SecondOutput::Hessian(a, b, x) = entry {
                if (1..=n).contains(&a) && (1..=n).contains(&b) {
                    out[(a - 1) * n + b - 1] = x;
                    out[(b - 1) * n + a - 1] = x;
                }
            }
        });
        true
    }

    fn gyroscopic_mass(&self) -> Option<&MassMatrix> {
        self.fast.gyro_mass.as_ref()
    }

    fn gyroscopic_terms(&self, t: &[f64], q: &[f64], v: &[f64], out: &mut [f64]) {
        match &self.fast.gyro {
            Some(tape) => tape.eval_points(t, q, v, out),
            None => {
                let n = self.dim();
                if n == 0 {
                    return;
                }
                let mut d = PointDerivatives::new(n);
                let points = q.chunks_exact(n).zip(v.chunks_exact(n));
                for ((&ti, (qi, vi)), oi) in t.iter().zip(points).zip(out.chunks_exact_mut(2 * n)) {
                    self.first_derivatives(ti, qi, vi, false, &mut d);
                    oi[..n].copy_from_slice(d.l_v());
                    oi[n..].copy_from_slice(d.l_q());
                }
            }
        }
    }

    fn first_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        let Some(tape) = &self.fast.first else {
            return out.first_by_ad(self, t, q, v, with_t);
        };
        if !fits(out, self.dim(), q, v) {
            return;
        }
        tape.eval(t, q, v, |j, x| match j {
            0 => out.value = x,
            _ => {
                if let Some(g) = out.grad.get_mut(j - 1) {
                    *g = x;
                }
            }
        });
        if !with_t || self.autonomous {
            out.grad[0] = 0.0;
        }
    }

    fn second_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        let Some(tape) = &self.fast.second else {
            return out.second_by_ad(self, t, q, v, with_t);
        };
        let m = out.hessian_mut().len();
        if !fits(out, self.dim(), q, v) {
            out.hess.iter_mut().for_each(|h| *h = f64::NAN);
            return;
        }
        let width = out.width();
        debug_assert_eq!(m, width * width);
        hessian_outputs(tape, (t, q, v), width, |entry| match entry {
            SecondOutput::Value(x) => out.value = x,
            SecondOutput::Gradient(i, x) => out.grad[i] = x,
            SecondOutput::Hessian(a, b, x) => {
                out.hess[a * width + b] = x;
                out.hess[b * width + a] = x;
            }
        });
        if !with_t || self.autonomous {
            out.grad[0] = 0.0;
            for k in 0..width {
                out.hess[k] = 0.0;
                out.hess[k * width] = 0.0;
            }
        }
    }

    fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        let n = self.coordinates.len();
        // A scalar without derivative parts (f64: the energy at every node of a run) takes
        // the program's machine code, equal to `Program::eval` bit for bit.
        #[cfg(feature = "jit")]
        if D::NDERIV == 0 {
            if let Some(x) = self.fast.value.as_deref().and_then(|code| native_value(code, t, q, v)) {
                return D::from(x);
            }
        }
        // q and v have n entries when the library calls; a shorter slice reads NaN.
        let nan = D::from(f64::NAN);
        self.program.eval(|i| {
            if i == 0 {
                t
            } else if i <= n {
                q.get(i - 1).copied().unwrap_or(nan)
            } else {
                v.get(i - 1 - n).copied().unwrap_or(nan)
            }
        })
    }
}

/// One output of the Hessian tape (`Fast::second`): L, ∂L/∂z_i, or ∂²L/∂z_a∂z_b (a ≤ b).
enum SecondOutput {
    Value(f64),
    Gradient(usize, f64),
    Hessian(usize, usize, f64),
}

/// Evaluates the Hessian tape at (t, q, v) over z of `width` = 2n + 1 variables and hands
/// each output to `f`: L, the gradient, then the upper triangle row by row.
fn hessian_outputs(tape: &tape::Tape, (t, q, v): (f64, &[f64], &[f64]), width: usize, mut f: impl FnMut(SecondOutput)) {
    let (mut a, mut b) = (0, 0);
    tape.eval(t, q, v, |j, x| {
        if j == 0 {
            f(SecondOutput::Value(x));
        } else if j <= width {
            f(SecondOutput::Gradient(j - 1, x));
        } else {
            f(SecondOutput::Hessian(a, b, x));
            b += 1;
            if b == width {
                a += 1;
                b = a;
            }
        }
    });
}

/// The value from machine code, for q and v of at most 16 entries (copied to f64 arrays);
/// `None` otherwise, or when they are shorter than the code reads.
#[cfg(feature = "jit")]
fn native_value<D: Scalar>(code: &native::Native, t: D, q: &[D], v: &[D]) -> Option<f64> {
    const MAX: usize = 16;
    let (mut qb, mut vb) = ([0.0; MAX], [0.0; MAX]);
    let (qb, vb) = (qb.get_mut(..q.len())?, vb.get_mut(..v.len())?);
    qb.iter_mut().zip(q).for_each(|(b, x)| *b = x.re());
    vb.iter_mut().zip(v).for_each(|(b, x)| *b = x.re());
    let mut out = [0.0];
    code.call(t.re(), qb, vb, &mut out).then_some(out[0])
}

/// Whether `out` holds buffers for dimension n and q, v have n entries; if not, its value and
/// gradient are set to NaN (as the automatic-differentiation path does).
fn fits(out: &mut PointDerivatives, n: usize, q: &[f64], v: &[f64]) -> bool {
    let ok = out.dim() == n && q.len() == n && v.len() == n && out.grad.len() == out.width();
    if !ok {
        out.value = f64::NAN;
        out.grad.iter_mut().for_each(|g| *g = f64::NAN);
    }
    ok
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lagrangian::PointDerivatives;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn pendulum_expression_and_derivatives() {
        let l = ExprLagrangian::new(
            "0.5*l^2*theta_dot^2 + g*l*cos(theta)",
            &names(&["theta"]),
            &[("g".into(), 9.81), ("l".into(), 2.0)],
        )
        .unwrap();
        let (q, v) = (0.3f64, 0.7f64);
        let val = l.value(0.0, &[q], &[v]);
        assert!((val - (0.5 * 4.0 * v * v + 9.81 * 2.0 * q.cos())).abs() < 1e-14);
        let mut d = PointDerivatives::new(1);
        l.second_derivatives(0.0, &[q], &[v], true, &mut d);
        assert!((d.l_q()[0] + 9.81 * 2.0 * q.sin()).abs() < 1e-13);
        assert!((d.l_v()[0] - 4.0 * v).abs() < 1e-14);
        assert!((d.h(2, 2) - 4.0).abs() < 1e-14);
        assert!((d.h(1, 1) + 9.81 * 2.0 * q.cos()).abs() < 1e-13);
        assert_eq!(d.l_t(), 0.0);
        assert!(!l.depends_on_time());
    }

    #[test]
    fn every_function_and_operator() {
        let c = names(&["x"]);
        let cases: &[(&str, f64)] = &[
            ("2^3^2", 512.0),
            ("-2^2", -4.0),
            ("2^-1", 0.5),
            ("1.5e1 + .5 + 1. + 2E-1", 16.7),
            ("(1+2)*3 - 4/2", 7.0),
            ("sin(pi/2) + cos(0) + tan(0)", 2.0),
            ("exp(0) + ln(1) + log(1) + sqrt(4) + abs(-3)", 6.0),
            ("sinh(0) + cosh(0) + tanh(0)", 1.0),
            (
                "asin(1) + acos(1) + atan(1)",
                std::f64::consts::FRAC_PI_2 + std::f64::consts::FRAC_PI_4,
            ),
            (
                "atan2(1, 1) + pow(2, 10) + min(1, 2) + max(1, 2)",
                std::f64::consts::FRAC_PI_4 + 1024.0 + 3.0,
            ),
            ("x*x_dot + t", 0.5 * 3.0 + 7.0),
        ];
        for (src, want) in cases {
            let l = ExprLagrangian::new(src, &c, &[]).unwrap();
            let got = l.value(7.0, &[0.5], &[3.0]);
            assert!((got - want).abs() < 1e-12, "{src}: {got} != {want}");
        }
    }

    /// The compiled directional derivative of the force and the compiled Jacobian against
    /// the hyper-dual default, on a chain of 20 coupled coordinates (time-dependent, with a
    /// transcendental coupling).
    #[test]
    fn compiled_force_derivatives_agree_with_automatic_differentiation() {
        let n = 20;
        let c: Vec<String> = (0..n).map(|i| format!("x{i}")).collect();
        let mut src: Vec<String> = (0..n).map(|i| format!("0.5*x{i}_dot^2")).collect();
        for i in 0..n - 1 {
            src.push(format!("(-0.5*(x{}-x{i})^2 - 0.1*cos(t)*(x{}-x{i})^4)", i + 1, i + 1));
        }
        src.push("(-sin(x0*x5))".into());
        let l = ExprLagrangian::new(&src.join(" + "), &c, &[]).unwrap();
        assert!(l.mass_matrix().is_some());
        let q: Vec<f64> = (0..n).map(|i| 0.3 * (i as f64).sin()).collect();
        let dq: Vec<f64> = (0..n).map(|i| 0.2 - 0.03 * i as f64).collect();
        let (mut got, mut want) = (vec![0.0; n], vec![0.0; n]);
        l.force_derivative(0.7, &q, &dq, &mut got);
        crate::lagrangian::force_derivative_by_ad(&l, 0.7, &q, &dq, &mut want);
        let mut jac = vec![0.0; n * n];
        assert!(l.force_jacobian(0.7, &q, &mut jac));
        for i in 0..n {
            let by_jac: f64 = (0..n).map(|j| jac[i * n + j] * dq[j]).sum();
            assert!((got[i] - want[i]).abs() < 1e-13, "{i}: {} vs {}", got[i], want[i]);
            assert!((by_jac - want[i]).abs() < 1e-13, "{i}: {by_jac} vs {}", want[i]);
        }
    }

    #[test]
    fn errors_point_at_the_problem() {
        let c = names(&["x"]);
        let e = ExprLagrangian::new("0.5*x_dot^2 - y", &c, &[]).unwrap_err();
        assert!(e.message.contains("unknown symbol 'y'"), "{}", e.message);
        assert_eq!((e.line, e.column), (1, 15));
        assert!(e.render().contains("              ^"), "{}", e.render());
        let e = ExprLagrangian::new("0.5*x_dot^2 +\n  (x", &c, &[]).unwrap_err();
        assert_eq!(e.line, 2);
        let e = ExprLagrangian::new("sin(x, x)", &c, &[]).unwrap_err();
        assert!(e.message.contains("takes 1 argument"), "{}", e.message);
        let e = ExprLagrangian::new("x $ 2", &c, &[]).unwrap_err();
        assert!(e.message.contains("unexpected character"), "{}", e.message);
        assert!(ExprLagrangian::new("", &c, &[]).is_err());
        assert!(ExprLagrangian::new("x 2", &c, &[]).is_err());
        assert!(ExprLagrangian::new("foo(x)", &c, &[])
            .unwrap_err()
            .message
            .contains("unknown function"));
        assert!(ExprLagrangian::new("x", &c, &[("x".into(), 1.0)]).is_err());
    }

    #[test]
    fn clashing_names_and_short_slices() {
        for coords in [&["x", "x"][..], &["t"], &["x", "x_dot"]] {
            let e = ExprLagrangian::new("x", &names(coords), &[]).unwrap_err();
            assert!(e.message.contains("twice"), "{coords:?}: {}", e.message);
        }
        let l = ExprLagrangian::new("x + y_dot", &names(&["x", "y"]), &[]).unwrap();
        assert!(l.value::<f64>(0.0, &[1.0], &[]).is_nan());
        assert_eq!(l.value::<f64>(0.0, &[1.0, 2.0], &[3.0, 4.0]), 5.0);
    }

    #[test]
    fn integer_powers_differentiate_at_zero() {
        let l = ExprLagrangian::new("x^2 + x_dot^2", &names(&["x"]), &[]).unwrap();
        let mut d = PointDerivatives::new(1);
        l.second_derivatives(0.0, &[0.0], &[0.0], false, &mut d);
        assert_eq!(d.h(1, 1), 2.0);
        assert!(d.grad.iter().all(|g| g.is_finite()));
    }
}
