//! The command line of `femvi` (clap): its subcommands and options, whose doc comments are
//! the `--help` text. They are written for the terminal (TOML tables in brackets, `<name>`
//! placeholders), not as rustdoc, whose link and HTML checks are off here.
#![allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)]

use clap::{Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "femvi",
    version,
    about = "Discrete mechanics from finite elements: variational integrators of any degree"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// Integrate a problem file; writes trajectory.csv and summary.json.
    ///
    /// SIGINT, SIGTERM and SIGHUP stop the run at the next step boundary: the rows so far are
    /// complete, summary.json says "interrupted by SIGINT at step k, t = ...", a checkpoint
    /// (checkpoint.json) is written and the exit code is 130, 143 or 129. A stopped or killed
    /// run continues with `femvi run PROBLEM --resume DIR` from its last checkpoint, with the
    /// outputs an uninterrupted run writes, byte for byte, events.csv and the plots included,
    /// for every kind of problem (forces, constraints, energy mode, adaptive). Rows reach the disk
    /// at least every second; a run that would write more than --max-output or the free space
    /// is refused before it starts; a run stops (exit 1) at the first non-finite state.
    #[command(verbatim_doc_comment)]
    Run {
        /// The problem file (TOML; - reads standard input).
        problem: PathBuf,
        /// Override a value of the problem file: key.path=value (repeatable; the value is
        /// TOML, a bare word a string), e.g. --set time.step=0.01.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Output directory (default: the `directory` of the output table, else out/NAME).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print nothing but errors (and no progress bar).
        #[arg(long)]
        quiet: bool,
        /// Output formats, comma-separated: csv, npy (trajectory.npy plus columns.txt).
        #[arg(long, value_delimiter = ',', default_value = "csv")]
        format: Vec<String>,
        /// Draw plots next to the trajectory: coordinates, phase portraits, energy error.
        #[arg(long)]
        plot: bool,
        /// Image format of the plots: svg or png.
        #[arg(long, default_value = "svg")]
        plot_format: String,
        /// Continue the stopped or killed run whose output directory is DIR from its last
        /// checkpoint (the same problem file and --set overrides; writes into DIR).
        #[arg(long, value_name = "DIR", conflicts_with = "out")]
        resume: Option<PathBuf>,
        /// Also write a checkpoint every N steps (default: only by time).
        #[arg(long, value_name = "N")]
        checkpoint_every_steps: Option<usize>,
        /// Write a checkpoint every SECONDS of run time (0: only at the first node and at a
        /// stop).
        #[arg(long, value_name = "SECONDS", default_value_t = 10.0)]
        checkpoint_every_seconds: f64,
        /// Refuse a run whose output would exceed this size (e.g. 500M, 10G, 2TiB).
        #[arg(long, value_name = "SIZE", default_value = "10G", value_parser = femvi_cli::estimate::parse_size)]
        max_output: u64,
    },
    /// Run a problem and measure symplecticity, energy error and drift, Noether momenta and
    /// time reversal.
    Check {
        /// The problem file (TOML; - reads standard input).
        problem: PathBuf,
        /// Override a value of the problem file: key.path=value (repeatable; the value is
        /// TOML, a bare word a string), e.g. --set time.step=0.01.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Print one JSON object on standard output.
        #[arg(long)]
        json: bool,
        /// Also write check.json into this directory.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Chaos indicators (MEGNO, largest Lyapunov exponent, FLI, spectrum) of a problem, or a
    /// map of them over a grid of initial conditions (chaos_map.csv/.npy), in parallel.
    Chaos {
        /// The problem file (TOML), or - for standard input.
        problem: PathBuf,
        /// Override a value of the problem file: key.path=value (repeatable; the value is
        /// TOML, a bare word a string), e.g. --set time.step=0.01.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Indicators, comma-separated: megno, lyapunov, fli, spectrum (default: the first three).
        #[arg(long, value_delimiter = ',')]
        indicator: Vec<String>,
        /// A map axis NAME=LO:HI:N over a coordinate, p_<coordinate> or <coordinate>_dot of
        /// the initial condition (repeatable).
        #[arg(long)]
        grid: Vec<String>,
        /// Print one JSON object (single point).
        #[arg(long)]
        json: bool,
        /// Output directory (chaos.json, or the map).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Threads for maps (0: all cores).
        #[arg(long, default_value_t = 0)]
        threads: usize,
        /// Draw the map: a heat map (chaos_map.svg) over two axes, the indicator against the
        /// axis over one.
        #[arg(long)]
        plot: bool,
        /// Spectrum: time from the start whose growth is not counted (the frame's transient;
        /// with it a Hamiltonian spectrum's ± pairs sum to round-off).
        #[arg(long, default_value_t = 0.0)]
        transient: f64,
        /// Image format of the plot: svg or png.
        #[arg(long, default_value = "svg")]
        plot_format: String,
    },
    /// Solve a two-point boundary value problem ([boundary] table) by the discrete variational
    /// principle; writes trajectory.csv and summary.json.
    Bvp {
        /// The problem file (TOML; - reads standard input) with a [boundary] table.
        problem: PathBuf,
        /// Override a value of the problem file: key.path=value (repeatable; the value is
        /// TOML, a bare word a string), e.g. --set time.step=0.01.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Output directory (default: the problem's output directory).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print nothing but errors.
        #[arg(long)]
        quiet: bool,
        /// Draw coordinates.svg (coordinates against t) and, with a moving mesh, steps.svg.
        #[arg(long)]
        plot: bool,
        /// Image format of the plots: svg or png.
        #[arg(long, default_value = "svg")]
        plot_format: String,
    },
    /// Solve an optimal control problem ([boundary] with velocities, [controls], [objective])
    /// by discrete mechanics; writes trajectory.csv, controls.csv and summary.json.
    Optimize {
        /// The problem file (TOML; - reads standard input).
        problem: PathBuf,
        /// Override a value of the problem file: key.path=value (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Output directory (default: the problem's output directory).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print nothing but errors.
        #[arg(long)]
        quiet: bool,
        /// Draw coordinates and controls against t.
        #[arg(long)]
        plot: bool,
        /// Image format of the plots: svg or png.
        #[arg(long, default_value = "svg")]
        plot_format: String,
    },
    /// Print the problem-file reference: every table and key the loader accepts, with its
    /// type, default and meaning (the guide's docs/src/problem-file.md).
    Schema,
    /// List the built-in models, or print a complete problem file for one
    /// (`femvi models kepler > k.toml && femvi run k.toml`).
    Models {
        /// A model name.
        name: Option<String>,
    },
    /// Run an ensemble: one problem from many initial states and/or parameter values, on all
    /// cores; writes ensemble.csv and ensemble.npy (one row per member).
    Ensemble {
        /// The problem file (TOML; - reads standard input).
        problem: PathBuf,
        #[command(flatten)]
        args: femvi_cli::ensemble::EnsembleArgs,
    },
    /// Measure convergence orders over several step sizes.
    Convergence {
        /// The problem file (TOML; - reads standard input).
        problem: PathBuf,
        /// Override a value of the problem file: key.path=value (repeatable; the value is
        /// TOML, a bare word a string), e.g. --set time.step=0.01.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Step sizes, comma-separated (e.g. 0.1,0.05,0.025).
        #[arg(long, value_delimiter = ',', required = true)]
        steps: Vec<f64>,
        /// Reference: exact, finest, or a step size for a reference run of degree s + 2.
        #[arg(long)]
        reference: Option<String>,
        /// Print one JSON object on standard output.
        #[arg(long)]
        json: bool,
        /// Also measure the L² error of the piecewise-polynomial trajectory.
        #[arg(long)]
        l2: bool,
        /// Draw convergence.svg: error against step on log-log axes with the fitted slopes.
        #[arg(long)]
        plot: bool,
        /// Image format of the plot: svg or png.
        #[arg(long, default_value = "svg")]
        plot_format: String,
        /// Directory for convergence.csv (default: the problem's output directory).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}
