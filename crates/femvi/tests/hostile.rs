//! Hostile inputs: every public library function that takes user data answers with a typed
//! error (or a documented harmless value) instead of panicking, aborting, hanging or
//! allocating without bound. Each test here failed on the code before its fix (a stack
//! overflow, an abort on a failed allocation, a hang or a panic; see the commit messages).

use femvi::expr::ExprLagrangian;
use femvi::Lagrangian;

/// Runs `f` in a thread with a 256 KiB stack: deep recursion overflows it and aborts the test.
fn on_small_stack<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::Builder::new()
        .stack_size(256 * 1024)
        .spawn(f)
        .unwrap()
        .join()
        .unwrap()
}

fn x() -> Vec<String> {
    vec!["x".to_string()]
}

// ---- 1. Deep and long expressions --------------------------------------------------------

#[test]
fn deeply_nested_expressions_are_rejected_without_deep_recursion() {
    let sources = [
        format!("{}x{}", "(".repeat(7000), ")".repeat(7000)),
        format!("{}x{}", "sin(".repeat(7000), ")".repeat(7000)),
        format!("{}x", "-".repeat(7000)),
        format!("x{}", "^x".repeat(7000)),
        format!("{}x", "2^-".repeat(7000)),
    ];
    for src in sources {
        let head: String = src.chars().take(12).collect();
        let result = on_small_stack(move || ExprLagrangian::new(&src, &x(), &[]).map(|_| ()));
        let e = result.expect_err(&head);
        assert!(e.message.contains("nested"), "{head}: {}", e.message);
    }
}

#[test]
fn nesting_up_to_the_limit_compiles_on_a_small_stack() {
    use femvi::expr::MAX_NESTING;
    let deep = MAX_NESTING - 1;
    // Each of these opens one level.
    for (open, close) in [("(", ")"), ("sin(", ")"), ("-", ""), ("2^", ""), ("pow(x,", ")")] {
        let src = format!("{}x{}", open.repeat(deep), close.repeat(deep));
        let ok = on_small_stack(move || ExprLagrangian::new(&src, &x(), &[]).map(|_| ()));
        assert!(ok.is_ok(), "{open}: {ok:?}");
        let src = format!("{}x{}", open.repeat(deep + 1), close.repeat(deep + 1));
        let err = on_small_stack(move || ExprLagrangian::new(&src, &x(), &[]).map(|_| ()));
        assert!(err.is_err(), "{open}");
    }
}

#[test]
fn long_sums_and_products_compile_and_evaluate() {
    for (op, want) in [("+", 14_000.0 * 0.5), ("*", 1.0)] {
        let unit = if op == "+" { "x" } else { "(x+0.5)" };
        let src = vec![unit; 14_000].join(op);
        let lag = on_small_stack(move || ExprLagrangian::new(&src, &x(), &[]).unwrap());
        let got: f64 = on_small_stack(move || lag.value(0.0, &[0.5], &[0.0]));
        assert!((got - want).abs() <= 1e-9 * want, "{op}: {got} != {want}");
    }
}
