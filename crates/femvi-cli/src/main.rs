//! The `femvi` command: a thin layer that parses problem files into library types, runs them,
//! writes what the library returns, and turns errors into messages and exit codes
//! (0 success, 1 numerical failure, 2 bad input).

use femvi_cli::{bvp, check, convergence, models, plot, problem, run};

mod args;

use args::{Cli, Command};
use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;

use femvi_cli::{BAD_INPUT, NUMERICAL};

fn main() -> ExitCode {
    // No Rust panic message reaches the user: a panic is an internal error, reported as such,
    // except a closed standard output (`femvi run p.toml | head -1`): the reader has gone, so
    // femvi stops quietly with the status of a process killed by SIGPIPE (128 + 13), as Unix
    // tools do. Files are written before anything is printed about them.
    std::panic::set_hook(Box::new(|info| {
        let text = info.to_string();
        if text.contains("failed printing to stdout") && text.contains("Broken pipe") {
            std::process::exit(141);
        }
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
        Command::Run {
            problem,
            set,
            out,
            quiet,
            format,
            plot,
            plot_format,
            resume,
            checkpoint_every_steps,
            checkpoint_every_seconds,
            max_output,
        } => {
            if checkpoint_every_seconds.is_nan() || checkpoint_every_seconds < 0.0 || checkpoint_every_steps == Some(0)
            {
                eprintln!("error: --checkpoint-every-seconds must be >= 0 and --checkpoint-every-steps >= 1");
                return ExitCode::from(BAD_INPUT);
            }
            let control = run::RunControl {
                checkpoints: femvi_cli::resume::Policy {
                    every_steps: checkpoint_every_steps,
                    every_seconds: (checkpoint_every_seconds > 0.0).then_some(checkpoint_every_seconds),
                },
                resume: resume.is_some(),
                max_output,
            };
            match plot_format_of(&plot_format) {
                Ok(f) => {
                    let args = RunArgs {
                        out: resume.or(out),
                        quiet,
                        format: &format,
                        plot: plot.then_some(f),
                        control,
                    };
                    cmd_run(&problem, &set, args)
                }
                Err(code) => code,
            }
        }
        Command::Check {
            problem,
            set,
            json,
            out,
        } => cmd_check(&problem, &set, json, out),
        Command::Bvp {
            problem,
            set,
            out,
            quiet,
            plot,
            plot_format,
        } => match plot_format_of(&plot_format) {
            Ok(f) => cmd_bvp(&problem, &set, out, quiet, plot.then_some(f)),
            Err(code) => code,
        },
        Command::Optimize {
            problem,
            set,
            out,
            quiet,
            plot,
            plot_format,
        } => match plot_format_of(&plot_format) {
            Ok(f) => cmd_optimize(&problem, &set, out, quiet, plot.then_some(f)),
            Err(code) => code,
        },
        Command::Chaos {
            problem,
            set,
            indicator,
            grid,
            json,
            out,
            threads,
            plot,
            plot_format,
            transient,
        } => {
            let plot = match plot_format_of(&plot_format) {
                Ok(f) => plot.then_some(f),
                Err(code) => return code,
            };
            let args = femvi_cli::chaos::ChaosArgs {
                indicators: indicator,
                grid,
                json,
                out,
                threads,
                plot,
                transient,
                command_line: std::env::args().collect(),
            };
            match load(&problem, &set).map(|p| femvi_cli::chaos::cmd_chaos(&p, &args)) {
                Ok(Ok(true)) => ExitCode::SUCCESS,
                Ok(Ok(false)) => ExitCode::from(NUMERICAL),
                Ok(Err((msg, code))) => {
                    eprintln!("error: {}: {msg}", problem.display());
                    ExitCode::from(code)
                }
                Err(code) => code,
            }
        }
        Command::Models { name } => models::cmd_models(name.as_deref()),
        Command::Schema => {
            print!("{}", femvi_cli::reference::PROBLEM_FILE);
            ExitCode::SUCCESS
        }
        Command::Ensemble { problem, args } => match femvi_cli::ensemble::command(&problem, &args) {
            Ok(true) => ExitCode::SUCCESS,
            Ok(false) => ExitCode::from(NUMERICAL),
            Err((msg, code)) => {
                eprintln!("error: {msg}");
                ExitCode::from(code)
            }
        },
        Command::Convergence {
            problem,
            set,
            steps,
            reference,
            json,
            l2,
            plot,
            plot_format,
            out,
        } => match plot_format_of(&plot_format) {
            Ok(f) => {
                let what = ConvergenceArgs {
                    steps: &steps,
                    reference: reference.as_deref(),
                    json,
                    l2,
                    plot: plot.then_some(f),
                    out,
                };
                cmd_convergence(&problem, &set, what)
            }
            Err(code) => code,
        },
    }
}

fn cmd_optimize(
    path: &std::path::Path,
    set: &[String],
    out: Option<PathBuf>,
    quiet: bool,
    plot: Option<plot::Format>,
) -> ExitCode {
    let problem = match problem::load_optimize_with(path, set) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(BAD_INPUT);
        }
    };
    let dir = out.unwrap_or_else(|| problem.directory.clone());
    match femvi_cli::optimize::run(&problem, &dir, plot).map(|(s, _)| s) {
        Err((msg, code)) => {
            eprintln!("error: {}: {msg}", path.display());
            ExitCode::from(code)
        }
        Ok(s) if s.error.is_some() => {
            eprintln!("error: {}", s.error.as_deref().unwrap_or(""));
            eprintln!(
                "the best iterate (objective {:.15e}, violation {:.2e}) is in {}",
                s.objective,
                s.violation,
                dir.display()
            );
            eprintln!("hint: try a guess ([boundary] guess = \"trajectory.csv\" from a coarser solve or a simulation), more iterations ([solver] max_iterations), or check that the boundary data can be reached within the bounds");
            ExitCode::from(NUMERICAL)
        }
        Ok(s) => {
            if !quiet {
                println!(
                    "{}: {} elements ({}), objective {:.15e}, t1 {}, violation {:.2e}, optimality {:.2e}, {} iterations, {:.3} s",
                    s.name, s.elements, s.scheme, s.objective, s.t1, s.violation, s.optimality, s.iterations, s.wall_seconds
                );
                println!(
                    "wrote {}, controls.csv and summary.json",
                    dir.join("trajectory.csv").display()
                );
            }
            ExitCode::SUCCESS
        }
    }
}

fn cmd_bvp(
    path: &std::path::Path,
    set: &[String],
    out: Option<PathBuf>,
    quiet: bool,
    plot: Option<plot::Format>,
) -> ExitCode {
    let problem = match problem::load_bvp_with(path, set) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(BAD_INPUT);
        }
    };
    let dir = out.unwrap_or_else(|| problem.directory.clone());
    match bvp::run_plotted(&problem, &dir, plot) {
        Err((msg, code)) => {
            eprintln!("error: {}: {msg}", path.display());
            ExitCode::from(code)
        }
        Ok(s) if s.error.is_some() => {
            eprintln!("error: {}", s.error.as_deref().unwrap_or(""));
            if s.time_mode == "energy" {
                eprintln!("hint: with a moving mesh the energy equations depend on the steps only at O(h^(2s)): use the midpoint rule or degree 1, fewer elements, or time_mode = \"fixed\"");
            } else {
                eprintln!("hint: try another initial guess ([boundary] guess = \"trajectory.csv\"), more elements, or check that a solution exists");
            }
            ExitCode::from(NUMERICAL)
        }
        Ok(s) => {
            if !quiet {
                println!(
                    "{}: {} elements ({}), action {:.15e}, residual {:.2e} (scaled {:.2e}), {} Newton iterations, {:.3} s",
                    s.name,
                    s.elements,
                    s.scheme,
                    s.action.unwrap_or(f64::NAN),
                    s.residual_norm.unwrap_or(f64::NAN),
                    s.scaled_residual.unwrap_or(f64::NAN),
                    s.newton_iterations,
                    s.wall_seconds
                );
                println!("wrote {} and summary.json", dir.join("trajectory.csv").display());
            }
            ExitCode::SUCCESS
        }
    }
}

fn load(path: &std::path::Path, set: &[String]) -> Result<problem::Problem, ExitCode> {
    problem::load_with(path, set).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(BAD_INPUT)
    })
}

fn cmd_check(path: &std::path::Path, set: &[String], json: bool, out: Option<PathBuf>) -> ExitCode {
    let problem = match load(path, set) {
        Ok(p) => p,
        Err(code) => return code,
    };
    let report = match check::check(&problem) {
        Ok(r) => r,
        Err((msg, code)) => {
            eprintln!("error: {}: {msg}", path.display());
            return ExitCode::from(code);
        }
    };
    if let Some(code) = emit_check(&report, json, out, check::print) {
        return code;
    }
    if report.error().is_some() {
        return ExitCode::from(NUMERICAL);
    }
    ExitCode::SUCCESS
}

/// Writes a check report to `out`/check.json if asked and shows it (JSON or `print`); an
/// exit code if the file cannot be written.
fn emit_check<T: serde::Serialize>(report: &T, json: bool, out: Option<PathBuf>, print: fn(&T)) -> Option<ExitCode> {
    let text = serde_json::to_string_pretty(report).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"));
    if let Some(dir) = out {
        if let Err(e) = std::fs::create_dir_all(&dir).and_then(|_| std::fs::write(dir.join("check.json"), &text)) {
            eprintln!("error: cannot write {}: {e}", dir.display());
            return Some(ExitCode::from(BAD_INPUT));
        }
    }
    if json {
        println!("{text}");
    } else {
        print(report);
    }
    None
}

/// What `femvi convergence` was asked for.
struct ConvergenceArgs<'a> {
    steps: &'a [f64],
    reference: Option<&'a str>,
    json: bool,
    l2: bool,
    plot: Option<plot::Format>,
    out: Option<PathBuf>,
}

fn cmd_convergence(path: &std::path::Path, set: &[String], what: ConvergenceArgs) -> ExitCode {
    let ConvergenceArgs {
        steps,
        reference,
        json,
        l2,
        plot,
        out,
    } = what;
    let problem = match load(path, set) {
        Ok(p) => p,
        Err(code) => return code,
    };
    let reference = match reference.map(str::parse::<convergence::Reference>).transpose() {
        Ok(r) => r,
        Err(msg) => {
            eprintln!("error: {msg}");
            return ExitCode::from(BAD_INPUT);
        }
    };
    let study = match convergence::study(&problem, steps, reference, l2) {
        Ok(s) => s,
        Err((msg, code)) => {
            eprintln!("error: {}: {msg}", path.display());
            return ExitCode::from(code);
        }
    };
    let dir = out.unwrap_or_else(|| problem.directory.clone());
    let csv = convergence::csv(&study, l2);
    if let Err(e) = std::fs::create_dir_all(&dir).and_then(|_| std::fs::write(dir.join("convergence.csv"), csv)) {
        eprintln!("error: cannot write {}: {e}", dir.display());
        return ExitCode::from(BAD_INPUT);
    }
    if let Some(f) = plot {
        if let Err(e) = convergence::plot(&dir, &study, f) {
            eprintln!("error: {e}");
            return ExitCode::from(BAD_INPUT);
        }
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&study).unwrap_or_default());
    } else {
        convergence::print(&study, &dir);
    }
    ExitCode::SUCCESS
}

fn plot_format_of(name: &str) -> Result<plot::Format, ExitCode> {
    match name {
        "svg" => Ok(plot::Format::Svg),
        "png" => Ok(plot::Format::Png),
        other => {
            eprintln!(
                "error: unknown --plot-format '{other}'{}; use svg or png",
                problem::did_you_mean(other, &["svg", "png"])
            );
            Err(ExitCode::from(BAD_INPUT))
        }
    }
}

/// What `femvi run` was asked for.
struct RunArgs<'a> {
    out: Option<PathBuf>,
    quiet: bool,
    format: &'a [String],
    plot: Option<plot::Format>,
    control: run::RunControl,
}

fn cmd_run(path: &std::path::Path, set: &[String], args: RunArgs) -> ExitCode {
    use std::io::IsTerminal;
    let RunArgs {
        out,
        quiet,
        format,
        plot,
        control,
    } = args;
    if let Some(f) = format.iter().find(|f| !matches!(f.as_str(), "csv" | "npy")) {
        eprintln!(
            "error: unknown --format '{f}'{}; use csv, npy or csv,npy",
            problem::did_you_mean(f, &["csv", "npy"])
        );
        return ExitCode::from(BAD_INPUT);
    }
    let problem = match load(path, set) {
        Ok(p) => p,
        Err(code) => return code,
    };
    let dir = out.unwrap_or_else(|| problem.directory.clone());
    let output = run::RunOutput {
        csv: format.iter().any(|f| f == "csv"),
        npy: format.iter().any(|f| f == "npy"),
        progress: !quiet && std::io::stderr().is_terminal(),
        plots: plot.is_some(),
        plot_format: plot.unwrap_or(plot::Format::Svg),
    };
    if let Err(e) = femvi_cli::signals::install() {
        eprintln!("warning: cannot handle stop signals ({e}); a signal will end the run at once");
    }
    match run::run_controlled(&problem, &dir, output, &control) {
        Err(e) => {
            eprintln!("error: cannot write the output in {}: {e}", dir.display());
            ExitCode::from(BAD_INPUT)
        }
        Ok(run::Outcome::Rejected(msg)) => {
            eprintln!("error: {}: {msg}", path.display());
            ExitCode::from(BAD_INPUT)
        }
        Ok(run::Outcome::Interrupted(s, sig)) => {
            eprintln!("error: {}", s.error.as_deref().unwrap_or("interrupted"));
            eprintln!(
                "hint: the rows up to step {} are in {}; continue with --resume {}",
                s.steps,
                dir.display(),
                dir.display()
            );
            ExitCode::from(sig.exit_code())
        }
        Ok(run::Outcome::Failed(s)) => {
            let error = s.error.as_deref().unwrap_or("unknown failure");
            eprintln!("error: {error}");
            let advice = if error.starts_with("non-finite energy") {
                // Overflow of an unstable run, or a Lagrangian outside its domain there.
                "a smaller step if the run is unstable, or check that L is finite at that state (sqrt, ln, division)"
            } else if error.contains("is degenerate") {
                // The Hessian's condition number was measured: not a matter of steps or iterations.
                "d2L/dv2 must be invertible along the path: check that the kinetic energy is positive definite at that state (a mass or length that vanishes, a coordinate singularity)"
            } else if error.contains("inverse Legendre transform") {
                "the velocity of that momentum was not found though d2L/dv2 is regular there: a smaller step keeps the guess closer; check that L is convex in the velocities on the way"
            } else {
                "try a smaller step, a larger [solver] max_iterations, or method = \"newton\""
            };
            eprintln!(
                "hint: {advice}; steps 0..{} are in {}",
                s.steps,
                dir.join("trajectory.csv").display()
            );
            ExitCode::from(NUMERICAL)
        }
        Ok(run::Outcome::Done(s)) => {
            if !quiet {
                if let Some(a) = &s.auto_step {
                    println!(
                        "accuracy {:.1e}: degree {}, step {} (estimated relative position error at the end {:.1e}; {} pilot steps)",
                        a.accuracy, a.degree, a.step, a.estimated_error, a.pilot_steps
                    );
                }
                let energy = if s.energy_conserved {
                    format!("max relative energy error {:.3e}", s.max_rel_energy_error)
                } else {
                    format!("max relative energy change {:.3e}", s.max_rel_energy_error)
                };
                println!(
                    "{}: {} steps to t = {} ({}), {energy}, {:.2} solver iterations per step, {:.3} s",
                    s.name, s.steps, s.final_t, s.scheme, s.mean_solver_iterations, s.wall_seconds
                );
                if let (Some(b), Some(w)) = (s.max_rel_energy_balance_error, s.final_work) {
                    println!("note: [forces] do work W = {w:.6e}; the energy balance H - H0 = W holds to {b:.3e} (relative, every node)");
                } else if let Some(b) = s.max_rel_energy_balance_error {
                    println!("note: the Lagrangian depends on time, so H is not conserved; dH/dt = -dL/dt holds to {b:.3e} (relative; trapezoid rule over the nodes)");
                }
                if let Some(n) = s.events_located {
                    let stop = match &s.stopped_by_event {
                        Some(Some(e)) => format!("; stopped at the first '{e}'"),
                        _ => String::new(),
                    };
                    println!("{n} events located (events.csv){stop}");
                }
                println!("wrote {} and summary.json", dir.join("trajectory.csv").display());
            }
            ExitCode::SUCCESS
        }
    }
}
