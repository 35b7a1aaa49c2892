//! Error messages about a problem file: [`InputError`] (a complete message), [`Source`] (the
//! file's name and text, which every table's check uses to name the file or point at a line
//! and column), and the "did you mean" hints for misspelt keys, values and model names.

use std::path::Path;

/// A bad problem file: the message is complete (file, position, excerpt).
#[derive(Debug)]
pub struct InputError(pub String);

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// An [`InputError`] with this message as it stands.
pub fn bad(msg: impl Into<String>) -> InputError {
    InputError(msg.into())
}

/// The problem file being read: its path and text, for messages that name it.
#[derive(Clone, Copy)]
pub struct Source<'a> {
    /// The file as given on the command line.
    pub path: &'a Path,
    /// Its contents.
    pub text: &'a str,
}

impl Source<'_> {
    /// "FILE: msg".
    pub fn error(&self, msg: impl std::fmt::Display) -> InputError {
        bad(format!("{}: {msg}", self.path.display()))
    }

    /// "FILE:LINE:COL: msg" with the line's text and a caret under byte `offset`.
    pub fn excerpt(&self, offset: usize, msg: &str) -> String {
        let (line, col, src) = locate(self.text, offset);
        format!(
            "{}:{line}:{col}: {msg}\n  {src}\n  {}^",
            self.path.display(),
            " ".repeat(col - 1)
        )
    }
}

/// Line and column (1-based) of a byte offset, and the line's text.
fn locate(text: &str, offset: usize) -> (usize, usize, String) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let start = before.rfind('\n').map_or(0, |i| i + 1);
    let col = text[start..offset].chars().count() + 1;
    let src = text[start..].lines().next().unwrap_or("").to_string();
    (line, col, src)
}

/// serde's "unknown field `x`, expected one of `a`, `b`" (or "unknown variant …") with a
/// "did you mean" for the closest expected name.
pub fn with_suggestion(msg: &str) -> String {
    let unknown = ["unknown field `", "unknown variant `"]
        .iter()
        .find_map(|p| msg.strip_prefix(p));
    let Some(rest) = unknown else { return msg.to_string() };
    let Some((word, tail)) = rest.split_once('`') else {
        return msg.to_string();
    };
    let expected: Vec<&str> = tail.split('`').skip(1).step_by(2).collect();
    let hint = did_you_mean(word, &expected);
    if hint.is_empty() {
        msg.to_string()
    } else {
        format!("{msg}{hint}")
    }
}

/// " (did you mean 'x'?)" for the closest name within edit distance 2, else "".
pub fn did_you_mean(word: &str, names: &[&str]) -> String {
    let best = names.iter().map(|n| (strsim(word, n), n)).min_by_key(|(d, _)| *d);
    match best {
        Some((d, n)) if d <= 2 => format!(" (did you mean '{n}'?)"),
        _ => String::new(),
    }
}

/// Levenshtein distance (small strings).
fn strsim(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != *cb)).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}
