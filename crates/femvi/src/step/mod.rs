//! The discrete flow with time steps as parameters (paper §2): one step maps (q_k, p_k) to
//! (q_{k+1}, p_{k+1}) by solving p_k = −∂L_d/∂Q^0 and ∂L_d/∂Q^j = 0 (0 < j < s) for the
//! internal and end nodes together ((2.40)–(2.42), generalised to any degree), then
//! p_{k+1} = ∂L_d/∂Q^s. Uniform or variable grids (generalised Veselov mechanics, (2.3)).

pub mod auto;
pub mod drive;
pub mod fixed_point;
pub mod grid;
pub mod integrator;
mod start;

pub use drive::{drive, DriveReport, Observer};
pub use grid::{TimeGrid, UniformRule};
pub use integrator::{Degenerate, EnergyOptions, EnergyStats, Integrator, Method, SolverOptions, Start};
