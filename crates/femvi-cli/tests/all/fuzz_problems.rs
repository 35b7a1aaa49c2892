//! Problem-file fuzzing: the bundled example problems (examples/ and examples/models/),
//! mutated — byte flips, truncations, numbers made huge, tiny, zero, negative, NaN or
//! infinite, deep nesting, values of the wrong type, tables removed, unknown keys, lines
//! duplicated or dropped, long expressions — are loaded by the real loader and, when they
//! load, run for a few steps in process. No case may panic or hang; any error must be typed.
//!
//! The CI run takes `FEMVI_FUZZ_CASES` cases (300 by default, a few seconds; `FEMVI_FUZZ_SEED`
//! picks another series); a long run:
//! `FEMVI_FUZZ_CASES=20000 cargo test --release -p femvi-cli --test all -- fuzz_problems::`.
//! With `FEMVI_FUZZ_WRITE=DIR` the `write_cases` test (ignored by default) writes the mutated
//! files instead, for `scripts/fuzz-problems.sh`, which runs them through the `femvi` binary.

use femvi::{Integrator, Lagrangian};
use femvi_cli::problem::{load_text, Problem};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// A small deterministic generator (SplitMix64), so that every case can be replayed by seed.
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub(crate) fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    pub(crate) fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

/// The bundled problem files (name, text).
fn seeds() -> Vec<(String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut files: Vec<PathBuf> = vec![];
    for dir in [root.clone(), root.join("models")] {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                files.push(path);
            }
        }
    }
    files.sort();
    assert!(files.len() >= 10, "the examples are missing");
    files
        .into_iter()
        .map(|p| (p.display().to_string(), std::fs::read_to_string(&p).unwrap()))
        .collect()
}

const NUMBERS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e-308",
    "5e-324",
    "0",
    "-0.0",
    "-1",
    "1e12",
    "1e17",
    "1e-12",
    "18446744073709551615",
    "9223372036854775807",
    "-9223372036854775808",
    "100000",
    "1000000000",
    "0.5",
    "2.5",
];

const VALUES: &[&str] = &[
    "\"text\"",
    "true",
    "[]",
    "[1, 2, 3]",
    "{}",
    "{ a = 1 }",
    "1979-05-27T07:32:00Z",
    "[[1.0], [2.0]]",
    "\"\"",
    "\"/dev/zero\"",
    "\"x^x^x^x^x^x^x^x^x^x\"",
    "\"sin(\"",
    "[nan, inf]",
];

/// Known keys with values at or past their limits, each with its table.
const EXTREMES: &[(&str, &str)] = &[
    ("[system]", "model = \"fpu\"\nparameters = { n = 100000 }"),
    (
        "[system]",
        "model = \"n-body\"\nparameters = { bodies = 10000, dim = 3 }",
    ),
    ("[system]", "model = \"fpu\"\nparameters = { n = 3000 }"),
    ("[scheme]", "degree = 64"),
    ("[scheme]", "degree = 1000"),
    ("[scheme]", "order = 200"),
    ("[scheme]", "quadrature = \"gauss-legendre\"\npoints = 1000"),
    ("[scheme]", "method = \"newton\""),
    ("[scheme]", "method = \"explicit\""),
    ("[solver]", "method = \"newton\""),
    ("[solver]", "max_iterations = 1000000000"),
    ("[solver]", "tolerance = 0.0"),
    ("[time]", "end = 1e12"),
    ("[time]", "t0 = 1e17"),
    ("[time]", "step = 1e-9"),
    ("[time]", "steps = [1e-300, 1.0]"),
    ("[time]", "mode = \"energy\""),
    ("[time]", "accuracy = 1e-300"),
    ("[output]", "every = 0"),
    ("[output]", "every = 18446744073709551615"),
    ("[output]", "plots = true"),
    ("[output]", "directory = \"/dev/null/x\""),
    ("[initial]", "q = [1e308]"),
    ("[boundary]", "elements = 1000000000"),
    ("[boundary]", "guess = \"/dev/zero\""),
];

const KEYS: &[&str] = &[
    "steps",
    "step",
    "end",
    "t0",
    "order",
    "degree",
    "quadrature",
    "nodes",
    "every",
    "mode",
    "method",
    "tolerance",
    "max_iterations",
    "accuracy",
    "q",
    "v",
    "p",
    "q0",
    "q1",
    "model",
    "lagrangian",
    "coordinates",
    "parameters",
    "n",
    "bodies",
    "dim",
    "elements",
    "guess",
    "directory",
    "plots",
    "format",
    "stop",
    "condition",
    "direction",
    "zzz_unknown",
];

/// Byte offsets of the numbers in `text` (runs of digits, signs, dots and exponents).
fn numbers(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut out = vec![];
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_digit() && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_')) {
            let start = if i > 0 && b[i - 1] == b'-' { i - 1 } else { i };
            let mut j = i;
            while j < b.len() && (b[j].is_ascii_digit() || b"._eE+-".contains(&b[j])) {
                j += 1;
            }
            out.push((start, j));
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

/// Splices `text[..a] + new + text[b..]`, keeping valid UTF-8 at the cut points.
fn splice(text: &str, a: usize, b: usize, new: &str) -> String {
    let floor = |mut i: usize| {
        i = i.min(text.len());
        while !text.is_char_boundary(i) {
            i -= 1;
        }
        i
    };
    let (a, b) = (floor(a), floor(b.max(a)));
    format!("{}{new}{}", &text[..a], &text[b..])
}

/// `text` with the keys of `line` (one `key = value` per line) set in `table`: those keys are
/// removed from the file first (a key twice is only a TOML error), then `line` goes right
/// after the table's header, or at the end under a new header.
pub(crate) fn set_in_table(text: &str, table: &str, line: &str) -> String {
    let keys: Vec<&str> = line
        .lines()
        .filter_map(|l| l.split('=').next())
        .map(str::trim)
        .collect();
    let mut out: Vec<String> = text
        .lines()
        .filter(|l| !keys.contains(&l.split('=').next().unwrap_or("").trim()))
        .map(|l| l.to_string())
        .collect();
    match out.iter().position(|l| l.trim() == table) {
        Some(i) => out.insert(i + 1, line.to_string()),
        None => out.push(format!("{table}\n{line}")),
    }
    out.join("\n")
}

/// One mutation of `text`.
pub(crate) fn mutate(text: &str, rng: &mut Rng) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let at_line = |rng: &mut Rng| rng.below(lines.len() + 1);
    match rng.below(14) {
        // A known key set, in its own table, to a value at or past its documented limits.
        12 | 13 => {
            let (table, line) = *rng.pick::<(&str, &str)>(EXTREMES);
            set_in_table(text, table, line)
        }
        // Flip bits of a few bytes (the result may not be UTF-8: lossy).
        0 => {
            let mut bytes = text.as_bytes().to_vec();
            for _ in 0..=rng.below(4) {
                if bytes.is_empty() {
                    break;
                }
                let i = rng.below(bytes.len());
                bytes[i] ^= 1 << rng.below(8);
            }
            String::from_utf8_lossy(&bytes).into_owned()
        }
        // Truncate.
        1 => splice(text, rng.below(text.len() + 1), text.len(), ""),
        // A number replaced by an extreme one.
        2 | 3 => {
            let nums = numbers(text);
            if nums.is_empty() {
                return text.to_string();
            }
            let (a, b) = *rng.pick(&nums);
            splice(text, a, b, rng.pick::<&str>(NUMBERS))
        }
        // A value replaced by one of another type.
        4 => {
            let i = rng.below(lines.len());
            match lines.get(i).and_then(|l| l.split_once('=')) {
                Some((k, _)) => {
                    let mut out: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
                    out[i] = format!("{k}= {}", *rng.pick::<&str>(VALUES));
                    out.join("\n")
                }
                None => text.to_string(),
            }
        }
        // A table removed (from its header to the next).
        5 => {
            let heads: Vec<usize> = (0..lines.len()).filter(|&i| lines[i].starts_with('[')).collect();
            if heads.is_empty() {
                return text.to_string();
            }
            let h = *rng.pick(&heads);
            let end = (h + 1..lines.len())
                .find(|&i| lines[i].starts_with('['))
                .unwrap_or(lines.len());
            let mut out: Vec<&str> = lines[..h].to_vec();
            out.extend_from_slice(&lines[end..]);
            out.join("\n")
        }
        // A key (known to some table, or unknown) with an extreme value, anywhere.
        6 | 7 => {
            let key = *rng.pick::<&str>(KEYS);
            let value = if rng.below(2) == 0 {
                *rng.pick::<&str>(NUMBERS)
            } else {
                *rng.pick::<&str>(VALUES)
            };
            let mut out: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
            out.insert(at_line(rng), format!("{key} = {value}"));
            out.join("\n")
        }
        // Deep nesting: arrays, inline tables or parentheses in an expression.
        8 => {
            let depth = *rng.pick(&[64usize, 1000, 20_000]);
            let nested = match rng.below(3) {
                0 => format!("deep = {}1{}", "[".repeat(depth), "]".repeat(depth)),
                1 => format!("deep = {}1{}", "{ a = ".repeat(depth), " }".repeat(depth)),
                _ => format!("lagrangian = \"{}x{}\"", "(".repeat(depth), ")".repeat(depth)),
            };
            let mut out: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
            out.insert(at_line(rng), nested);
            out.join("\n")
        }
        // A line duplicated or dropped.
        9 => {
            let mut out: Vec<&str> = lines.clone();
            if out.is_empty() {
                return String::new();
            }
            let i = rng.below(out.len());
            if rng.below(2) == 0 {
                out.insert(i, lines[i]);
            } else {
                out.remove(i);
            }
            out.join("\n")
        }
        // A long or odd expression as the Lagrangian.
        10 => {
            let terms = *rng.pick(&[10usize, 5000, 30_000]);
            let expr = match rng.below(3) {
                0 => vec!["x_dot^2"; terms].join(" + "),
                1 => format!("{}x", "-".repeat(terms)),
                _ => format!("{}1", "exp(".repeat(terms.min(2000))) + &")".repeat(terms.min(2000)),
            };
            let mut out: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
            out.insert(at_line(rng), format!("lagrangian = \"{expr}\""));
            out.join("\n")
        }
        // Random bytes inserted.
        _ => {
            let junk: String = (0..=rng.below(8))
                .map(|_| {
                    *rng.pick(&[
                        '"', '[', ']', '{', '}', '=', '\n', '#', '\\', '.', ',', 'e', '-', '\u{0}', 'é',
                    ])
                })
                .collect();
            let i = rng.below(text.len() + 1);
            splice(text, i, i, &junk)
        }
    }
}

/// Case `k`: a seed file with one to three mutations.
fn case(seeds: &[(String, String)], k: u64) -> (String, String) {
    let seed: u64 = std::env::var("FEMVI_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    let mut rng = Rng(k.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ seed.wrapping_mul(0x9E37_79B9) ^ 0x5EED);
    let (name, text) = rng.pick(seeds).clone();
    let mut text = text;
    for _ in 0..=rng.below(3) {
        text = mutate(&text, &mut rng);
    }
    (name, text)
}

/// Loads the text and, if it loads, takes up to 20 steps (or 0.5 s of them).
fn exercise(text: &str) -> String {
    let problem: Problem = match load_text(Path::new("fuzz.toml"), text, &[]) {
        Ok(p) => p,
        Err(e) => return format!("rejected: {e}"),
    };
    femvi_cli::with_system!(&problem.system, l => steps(l, &problem))
}

fn steps<L: Lagrangian>(lag: &L, problem: &Problem) -> String {
    let (grid, start, el, opts) = (
        problem.grid.clone(),
        problem.start.clone(),
        &problem.element,
        problem.options,
    );
    let it = match problem.energy {
        None => Integrator::new(lag, el, grid, start, opts),
        Some(e) => Integrator::with_energy(lag, el, grid, start, opts, e),
    };
    let mut it = match it {
        Ok(it) => it,
        Err(e) => return format!("set-up error: {e}"),
    };
    let began = Instant::now();
    for _ in 0..20 {
        match it.step() {
            Ok(true) if began.elapsed() < Duration::from_millis(500) => {}
            Ok(_) => break,
            Err(e) => return format!("step error: {e}"),
        }
    }
    format!("ran to t = {}", it.node().t)
}

fn cases() -> u64 {
    std::env::var("FEMVI_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(300)
}

/// Every case loads (or is rejected) and runs a few steps without a panic, each within 60 s
/// (a load may legitimately take seconds: `[time] accuracy` runs pilots, and a file may ask
/// for 1000 quadrature points; cases over 2 s are listed).
#[test]
fn mutated_problem_files_never_panic_or_hang() {
    let seeds = seeds();
    let mut outcomes = std::collections::BTreeMap::<String, usize>::new();
    let mut slow = vec![];
    for k in 0..cases() {
        let began = Instant::now();
        let (name, text) = case(&seeds, k);
        // A thread per case with the main thread's stack size: a panic or a hang is reported
        // with the case that caused it.
        let (tx, rx) = std::sync::mpsc::channel();
        let handle = std::thread::Builder::new()
            .stack_size(8 << 20)
            .spawn(move || {
                let _ = tx.send(exercise(&text));
            })
            .unwrap();
        match rx.recv_timeout(Duration::from_secs(60)) {
            Ok(outcome) => {
                let kind = outcome
                    .split(':')
                    .next()
                    .unwrap_or("")
                    .split(" t =")
                    .next()
                    .unwrap_or("")
                    .to_string();
                *outcomes.entry(kind).or_default() += 1;
            }
            Err(_) => panic!("case {k} (from {name}) panicked or did not finish within 60 s"),
        }
        handle
            .join()
            .unwrap_or_else(|_| panic!("case {k} (from {name}) panicked"));
        if began.elapsed() > Duration::from_secs(2) {
            slow.push((k, began.elapsed().as_secs_f64()));
        }
    }
    eprintln!("{} cases: {outcomes:?}; over 2 s (case, s): {slow:?}", cases());
    // The mutations do not all break the file: some problems still load and run.
    assert!(outcomes.get("ran to").copied().unwrap_or(0) > 0, "{outcomes:?}");
    assert!(outcomes.get("rejected").copied().unwrap_or(0) > 0, "{outcomes:?}");
}

/// Writes the cases as files 00000.toml, 00001.toml, … into `FEMVI_FUZZ_WRITE` (for
/// scripts/fuzz-problems.sh).
#[test]
#[ignore]
fn write_cases() {
    let Ok(dir) = std::env::var("FEMVI_FUZZ_WRITE") else {
        return;
    };
    std::fs::create_dir_all(&dir).unwrap();
    let seeds = seeds();
    for k in 0..cases() {
        let (_, text) = case(&seeds, k);
        std::fs::write(Path::new(&dir).join(format!("{k:05}.toml")), text).unwrap();
    }
}
