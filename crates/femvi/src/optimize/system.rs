//! The controlled system of an optimal control problem: the generalised force F(t, q, v, u)
//! through which the controls act (the discrete Lagrange–d'Alembert principle, DESIGN §4) and
//! the running cost C(t, q, v, u) of the objective. [`Controls`] is generic over num-dual
//! scalars, as [`Lagrangian`](crate::Lagrangian) is, so one definition gives every derivative
//! the optimiser needs; [`ExprControls`] compiles both from math expressions.

use crate::expr::{ExprError, Program};
use crate::lagrangian::Scalar;

/// The controls of a system: how they force it and what they cost.
///
/// # Example
///
/// The double integrator x″ = u: L = ½ẋ², the force is u and the running cost u².
///
/// ```
/// use femvi::optimize::Controls;
/// use femvi::Scalar;
///
/// struct Push;
/// impl Controls for Push {
///     fn dim(&self) -> usize { 1 }
///     fn controls(&self) -> usize { 1 }
///     fn force<D: Scalar>(&self, _t: D, _q: &[D], _v: &[D], u: &[D], out: &mut [D]) {
///         out[0] = u[0];
///     }
///     fn running_cost<D: Scalar>(&self, _t: D, _q: &[D], _v: &[D], u: &[D]) -> D {
///         u[0] * u[0]
///     }
/// }
/// let mut f = [0.0];
/// Push.force(0.0, &[0.0], &[0.0], &[2.0], &mut f);
/// assert_eq!((f[0], Push.running_cost(0.0, &[0.0], &[0.0], &[2.0])), (2.0, 4.0));
/// ```
pub trait Controls {
    /// Dimension n of the configuration space (that of the Lagrangian).
    fn dim(&self) -> usize;
    /// Number m of controls.
    fn controls(&self) -> usize;
    /// The generalised force F(t, q, v, u) ∈ Rⁿ into `out` (n entries).
    fn force<D: Scalar>(&self, t: D, q: &[D], v: &[D], u: &[D], out: &mut [D]);
    /// The running cost C(t, q, v, u), integrated over [t0, t1] by the element's quadrature.
    fn running_cost<D: Scalar>(&self, t: D, q: &[D], v: &[D], u: &[D]) -> D;
    /// The terminal cost Φ(t1, q_N, v_N) in the end state; none by default. It matters when
    /// a component of the end state, or t1, is left free.
    fn terminal_cost<D: Scalar>(&self, _t: D, _q: &[D], _v: &[D]) -> D {
        D::from(0.0)
    }
}

/// Controls from math expressions in t, the coordinates, their `_dot` velocities and the
/// control names (the syntax of [`ExprLagrangian`](crate::expr::ExprLagrangian)).
#[derive(Debug, Clone)]
pub struct ExprControls {
    n: usize,
    m: usize,
    force: Vec<Program>,
    cost: Program,
    terminal: Option<Program>,
}

impl ExprControls {
    /// Compiles one force expression per coordinate and the running cost.
    ///
    /// # Errors
    /// [`ExprError`] for an expression that does not compile (its position in the text),
    /// a number of force expressions other than the number of coordinates, or a control
    /// named like a coordinate, a velocity or `t`.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::optimize::{Controls, ExprControls};
    ///
    /// let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    /// let c = ExprControls::new(&names(&["x"]), &names(&["u"]), &names(&["u - 0.1*x_dot"]), "u^2", &[])?;
    /// let mut f = [0.0];
    /// c.force(0.0, &[0.0], &[1.0], &[2.0], &mut f);
    /// assert!((f[0] - 1.9_f64).abs() < 1e-15);
    /// assert!(ExprControls::new(&names(&["x"]), &names(&["x"]), &names(&["x"]), "x^2", &[]).is_err());
    /// # Ok::<(), femvi::expr::ExprError>(())
    /// ```
    pub fn new(
        coordinates: &[String],
        controls: &[String],
        force: &[String],
        running: &str,
        parameters: &[(String, f64)],
    ) -> Result<Self, ExprError> {
        let mut vars = vec!["t".to_string()];
        vars.extend(coordinates.iter().cloned());
        vars.extend(coordinates.iter().map(|c| format!("{c}_dot")));
        for name in controls {
            if vars.contains(name) {
                return Err(ExprError::at(
                    name,
                    0,
                    format!("control '{name}' has the name of a variable"),
                ));
            }
            vars.push(name.clone());
        }
        if force.len() != coordinates.len() {
            let text = force.join(", ");
            let why = format!(
                "{} force expressions for {} coordinates: give one per coordinate",
                force.len(),
                coordinates.len()
            );
            return Err(ExprError::at(&text, 0, why));
        }
        let force = force
            .iter()
            .map(|f| Program::compile(f, &vars, parameters))
            .collect::<Result<Vec<_>, _>>()?;
        let cost = Program::compile(running, &vars, parameters)?;
        Ok(Self {
            n: coordinates.len(),
            m: controls.len(),
            force,
            cost,
            terminal: None,
        })
    }

    /// Adds the terminal cost Φ(t, q, q_dot) in the end state, an expression in t, the
    /// coordinates and their `_dot` velocities (not the controls).
    ///
    /// # Errors
    /// [`ExprError`] for an expression that does not compile or names a control.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::optimize::{Controls, ExprControls};
    ///
    /// let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    /// let x = names(&["x"]);
    /// let c = ExprControls::new(&x, &names(&["u"]), &names(&["u"]), "u^2", &[])?
    ///     .with_terminal(&x, "3*(x - 1)^2 + x_dot^2", &[])?;
    /// assert_eq!(c.terminal_cost(0.0, &[2.0], &[1.0]), 4.0);
    /// assert!(c.clone().with_terminal(&x, "u", &[]).is_err());
    /// # Ok::<(), femvi::expr::ExprError>(())
    /// ```
    pub fn with_terminal(
        mut self,
        coordinates: &[String],
        terminal: &str,
        parameters: &[(String, f64)],
    ) -> Result<Self, ExprError> {
        if coordinates.len() != self.n {
            let why = format!("{} coordinates for controls of {}", coordinates.len(), self.n);
            return Err(ExprError::at(terminal, 0, why));
        }
        let mut vars = vec!["t".to_string()];
        vars.extend(coordinates.iter().cloned());
        vars.extend(coordinates.iter().map(|c| format!("{c}_dot")));
        self.terminal = Some(Program::compile(terminal, &vars, parameters)?);
        Ok(self)
    }

    fn var<D: Scalar>(&self, t: D, q: &[D], v: &[D], u: &[D], i: usize) -> D {
        let nan = D::from(f64::NAN);
        let n = self.n;
        if i == 0 {
            t
        } else if i <= n {
            q.get(i - 1).copied().unwrap_or(nan)
        } else if i <= 2 * n {
            v.get(i - 1 - n).copied().unwrap_or(nan)
        } else {
            u.get(i - 1 - 2 * n).copied().unwrap_or(nan)
        }
    }
}

impl Controls for ExprControls {
    fn dim(&self) -> usize {
        self.n
    }

    fn controls(&self) -> usize {
        self.m
    }

    fn force<D: Scalar>(&self, t: D, q: &[D], v: &[D], u: &[D], out: &mut [D]) {
        for (o, f) in out.iter_mut().zip(&self.force) {
            *o = f.eval(|i| self.var(t, q, v, u, i));
        }
    }

    fn running_cost<D: Scalar>(&self, t: D, q: &[D], v: &[D], u: &[D]) -> D {
        self.cost.eval(|i| self.var(t, q, v, u, i))
    }

    fn terminal_cost<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        self.terminal
            .as_ref()
            .map_or(D::from(0.0), |p| p.eval(|i| self.var(t, q, v, &[], i)))
    }
}

/// Controls with the system's own force beside them (friction plus controls): the force is
/// F_controls(t, q, v, u) + F_system(t, q, v), the cost that of the controls.
///
/// # Example
///
/// ```
/// use femvi::forces::Force;
/// use femvi::optimize::{Controls, ExprControls, WithForce};
/// use femvi::Scalar;
///
/// struct Friction;
/// impl Force for Friction {
///     fn dim(&self) -> usize { 1 }
///     fn force<D: Scalar>(&self, _t: D, _q: &[D], v: &[D], out: &mut [D]) { out[0] = -v[0] * 0.5; }
/// }
/// let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
/// let push = ExprControls::new(&s(&["x"]), &s(&["u"]), &s(&["u"]), "u^2", &[])?;
/// let both = WithForce { controls: &push, force: &Friction };
/// let mut f = [0.0];
/// both.force(0.0, &[0.0], &[2.0], &[3.0], &mut f);
/// assert_eq!(f[0], 2.0);
/// # Ok::<(), femvi::expr::ExprError>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct WithForce<'a, C, F> {
    /// The controls.
    pub controls: &'a C,
    /// The system's own force.
    pub force: &'a F,
}

impl<C: Controls, F: crate::forces::Force> Controls for WithForce<'_, C, F> {
    fn dim(&self) -> usize {
        self.controls.dim()
    }

    fn controls(&self) -> usize {
        self.controls.controls()
    }

    fn force<D: Scalar>(&self, t: D, q: &[D], v: &[D], u: &[D], out: &mut [D]) {
        self.controls.force(t, q, v, u, out);
        let mut own = vec![D::from(0.0); out.len()];
        self.force.force(t, q, v, &mut own);
        out.iter_mut().zip(own).for_each(|(o, f)| *o += f);
    }

    fn running_cost<D: Scalar>(&self, t: D, q: &[D], v: &[D], u: &[D]) -> D {
        self.controls.running_cost(t, q, v, u)
    }

    fn terminal_cost<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        self.controls.terminal_cost(t, q, v)
    }
}
