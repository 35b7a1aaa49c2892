//! The `[time]` table: the time grid of an initial value problem (a uniform step, a list of
//! steps used in turn, or a step chosen for a requested accuracy), energy mode (time steps
//! as variables) and adaptive mode (fixed steps `ds` in the fictitious time of the Poincaré
//! transformation dt/ds = g(q), [`femvi::adaptive`]), checked and turned into a [`TimeGrid`],
//! [`femvi::EnergyOptions`] and [`AdaptiveTime`].

use super::errors::{InputError, Source};
use super::system::System;
use femvi::step::auto::StepChoice;
use femvi::{Element, SolverOptions, Start, TimeGrid};
use serde::Deserialize;

/// `[time] mode` (and `[boundary] time_mode`): fixed steps, or steps solved from the discrete
/// energy equation.
#[derive(Debug, Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// Steps as given (the default).
    #[default]
    Fixed,
    /// Steps as variables (paper §3).
    Energy,
    /// Fixed steps `ds` in fictitious time, dt/ds = `monitor`(q) (issue 21).
    Adaptive,
}

/// `[time] on_degenerate`: what energy mode does at a step whose energy equation has no
/// admissible root.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
pub enum OnDegenerate {
    /// Stop with an error (the default).
    Error,
    /// Take that step with the previous step size as a parameter, and count it.
    Fixed,
}

/// Adaptive mode's settings from `[time]`, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptiveTime {
    /// The step in fictitious time.
    pub ds: f64,
    /// "kepler", "nbody" or an expression in the coordinates; None: the model's default.
    pub monitor: Option<String>,
    /// Write rows at t0, t0 + output_step, … (physical times) instead of the nodes.
    pub output_step: Option<f64>,
}

/// `[time]` as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeTable {
    /// Fixed steps or energy mode.
    #[serde(default)]
    pub mode: Mode,
    /// A uniform step (energy mode: the first step).
    pub step: Option<f64>,
    /// Steps used in turn.
    pub steps: Option<Vec<f64>>,
    /// Relative position error wanted at `end`: femvi chooses the step (and, without
    /// [scheme] order or degree, the degree) by pilot runs (femvi::step::auto).
    pub accuracy: Option<f64>,
    /// Final time.
    pub end: f64,
    /// Energy mode: the smallest step allowed.
    pub min_step: Option<f64>,
    /// Energy mode: the largest step allowed.
    pub max_step: Option<f64>,
    /// Energy mode: the policy where the energy equation degenerates.
    pub on_degenerate: Option<OnDegenerate>,
    /// Adaptive mode: the monitor g(q) ("kepler", "nbody" or an expression in q).
    pub monitor: Option<String>,
    /// Adaptive mode: the step in fictitious time.
    pub ds: Option<f64>,
    /// Adaptive mode: write rows at uniform physical times with this spacing.
    pub output_step: Option<f64>,
}

impl TimeTable {
    /// Energy mode's options (None in fixed mode), checked against the other keys.
    pub fn energy(&self, src: &Source) -> Result<Option<femvi::EnergyOptions>, InputError> {
        if self.mode != Mode::Adaptive && (self.monitor.is_some() || self.ds.is_some() || self.output_step.is_some()) {
            return Err(src.error("[time] monitor, ds and output_step apply only to mode = \"adaptive\""));
        }
        if self.mode == Mode::Adaptive {
            self.adaptive(src)?;
            return Ok(None);
        }
        if self.mode == Mode::Fixed {
            if self.min_step.is_some() || self.max_step.is_some() || self.on_degenerate.is_some() {
                return Err(src.error("[time] min_step, max_step and on_degenerate apply only to mode = \"energy\""));
            }
            return Ok(None);
        }
        if self.accuracy.is_some() {
            return Err(
                src.error("[time] accuracy chooses a uniform step; mode = \"energy\" takes the first `step` instead")
            );
        }
        let h = self.step.ok_or_else(|| {
            src.error("[time] mode = \"energy\" needs `step` (the first step; later steps are variables)")
        })?;
        if self.steps.is_some() {
            return Err(src.error("[time] mode = \"energy\" takes `step`, not a list of `steps`"));
        }
        let d = femvi::EnergyOptions::from_step(h);
        Ok(Some(femvi::EnergyOptions {
            min_step: self.min_step.unwrap_or(d.min_step),
            max_step: self.max_step.unwrap_or(d.max_step),
            on_degenerate: match self.on_degenerate {
                Some(OnDegenerate::Fixed) => femvi::Degenerate::Fixed,
                _ => femvi::Degenerate::Error,
            },
        }))
    }

    /// Adaptive mode's settings (None in the other modes), checked against the other keys.
    pub fn adaptive(&self, src: &Source) -> Result<Option<AdaptiveTime>, InputError> {
        self.adaptive_checked().map_err(|e| src.error(e))
    }

    /// [`TimeTable::adaptive`] with the error as a message without the file name.
    pub fn adaptive_checked(&self) -> Result<Option<AdaptiveTime>, String> {
        if self.mode != Mode::Adaptive {
            return Ok(None);
        }
        let others = [
            (self.step.is_some(), "step"),
            (self.steps.is_some(), "steps"),
            (self.accuracy.is_some(), "accuracy"),
            (self.min_step.is_some(), "min_step"),
            (self.max_step.is_some(), "max_step"),
            (self.on_degenerate.is_some(), "on_degenerate"),
        ];
        if let Some((_, key)) = others.iter().find(|(given, _)| *given) {
            return Err(format!(
                "[time] mode = \"adaptive\" takes `ds` (the step in fictitious time), not `{key}`"
            ));
        }
        let ds = self
            .ds
            .ok_or("[time] mode = \"adaptive\" needs `ds`, the step in fictitious time s (dt/ds = monitor)")?;
        if !(ds.is_finite() && ds > 0.0) {
            return Err(format!("[time] ds = {ds} is not a positive finite number"));
        }
        if let Some(h) = self.output_step {
            if !(h.is_finite() && h > 0.0) {
                return Err(format!("[time] output_step = {h} is not a positive finite number"));
            }
        }
        Ok(Some(AdaptiveTime {
            ds,
            monitor: self.monitor.clone(),
            output_step: self.output_step,
        }))
    }

    /// The grid from `t0` to `end`; with `accuracy`, a placeholder until
    /// [`TimeTable::choose_step`] has the initial values; in adaptive mode a nominal grid with
    /// step `ds` (the run's nodes are in fictitious time and end at the first node at or past
    /// `end`).
    pub fn grid(&self, t0: f64, src: &Source) -> Result<TimeGrid, InputError> {
        if let Some(a) = self.adaptive(src)? {
            return TimeGrid::uniform(t0, a.ds, self.end).map_err(|e| src.error(format!("[time]: {e}")));
        }
        match (&self.step, &self.steps, &self.accuracy) {
            (Some(h), None, None) => TimeGrid::uniform(t0, *h, self.end),
            (None, Some(list), None) => TimeGrid::steps(t0, list.clone(), self.end),
            (None, None, Some(_)) => TimeGrid::uniform(t0, (self.end - t0).abs().max(1.0), self.end),
            _ => return Err(src.error("[time] needs exactly one of `step`, `steps` or `accuracy`")),
        }
        .map_err(|e| src.error(format!("[time]: {e}")))
    }

    /// With `accuracy`: the step that pilot runs choose (femvi::step::auto) and the uniform
    /// grid with it. Without: None.
    pub fn choose_step(
        &self,
        system: &System,
        element: &Element,
        start: &Start,
        t0: f64,
        options: SolverOptions,
        src: &Source,
    ) -> Result<Option<(TimeGrid, StepChoice)>, InputError> {
        let Some(accuracy) = self.accuracy else {
            return Ok(None);
        };
        let choice = crate::with_system!(system, l => femvi::step::auto::choose_step(
            l, element, start, t0, self.end, accuracy, options
        ))
        .map_err(|e| src.error(format!("[time] accuracy = {accuracy:e}: {e}")))?;
        let grid = TimeGrid::uniform(t0, choice.step, self.end).map_err(|e| src.error(format!("[time]: {e}")))?;
        Ok(Some((grid, choice)))
    }

    /// The grid as the library's solve API describes it ([`femvi::Steps`]): `chosen` is the
    /// step [`TimeTable::choose_step`] picked for `accuracy`. Call after [`TimeTable::grid`]
    /// has accepted the table.
    pub fn solve_steps(&self, energy: Option<femvi::EnergyOptions>, chosen: Option<f64>) -> femvi::Steps {
        match (energy, chosen, &self.steps) {
            (Some(options), _, _) => femvi::Steps::Energy {
                step: self.step.unwrap_or(f64::NAN),
                options,
            },
            (None, Some(h), _) => femvi::Steps::Fixed(h),
            (None, None, Some(list)) => femvi::Steps::Cycle(list.clone()),
            (None, None, None) => femvi::Steps::Fixed(self.step.unwrap_or(f64::NAN)),
        }
    }
}
