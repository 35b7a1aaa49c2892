//! The one integrator of a loaded problem (issue 33, item 5: thin front ends): the
//! Lagrangian with the problem's terms — rotations (the Lie-group element), forces,
//! constraints, time steps as variables — built by one function that `femvi run`,
//! `ensemble`, `convergence` and `chaos` all call, so that a term the loader accepts reaches
//! every command the capability table lets through ([`super::capabilities`]).

use super::Problem;
use femvi::{Element, EnergyOptions, Integrator, Lagrangian, Start, TimeGrid};

impl Problem {
    /// The integrator of this problem's terms for the Lagrangian `lag`, with `element`,
    /// `grid`, `start`, and time steps as variables when `energy` is given (commands pass
    /// [`Problem::energy`], or None for runs on a grid of fixed steps).
    ///
    /// Combinations the loader refuses (rotations with constraints, adaptive steps or the
    /// energy mode, constraints in the energy mode) do not reach here; rotations take
    /// precedence (with the force, if any: `Integrator::with_rotations_and_force`), and
    /// constraints ignore `energy`.
    ///
    /// # Errors
    /// As the library's constructors: a start of the wrong size, a start off SO(3), a failed
    /// first element of a start from (q0, q1).
    ///
    /// # Example
    ///
    /// ```
    /// let text = "[system]\nmodel = \"rigid-body\"\n[initial]\nR_quaternion = [1.0, 0.0, 0.0, 0.0]\n\
    ///             R_w = [0.5, 1.0, 0.3]\n[time]\nstep = 0.01\nend = 0.1\n";
    /// let problem = femvi_cli::problem::load_text(std::path::Path::new("body.toml"), text, &[])
    ///     .map_err(|e| e.to_string())?;
    /// let femvi_cli::problem::System::Rigid(lag) = &problem.system else { unreachable!() };
    /// let mut it = problem
    ///     .integrator(lag, &problem.element, problem.grid.clone(), problem.start.clone(), problem.energy)
    ///     .map_err(|e| e.to_string())?;
    /// while it.step().map_err(|e| e.to_string())? {}
    /// // The Lie-group element: the body angular momentum is at the node.
    /// assert_eq!(it.node_rotations().map(|b| b.len()), Some(1));
    /// # Ok::<(), String>(())
    /// ```
    pub fn integrator<'a, L: Lagrangian + Sync>(
        &'a self,
        lag: &'a L,
        element: &'a Element,
        grid: TimeGrid,
        start: Start,
        energy: Option<EnergyOptions>,
    ) -> femvi::Result<Integrator<'a, L>> {
        let opts = self.options;
        let (force, constraints) = (&self.terms.force, &self.terms.constraints);
        if let Some(r) = &self.terms.rotations {
            return match force {
                Some(f) => Integrator::with_rotations_and_force(lag, element, grid, start, opts, r.clone(), f),
                None => Integrator::with_rotations(lag, element, grid, start, opts, r.clone()),
            };
        }
        match (energy, force, constraints) {
            (None, None, None) => Integrator::new(lag, element, grid, start, opts),
            (None, Some(f), None) => Integrator::with_force(lag, element, grid, start, opts, f),
            (_, None, Some((c, e))) => Integrator::with_constraints(lag, element, grid, start, opts, c, *e),
            (_, Some(f), Some((c, e))) => {
                Integrator::with_constraints_and_force(lag, element, grid, start, opts, c, *e, f)
            }
            (Some(e), Some(f), None) => Integrator::with_force_energy(lag, element, grid, start, opts, f, e),
            (Some(e), None, None) => Integrator::with_energy(lag, element, grid, start, opts, e),
        }
    }
}
