//! Problem-file fuzzing of the `[constraints]` and `[forces]` tables (issue 34): the bundled
//! constrained and forced examples (examples/constrained, examples/forces), mutated by the
//! mutator of `fuzz_problems` and by mutations aimed at those tables (constraints and forces
//! that are not finite, overflow, refer to unknown names or are of the wrong shape, starts
//! off or far off the manifold), run through the `femvi` binary (`femvi run` or `femvi bvp`,
//! as the file asks), each with a 20 s limit. No case may panic, be killed by a signal or hang;
//! every refusal must be an exit code of the command (0, 1, 2 or 3).
//!
//! The CI run takes `FEMVI_FUZZ_TERM_CASES` cases (120 by default); a long one:
//! `FEMVI_FUZZ_TERM_CASES=3000 cargo test --release -p femvi-cli --test all -- fuzz_terms::`.

use super::fuzz_problems::{mutate, set_in_table, Rng};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The constrained and forced examples (name, text).
fn seeds() -> Vec<(String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut files: Vec<PathBuf> = vec![];
    for dir in [root.join("constrained"), root.join("forces")] {
        for entry in std::fs::read_dir(dir).expect("examples") {
            let path = entry.expect("entry").path();
            if path.extension().is_some_and(|e| e == "toml") {
                files.push(path);
            }
        }
    }
    files.sort();
    assert!(files.len() >= 8, "the constrained and forced examples are missing");
    files
        .into_iter()
        .map(|p| (p.display().to_string(), std::fs::read_to_string(&p).expect("example")))
        .collect()
}

/// Values for the terms' keys at or past their limits.
const TERMS: &[(&str, &str)] = &[
    ("[constraints]", "holonomic = [\"1e308*x1^2 + 1e308*y1^2\"]"),
    ("[constraints]", "holonomic = [\"sqrt(-1 - x1^2)\"]"),
    ("[constraints]", "holonomic = [\"x1/0\"]"),
    ("[constraints]", "holonomic = [\"nope(x1)\"]"),
    ("[constraints]", "holonomic = [\"zz\"]"),
    ("[constraints]", "holonomic = []"),
    (
        "[constraints]",
        "holonomic = [\"x1\", \"x1\", \"x1\", \"x1\", \"x1\", \"x1\"]",
    ),
    ("[constraints]", "holonomic = [\"0\"]"),
    (
        "[constraints]",
        "holonomic = [\"x^2 + y^2 + z^2 - 1\", \"x^2 + y^2 + z^2 - 1\"]",
    ),
    ("[constraints]", "enforcement = \"nowhere\""),
    ("[constraints]", "enforcement = \"strong\""),
    ("[forces]", "generalized = [\"1e308*x_dot^9\"]"),
    ("[forces]", "generalized = [\"nan\"]"),
    ("[forces]", "generalized = [\"0/0\", \"1\", \"2\", \"3\"]"),
    ("[forces]", "generalized = []"),
    ("[forces]", "generalized = [\"log(-x_dot^2 - 1)\"]"),
    ("[forces]", "dissipation = \"1e308*x_dot^4\""),
    ("[forces]", "dissipation = \"-x_dot^2\""),
    ("[forces]", "dissipation = \"sqrt(x)\""),
    ("[forces]", "dissipation = \"\""),
    (
        "[initial]",
        "q = [0.8414709848078965, -0.5403023058681398, 1.3208965234120995, -1e308]",
    ),
    ("[initial]", "q = [nan, 0.0, 0.0, 0.0]"),
    ("[initial]", "v = [1e308, 1e308, 1e308, 1e308]"),
    ("[initial]", "p = [inf, 0.0, 0.0]"),
    ("[scheme]", "degree = 7"),
    ("[scheme]", "method = \"fixed-point\""),
    ("[time]", "mode = \"adaptive\""),
    ("[time]", "end = 1e12"),
    ("[boundary]", "guess = \"/dev/zero\""),
];

/// One mutation: a term's key set to an extreme (as `fuzz_problems`' extremes: the key removed
/// first, then set in its table), or one of the general mutations.
fn mutate_terms(text: &str, rng: &mut Rng) -> String {
    if rng.below(2) == 0 {
        return mutate(text, rng);
    }
    let (table, line) = *rng.pick::<(&str, &str)>(TERMS);
    set_in_table(text, table, line)
}

fn cases() -> u64 {
    std::env::var("FEMVI_FUZZ_TERM_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(120)
}

/// CPU time (user + system, clock ticks) of process `pid`, from /proc.
fn cpu_ticks(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // Fields after the command name (which may hold spaces) in parentheses: utime is the
    // 14th field of the line, stime the 15th.
    let rest = stat.rsplit_once(')')?.1;
    let fields: Vec<&str> = rest.split_whitespace().collect();
    Some(fields.get(11)?.parse::<u64>().ok()? + fields.get(12)?.parse::<u64>().ok()?)
}

/// How a case ended when it was still running at the limit.
#[derive(Debug, Clone, Copy, PartialEq)]
enum AtLimit {
    /// It finished before the limit.
    No,
    /// Still computing (its CPU time grew over the last half second): a long run.
    Computing,
    /// Not computing: a hang (blocked, or spinning without making system progress is not
    /// distinguished from computing, but a process blocked on a read or a lock is).
    Idle,
}

/// Runs the binary on `file`, killed after `limit`; the exit code (None if killed by a signal
/// or at the limit), stderr and whether (and how) it was still running at the limit.
fn run(file: &Path, out: &Path, limit: Duration) -> (Option<i32>, String, AtLimit) {
    let text = std::fs::read_to_string(file).unwrap_or_default();
    let command = if text.contains("[boundary]") { "bvp" } else { "run" };
    let mut child = Command::new(env!("CARGO_BIN_EXE_femvi"))
        .args([
            command,
            &file.display().to_string(),
            "--quiet",
            "--out",
            &out.display().to_string(),
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("femvi runs");
    let began = Instant::now();
    let mut stderr = child.stderr.take().expect("stderr");
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut stderr, &mut s);
        s
    });
    loop {
        if let Some(status) = child.try_wait().expect("wait") {
            return (status.code(), reader.join().unwrap_or_default(), AtLimit::No);
        }
        if began.elapsed() > limit {
            let before = cpu_ticks(child.id());
            std::thread::sleep(Duration::from_millis(500));
            let after = cpu_ticks(child.id());
            let how = match (before, after) {
                (Some(a), Some(b)) if b > a => AtLimit::Computing,
                _ => AtLimit::Idle,
            };
            let _ = child.kill();
            let _ = child.wait();
            return (None, reader.join().unwrap_or_default(), how);
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn mutated_constrained_and_forced_files_never_panic() {
    let seeds = seeds();
    let seed: u64 = std::env::var("FEMVI_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    let dir = tempfile::tempdir().expect("temp dir");
    let mut codes = std::collections::BTreeMap::<String, usize>::new();
    for k in 0..cases() {
        let mut rng = Rng(k.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ seed.wrapping_mul(0x2545_F491) ^ 0x7E57);
        let (name, mut text): (String, String) = rng.pick(&seeds[..]).clone();
        for _ in 0..=rng.below(2) {
            text = mutate_terms(&text, &mut rng);
        }
        let file = dir.path().join(format!("{k:05}.toml"));
        std::fs::write(&file, &text).expect("write case");
        let out = dir.path().join("out");
        let _ = std::fs::remove_dir_all(&out);
        let (code, stderr, at_limit) = run(&file, &out, Duration::from_secs(20));
        assert!(
            !stderr.contains("panicked at"),
            "case {k} (from {name}) panicked:\n{text}\n{stderr}"
        );
        // A long run is not a hang: the limit only cuts it. Runs with [constraints] or
        // [forces] write their rows when they end (issue 33), so a run still computing at the
        // limit counts as a long run even without rows; one that is not computing is a hang.
        assert!(
            at_limit != AtLimit::Idle,
            "case {k} (from {name}) hung: not computing after 20 s:\n{text}"
        );
        let timed_out = at_limit == AtLimit::Computing;
        let label = match code {
            Some(c) => {
                assert!(
                    (0..=3).contains(&c) || c == 130,
                    "case {k} (from {name}): exit {c}\n{text}\n{stderr}"
                );
                format!("exit {c}")
            }
            None if timed_out => "long run".to_string(),
            None => panic!("case {k} (from {name}) was killed by a signal:\n{text}\n{stderr}"),
        };
        *codes.entry(label).or_default() += 1;
    }
    eprintln!("{} cases of constrained and forced files: {codes:?}", cases());
    // Some mutated problems still run, and some are refused.
    assert!(codes.get("exit 0").copied().unwrap_or(0) > 0, "{codes:?}");
    assert!(codes.get("exit 2").copied().unwrap_or(0) > 0, "{codes:?}");
}
