//! The `femvi` command: a thin layer that parses problem files into library types, runs them,
//! writes what the library returns, and turns errors into messages and exit codes
//! (0 success, 1 numerical failure, 2 bad input).

mod problem;
mod run;

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "femvi",
    version,
    about = "Discrete mechanics from finite elements: variational integrators of any degree"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Integrate a problem file; writes trajectory.csv and summary.json.
    Run {
        /// The problem file (TOML).
        problem: PathBuf,
        /// Output directory (default: the `directory` of the output table, else out/NAME).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print nothing but errors.
        #[arg(long)]
        quiet: bool,
    },
}

const NUMERICAL: u8 = 1;
const BAD_INPUT: u8 = 2;

fn main() -> ExitCode {
    // No Rust panic message reaches the user: a panic is an internal error, reported as such.
    std::panic::set_hook(Box::new(|info| {
        eprintln!("error: internal error in femvi ({info}); please report it with the problem file");
    }));
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { BAD_INPUT } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    match std::panic::catch_unwind(|| dispatch(cli)) {
        Ok(code) => code,
        Err(_) => ExitCode::from(NUMERICAL),
    }
}

fn dispatch(cli: Cli) -> ExitCode {
    match cli.command {
        Command::Run { problem, out, quiet } => cmd_run(&problem, out, quiet),
    }
}

fn cmd_run(path: &std::path::Path, out: Option<PathBuf>, quiet: bool) -> ExitCode {
    let problem = match problem::load(path) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(BAD_INPUT);
        }
    };
    let dir = out.unwrap_or_else(|| problem.directory.clone());
    match run::run(&problem, &dir) {
        Err(e) => {
            eprintln!("error: cannot write the output in {}: {e}", dir.display());
            ExitCode::from(BAD_INPUT)
        }
        Ok(run::Outcome::Rejected(msg)) => {
            eprintln!("error: {}: {msg}", path.display());
            ExitCode::from(BAD_INPUT)
        }
        Ok(run::Outcome::Failed(s)) => {
            eprintln!("error: {}", s.error.as_deref().unwrap_or("unknown failure"));
            eprintln!(
                "hint: try a smaller step, a larger [solver] max_iterations, or method = \"newton\"; steps 0..{} are in {}",
                s.steps,
                dir.join("trajectory.csv").display()
            );
            ExitCode::from(NUMERICAL)
        }
        Ok(run::Outcome::Done(s)) => {
            if !quiet {
                println!(
                    "{}: {} steps to t = {} ({}), max relative energy error {:.3e}, {:.2} solver iterations per step, {:.3} s",
                    s.name, s.steps, s.final_t, s.scheme, s.max_rel_energy_error, s.mean_solver_iterations, s.wall_seconds
                );
                println!("wrote {} and summary.json", dir.join("trajectory.csv").display());
            }
            ExitCode::SUCCESS
        }
    }
}
