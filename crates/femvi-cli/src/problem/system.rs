//! The `[system]` table: a built-in model with its parameters, or a Lagrangian expression
//! with its coordinates and parameters, checked and turned into a [`System`]; and the
//! [`with_system!`](crate::with_system) macro that runs generic code on whichever Lagrangian a
//! [`System`] holds.

use super::errors::{did_you_mean, InputError, Source};
use femvi::expr::ExprLagrangian;
use femvi::models;
use serde::Deserialize;
use std::collections::BTreeMap;

/// `[system]` as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SystemTable {
    /// Coordinate names (required with `lagrangian`; with `model`, must match the model's).
    pub coordinates: Option<Vec<String>>,
    /// Named constants of the expression, or the model's parameters.
    #[serde(default)]
    pub parameters: BTreeMap<String, f64>,
    /// L(t, q, q_dot) as an expression, with its position in the file for error messages.
    pub lagrangian: Option<toml::Spanned<String>>,
    /// A built-in model name (`femvi models` lists them).
    pub model: Option<String>,
    /// Names of rotations (configuration variables in SO(3), [`femvi::rotation`]): each X
    /// adds the coordinates X11 … X33 (the entries of X, row-major) before `coordinates`, and
    /// the expression may use X_w1, X_w2, X_w3 (the body angular velocity, Ẋ = X ŵ).
    pub rotations: Option<Vec<String>>,
}

/// The system a problem describes: built-in or from an expression.
pub enum System {
    /// A Lagrangian expression.
    Expr(ExprLagrangian),
    /// Built-in "harmonic".
    Harmonic(femvi::Mechanical<models::HarmonicPotential>),
    /// Built-in "pendulum".
    Pendulum(femvi::Mechanical<models::PendulumPotential>),
    /// Built-in "kepler".
    Kepler(femvi::Mechanical<models::KeplerPotential>),
    /// Built-in "henon-heiles".
    HenonHeiles(femvi::Mechanical<models::HenonHeilesPotential>),
    /// Built-in "double-pendulum".
    DoublePendulum(models::DoublePendulum),
    /// Built-in "forced-oscillator".
    Forced(femvi::Mechanical<models::ForcedPotential>),
    /// Built-in "fpu".
    Fpu(femvi::Mechanical<models::FpuPotential>),
    /// Built-in "n-body" and "outer-solar-system".
    Gravity(femvi::Mechanical<models::GravityPotential>),
    /// Built-in "rigid-body" and "heavy-top".
    Rigid(models::RigidBody),
}

/// Dispatches `$body` with `$l` bound to the concrete Lagrangian of a [`System`].
#[macro_export]
macro_rules! with_system {
    ($sys:expr, $l:ident => $body:expr) => {
        match $sys {
            $crate::problem::System::Expr($l) => $body,
            $crate::problem::System::Harmonic($l) => $body,
            $crate::problem::System::Pendulum($l) => $body,
            $crate::problem::System::Kepler($l) => $body,
            $crate::problem::System::HenonHeiles($l) => $body,
            $crate::problem::System::DoublePendulum($l) => $body,
            $crate::problem::System::Forced($l) => $body,
            $crate::problem::System::Fpu($l) => $body,
            $crate::problem::System::Gravity($l) => $body,
            $crate::problem::System::Rigid($l) => $body,
        }
    };
}

/// A checked `[system]` table.
pub struct Resolved {
    /// The Lagrangian.
    pub system: System,
    /// Its coordinate names.
    pub coordinates: Vec<String>,
    /// Built-in model name, if any, and its resolved parameters.
    pub model: Option<(String, Vec<f64>)>,
    /// The rotations' names; their blocks of nine are the first coordinates.
    pub rotations: Vec<String>,
}

impl SystemTable {
    /// Checks the table and builds the Lagrangian it describes.
    pub fn resolve(&self, src: &Source) -> Result<Resolved, InputError> {
        let params: Vec<(String, f64)> = self.parameters.iter().map(|(k, v)| (k.clone(), *v)).collect();
        match (&self.lagrangian, &self.model) {
            (Some(_), Some(_)) => Err(src.error("[system] has both `lagrangian` and `model`; give one")),
            (None, None) => {
                Err(src.error("[system] needs `lagrangian` (an expression) or `model` (a built-in system)"))
            }
            (None, Some(model)) => self.model_system(model, &params, src),
            (Some(expr), None) => self.expr_system(expr, &params, src),
        }
    }

    /// A built-in model with its parameters (defaults filled in).
    fn model_system(&self, model: &str, params: &[(String, f64)], src: &Source) -> Result<Resolved, InputError> {
        models::info(model).ok_or_else(|| {
            let names: Vec<&str> = models::MODELS.iter().map(|m| m.name).collect();
            let hint = did_you_mean(model, &names);
            src.error(format!(
                "unknown model '{model}'{hint}; built-in models: {}",
                names.join(", ")
            ))
        })?;
        let p = models::parameters(model, params).map_err(|e| src.error(e))?;
        let coords = models::coordinates(model, &p);
        if let Some(given) = &self.coordinates {
            if *given != coords {
                return Err(src.error(format!(
                    "model '{model}' has coordinates [{}]; [system] coordinates = [{}] disagree (leave them out)",
                    coords.join(", "),
                    given.join(", ")
                )));
            }
        }
        let rotations: Vec<String> = models::rotations(model).iter().map(|s| s.to_string()).collect();
        if self.rotations.as_ref().is_some_and(|given| *given != rotations) {
            return Err(src.error(format!(
                "model '{model}' has rotations [{}]; [system] rotations disagree (leave them out)",
                rotations.join(", ")
            )));
        }
        let system = built_in(model, &p).map_err(|e| src.error(format!("model {model}: {e}")))?;
        Ok(Resolved {
            system,
            coordinates: coords,
            model: Some((model.to_string(), p)),
            rotations,
        })
    }

    /// A Lagrangian expression in the declared coordinates and parameters.
    fn expr_system(
        &self,
        expr: &toml::Spanned<String>,
        params: &[(String, f64)],
        src: &Source,
    ) -> Result<Resolved, InputError> {
        let rotations = self.rotations.clone().unwrap_or_default();
        let mut coords: Vec<String> = rotations.iter().flat_map(|x| super::rotations::entries(x)).collect();
        match (&self.coordinates, rotations.is_empty()) {
            (Some(c), _) => coords.extend(c.iter().cloned()),
            (None, false) => {}
            (None, true) => {
                return Err(src.error("[system] with a `lagrangian` needs `coordinates` (a list of names)"));
            }
        }
        check_coordinate_names(&coords, src)?;
        if let Some((k, v)) = params.iter().find(|(_, v)| !v.is_finite()) {
            return Err(src.error(format!("parameter '{k}' = {v} is not finite")));
        }
        let lag = if rotations.is_empty() {
            ExprLagrangian::new(expr.get_ref(), &coords, params).map_err(|e| expr_error(src, expr, &e))?
        } else {
            let text = super::rotations::embed(expr.get_ref(), &rotations);
            ExprLagrangian::new(&text, &coords, params).map_err(|e| {
                src.error(format!(
                    "in the lagrangian (with the rotations' X_w written out): {}",
                    e.message
                ))
            })?
        };
        Ok(Resolved {
            system: System::Expr(lag),
            coordinates: coords,
            model: None,
            rotations,
        })
    }
}

/// Coordinate names of an expression: at least one, identifiers, not `t` or `pi`, distinct.
fn check_coordinate_names(coords: &[String], src: &Source) -> Result<(), InputError> {
    if coords.is_empty() {
        return Err(src.error("[system] coordinates is empty"));
    }
    for c in coords {
        let ok = c.chars().next().is_some_and(|ch| ch.is_ascii_alphabetic() || ch == '_')
            && c.chars().all(|ch| ch.is_ascii_alphanumeric() || ch == '_');
        if !ok || c == "t" || c == "pi" {
            return Err(src.error(format!(
                "coordinate name '{c}' is not allowed (letters, digits, _; not t or pi)"
            )));
        }
    }
    if let Some(d) = coords.iter().enumerate().find(|(i, c)| coords[..*i].contains(c)) {
        return Err(src.error(format!("coordinate '{}' is named twice", d.1)));
    }
    Ok(())
}

/// The built-in model `model` (a name [`models::info`] knows) with resolved parameters `p`.
fn built_in(model: &str, p: &[f64]) -> femvi::Result<System> {
    Ok(match model {
        "harmonic" => System::Harmonic(models::harmonic(p[0], p[1])?),
        "pendulum" => System::Pendulum(models::pendulum(p[0], p[1], p[2])?),
        "kepler" => System::Kepler(models::kepler(p[0])?),
        "henon-heiles" => System::HenonHeiles(models::henon_heiles()),
        "forced-oscillator" => System::Forced(models::forced_oscillator(p[0], p[1], p[2], p[3])?),
        "fpu" => System::Fpu(models::fpu(p[0] as usize, p[1], p[2])?),
        "n-body" => System::Gravity(models::n_body(p[2], p[3..].to_vec(), p[1] as usize)?),
        "outer-solar-system" => System::Gravity(models::outer_solar_system()),
        "rigid-body" => System::Rigid(models::RigidBody::free([p[0], p[1], p[2]])?),
        "heavy-top" => System::Rigid(models::RigidBody::heavy_top(
            [p[0], p[1], p[2]],
            p[3],
            p[4],
            [p[5], p[6], p[7]],
        )?),
        _ => System::DoublePendulum(models::DoublePendulum {
            m1: p[0],
            m2: p[1],
            l1: p[2],
            l2: p[3],
            g: p[4],
        }),
    })
}

/// Maps an expression error to a position in the file where the string has no escapes.
fn expr_error(src: &Source, expr: &toml::Spanned<String>, e: &femvi::expr::ExprError) -> InputError {
    let span = expr.span();
    let raw = src.text.get(span.clone()).unwrap_or("");
    let (mut open, close) = if raw.starts_with("\"\"\"") || raw.starts_with("'''") {
        (3, 3)
    } else {
        (1, 1)
    };
    if open == 3 && raw[3..].starts_with('\n') {
        open += 1;
    }
    let inner = raw.get(open..raw.len().saturating_sub(close)).unwrap_or("");
    if inner == expr.get_ref() {
        super::errors::bad(src.excerpt(
            span.start + open + e.offset,
            &format!("in the lagrangian: {}", e.message),
        ))
    } else {
        src.error(format!("in the lagrangian: {}", e.render()))
    }
}
