//! Rotations in a Lagrangian expression (`[system] rotations = ["R"]`): the coordinates of a
//! rotation X are its entries X11 … X33 (row-major), and the expression's X_w1, X_w2, X_w3
//! (the body angular velocity, Ẋ = X ŵ) are written out in them before it is compiled:
//! w = vee(skew(XᵀẊ)). The embedded Lagrangian also gains ½ |sym(XᵀẊ)|², which vanishes with
//! its first derivatives on T SO(3) and makes the Hessian in Ẋ regular (module docs of
//! [`femvi::rotation`]).

/// The coordinate names of rotation `x`: x11, x12, …, x33.
///
/// # Example
/// ```
/// let names = femvi_cli::problem::rotations::entries("R");
/// assert_eq!((names[0].as_str(), names[5].as_str()), ("R11", "R23"));
/// ```
pub fn entries(x: &str) -> Vec<String> {
    (1..=3)
        .flat_map(|i| (1..=3).map(move |j| format!("{x}{i}{j}")))
        .collect()
}

/// (XᵀẊ)_ab as an expression.
fn product(x: &str, a: usize, b: usize) -> String {
    format!("({x}1{a}*{x}1{b}_dot + {x}2{a}*{x}2{b}_dot + {x}3{a}*{x}3{b}_dot)")
}

/// The expression of w_c of rotation `x` (c = 1, 2, 3).
fn spin(x: &str, c: usize) -> String {
    let (a, b) = [(3, 2), (1, 3), (2, 1)][c - 1];
    format!("(0.5*({} - {}))", product(x, a, b), product(x, b, a))
}

/// `expr` with each rotation's X_w1 … X_w3 written out, plus the regularising term.
///
/// # Example
/// ```
/// let text = femvi_cli::problem::rotations::embed("0.5*R_w3^2", &["R".to_string()]);
/// assert!(text.starts_with("(0.5*(0.5*((R12*R11_dot") && !text.contains("R_w3"));
/// ```
pub fn embed(expr: &str, rotations: &[String]) -> String {
    let mut out = String::with_capacity(expr.len() * 4);
    let mut chars = expr.char_indices().peekable();
    while let Some((i, ch)) = chars.next() {
        if ch.is_ascii_alphabetic() || ch == '_' || ch.is_ascii_digit() {
            let mut end = i + ch.len_utf8();
            while let Some(&(j, c)) = chars.peek() {
                if c.is_ascii_alphanumeric() || c == '_' {
                    end = j + c.len_utf8();
                    chars.next();
                } else {
                    break;
                }
            }
            let word = &expr[i..end];
            let replaced = rotations.iter().find_map(|x| {
                let rest = word.strip_prefix(x.as_str())?.strip_prefix("_w")?;
                let c: usize = rest.parse().ok().filter(|c| (1..=3).contains(c))?;
                Some(spin(x, c))
            });
            out.push_str(replaced.as_deref().unwrap_or(word));
        } else {
            out.push(ch);
        }
    }
    let mut text = format!("({out})");
    for x in rotations {
        let mut sym = Vec::new();
        for a in 1..=3 {
            for b in 1..=3 {
                sym.push(format!("(0.5*({} + {}))^2", product(x, a, b), product(x, b, a)));
            }
        }
        text.push_str(&format!(" + 0.5*({})", sym.join(" + ")));
    }
    text
}
