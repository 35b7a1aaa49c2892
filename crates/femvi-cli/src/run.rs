//! `femvi run`: integrates a problem, streaming trajectory.csv as it goes and writing
//! summary.json at the end (also after a failure, with the error).

use crate::problem::Problem;
use femvi::lagrangian::{hamiltonian, PointDerivatives};
use femvi::{Integrator, Lagrangian};
use serde::Serialize;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// What summary.json holds.
#[derive(Debug, Serialize)]
pub struct Summary {
    pub name: String,
    pub scheme: String,
    pub steps: usize,
    pub t_end: f64,
    pub final_t: f64,
    pub final_q: Vec<f64>,
    pub final_p: Vec<f64>,
    pub max_rel_energy_error: f64,
    pub mean_solver_iterations: f64,
    pub wall_seconds: f64,
    pub error: Option<String>,
    /// Energy mode only: largest relative residual of the discrete energy equations (3.3).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_rel_discrete_energy_error: Option<f64>,
    /// Energy mode only: smallest step taken.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_step: Option<f64>,
    /// Energy mode only: largest step taken.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_step: Option<f64>,
    /// Energy mode only: steps taken with time as a parameter (on_degenerate = "fixed").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub degenerate_steps: Option<usize>,
    /// `[time] accuracy` only: the step femvi chose.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto_step: Option<AutoStep>,
}

/// The step chosen for `[time] accuracy` (femvi::step::auto::StepChoice), for summary.json.
#[derive(Debug, Serialize)]
pub struct AutoStep {
    /// The relative position error requested at the end.
    pub accuracy: f64,
    /// The step chosen.
    pub step: f64,
    /// The element degree used.
    pub degree: usize,
    /// The estimated relative position error at the end with this step.
    pub estimated_error: f64,
    /// Steps taken by the pilot runs.
    pub pilot_steps: usize,
}

fn auto_step(problem: &Problem) -> Option<AutoStep> {
    problem.auto_step.as_ref().map(|c| AutoStep {
        accuracy: c.accuracy,
        step: c.step,
        degree: problem.element.degree(),
        estimated_error: c.estimated_error,
        pilot_steps: c.pilot_steps,
    })
}

/// How a run ended.
pub enum Outcome {
    /// Finished; the summary.
    Done(Summary),
    /// A numerical failure after some steps (written to disk); the summary has the error.
    Failed(Summary),
    /// The problem could not be started (bad input the library detected).
    Rejected(String),
}

/// Output formats of a run and whether a progress bar may be shown.
#[derive(Debug, Clone, Copy)]
pub struct RunOutput {
    pub csv: bool,
    pub npy: bool,
    pub progress: bool,
    pub plots: bool,
    pub plot_format: crate::plot::Format,
}

/// What the plots need, gathered as the run goes.
#[derive(Default)]
struct PlotData {
    t: Vec<f64>,
    q: Vec<f64>,
    p: Vec<f64>,
    rel_energy: Vec<f64>,
    steps: Vec<(f64, f64)>,
}

/// Draws coordinates against time, phase portraits, the energy error and (energy mode) the
/// step sizes into `dir`.
fn draw_plots(dir: &Path, problem: &Problem, d: &PlotData, f: crate::plot::Format) -> Result<(), String> {
    use crate::plot::{file, lines, log_lines, Series};
    let n = problem.coordinates.len();
    let name = &problem.name;
    let coords: Vec<Series> = (0..n)
        .map(|c| Series {
            name: problem.coordinates[c].clone(),
            points: d.t.iter().enumerate().map(|(k, t)| (*t, d.q[k * n + c])).collect(),
        })
        .collect();
    lines(
        &file(dir, "coordinates", f),
        f,
        &format!("{name}: coordinates"),
        "t",
        "q",
        &coords,
    )?;
    for (c, cname) in problem.coordinates.iter().enumerate() {
        let pts = (0..d.t.len()).map(|k| (d.q[k * n + c], d.p[k * n + c])).collect();
        let series = [Series {
            name: cname.clone(),
            points: pts,
        }];
        let title = format!("{name}: phase portrait of {cname}");
        lines(
            &file(dir, &format!("phase_{cname}"), f),
            f,
            &title,
            cname,
            &format!("p_{cname}"),
            &series,
        )?;
    }
    let energy = [Series {
        name: "relative energy error".into(),
        points: d.t.iter().zip(&d.rel_energy).map(|(t, e)| (*t, *e)).collect(),
    }];
    let title = format!("{name}: relative energy error");
    log_lines(
        &file(dir, "energy_error", f),
        f,
        &title,
        "t",
        "|H - H0| / |H0|",
        &energy,
        false,
    )?;
    if problem.energy.is_some() {
        let steps = [Series {
            name: "step".into(),
            points: d.steps.clone(),
        }];
        lines(
            &file(dir, "step_size", f),
            f,
            &format!("{name}: step size (energy mode)"),
            "t",
            "h",
            &steps,
        )?;
    }
    Ok(())
}

/// Runs a problem with output into `dir`.
pub fn run(problem: &Problem, dir: &Path, out: RunOutput) -> std::io::Result<Outcome> {
    crate::with_system!(&problem.system, l => run_with(l, problem, dir, out))
}

/// Writes the buffered rows as one 2-D float64 array and the column names, one per line.
fn write_npy(dir: &Path, header: &[String], rows: &[f64]) -> std::io::Result<()> {
    let cols = header.len() as u64;
    let file = std::io::BufWriter::new(std::fs::File::create(dir.join("trajectory.npy"))?);
    use npyz::WriterBuilder;
    let mut w = npyz::WriteOptions::<f64>::new()
        .default_dtype()
        .shape(&[rows.len() as u64 / cols, cols])
        .writer(file)
        .begin_nd()?;
    w.extend(rows.iter().copied())?;
    w.finish()?;
    std::fs::write(dir.join("columns.txt"), header.join("\n") + "\n")
}

/// A progress bar that appears once a run has taken a second.
struct Progress {
    enabled: bool,
    total: u64,
    t_end: f64,
    clock: Instant,
    bar: Option<indicatif::ProgressBar>,
}

impl Progress {
    fn update(&mut self, steps: u64, t: f64) {
        if !self.enabled || (steps & 255) != 0 {
            return;
        }
        if self.bar.is_none() && self.clock.elapsed().as_secs_f64() > 1.0 {
            let bar =
                indicatif::ProgressBar::with_draw_target(Some(self.total), indicatif::ProgressDrawTarget::stderr());
            let style = indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} steps, {msg}, ETA {eta}");
            if let Ok(style) = style {
                bar.set_style(style);
            }
            self.bar = Some(bar);
        }
        if let Some(bar) = &self.bar {
            bar.set_position(steps.min(self.total));
            let rate = steps as f64 / self.clock.elapsed().as_secs_f64().max(1e-9);
            bar.set_message(format!("t = {t:.6} of {}, {rate:.0} steps/s", self.t_end));
        }
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

fn num(x: f64) -> String {
    // Debug formatting of f64 is the shortest string that reads back to the same number.
    format!("{x:?}")
}

fn run_with<L: Lagrangian>(lag: &L, problem: &Problem, dir: &Path, out: RunOutput) -> std::io::Result<Outcome> {
    let clock = Instant::now();
    let out = RunOutput {
        plots: out.plots || problem.plots,
        ..out
    };
    let (grid, start) = (problem.grid.clone(), problem.start.clone());
    let made = match problem.energy {
        None => Integrator::new(lag, &problem.element, grid, start, problem.options),
        Some(e) => Integrator::with_energy(lag, &problem.element, grid, start, problem.options, e),
    };
    let mut it = match made {
        Ok(it) => it,
        Err(femvi::Error::Step(e)) => {
            // Only the start from (q0, q1) solves anything here.
            let summary = empty_summary(problem, clock.elapsed().as_secs_f64(), format!("first element: {e}"));
            std::fs::create_dir_all(dir)?;
            write_summary(dir, &summary)?;
            return Ok(Outcome::Failed(summary));
        }
        Err(e) => return Ok(Outcome::Rejected(e.to_string())),
    };
    std::fs::create_dir_all(dir)?;
    let mut csv = if out.csv {
        Some(csv::Writer::from_path(dir.join("trajectory.csv"))?)
    } else {
        None
    };
    let mut npy_rows: Vec<f64> = vec![];
    let mut plot_data = PlotData::default();
    let mut header = vec!["step".to_string(), "t".to_string()];
    header.extend(problem.coordinates.iter().cloned());
    header.extend(problem.coordinates.iter().map(|c| format!("p_{c}")));
    header.push("energy".into());
    let energy_mode = problem.energy.is_some();
    if energy_mode {
        header.push("discrete_energy".into());
    }
    if let Some(w) = csv.as_mut() {
        w.write_record(&header)?;
    }
    let n = lag.dim();
    let mut work = PointDerivatives::new(n);
    let mut v = match &problem.start {
        femvi::Start::Velocity { v, .. } => v.clone(),
        _ => vec![0.0; n],
    };
    let mut e0 = f64::NAN;
    let mut max_rel = 0.0f64;
    let mut error = None;
    let mut row = Vec::with_capacity(header.len());
    let mut last_written = usize::MAX;
    let mut steps = 0;
    let mut record = |it: &Integrator<L>,
                      csv: &mut Option<csv::Writer<std::fs::File>>,
                      npy_rows: &mut Vec<f64>,
                      plot_data: &mut PlotData,
                      force: bool|
     -> Result<(), String> {
        let node = it.node();
        let h = hamiltonian(lag, node.t, node.q, node.p, &mut v, &mut work).map_err(|e| e.to_string())?;
        if e0.is_nan() {
            e0 = h;
        }
        let rel = if e0 != 0.0 {
            ((h - e0) / e0).abs()
        } else {
            (h - e0).abs()
        };
        max_rel = max_rel.max(rel);
        if (force || node.k.is_multiple_of(problem.every)) && last_written != node.k {
            last_written = node.k;
            row.clear();
            row.push(node.k.to_string());
            row.push(num(node.t));
            row.extend(node.q.iter().map(|&x| num(x)));
            row.extend(node.p.iter().map(|&x| num(x)));
            row.push(num(h));
            if let Some(st) = it.energy_stats() {
                row.push(num(st.energy));
            }
            if let Some(w) = csv.as_mut() {
                w.write_record(&row).map_err(|e| e.to_string())?;
            }
            if out.plots {
                if let Some(&last) = plot_data.t.last() {
                    plot_data.steps.push((node.t, node.t - last));
                }
                plot_data.t.push(node.t);
                plot_data.q.extend_from_slice(node.q);
                plot_data.p.extend_from_slice(node.p);
                plot_data.rel_energy.push(rel);
            }
            if out.npy {
                npy_rows.push(node.k as f64);
                npy_rows.push(node.t);
                npy_rows.extend_from_slice(node.q);
                npy_rows.extend_from_slice(node.p);
                npy_rows.push(h);
                if let Some(st) = it.energy_stats() {
                    npy_rows.push(st.energy);
                }
            }
        }
        Ok(())
    };
    if let Err(e) = record(&it, &mut csv, &mut npy_rows, &mut plot_data, true) {
        error = Some(e);
    }
    let total = match problem.energy {
        None => problem.grid.count() as u64,
        Some(_) => ((problem.grid.end() - problem.grid.t0()) / problem.grid.nominal(0)).ceil() as u64,
    };
    let mut progress = Progress {
        enabled: out.progress,
        total,
        t_end: problem.grid.end(),
        clock: Instant::now(),
        bar: None,
    };
    while error.is_none() {
        match it.step() {
            Ok(true) => {
                steps += 1;
                let last = it.finished();
                if let Err(e) = record(&it, &mut csv, &mut npy_rows, &mut plot_data, last) {
                    error = Some(e);
                }
                progress.update(steps as u64, it.node().t);
            }
            Ok(false) => break,
            Err(e) => error = Some(e.to_string()),
        }
    }
    progress.finish();
    if let Some(w) = csv.as_mut() {
        w.flush()?;
    }
    if out.npy {
        write_npy(dir, &header, &npy_rows)?;
    }
    if out.plots {
        if let Err(e) = draw_plots(dir, problem, &plot_data, out.plot_format) {
            error = error.or(Some(e));
        }
    }
    let node = it.node();
    let summary = Summary {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        steps,
        t_end: problem.grid.end(),
        final_t: node.t,
        final_q: node.q.to_vec(),
        final_p: node.p.to_vec(),
        max_rel_energy_error: max_rel,
        mean_solver_iterations: it.mean_iterations(),
        wall_seconds: clock.elapsed().as_secs_f64(),
        error,
        max_rel_discrete_energy_error: it.energy_stats().map(|s| s.max_rel_residual),
        min_step: it.energy_stats().map(|s| s.min_step),
        max_step: it.energy_stats().map(|s| s.max_step),
        degenerate_steps: it.energy_stats().map(|s| s.degenerate_steps),
        auto_step: auto_step(problem),
    };
    write_summary(dir, &summary)?;
    Ok(if summary.error.is_some() {
        Outcome::Failed(summary)
    } else {
        Outcome::Done(summary)
    })
}

fn empty_summary(problem: &Problem, wall: f64, error: String) -> Summary {
    Summary {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        steps: 0,
        t_end: problem.grid.end(),
        final_t: problem.grid.t0(),
        final_q: vec![],
        final_p: vec![],
        max_rel_energy_error: f64::NAN,
        mean_solver_iterations: 0.0,
        wall_seconds: wall,
        error: Some(error),
        max_rel_discrete_energy_error: None,
        min_step: None,
        max_step: None,
        degenerate_steps: None,
        auto_step: auto_step(problem),
    }
}

fn write_summary(dir: &Path, s: &Summary) -> std::io::Result<()> {
    let mut f = std::fs::File::create(dir.join("summary.json"))?;
    let text = serde_json::to_string_pretty(s).map_err(std::io::Error::other)?;
    writeln!(f, "{text}")
}
