//! `femvi chaos`: the chaos indicators of a problem (the library's `femvi::chaos`: MEGNO,
//! FLI, the largest Lyapunov exponent, the spectrum), for its initial condition or over a
//! grid of initial conditions and/or parameters (`--grid x=-0.5:0.5:200 --grid
//! mu=0.1:0.3:50`), run in parallel on all cores and written as a map (`chaos_map.csv`,
//! `chaos_map.npy` with `chaos_columns.txt`). An axis that is not a coordinate, `p_<q>` or
//! `<q>_dot` is a parameter of `[system] parameters`, set at each point as `--set` would.
//! Problems with `[forces]` or `[constraints]` go through `chaos_forced.rs` at each point.

use crate::chaos_forced::Tables;
use crate::problem::Problem;
use femvi::chaos::{indicators_on, ChaosOptions, ChaosReport};
use femvi::{Lagrangian, Start};
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
/// initial condition, or a parameter of `[system] parameters`, from `lo` to `hi` in `n` points.
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
    /// Positions at the last node (summary.json, not chaos.json).
    #[serde(skip)]
    pub final_q: Vec<f64>,
    /// Momenta at the last node (summary.json, not chaos.json).
    #[serde(skip)]
    pub final_p: Vec<f64>,
}

fn pick(report: &ChaosReport, wanted: &[Indicator]) -> Indicators {
    let has = |i| wanted.contains(&i);
    Indicators {
        megno: has(Indicator::Megno).then_some(report.last.mean_megno),
        lyapunov: has(Indicator::Lyapunov).then_some(report.last.lyapunov),
        fli: has(Indicator::Fli).then_some(report.last.fli),
        spectrum: report.spectrum.clone(),
        steps: report.steps,
        final_q: report.final_node.1.clone(),
        final_p: report.final_node.2.clone(),
        t: report.last.t,
        error: report.error.as_ref().map(|e| e.to_string()),
    }
}

/// Whether `name` names part of the initial condition (a coordinate, `p_<coordinate>` or
/// `<coordinate>_dot`, or a rotation's `X_w1` … `p_X3`); other axes are parameters of
/// `[system] parameters`.
fn is_start_axis(problem: &Problem, name: &str) -> bool {
    let coord = |n: &str| problem.coordinates.iter().any(|c| c == n);
    coord(name)
        || name.strip_prefix("p_").is_some_and(coord)
        || name.strip_suffix("_dot").is_some_and(coord)
        || body_axis(problem, name).is_some()
}

/// A component of a rotation's start: `X_w1` … `X_w3` (body angular velocity) or `p_X1` …
/// `p_X3` (body angular momentum) of rotation X, as (offset of its block, component, whether
/// it is the momentum).
fn body_axis(problem: &Problem, name: &str) -> Option<(usize, usize, bool)> {
    let offsets = problem.terms.rotations.as_ref()?.offsets().to_vec();
    let names = crate::record::rotation_names(problem);
    names.iter().zip(offsets).find_map(|(x, o)| {
        let component = |rest: Option<&str>| match rest? {
            "1" => Some(0),
            "2" => Some(1),
            "3" => Some(2),
            _ => None,
        };
        let w = component(name.strip_prefix(x.as_str()).and_then(|r| r.strip_prefix("_w")));
        let p = component(name.strip_prefix("p_").and_then(|r| r.strip_prefix(x.as_str())));
        w.map(|c| (o, c, false)).or(p.map(|c| (o, c, true)))
    })
}

/// Sets component `c` of the body angular velocity (or, with `momentum`, of the body angular
/// momentum) of the rotation block at `o` in `start` to `value`, keeping R; false if the
/// start does not give that quantity (a velocity axis with initial p, or the reverse).
fn set_body_axis(start: &mut Start, (o, c, momentum): (usize, usize, bool), value: f64) -> bool {
    use femvi::rotation::so3::{hat, mul, mul_tn, vee};
    let block = |x: &[f64]| -> Option<[f64; 9]> { x.get(o..o + 9)?.try_into().ok() };
    match (start, momentum) {
        (Start::Velocity { q, v }, false) => {
            let (Some(r), Some(rv)) = (block(q), block(v)) else {
                return false;
            };
            let mut w = vee(&mul_tn(&r, &rv));
            w[c] = value;
            v[o..o + 9].copy_from_slice(&femvi::rotation::embedded_velocity(&r, &w));
            true
        }
        (Start::Momentum { q, p }, true) => {
            if block(q).is_none() || block(p).is_none() {
                return false;
            }
            let (r, mut pi) = femvi::rotation::body_state(q, p, o);
            pi[c] = value;
            p[o..o + 9].copy_from_slice(&mul(&r, &hat(&pi)).map(|x| 0.5 * x));
            true
        }
        _ => false,
    }
}

/// The values of the axes at grid point `idx` (the first axis varies fastest).
fn values_at(axes: &[Axis], idx: usize) -> Vec<f64> {
    let mut rest = idx;
    axes.iter()
        .map(|a| {
            let v = a.value(rest % a.n);
            rest /= a.n;
            v
        })
        .collect()
}

/// The `--set` overrides of the parameter axes at grid point `idx`.
fn parameter_overrides(problem: &Problem, axes: &[Axis], idx: usize) -> Vec<String> {
    axes.iter()
        .zip(values_at(axes, idx))
        .filter(|(a, _)| !is_start_axis(problem, &a.name))
        .map(|(a, v)| format!("system.parameters.{}={v:?}", a.name))
        .collect()
}

/// The start of `problem` with the start axes' values of grid point `idx` set.
fn start_at(problem: &Problem, axes: &[Axis], idx: usize) -> Result<Start, String> {
    let mut start = problem.start.clone();
    for (axis, value) in axes.iter().zip(values_at(axes, idx)) {
        if !is_start_axis(problem, &axis.name) {
            continue;
        }
        if let Some(at) = body_axis(problem, &axis.name) {
            if !set_body_axis(&mut start, at, value) {
                return Err(format!(
                    "grid axis '{}': an X_w axis needs initial X_w and a p_X axis initial p_X",
                    axis.name
                ));
            }
            continue;
        }
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
                "grid axis '{}': a p_<coordinate> axis needs initial p and a <coordinate>_dot axis initial v",
                axis.name
            )
        })? = value;
    }
    Ok(start)
}

/// Runs the indicators at every grid point (one point without axes), on `threads` threads.
pub fn compute<L: Lagrangian + Clone + Sync>(
    lag: &L,
    problem: &Problem,
    axes: &[Axis],
    wanted: &[Indicator],
    (threads, transient): (usize, f64),
) -> Result<Vec<Indicators>, String> {
    if !(transient.is_finite() && transient >= 0.0) {
        return Err(format!("--transient must be a time >= 0, not {transient}"));
    }
    if problem.energy.is_some() && !lag.is_autonomous() {
        return Err("femvi chaos in energy mode needs an autonomous Lagrangian (use [time] mode = \"fixed\")".into());
    }
    // [forces] or [constraints]: `chaos_forced.rs`.
    let tables = Tables::of(problem)?;
    let points: usize = axes.iter().map(|a| a.n).product();
    let starts = (0..points)
        .map(|i| start_at(problem, axes, i))
        .collect::<Result<Vec<_>, _>>()?;
    let chaos = ChaosOptions {
        spectrum: wanted.contains(&Indicator::Spectrum),
        spectrum_transient: transient,
        ..ChaosOptions::default()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| e.to_string())?;
    let parametric = axes.iter().any(|a| !is_start_axis(problem, &a.name));
    if !parametric {
        let one = |start: &Start| one_point(lag, problem, start.clone(), &tables, &chaos, wanted);
        return Ok(pool.install(|| starts.par_iter().map(one).collect()));
    }
    // Parameter axes: each point's problem is the file again with its parameter values set
    // (an unknown parameter is an input error, found at the first point).
    // The text as run; a path named after the problem keeps its default name.
    let label = std::path::PathBuf::from(format!("{}.toml", problem.name));
    let reload = |i: usize| crate::problem::load_text(&label, &problem.source, &parameter_overrides(problem, axes, i));
    reload(0).map_err(|e| e.to_string())?;
    let one = |i: usize| match reload(i) {
        Ok(p) => match start_at(&p, axes, i) {
            // The point's parameters also in its forces or constraints.
            Ok(start) => match if tables.is_none() {
                Ok(Tables::None)
            } else {
                Tables::of(&p)
            } {
                Ok(t) => crate::with_system!(&p.system, l => one_point(l, &p, start, &t, &chaos, wanted)),
                Err(e) => failed(&p, e),
            },
            Err(e) => failed(&p, e),
        },
        Err(e) => failed(problem, e.to_string()),
    };
    Ok(pool.install(|| (0..points).into_par_iter().map(one).collect()))
}

/// The indicators of one start of `problem` with the Lagrangian `lag`.
fn one_point<L: Lagrangian + Clone + Sync>(
    lag: &L,
    problem: &Problem,
    start: Start,
    tables: &Tables,
    chaos: &ChaosOptions,
    wanted: &[Indicator],
) -> Indicators {
    if let Some(r) = tables.indicators(lag, problem, &start, chaos) {
        return r.map_or_else(|e| failed(problem, e.to_string()), |r| pick(&r, wanted));
    }
    let made = problem.integrator(lag, &problem.element, problem.grid.clone(), start, problem.energy);
    match made.and_then(|mut it| indicators_on(&mut it, chaos)) {
        Ok(r) => pick(&r, wanted),
        Err(e) => failed(problem, e.to_string()),
    }
}

fn failed(problem: &Problem, error: String) -> Indicators {
    Indicators {
        megno: None,
        lyapunov: None,
        fli: None,
        spectrum: None,
        steps: 0,
        t: problem.grid.t0(),
        error: Some(error),
        final_q: vec![],
        final_p: vec![],
    }
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
        let mut values = values_at(axes, idx);
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

pub use crate::chaos_command::{cmd_chaos, ChaosArgs};
