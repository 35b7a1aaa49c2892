//! Which nodes the energy report covers (issue 15, item 4: the energy "inside the fast loops
//! where it is cheap … or only at written nodes where it is not, with the summary saying
//! which"). For a Lagrangian with a constant mass matrix H = ½pᵀM⁻¹p + V costs less than a
//! step, and every node is checked. For any other Lagrangian H needs an inverse Legendre
//! transform (a Newton solve) per node, about a quarter of a `femvi run` of a relativistic
//! Kepler orbit: there, by default, only the nodes kept in the output (every `every`-th, the
//! first and the last) are checked, each inversion started from the velocity of the element
//! that ends on the node (the interpolant's derivative, the paper's (2.26)), so that it does
//! not depend on a node many steps back. A time-dependent Lagrangian is checked at every node
//! whatever is asked, since its energy balance integrates −∂L/∂t over the nodes.

use crate::lagrangian::Lagrangian;

/// Which nodes the energy report covers ([`crate::SolveOptions::energy_nodes`], the problem
/// file's `[output] energy_nodes`).
///
/// ```
/// use femvi::solution::EnergyNodes;
/// use femvi::models;
/// // A constant mass matrix: every node is cheap.
/// assert_eq!(EnergyNodes::Auto.resolve(&models::kepler(1.0)?), EnergyNodes::Every);
/// // An autonomous Lagrangian without one: the kept nodes only, unless asked otherwise.
/// let rel = models::RelativisticKepler { c: 10.0 };
/// assert_eq!(EnergyNodes::Auto.resolve(&rel), EnergyNodes::Kept);
/// assert_eq!(EnergyNodes::Every.resolve(&rel), EnergyNodes::Every);
/// assert_eq!("kept".parse::<EnergyNodes>(), Ok(EnergyNodes::Kept));
/// # Ok::<(), femvi::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EnergyNodes {
    /// [`EnergyNodes::Every`] where H is cheap (a constant mass matrix) or the energy balance
    /// needs every node (a time-dependent Lagrangian); [`EnergyNodes::Kept`] otherwise.
    #[default]
    Auto,
    /// Every node of the run.
    Every,
    /// The nodes kept in the output: node 0, every `every`-th, the last (and the node a
    /// stopped run ends on). Time-dependent Lagrangians are checked at every node anyway.
    Kept,
}

impl EnergyNodes {
    /// What `self` means for `lag`: [`EnergyNodes::Every`] or [`EnergyNodes::Kept`].
    pub fn resolve<L: Lagrangian>(self, lag: &L) -> Self {
        let cheap = lag.mass_matrix().is_some();
        match self {
            _ if !lag.is_autonomous() => Self::Every,
            Self::Auto if cheap => Self::Every,
            Self::Auto | Self::Kept => Self::Kept,
            Self::Every => Self::Every,
        }
    }

    /// The name the problem file, summary.json and the Python package use.
    pub fn name(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Every => "every",
            Self::Kept => "kept",
        }
    }
}

impl std::str::FromStr for EnergyNodes {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            "every" => Ok(Self::Every),
            "kept" => Ok(Self::Kept),
            _ => Err(format!(
                "energy_nodes must be \"auto\", \"every\" or \"kept\", not {s:?}"
            )),
        }
    }
}
