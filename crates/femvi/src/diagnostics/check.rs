//! A whole-run check of what the paper proves: symplecticity of the step maps ((2.17),
//! (2.46); in energy mode the extended form of (3.6)), the energy error and its drift, the
//! Noether momenta of declared symmetries, and the time-reversal error of the symmetric
//! schemes. The command `femvi check` prints this report.
//!
//! The check streams: everything is tallied node by node, and the time reversal takes the
//! forward steps again from the grid (they are not stored), so its memory does not grow with
//! the length of the run.

use super::symplecticity_defect;
pub use super::Symmetry;
use crate::error::Result;
use crate::lagrangian::{hamiltonian, Lagrangian, PointDerivatives};
use crate::step::{EnergyOptions, Integrator, SolverOptions, Start, TimeGrid};
use crate::Element;

/// At most this many steps get their tangent map checked (evenly spaced).
pub const MAX_SAMPLES: usize = 1000;

/// The two-form coefficient of the paper's examples, computed and predicted.
#[derive(Debug, Clone, PartialEq)]
pub struct TwoFormCheck {
    /// Which formula: "(2.21)", "(2.31)" or "(2.51) corrected".
    pub formula: String,
    /// max |computed − predicted| / |predicted| over the sampled steps.
    pub max_rel_difference: f64,
    /// Steps compared.
    pub samples: usize,
}

/// Which of the paper's two-form formulas describes `element`, if any.
fn paper_formula(element: &Element) -> Option<&'static str> {
    use crate::fem::{NodeFamily, QuadratureKind};
    match (element.degree(), element.basis.family, element.rule.kind) {
        (1, _, QuadratureKind::Midpoint | QuadratureKind::GaussLegendre(1)) => Some("(2.21)"),
        (1, _, _) => Some("(2.31)"),
        (2, NodeFamily::Equispaced, _) => Some("(2.51) corrected"),
        _ => None,
    }
}

/// The paper's prediction of ∂²L_d/∂q_k∂q_{k+1} for a unit-mass 1-D Lagrangian ½v² − V(q),
/// with V'' from `vpp` and integrals by the element's own quadrature. `nodes` are the element's
/// nodal values (q_k, \[q_m,\] q_{k+1}).
fn predicted(element: &Element, formula: &str, h: f64, nodes: &[f64], vpp: &dyn Fn(f64) -> f64) -> f64 {
    let rule = &element.rule;
    match formula {
        // −(1/h + h/4 V''(q̄)) (the paper orients dq_{k+1}∧dq_k).
        "(2.21)" => -(1.0 / h + h / 4.0 * vpp(0.5 * (nodes[0] + nodes[1]))),
        // −(1/h + h F_12), F_12 = ∫ V''((1−c) q_k + c q_{k+1}) (1−c) c dc by the rule.
        "(2.31)" => {
            let f12: f64 = rule
                .nodes
                .iter()
                .zip(&rule.weights)
                .map(|(c, b)| b * vpp((1.0 - c) * nodes[0] + c * nodes[1]) * (1.0 - c) * c)
                .sum();
            -(1.0 / h + h * f12)
        }
        // 1/(3h) − h G_{k,k+1} − (8/(3h) + h G_{m,k})(8/(3h) + h G_{m,k+1}) / (16/(3h) − h G_{m,m}).
        _ => {
            let g = |a: usize, bb: usize| -> f64 {
                rule.nodes
                    .iter()
                    .zip(&rule.weights)
                    .map(|(t, b)| {
                        let f = [(2.0 * t - 1.0) * (t - 1.0), 4.0 * t * (1.0 - t), t * (2.0 * t - 1.0)];
                        b * vpp(nodes[0] * f[0] + nodes[1] * f[1] + nodes[2] * f[2]) * f[a] * f[bb]
                    })
                    .sum()
            };
            let m =
                (8.0 / (3.0 * h) + h * g(1, 0)) * (8.0 / (3.0 * h) + h * g(1, 2)) / (16.0 / (3.0 * h) - h * g(1, 1));
            1.0 / (3.0 * h) - h * g(0, 2) - m
        }
    }
}

/// The measured quantities of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckReport {
    /// Steps taken.
    pub steps: usize,
    /// Time of the last node.
    pub final_t: f64,
    /// max |MᵀJM − J| over the sampled steps (extended map in energy mode).
    pub symplecticity_defect: Option<f64>,
    /// The same with each sample divided by max(1, max|M|²).
    pub symplecticity_defect_relative: Option<f64>,
    /// Steps whose tangent map was checked.
    pub symplecticity_samples: usize,
    /// max |H − H₀| / |H₀| (absolute if H₀ = 0).
    pub max_rel_energy_error: f64,
    /// Least-squares slope of the relative energy error against time.
    pub energy_drift: f64,
    /// max |J − J₀| / |J₀| (absolute if J₀ = 0), per symmetry in the order given.
    pub momentum_drift: Vec<f64>,
    /// Distance between the start and the end of a forward-then-backward run with reversed
    /// momenta; None for time-dependent Lagrangians or variable steps.
    pub time_reversal_error: Option<f64>,
    /// Energy mode: the largest relative residual of the energy equations.
    pub max_rel_discrete_energy_error: Option<f64>,
    /// For the paper's Lagrangians (n = 1, L = ½v² − V(q)): the preserved two-form coefficient
    /// ∂²L_d/∂q_k∂q_{k+1} from the tangent map against the paper's formula for the element.
    pub two_form: Option<TwoFormCheck>,
    /// Remarks on what was or was not measured.
    pub notes: Vec<String>,
}

/// Runs `lag` with `element` over `grid` from `start` (steps as variables if `energy` is
/// given) and measures the report's quantities.
///
/// # Errors
/// A symmetry that does not fit the system ([`Symmetry::validate`]), or any error of the run,
/// the tangent maps or the Legendre transform.
#[allow(clippy::too_many_arguments)]
pub fn check<L: Lagrangian>(
    lag: &L,
    element: &Element,
    grid: TimeGrid,
    start: Start,
    options: SolverOptions,
    energy: Option<EnergyOptions>,
    symmetries: &[Symmetry],
) -> Result<CheckReport> {
    let n = lag.dim();
    symmetries.iter().try_for_each(|s| s.validate(n))?;
    let mut notes = vec![];
    let total = expected_steps(&grid, energy.is_some());
    let stride = (total / MAX_SAMPLES).max(1);
    let mut v = match &start {
        Start::Velocity { v, .. } => v.clone(),
        _ => vec![0.0; n],
    };
    let mut it = match energy {
        None => Integrator::new(lag, element, grid, start, options)?,
        Some(e) => Integrator::with_energy(lag, element, grid, start, options, e)?,
    };
    let mut work = PointDerivatives::new(n);
    let node = it.node();
    let (q0, p0, t0) = (node.q.to_vec(), node.p.to_vec(), node.t);
    let h0 = hamiltonian(lag, t0, &q0, &p0, &mut v, &mut work)?;
    let j0: Vec<f64> = symmetries.iter().map(|s| s.momentum(&q0, &p0)).collect();
    let mut tally = Tally::new(h0, j0, t0);
    // The paper's two-form formulas: n = 1, unit mass, autonomous, steps as parameters.
    let formula = match (n, lag.mass_matrix(), energy) {
        (1, Some(mass), None) if mass.is_identity() && lag.is_autonomous() => paper_formula(element),
        _ => None,
    };
    // The node each step starts from: the last one's, for the time reversal.
    let mut previous = (0, t0);
    while it.step()? {
        let k = it.node().k;
        // In energy mode the first element has its step as a parameter: no extended map there.
        let sample = k.is_multiple_of(stride) || it.finished();
        if sample && (energy.is_none() || k >= 2) {
            sample_tangent_map(&mut it, lag, element, energy, formula, &mut tally)?;
        }
        let node = it.node();
        let h = hamiltonian(lag, node.t, node.q, node.p, &mut v, &mut work)?;
        tally.node(node.t, h, node.q, node.p, symmetries);
        tally.last_node = previous;
        previous = (node.k, node.t);
    }
    let node = it.node();
    let (final_q, final_p, final_t) = (node.q.to_vec(), node.p.to_vec(), node.t);
    let samples = tally.samples;
    if stride > 1 {
        notes.push(format!(
            "symplecticity sampled at {samples} of about {total} steps (every {stride}-th)"
        ));
    }
    if energy.is_some() {
        notes.push("energy mode: symplecticity of the extended map in (q, t; p, -E), paper (3.6)".into());
    }
    let time_reversal_error = if energy.is_none() && lag.is_autonomous() && tally.steps > 0 {
        let reverse = Reverse {
            grid: it.grid(),
            steps: tally.steps,
            last: tally.last_node,
        };
        Some(time_reversal(
            lag,
            element,
            options,
            &reverse,
            (final_q, final_p),
            (&q0, &p0),
        )?)
    } else {
        notes.push("time reversal skipped: the Lagrangian depends on time, or the steps are variables".into());
        None
    };
    Ok(tally.report(
        final_t,
        time_reversal_error,
        it.energy_stats().map(|s| s.max_rel_residual),
        formula,
        notes,
    ))
}

/// The steps a run over `grid` is expected to take (in energy mode, at the nominal step).
fn expected_steps(grid: &TimeGrid, energy: bool) -> usize {
    if energy {
        ((grid.end() - grid.t0()) / grid.nominal(0)).ceil() as usize
    } else {
        grid.count()
    }
}

/// Measures the tangent map of the step just taken (the extended map in energy mode) into
/// `tally`: its symplecticity defect and, with a paper's `formula`, its two-form coefficient.
fn sample_tangent_map<L: Lagrangian>(
    it: &mut Integrator<'_, L>,
    lag: &L,
    element: &Element,
    energy: Option<EnergyOptions>,
    formula: Option<&str>,
    tally: &mut Tally,
) -> Result<()> {
    let n = lag.dim();
    let (m, d) = match energy {
        None => (it.tangent_map()?, n),
        Some(_) => (it.extended_tangent_map()?, n + 1),
    };
    let dev = symplecticity_defect(&m, d);
    let size = m.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    tally.defect = tally.defect.max(dev);
    tally.defect_rel = tally.defect_rel.max(dev / size.powi(2).max(1.0));
    tally.samples += 1;
    if let (Some(f), Some(e)) = (formula, it.last_element()) {
        // dp_k = −D11 dq_k − D12 dq_{k+1}: at fixed q_k, ∂q_{k+1}/∂p_k = −1/D12.
        let computed = -1.0 / m[1];
        let nodes: Vec<f64> = e.incr.iter().map(|d| e.base[0] + d).collect();
        let (h, t) = (e.h, e.t);
        let vpp = |q: f64| {
            let mut pd = PointDerivatives::new(1);
            lag.second_derivatives(t, &[q], &[0.0], false, &mut pd);
            -pd.h(1, 1)
        };
        let want = predicted(element, f, h, &nodes, &vpp);
        tally.two_form_worst = tally.two_form_worst.max(((computed - want) / want).abs());
        tally.two_form_samples += 1;
    }
    Ok(())
}

/// The time-reversal error: from (q_N, −p_N) = (`end.0`, −`end.1`) back over the steps of
/// the forward run in reverse order, the largest distance of the positions from q_0 and of
/// the momenta from −p_0 (`start` = (q_0, p_0)).
///
/// The reverse run takes the steps the forward run took on `grid` (`steps` of them, the last
/// from node `last` = (k, t)) without storing them, so that its memory does not grow with the
/// run: first the forward run's last step (shortened to land on the end) on its own, then the
/// others from a grid with the same step (uniform) or the list of steps rotated to run
/// backwards (a list of steps, cyclic). The second part starts from the node the first one
/// reaches, so its solver starts afresh there.
fn time_reversal<L: Lagrangian>(
    lag: &L,
    element: &Element,
    options: SolverOptions,
    reverse: &Reverse,
    end: (Vec<f64>, Vec<f64>),
    start: (&[f64], &[f64]),
) -> Result<f64> {
    let (mut q, final_p) = end;
    let mut p: Vec<f64> = final_p.iter().map(|x| -x).collect();
    let (q0, p0) = start;
    for grid in [Some(reverse.first()?), reverse.rest()?].into_iter().flatten() {
        let mut rev = Integrator::new(lag, element, grid, Start::Momentum { q, p }, options)?;
        while rev.step()? {}
        let r = rev.node();
        (q, p) = (r.q.to_vec(), r.p.to_vec());
    }
    let dq = q.iter().zip(q0).map(|(a, b)| (a - b).abs());
    let dp = p.iter().zip(p0).map(|(a, b)| (a + b).abs());
    Ok(dq.chain(dp).fold(0.0, f64::max))
}

/// The steps of a forward run, to be taken backwards ([`time_reversal`]): its grid, the
/// number of steps taken and the node (k, t) the last step started from.
struct Reverse<'g> {
    grid: &'g TimeGrid,
    steps: usize,
    last: (usize, f64),
}

impl Reverse<'_> {
    /// A grid of one step: the forward run's last.
    fn first(&self) -> Result<TimeGrid> {
        let (k, t) = self.last;
        let h = match self.grid.next(k, t) {
            Some((h, _)) => h,
            None => self.grid.nominal(k),
        };
        TimeGrid::uniform(0.0, h, h)
    }

    /// The grid of the forward steps before the last, in reverse order; None for a run of
    /// one step.
    fn rest(&self) -> Result<Option<TimeGrid>> {
        let m = self.steps.saturating_sub(1);
        if m == 0 {
            return Ok(None);
        }
        if self.grid.is_uniform() {
            let h = self.grid.nominal(0);
            return TimeGrid::uniform(0.0, h, m as f64 * h).map(Some);
        }
        // Step j of the reverse run is forward step m − 1 − j: the list rotated and reversed,
        // and the end where the reverse run's own sums of steps put it.
        let period = self.grid.period();
        let list: Vec<f64> = (0..period)
            .map(|j| self.grid.nominal((m - 1 + period - j) % period))
            .collect();
        let end = (0..m).fold(0.0, |t, j| t + list[j % period]);
        TimeGrid::steps(0.0, list, end).map(Some)
    }
}

/// The quantities accumulated step by step over a run.
struct Tally {
    /// Energy and Noether momenta at the start.
    h0: f64,
    j0: Vec<f64>,
    momentum_drift: Vec<f64>,
    max_rel: f64,
    /// Symplecticity defects (absolute, relative) and the tangent maps sampled.
    defect: f64,
    defect_rel: f64,
    samples: usize,
    /// Online least squares of the relative energy error against time: Σ1, Σt, Σe, Σt², Σte.
    sn: f64,
    st: f64,
    se: f64,
    stt: f64,
    ste: f64,
    /// Steps taken, and the node (k, t) the last one started from.
    steps: usize,
    last_node: (usize, f64),
    two_form_worst: f64,
    two_form_samples: usize,
}

impl Tally {
    fn new(h0: f64, j0: Vec<f64>, t0: f64) -> Self {
        let momentum_drift = vec![0.0f64; j0.len()];
        Tally {
            h0,
            j0,
            momentum_drift,
            max_rel: 0.0,
            defect: 0.0,
            defect_rel: 0.0,
            samples: 0,
            sn: 0.0,
            st: 0.0,
            se: 0.0,
            stt: 0.0,
            ste: 0.0,
            steps: 0,
            last_node: (0, t0),
            two_form_worst: 0.0,
            two_form_samples: 0,
        }
    }

    /// The node (t, q, p) reached by a step, with energy h: the step, the relative energy
    /// error and the momenta's drifts.
    fn node(&mut self, t: f64, h: f64, q: &[f64], p: &[f64], symmetries: &[Symmetry]) {
        self.steps += 1;
        let h0 = self.h0;
        let rel = if h0 != 0.0 { (h - h0) / h0.abs() } else { h - h0 };
        self.max_rel = self.max_rel.max(rel.abs());
        self.sn += 1.0;
        self.st += t;
        self.se += rel;
        self.stt += t * t;
        self.ste += t * rel;
        let j0 = &self.j0;
        for (i, s) in symmetries.iter().enumerate() {
            let j = s.momentum(q, p);
            let d = if j0[i] != 0.0 {
                (j - j0[i]).abs() / j0[i].abs()
            } else {
                (j - j0[i]).abs()
            };
            self.momentum_drift[i] = self.momentum_drift[i].max(d);
        }
    }

    /// The report from the tallies and what was measured after the run.
    fn report(
        self,
        final_t: f64,
        time_reversal_error: Option<f64>,
        max_rel_discrete_energy_error: Option<f64>,
        formula: Option<&str>,
        notes: Vec<String>,
    ) -> CheckReport {
        let denom = self.sn * self.stt - self.st * self.st;
        let energy_drift = if denom > 0.0 {
            (self.sn * self.ste - self.st * self.se) / denom
        } else {
            0.0
        };
        let (symplecticity_defect, symplecticity_defect_relative) = if self.samples > 0 {
            (Some(self.defect), Some(self.defect_rel))
        } else {
            (None, None)
        };
        CheckReport {
            steps: self.steps,
            final_t,
            symplecticity_defect,
            symplecticity_defect_relative,
            symplecticity_samples: self.samples,
            max_rel_energy_error: self.max_rel,
            energy_drift,
            momentum_drift: self.momentum_drift,
            time_reversal_error,
            max_rel_discrete_energy_error,
            two_form: formula.map(|f| TwoFormCheck {
                formula: f.to_string(),
                max_rel_difference: self.two_form_worst,
                samples: self.two_form_samples,
            }),
            notes,
        }
    }
}
