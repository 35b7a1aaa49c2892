//! The `[[events]]` tables: named conditions g(t, q, v) whose zeros `femvi run` locates with
//! the library's [`femvi::solution::Event`] (Poincaré sections, stopping conditions). The
//! condition is an expression in `t`, the coordinates, their `_dot` velocities and the
//! `[system]` parameters, compiled by the library's expression machinery: an
//! [`ExprLagrangian`] whose "Lagrangian" is the expression evaluates g(t, q, v) as its value.

use super::errors::{InputError, Source};
use femvi::expr::ExprLagrangian;
use femvi::solution::{Direction, Event};
use femvi::Lagrangian;
use serde::Deserialize;

/// `[[events]]` as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EventTable {
    /// A label (letters, digits, `_`, `-`): the `event` column of events.csv and the plot's
    /// file name.
    pub name: String,
    /// g(t, q, v) as an expression.
    pub when: String,
    /// Which sign changes count.
    #[serde(default)]
    pub direction: DirectionName,
    /// End the run at the first occurrence.
    #[serde(default)]
    pub stop: bool,
}

/// `direction` as written.
#[derive(Debug, Deserialize, Default, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum DirectionName {
    /// From negative to non-negative.
    Rising,
    /// From positive to non-positive.
    Falling,
    /// Both (the default).
    #[default]
    Both,
}

/// A checked event.
#[derive(Debug, Clone)]
pub struct EventSpec {
    /// Its label.
    pub name: String,
    /// The expression as written.
    pub when: String,
    /// The compiled condition (its value is g).
    pub condition: ExprLagrangian,
    /// Which sign changes count.
    pub direction: Direction,
    /// End the run at the first occurrence.
    pub stop: bool,
}

impl EventSpec {
    /// The library's event.
    pub fn event(&self) -> Event {
        let g = self.condition.clone();
        Event::new(self.name.clone(), move |t, q, v| g.value(t, q, v))
            .direction(self.direction)
            .stop(self.stop)
    }
}

/// Checks the `[[events]]` tables: names present, distinct and usable in file names,
/// conditions that compile with these coordinates and parameters.
pub fn resolve(
    tables: &[EventTable],
    coordinates: &[String],
    parameters: &[(String, f64)],
    src: &Source,
) -> Result<Vec<EventSpec>, InputError> {
    let mut out: Vec<EventSpec> = Vec::with_capacity(tables.len());
    for (i, e) in tables.iter().enumerate() {
        let ok = !e.name.is_empty()
            && e.name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        if !ok {
            return Err(src.error(format!(
                "events[{i}]: name '{}' is not allowed (letters, digits, _ and -)",
                e.name
            )));
        }
        if out.iter().any(|o| o.name == e.name) {
            return Err(src.error(format!("events[{i}]: the name '{}' is used twice", e.name)));
        }
        let condition = ExprLagrangian::new(&e.when, coordinates, parameters)
            .map_err(|err| src.error(format!("events[{i}] ('{}'): in `when`: {}", e.name, err.render())))?;
        out.push(EventSpec {
            name: e.name.clone(),
            when: e.when.clone(),
            condition,
            direction: match e.direction {
                DirectionName::Rising => Direction::Rising,
                DirectionName::Falling => Direction::Falling,
                DirectionName::Both => Direction::Both,
            },
            stop: e.stop,
        });
    }
    Ok(out)
}
