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
    /// Number of holonomic constraints g(q) = 0 the system is held to; none by default
    /// ([`WithConstraints`] adds them).
    fn constraint_count(&self) -> usize {
        0
    }
    /// g(q) into `out` ([`Controls::constraint_count`] entries).
    fn constraints<D: Scalar>(&self, _q: &[D], _out: &mut [D]) {}
    /// The number of coordinates the constraints are written for (checked against
    /// [`Controls::dim`]); that of the controls by default.
    fn constraint_dim(&self) -> usize {
        self.dim()
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

    fn constraint_count(&self) -> usize {
        self.controls.constraint_count()
    }

    fn constraints<D: Scalar>(&self, q: &[D], out: &mut [D]) {
        self.controls.constraints(q, out)
    }

    fn constraint_dim(&self) -> usize {
        self.controls.constraint_dim()
    }
}

/// Controls on a system held to holonomic constraints g(q) = 0 (DESIGN §4): the constraint
/// forces −G(q)ᵀν act at every node beside the controls' force.
///
/// # Example
///
/// ```
/// use femvi::constraints::ExprConstraints;
/// use femvi::optimize::{Controls, ExprControls, WithConstraints};
///
/// let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
/// let xy = s(&["x", "y"]);
/// let push = ExprControls::new(&xy, &s(&["u"]), &s(&["u", "0"]), "u^2", &[])?;
/// let circle = ExprConstraints::new(&s(&["x^2 + y^2 - 1"]), &xy, &[])?;
/// let held = WithConstraints { controls: &push, constraints: &circle };
/// let mut g = [0.0f64];
/// held.constraints(&[0.6, 0.8], &mut g);
/// assert_eq!(held.constraint_count(), 1);
/// assert!(g[0].abs() < 1e-15);
/// # Ok::<(), femvi::expr::ExprError>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct WithConstraints<'a, C, K> {
    /// The controls.
    pub controls: &'a C,
    /// The constraints.
    pub constraints: &'a K,
}

impl<C: Controls, K: crate::constraints::Constraints> Controls for WithConstraints<'_, C, K> {
    fn dim(&self) -> usize {
        self.controls.dim()
    }

    fn controls(&self) -> usize {
        self.controls.controls()
    }

    fn force<D: Scalar>(&self, t: D, q: &[D], v: &[D], u: &[D], out: &mut [D]) {
        self.controls.force(t, q, v, u, out);
    }

    fn running_cost<D: Scalar>(&self, t: D, q: &[D], v: &[D], u: &[D]) -> D {
        self.controls.running_cost(t, q, v, u)
    }

    fn terminal_cost<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        self.controls.terminal_cost(t, q, v)
    }

    fn constraint_count(&self) -> usize {
        self.constraints.count()
    }

    fn constraints<D: Scalar>(&self, q: &[D], out: &mut [D]) {
        self.constraints.value(q, out)
    }

    fn constraint_dim(&self) -> usize {
        self.constraints.dim()
    }
}

/// The constraints of [`Controls`] as [`Constraints`](crate::constraints::Constraints), for
/// the library's constraint jets and projections.
pub(super) struct Held<'a, C>(pub(super) &'a C);

impl<C: Controls> crate::constraints::Constraints for Held<'_, C> {
    fn dim(&self) -> usize {
        self.0.dim()
    }

    fn count(&self) -> usize {
        self.0.constraint_count()
    }

    fn value<D: Scalar>(&self, q: &[D], out: &mut [D]) {
        self.0.constraints(q, out)
    }
}
