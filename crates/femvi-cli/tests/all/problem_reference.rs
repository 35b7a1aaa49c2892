//! The problem-file reference (docs/src/problem-file.md, printed by `femvi schema`) against
//! the loader, in both directions: for each documented table, the keys the loader accepts
//! (read from its own refusal of an unknown key, which lists them) are exactly the keys the
//! reference documents.

use std::collections::{BTreeMap, BTreeSet};
use std::process::{Command, Stdio};

/// The reference's tables: heading (`(top level)`, `[time]`, `[[events]]`, …) → documented keys.
fn documented() -> BTreeMap<String, BTreeSet<String>> {
    let mut out = BTreeMap::<String, BTreeSet<String>>::new();
    let mut current: Option<String> = None;
    for line in femvi_cli::reference::PROBLEM_FILE.lines() {
        if let Some(h) = line.strip_prefix("## ") {
            current = Some(h.trim().to_string());
            out.entry(h.trim().to_string()).or_default();
        } else if let (Some(h), Some(row)) = (&current, line.strip_prefix("| `")) {
            let key = row.split('`').next().unwrap_or("").to_string();
            out.entry(h.clone()).or_default().insert(key);
        }
    }
    out
}

/// The keys the loader accepts in a table: it refuses `zz_unknown_key` there with serde's
/// "unknown field `zz_unknown_key`, expected one of `a`, `b`" (or "expected `a` or `b`").
fn accepted(header: &str) -> BTreeSet<String> {
    let text = format!("{header}\nzz_unknown_key = 1\n");
    let mut child = Command::new(env!("CARGO_BIN_EXE_femvi"))
        .args(["check", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("femvi runs");
    std::io::Write::write_all(&mut child.stdin.take().expect("stdin"), text.as_bytes()).expect("write");
    let o = child.wait_with_output().expect("wait");
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    let tail = err
        .split("unknown field `zz_unknown_key`, expected")
        .nth(1)
        .unwrap_or_else(|| panic!("{header}: no list of keys in {err}"));
    let tail = tail.lines().next().unwrap_or("");
    tail.split('`').skip(1).step_by(2).map(str::to_string).collect()
}

#[test]
fn every_accepted_key_is_documented_and_every_documented_key_is_accepted() {
    let doc = documented();
    let top = doc.get("(top level)").expect("a (top level) section");
    assert_eq!(top, &accepted(""), "top-level keys");
    let mut tables = 0;
    for (heading, keys) in &doc {
        if heading == "(top level)" || heading == "[system.parameters]" {
            continue;
        }
        assert_eq!(keys, &accepted(heading), "keys of {heading}");
        tables += 1;
    }
    // Every table of the file's top level (all but `name`) has its section.
    for key in top.iter().filter(|k| *k != "name") {
        assert!(
            doc.contains_key(&format!("[{key}]")) || doc.contains_key(&format!("[[{key}]]")),
            "no section for [{key}]"
        );
    }
    assert!(tables >= 11, "{tables} tables");
}

#[test]
fn femvi_schema_prints_the_reference() {
    let o = Command::new(env!("CARGO_BIN_EXE_femvi"))
        .arg("schema")
        .output()
        .expect("femvi schema");
    assert!(o.status.success());
    assert_eq!(String::from_utf8_lossy(&o.stdout), femvi_cli::reference::PROBLEM_FILE);
}
