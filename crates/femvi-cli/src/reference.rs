//! The problem-file reference (`femvi schema`): the guide's chapter docs/src/problem-file.md,
//! built into the binary. A test (`tests/all/problem_reference.rs`) checks it against the
//! loader in both directions: every key the loader accepts is documented, and every documented
//! key is accepted.

/// The reference as Markdown: one `## [table]` heading per table (`## (top level)` for the
/// file's own keys), each followed by a table whose first column is the key in backticks.
///
/// ```
/// assert!(femvi_cli::reference::PROBLEM_FILE.contains("## [time]"));
/// ```
pub const PROBLEM_FILE: &str = include_str!("../../../docs/src/problem-file.md");
