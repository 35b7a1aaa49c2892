//! The `femvi chaos` command around the computations of `chaos.rs`: its arguments, the
//! one-orbit report (printed, `--json`, chaos.json and summary.json) and the map's files and
//! plot.

use crate::chaos::{compute, write_map, Axis, Indicator, Indicators};
use crate::problem::capabilities::Use;
use crate::problem::Problem;
use std::path::Path;

/// What `femvi chaos` was asked.
pub struct ChaosArgs {
    /// The indicators (default: all but the spectrum).
    pub indicators: Vec<String>,
    /// `NAME=LO:HI:N` axes of a map.
    pub grid: Vec<String>,
    /// Print one JSON object.
    pub json: bool,
    /// Output directory (chaos.json, and the map).
    pub out: Option<std::path::PathBuf>,
    /// Threads (0: all cores).
    pub threads: usize,
    /// Draw the map in this format.
    pub plot: Option<crate::plot::Format>,
    /// The spectrum's transient ([`femvi::chaos::ChaosOptions::spectrum_transient`]).
    pub transient: f64,
    /// The command line, for summary.json.
    pub command_line: Vec<String>,
}

/// summary.json of a one-orbit `femvi chaos`: the run's summary fields (the energy error is
/// not tracked there: null) with the indicators under `chaos`.
fn summary_of(
    problem: &Problem,
    one: &Indicators,
    clock: std::time::Instant,
    command: &[String],
) -> crate::summary::Summary {
    let error = one.error.clone();
    crate::summary::Summary {
        status: crate::summary::status_of(error.as_deref()).into(),
        steps: one.steps,
        final_t: one.t,
        final_q: one.final_q.clone(),
        final_p: one.final_p.clone(),
        chaos: Some(one.clone()),
        error: error.clone(),
        ..crate::summary::empty_summary(problem, clock, String::new(), command)
    }
}

/// `femvi chaos`: exit code 0, 1 (a run failed) or 2 (bad input).
pub fn cmd_chaos(problem: &Problem, args: &ChaosArgs) -> Result<bool, (String, u8)> {
    let clock = std::time::Instant::now();
    let bad = |m: String| (m, crate::BAD_INPUT);
    problem.refuse(Use::Chaos, "femvi chaos").map_err(bad)?;
    let mut wanted = args
        .indicators
        .iter()
        .map(|s| Indicator::parse(s.trim()))
        .collect::<Result<Vec<_>, _>>()
        .map_err(bad)?;
    if wanted.is_empty() {
        wanted = vec![Indicator::Megno, Indicator::Lyapunov, Indicator::Fli];
    }
    let axes = args
        .grid
        .iter()
        .map(|g| Axis::parse(g))
        .collect::<Result<Vec<_>, _>>()
        .map_err(bad)?;
    let points: usize = axes.iter().map(|a| a.n).product();
    if points > 4_000_000 {
        return Err(bad(format!("{points} grid points: at most 4 000 000")));
    }
    let rows =
        crate::with_system!(&problem.system, l => compute(l, problem, &axes, &wanted, (args.threads, args.transient)))
            .map_err(bad)?;
    let failed = rows.iter().filter(|r| r.error.is_some()).count();
    let io = |e: std::io::Error| (format!("cannot write output: {e}"), crate::BAD_INPUT);
    if axes.is_empty() {
        let one = &rows[0];
        let text = serde_json::to_string_pretty(one).unwrap_or_default();
        if let Some(dir) = &args.out {
            std::fs::create_dir_all(dir)
                .and_then(|_| std::fs::write(dir.join("chaos.json"), &text))
                .and_then(|_| crate::summary::write_summary(dir, &summary_of(problem, one, clock, &args.command_line)))
                .map_err(io)?;
        }
        if args.json {
            println!("{text}");
        } else {
            print_one(problem, one);
        }
    } else {
        let dir = args.out.clone().unwrap_or_else(|| problem.directory.clone());
        write_map(&dir, &axes, &rows, &wanted).map_err(io)?;
        if let Some(format) = args.plot {
            plot_map(&dir, format, problem, &axes, &rows, &wanted).map_err(bad)?;
        }
        println!(
            "{}: {points} points ({failed} failed) written to {}",
            problem.name,
            dir.join("chaos_map.csv").display()
        );
    }
    Ok(failed == 0)
}

fn print_one(problem: &Problem, r: &Indicators) {
    println!(
        "{} ({}), {} steps to t = {}",
        problem.name, problem.scheme_label, r.steps, r.t
    );
    let show = |label: &str, v: Option<f64>| {
        if let Some(v) = v {
            println!("  {label:<22} {v:.6}");
        }
    };
    show("MEGNO <Y>", r.megno);
    show("Lyapunov exponent", r.lyapunov);
    show("FLI", r.fli);
    if let Some(s) = &r.spectrum {
        println!("  {:<22} {s:?}", "Lyapunov spectrum");
    }
    if let Some(e) = &r.error {
        println!("  error: {e}");
    }
}

/// Draws the map's first scalar indicator (MEGNO, else FLI, else the largest exponent):
/// `chaos_map.<ext>`, a heat map over two axes or a line over one.
fn plot_map(
    dir: &Path,
    format: crate::plot::Format,
    problem: &Problem,
    axes: &[Axis],
    rows: &[Indicators],
    wanted: &[Indicator],
) -> Result<(), String> {
    let (label, pick): (&str, fn(&Indicators) -> Option<f64>) = if wanted.contains(&Indicator::Megno) {
        ("MEGNO <Y>", |r| r.megno)
    } else if wanted.contains(&Indicator::Fli) {
        ("FLI", |r| r.fli)
    } else {
        ("largest Lyapunov exponent", |r| r.lyapunov)
    };
    let values: Vec<Option<f64>> = rows.iter().map(|r| pick(r).filter(|_| r.error.is_none())).collect();
    let path = crate::plot::file(dir, "chaos_map", format);
    let title = format!("{}: {label}", problem.name);
    match axes {
        [a] => {
            let points = (0..a.n)
                .filter_map(|i| values.get(i).copied().flatten().map(|v| (a.value(i), v)))
                .collect();
            let series = [crate::plot::Series {
                name: label.to_string(),
                points,
            }];
            crate::plot::lines(&path, format, &title, &a.name, label, &series)
        }
        [a, b] => {
            let finite = values.iter().flatten().copied().filter(|v| v.is_finite());
            let range = if label.starts_with("MEGNO") {
                (0.0, 8.0)
            } else {
                let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| (l.min(v), h.max(v)));
                if lo < hi {
                    (lo, hi)
                } else {
                    (lo - 1.0, lo + 1.0)
                }
            };
            let map = crate::chaos_plot::HeatMap {
                axes: (a, b),
                values: &values,
                label,
                range,
                title: &title,
            };
            crate::chaos_plot::heat_map(&path, format, &map)
        }
        _ => Err("--plot draws maps over one or two axes".into()),
    }
}
