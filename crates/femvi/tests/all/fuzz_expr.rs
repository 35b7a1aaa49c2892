//! Property tests of the expression parser and compiler (`femvi::expr`): random strings never
//! panic, and random well-formed expressions — trees over every operator and function with
//! numbers from 5e-324 to f64::MAX, nesting up to and past `MAX_NESTING`, sums and products of
//! up to 20 000 terms — compile and evaluate to what the reference evaluator written here
//! computes (within relative 1e-12, or both NaN).
//!
//! The reference follows the documented folding rules (`expr/compile.rs`): `a ^ b` of two
//! constants is `powf`; a constant exponent (`x ^ 3`, `pow(x, 3)`) is `powi` for integers up
//! to 64 in magnitude and `powf` otherwise; everything else is evaluated as written.
//!
//! Cases per property: `PROPTEST_CASES` (default 256: a few seconds); the long sums and the
//! deep nesting run at most 2 000 and 20 000 cases. A campaign:
//! `PROPTEST_CASES=1000000 cargo test -p femvi --test all -- fuzz_expr:: --nocapture` prints the
//! count of each outcome.

use femvi::expr::{ExprLagrangian, MAX_NESTING};
use femvi::lagrangian::PointDerivatives;
use femvi::Lagrangian;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

const F1: &[&str] = &[
    "sin", "cos", "tan", "exp", "ln", "log", "sqrt", "abs", "sinh", "cosh", "tanh", "asin", "acos", "atan",
];
const F2: &[&str] = &["atan2", "pow", "min", "max"];

fn runner(most: u32) -> TestRunner {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(256u32);
    TestRunner::new(Config {
        cases: cases.min(most),
        failure_persistence: None,
        ..Config::default()
    })
}

/// A well-formed expression: t, x, x_dot are variables 0, 1, 2; a, b the parameters.
#[derive(Debug, Clone)]
enum E {
    Num(f64),
    Var(usize),
    Param(usize),
    Pi,
    Neg(Box<E>),
    Bin(char, Box<E>, Box<E>),
    Call1(&'static str, Box<E>),
    Call2(&'static str, Box<E>, Box<E>),
    Paren(Box<E>),
}

/// Non-negative finite numbers (a sign is a `Neg`), from 5e-324 to f64::MAX.
fn number() -> impl Strategy<Value = f64> {
    prop_oneof![
        (0u32..10).prop_map(f64::from),
        0.0..10.0f64,
        (-320i32..309)
            .prop_map(|e| 10f64.powi(e))
            .prop_filter("finite", |v| v.is_finite()),
        any::<f64>().prop_map(f64::abs).prop_filter("finite", |v| v.is_finite()),
        Just(f64::MAX),
        Just(5e-324),
        (-70i32..70).prop_map(f64::from).prop_map(f64::abs),
    ]
}

fn leaf() -> impl Strategy<Value = E> {
    prop_oneof![
        3 => number().prop_map(E::Num),
        3 => (0..3usize).prop_map(E::Var),
        1 => (0..2usize).prop_map(E::Param),
        1 => Just(E::Pi),
    ]
}

fn tree() -> impl Strategy<Value = E> {
    leaf().prop_recursive(8, 64, 2, |inner| {
        let b = |e: E| Box::new(e);
        prop_oneof![
            inner.clone().prop_map(move |a| E::Neg(b(a))),
            (
                prop::sample::select(vec!['+', '-', '*', '/', '^']),
                inner.clone(),
                inner.clone()
            )
                .prop_map(move |(op, x, y)| E::Bin(op, b(x), b(y))),
            (prop::sample::select(F1), inner.clone()).prop_map(move |(f, a)| E::Call1(f, b(a))),
            (prop::sample::select(F2), inner.clone(), inner.clone()).prop_map(move |(f, x, y)| E::Call2(f, b(x), b(y))),
            inner.prop_map(move |a| E::Paren(b(a))),
        ]
    })
}

/// Binding strength: + - 1, * / 2, unary minus 3, ^ 4, atoms 5.
fn prec(e: &E) -> u8 {
    match e {
        E::Bin('+' | '-', ..) => 1,
        E::Bin('*' | '/', ..) => 2,
        E::Neg(_) => 3,
        E::Bin(..) => 4,
        _ => 5,
    }
}

fn wrap(e: &E, parens: bool) -> String {
    if parens {
        format!("({})", render(e))
    } else {
        render(e)
    }
}

/// The expression as text with the parentheses its structure needs (and no others).
fn render(e: &E) -> String {
    match e {
        E::Num(v) if v.to_bits() % 2 == 0 => format!("{v:e}"),
        E::Num(v) => format!("{v}"),
        E::Var(i) => ["t", "x", "x_dot"][*i].to_string(),
        E::Param(i) => ["a", "b"][*i].to_string(),
        E::Pi => "pi".to_string(),
        E::Neg(a) => format!("-{}", wrap(a, prec(a) < 3)),
        E::Bin('^', a, b) => format!("{}^{}", wrap(a, prec(a) < 5), wrap(b, prec(b) < 3)),
        E::Bin(op, a, b) => {
            let p = prec(e);
            format!("{} {op} {}", wrap(a, prec(a) < p), wrap(b, prec(b) <= p))
        }
        E::Call1(f, a) => format!("{f}({})", render(a)),
        E::Call2(f, a, b) => format!("{f}({}, {})", render(a), render(b)),
        E::Paren(a) => format!("({})", render(a)),
    }
}

/// A power with a constant exponent, as the compiler folds it.
fn pow_const(x: f64, e: f64) -> f64 {
    if e.fract() == 0.0 && e.abs() <= 64.0 {
        x.powi(e as i32)
    } else {
        x.powf(e)
    }
}

/// a op b, where `konst` says whether both operands are constants.
fn binary(op: char, (x, cx): (f64, bool), (y, cy): (f64, bool)) -> (f64, bool) {
    let v = match op {
        '+' => x + y,
        '-' => x - y,
        '*' => x * y,
        '/' => x / y,
        _ if cx && cy => x.powf(y),
        _ if cy => pow_const(x, y),
        _ => x.powf(y),
    };
    (v, cx && cy)
}

fn call1(f: &str, x: f64) -> f64 {
    match f {
        "sin" => x.sin(),
        "cos" => x.cos(),
        "tan" => x.tan(),
        "exp" => x.exp(),
        "ln" | "log" => x.ln(),
        "sqrt" => x.sqrt(),
        "abs" => x.abs(),
        "sinh" => x.sinh(),
        "cosh" => x.cosh(),
        "tanh" => x.tanh(),
        "asin" => x.asin(),
        "acos" => x.acos(),
        _ => x.atan(),
    }
}

/// The reference value and whether the subexpression is a constant (no variable in it).
fn reference(e: &E, var: &[f64; 3], par: &[f64; 2]) -> (f64, bool) {
    match e {
        E::Num(v) => (*v, true),
        E::Var(i) => (var[*i], false),
        E::Param(i) => (par[*i], true),
        E::Pi => (std::f64::consts::PI, true),
        E::Neg(a) => {
            let (v, c) = reference(a, var, par);
            (-v, c)
        }
        E::Paren(a) => reference(a, var, par),
        E::Bin(op, a, b) => binary(*op, reference(a, var, par), reference(b, var, par)),
        E::Call1(f, a) => {
            let (v, c) = reference(a, var, par);
            (call1(f, v), c)
        }
        E::Call2(f, a, b) => {
            let ((x, cx), (y, cy)) = (reference(a, var, par), reference(b, var, par));
            let v = match *f {
                "pow" if cy => pow_const(x, y),
                "pow" => x.powf(y),
                "atan2" => x.atan2(y),
                "min" if y < x => y,
                "max" if y > x => y,
                _ => x,
            };
            (v, cx && cy)
        }
    }
}

fn close(got: f64, want: f64) -> bool {
    (got.is_nan() && want.is_nan()) || got == want || (got - want).abs() <= 1e-12 * got.abs().max(want.abs())
}

fn compile(src: &str, par: &[f64; 2]) -> Result<ExprLagrangian, femvi::expr::ExprError> {
    let params = [("a".to_string(), par[0]), ("b".to_string(), par[1])];
    ExprLagrangian::new(src, &["x".to_string()], &params)
}

fn point() -> impl Strategy<Value = f64> {
    prop_oneof![4 => -10.0..10.0f64, 1 => Just(0.0), 1 => any::<f64>()]
}

/// Counts of outcomes, printed at the end of a property.
#[derive(Default)]
struct Tally {
    parsed: usize,
    rejected: usize,
}

impl Tally {
    fn report(&self, name: &str, clock: std::time::Instant) {
        eprintln!(
            "{name}: {} parsed ok, {} rejected with an error, 0 panics ({:.1} s)",
            self.parsed,
            self.rejected,
            clock.elapsed().as_secs_f64()
        );
    }
}

#[test]
fn random_strings_never_panic() {
    const PIECES: &[&str] = &[
        "x", "x_dot", "t", "a", "b", "pi", "sin", "pow", "atan2", "min", "ln", "foo", "(", ")", ",", "+", "-", "*",
        "/", "^", " ", "\n", "1", "2.5", "1e300", "1e-320", ".5", "e", "E", "_", "1.2.3", "9e9999", "é", "∞", "$",
        "((((", "))))", "^-", "--",
    ];
    let piece = || {
        prop_oneof![
            4 => prop::sample::select(PIECES).prop_map(str::to_string),
            1 => any::<char>().prop_map(String::from),
        ]
    };
    // Pieces at random, or a well-formed expression with a few pieces cut out or put in.
    let edit = (any::<prop::sample::Index>(), 0..3usize, prop::option::of(piece()));
    let mutated = (tree(), prop::collection::vec(edit, 0..3)).prop_map(|(e, edits)| {
        let mut chars: Vec<String> = render(&e).chars().map(String::from).collect();
        for (at, len, p) in edits {
            let i = at.index(chars.len() + 1);
            chars.drain(i..(i + len).min(chars.len()));
            if let Some(p) = p {
                chars.insert(i.min(chars.len()), p);
            }
        }
        chars
    });
    let pieces = prop_oneof![prop::collection::vec(piece(), 0..40), mutated];
    let strategy = (pieces, point(), point());
    let (clock, tally) = (std::time::Instant::now(), std::cell::RefCell::new(Tally::default()));
    runner(u32::MAX)
        .run(&strategy, |(pieces, x, v)| {
            let src = pieces.concat();
            match compile(&src, &[1.5, -2.0]) {
                Ok(lag) => {
                    tally.borrow_mut().parsed += 1;
                    let _: f64 = lag.value(0.5, &[x], &[v]);
                    let mut d = PointDerivatives::new(1);
                    lag.second_derivatives(0.5, &[x], &[v], true, &mut d);
                }
                Err(e) => {
                    tally.borrow_mut().rejected += 1;
                    prop_assert!(e.line >= 1 && e.column >= 1 && !e.render().is_empty());
                }
            }
            Ok(())
        })
        .unwrap();
    tally.borrow().report("random strings", clock);
}

#[test]
fn random_trees_evaluate_like_the_reference() {
    let strategy = (tree(), [point(), point(), point()], [point(), point()]);
    let (clock, tally) = (std::time::Instant::now(), std::cell::RefCell::new(Tally::default()));
    runner(u32::MAX)
        .run(&strategy, |(e, var, par)| {
            let src = render(&e);
            let lag = compile(&src, &par).map_err(|err| TestCaseError::fail(format!("{src}: {err}")))?;
            tally.borrow_mut().parsed += 1;
            let got: f64 = lag.value(var[0], &[var[1]], &[var[2]]);
            let want = reference(&e, &var, &par).0;
            prop_assert!(close(got, want), "{src} at {var:?}, {par:?}: {got:e} != {want:e}");
            Ok(())
        })
        .unwrap();
    tally.borrow().report("random trees", clock);
}

#[test]
fn nesting_is_accepted_up_to_the_limit_and_rejected_past_it() {
    // Each wrapper around x opens one level: k wrappers are k + 1 levels.
    let wrappers = prop::collection::vec(0..5usize, 1..2 * MAX_NESTING);
    let (clock, tally) = (std::time::Instant::now(), std::cell::RefCell::new(Tally::default()));
    runner(20_000)
        .run(&(wrappers, point()), |(kinds, x)| {
            let mut e = E::Var(1);
            for k in &kinds {
                let b = Box::new(e);
                e = match k {
                    0 => E::Paren(b),
                    1 => E::Call1("atan", b),
                    2 => E::Neg(b),
                    3 => E::Call2("pow", b, Box::new(E::Num(1.0))),
                    _ => E::Call2("max", Box::new(E::Num(0.5)), b),
                };
            }
            let src = render(&e);
            match compile(&src, &[0.0, 0.0]) {
                Ok(lag) => {
                    tally.borrow_mut().parsed += 1;
                    prop_assert!(kinds.len() < MAX_NESTING);
                    let got: f64 = lag.value(0.0, &[x], &[0.0]);
                    let want = reference(&e, &[0.0, x, 0.0], &[0.0, 0.0]).0;
                    prop_assert!(close(got, want), "{src}: {got} != {want}");
                }
                Err(err) => {
                    tally.borrow_mut().rejected += 1;
                    prop_assert!(kinds.len() >= MAX_NESTING && err.message.contains("nested"));
                }
            }
            Ok(())
        })
        .unwrap();
    tally.borrow().report("nesting", clock);
}

#[test]
fn long_sums_and_products_evaluate_like_a_fold() {
    let term = prop_oneof![
        number().prop_map(E::Num),
        (0..3usize).prop_map(E::Var),
        Just(E::Param(0))
    ];
    let len = prop_oneof![3 => 1..100usize, 1 => 100..20_000usize];
    let chain = (
        any::<bool>(),
        len.prop_flat_map(move |n| prop::collection::vec((any::<bool>(), term.clone()), n)),
    );
    let (clock, tally) = (std::time::Instant::now(), std::cell::RefCell::new(Tally::default()));
    runner(2_000)
        .run(&(chain, [point(), point(), point()]), |((sum, terms), var)| {
            let ops = if sum { ['+', '-'] } else { ['*', '/'] };
            let par = [1.25, 0.0];
            let mut src = render(&terms[0].1);
            let mut acc = reference(&terms[0].1, &var, &par);
            for (first, t) in &terms[1..] {
                let op = ops[usize::from(*first)];
                src.push(op);
                src.push_str(&render(t));
                acc = binary(op, acc, reference(t, &var, &par));
            }
            let lag = compile(&src, &par).map_err(|err| TestCaseError::fail(err.to_string()))?;
            tally.borrow_mut().parsed += 1;
            let got: f64 = lag.value(var[0], &[var[1]], &[var[2]]);
            prop_assert!(close(got, acc.0), "{} terms: {got:e} != {:e}", terms.len(), acc.0);
            Ok(())
        })
        .unwrap();
    tally.borrow().report("long sums and products", clock);
}
