//! `--set key.path=value`: overrides of any value of a problem file, applied to its TOML text
//! before the file is checked, so that an overridden file is validated exactly like one
//! written by hand. The value is parsed as a TOML value (`0.01`, `[1.0, 0.0]`, `true`,
//! `"text"`, `{ g = 3.7 }`); anything that does not parse (a bare word) is a string. Path
//! segments are table keys, or indices into arrays (`events.0.when`). The Python package
//! calls [`apply_overrides`] too.

use super::errors::{bad, InputError};
use toml::{Table, Value};

/// One override, `key.path=value`, split into its path and its value.
#[derive(Debug, Clone, PartialEq)]
pub struct Override {
    /// The dotted key path as written.
    pub key: String,
    /// The value.
    pub value: Value,
}

impl Override {
    /// Parses `key.path=value` (the value as TOML, else as a bare string).
    ///
    /// # Errors
    /// No `=`, or an empty key or key segment.
    pub fn parse(text: &str) -> Result<Self, InputError> {
        let (key, raw) = text
            .split_once('=')
            .ok_or_else(|| bad(format!("--set '{text}': expected key.path=value")))?;
        let key = key.trim();
        if key.is_empty() || key.split('.').any(|s| s.trim().is_empty()) {
            return Err(bad(format!("--set '{text}': the key '{key}' has an empty part")));
        }
        Ok(Override {
            key: key.to_string(),
            value: parse_value(raw.trim()),
        })
    }
}

/// A TOML value, or the text itself as a string when it is not one.
fn parse_value(raw: &str) -> Value {
    format!("v = {raw}")
        .parse::<Table>()
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| Value::String(raw.to_string()))
}

/// The problem text `text` with `overrides` (each `key.path=value`) applied, as TOML text.
/// Without overrides the text is returned unchanged (so error positions refer to the file).
///
/// # Errors
/// Text that is not TOML, a malformed override, or a path through something that is not a
/// table or an array (the message names the key).
pub fn apply_overrides(text: &str, overrides: &[String]) -> Result<String, InputError> {
    if overrides.is_empty() {
        return Ok(text.to_string());
    }
    let parsed: Vec<Override> = overrides.iter().map(|o| Override::parse(o)).collect::<Result<_, _>>()?;
    let mut table: Table = text
        .parse()
        .map_err(|e: toml::de::Error| bad(format!("cannot apply --set: the problem is not TOML: {}", e.message())))?;
    for o in &parsed {
        check_parameter(&table, o)?;
        set(&mut table, o)?;
    }
    toml::to_string(&table).map_err(|e| bad(format!("cannot apply --set: {e}")))
}

/// `system.parameters.NAME=value` of an expression system must name a parameter the file
/// declares: a new one would be a constant nothing reads, and a misspelt name would leave the
/// intended parameter unchanged without a word. (A model's loader checks its own names.)
fn check_parameter(table: &Table, o: &Override) -> Result<(), InputError> {
    let parts: Vec<&str> = o.key.split('.').map(str::trim).collect();
    let ["system", "parameters", name] = parts.as_slice() else {
        return Ok(());
    };
    let system = table.get("system").and_then(Value::as_table);
    if system.is_some_and(|s| s.contains_key("model")) {
        return Ok(());
    }
    let declared = system.and_then(|s| s.get("parameters")).and_then(Value::as_table);
    if declared.is_some_and(|d| d.contains_key(*name)) {
        return Ok(());
    }
    let known: Vec<&str> = declared
        .map(|d| d.keys().map(String::as_str).collect())
        .unwrap_or_default();
    Err(bad(format!(
        "--set {}: the problem has no parameter '{name}' (it has: {})",
        o.key,
        if known.is_empty() {
            "none".to_string()
        } else {
            known.join(", ")
        }
    )))
}

/// Sets `o.key` in `table` to `o.value`, creating missing tables on the way.
fn set(table: &mut Table, o: &Override) -> Result<(), InputError> {
    let parts: Vec<&str> = o.key.split('.').map(str::trim).collect();
    let mut root = Value::Table(std::mem::take(table));
    let result = set_in(&mut root, &parts, o);
    if let Value::Table(t) = root {
        *table = t;
    }
    result
}

/// Walks `parts` from `root` and stores the value at the end.
fn set_in(root: &mut Value, parts: &[&str], o: &Override) -> Result<(), InputError> {
    let Some((last, path)) = parts.split_last() else {
        return Err(bad(format!("--set {}: empty key", o.key)));
    };
    let mut here = root;
    for (i, part) in path.iter().enumerate() {
        here = child(here, part, &parts[..i].join("."), &o.key, true)?;
    }
    *child(here, last, &path.join("."), &o.key, false)? = o.value.clone();
    Ok(())
}

/// The value under `part` of `v` (a table key, or an array index; `parent` is the path of
/// `v`), created if missing: as an empty table if `create`, else as a placeholder to be
/// overwritten.
fn child<'v>(v: &'v mut Value, part: &str, parent: &str, key: &str, create: bool) -> Result<&'v mut Value, InputError> {
    match v {
        Value::Table(t) => Ok(t.entry(part.to_string()).or_insert_with(|| {
            if create {
                Value::Table(Table::new())
            } else {
                Value::Boolean(false)
            }
        })),
        Value::Array(a) => {
            let len = a.len();
            let i: usize = part
                .parse()
                .map_err(|_| bad(format!("--set {key}: '{parent}' is an array; '{part}' is not an index")))?;
            a.get_mut(i).ok_or_else(|| {
                bad(format!(
                    "--set {key}: index {i} is past the end of '{parent}' ({len} items)"
                ))
            })
        }
        other => Err(bad(format!(
            "--set {key}: '{parent}' is a {}, not a table",
            other.type_str()
        ))),
    }
}
