//! What a run writes ([`RunOutput`]): the formats, plots and progress bar, as the command
//! line and `[output]` ask for them. A leaf module: the recorders, the output estimate, the
//! checkpoints and every run read it.

/// Output formats of a run and whether a progress bar may be shown.
#[derive(Debug, Clone, Copy)]
pub struct RunOutput {
    /// Write trajectory.csv.
    pub csv: bool,
    /// Write trajectory.npy and columns.txt.
    pub npy: bool,
    /// Show a progress bar (on a terminal, after a second).
    pub progress: bool,
    /// Draw plots.
    pub plots: bool,
    /// Image format of the plots.
    pub plot_format: crate::plot::Format,
}
