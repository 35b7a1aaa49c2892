//! `femvi chaos`: the chaos indicators of a problem (the library's `femvi::chaos`: MEGNO,
//! FLI, the largest Lyapunov exponent, the spectrum), for its initial condition or over a
//! grid of initial conditions (`--grid x=-0.5:0.5:200`), run in parallel on all cores and
//! written as a map (`chaos_map.csv`, `chaos_map.npy` with `chaos_columns.txt`).

use crate::problem::Problem;
use femvi::chaos::{indicators_on, ChaosOptions, ChaosReport};
use femvi::{Integrator, Lagrangian, Start};
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;

/// Which indicators to report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Indicator {
    /// MEGNO ⟨Y⟩.
    Megno,
    /// The largest Lyapunov exponent.
    Lyapunov,
    /// The fast Lyapunov indicator.
    Fli,
    /// The whole Lyapunov spectrum.
    Spectrum,
}

impl Indicator {
    /// Parses `megno`, `lyapunov`, `fli` or `spectrum`.
    pub fn parse(s: &str) -> Result<Self, String> {
        Ok(match s {
            "megno" => Indicator::Megno,
            "lyapunov" => Indicator::Lyapunov,
            "fli" => Indicator::Fli,
            "spectrum" => Indicator::Spectrum,
            _ => return Err(format!("unknown indicator '{s}' (megno, lyapunov, fli, spectrum)")),
        })
    }
}

/// One axis of a map: a coordinate (`x`), a momentum (`p_x`) or a velocity (`x_dot`) of the
/// initial condition, from `lo` to `hi` in `n` points.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// The name as given.
    pub name: String,
    /// First value.
    pub lo: f64,
    /// Last value.
    pub hi: f64,
    /// Number of values (≥ 1).
    pub n: usize,
}

impl Axis {
    /// Parses `NAME=LO:HI:N`.
    pub fn parse(s: &str) -> Result<Self, String> {
        let err = || format!("grid '{s}': expected NAME=LO:HI:N, e.g. x=-0.5:0.5:200");
        let (name, range) = s.split_once('=').ok_or_else(err)?;
        let parts: Vec<&str> = range.split(':').collect();
        let [lo, hi, n] = parts.as_slice() else {
            return Err(err());
        };
        let (lo, hi) = (
            lo.trim().parse::<f64>().map_err(|_| err())?,
            hi.trim().parse::<f64>().map_err(|_| err())?,
        );
        let n = n.trim().parse::<usize>().map_err(|_| err())?;
        if !(lo.is_finite() && hi.is_finite()) || n == 0 || n > 100_000 {
            return Err(format!("grid '{s}': finite bounds and 1 to 100000 points"));
        }
        Ok(Self {
            name: name.trim().to_string(),
            lo,
            hi,
            n,
        })
    }

    /// The i-th of the n values (lo for a single point).
    pub fn value(&self, i: usize) -> f64 {
        if self.n == 1 {
            self.lo
        } else {
            self.lo + (self.hi - self.lo) * i as f64 / (self.n - 1) as f64
        }
    }
}

/// The indicators at one point, as JSON and map rows carry them.
#[derive(Debug, Clone, Serialize)]
pub struct Indicators {
    /// ⟨Y⟩ at the end.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub megno: Option<f64>,
    /// The largest exponent's estimate ln|δ|/t.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lyapunov: Option<f64>,
    /// The largest ln|δ|.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fli: Option<f64>,
    /// The spectrum, largest first.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spectrum: Option<Vec<f64>>,
    /// Steps taken.
    pub steps: usize,
    /// Time reached.
    pub t: f64,
    /// The error that stopped the run, if any.
    pub error: Option<String>,
}

fn pick(report: &ChaosReport, wanted: &[Indicator]) -> Indicators {
    let has = |i| wanted.contains(&i);
    Indicators {
        megno: has(Indicator::Megno).then_some(report.last.mean_megno),
        lyapunov: has(Indicator::Lyapunov).then_some(report.last.lyapunov),
        fli: has(Indicator::Fli).then_some(report.last.fli),
        spectrum: report.spectrum.clone(),
        steps: report.steps,
        t: report.last.t,
        error: report.error.as_ref().map(|e| e.to_string()),
    }
}

/// The start of `problem` with the axes' values of grid point `idx` set.
fn start_at(problem: &Problem, axes: &[Axis], idx: usize) -> Result<Start, String> {
    let mut start = problem.start.clone();
    let mut rest = idx;
    for axis in axes {
        let value = axis.value(rest % axis.n);
        rest /= axis.n;
        let coord = |name: &str| problem.coordinates.iter().position(|c| c == name);
        let slot = match (&mut start, axis.name.as_str()) {
            (Start::Velocity { q, .. } | Start::Momentum { q, .. }, name) if coord(name).is_some() => {
                coord(name).and_then(|i| q.get_mut(i))
            }
            (Start::Momentum { p, .. }, name) => name.strip_prefix("p_").and_then(coord).and_then(|i| p.get_mut(i)),
            (Start::Velocity { v, .. }, name) => name.strip_suffix("_dot").and_then(coord).and_then(|i| v.get_mut(i)),
            (Start::Positions { .. }, _) => None,
        };
        *slot.ok_or_else(|| {
            format!(
                "grid axis '{}' is not a coordinate, a p_<coordinate> (with initial p) or a <coordinate>_dot (with initial v) of this problem",
                axis.name
            )
        })? = value;
    }
    Ok(start)
}

/// Runs the indicators at every grid point (one point without axes), on `threads` threads.
pub fn compute<L: Lagrangian + Sync>(
    lag: &L,
    problem: &Problem,
    axes: &[Axis],
    wanted: &[Indicator],
    (threads, transient): (usize, f64),
) -> Result<Vec<Indicators>, String> {
    if !(transient.is_finite() && transient >= 0.0) {
        return Err(format!("--transient must be a time >= 0, not {transient}"));
    }
    if problem.energy.is_some() {
        return Err("femvi chaos needs steps as parameters ([time] mode = \"fixed\")".into());
    }
    let points: usize = axes.iter().map(|a| a.n).product();
    let starts = (0..points)
        .map(|i| start_at(problem, axes, i))
        .collect::<Result<Vec<_>, _>>()?;
    let chaos = ChaosOptions {
        spectrum: wanted.contains(&Indicator::Spectrum),
        spectrum_transient: transient,
        ..ChaosOptions::default()
    };
    let one = |start: &Start| -> Indicators {
        let made = Integrator::new(
            lag,
            &problem.element,
            problem.grid.clone(),
            start.clone(),
            problem.options,
        );
        match made.and_then(|mut it| indicators_on(&mut it, &chaos)) {
            Ok(r) => pick(&r, wanted),
            Err(e) => Indicators {
                megno: None,
                lyapunov: None,
                fli: None,
                spectrum: None,
                steps: 0,
                t: problem.grid.t0(),
                error: Some(e.to_string()),
            },
        }
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| e.to_string())?;
    Ok(pool.install(|| starts.par_iter().map(one).collect()))
}

/// Writes the map as `chaos_map.csv` (axis values, then the indicators) and
/// `chaos_map.npy` with `chaos_columns.txt`.
pub fn write_map(dir: &Path, axes: &[Axis], rows: &[Indicators], wanted: &[Indicator]) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let mut header: Vec<String> = axes.iter().map(|a| a.name.clone()).collect();
    let names = [
        (Indicator::Megno, "megno"),
        (Indicator::Lyapunov, "lyapunov"),
        (Indicator::Fli, "fli"),
    ];
    header.extend(
        names
            .iter()
            .filter(|(i, _)| wanted.contains(i))
            .map(|(_, n)| n.to_string()),
    );
    let mut csv = csv::Writer::from_path(dir.join("chaos_map.csv"))?;
    csv.write_record(&header)?;
    let mut flat = Vec::with_capacity(rows.len() * header.len());
    for (idx, r) in rows.iter().enumerate() {
        let mut rest = idx;
        let mut values: Vec<f64> = axes
            .iter()
            .map(|a| {
                let v = a.value(rest % a.n);
                rest /= a.n;
                v
            })
            .collect();
        for (i, _) in names.iter().filter(|(i, _)| wanted.contains(i)) {
            let v = match i {
                Indicator::Megno => r.megno,
                Indicator::Lyapunov => r.lyapunov,
                _ => r.fli,
            };
            values.push(v.unwrap_or(f64::NAN));
        }
        csv.write_record(values.iter().map(|x| format!("{x:?}")))?;
        flat.extend_from_slice(&values);
    }
    csv.flush()?;
    crate::record::write_table(
        &dir.join("chaos_map.npy"),
        &dir.join("chaos_columns.txt"),
        &header,
        &flat,
    )
}

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
    /// The spectrum's transient ([`ChaosOptions::spectrum_transient`]).
    pub transient: f64,
}

/// `femvi chaos`: exit code 0, 1 (a run failed) or 2 (bad input).
pub fn cmd_chaos(problem: &Problem, args: &ChaosArgs) -> Result<bool, (String, u8)> {
    let bad = |m: String| (m, crate::BAD_INPUT);
    crate::adaptive::refuse(problem, "femvi chaos").map_err(bad)?;
    crate::constrained::refuse(problem, "femvi chaos").map_err(bad)?;
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
