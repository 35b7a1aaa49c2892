//! Rotations in a Lagrangian expression (`[system] rotations = ["R"]`): the coordinates of a
//! rotation X are its entries X11 … X33 (row-major), and the expression's X_w1, X_w2, X_w3
//! (the body angular velocity, Ẋ = X ŵ) are written out in them before it is compiled:
//! w = vee(skew(XᵀẊ)). The expression's velocities of the entries, X11_dot … X33_dot, are
//! written out as the entries of the tangent part X skew(XᵀẊ) of Ẋ (equal to Ẋ on T SO(3)), so
//! that the expression depends on Ẋ only through w: the momentum conjugate to the entries at a
//! tangent velocity is then ½ X Π̂, with no part normal to the group, as the Lie-group element's
//! nodes hold it (a Lagrangian written in Ẋ directly, such as ½ m |Ẋ c|² for a point of the
//! body, would otherwise give the nodes a momentum, hence a velocity and an energy, off the
//! group's). The embedded Lagrangian also gains ½ |sym(XᵀẊ)|², which vanishes with its first
//! derivatives on T SO(3) and makes the Hessian in Ẋ regular (module docs of
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

/// The expression of (X skew(XᵀẊ))_ij, the tangent part of Ẋ_ij (i, j = 1, 2, 3).
fn tangent_velocity(x: &str, i: usize, j: usize) -> String {
    let terms: Vec<String> = (1..=3)
        .map(|k| format!("{x}{i}{k}*({} - {})", product(x, k, j), product(x, j, k)))
        .collect();
    format!("(0.5*({}))", terms.join(" + "))
}

/// `expr` with each rotation's X_w1 … X_w3 and X11_dot … X33_dot written out (no
/// regularising term): for the expressions of `[forces]`.
///
/// # Example
/// ```
/// let text = femvi_cli::problem::rotations::substitute("-c*R_w3", &["R".to_string()]);
/// assert!(text.starts_with("-c*(0.5*((R12*R11_dot") && !text.contains("R_w3"));
/// ```
pub fn substitute(expr: &str, rotations: &[String]) -> String {
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
            out.push_str(word_for(word, rotations).as_deref().unwrap_or(word));
        } else {
            out.push(ch);
        }
    }
    out
}

/// The expression that replaces the identifier `word` (X_wc or Xij_dot of a rotation X).
fn word_for(word: &str, rotations: &[String]) -> Option<String> {
    rotations.iter().find_map(|x| {
        let rest = word.strip_prefix(x.as_str())?;
        if let Some(c) = rest.strip_prefix("_w") {
            let c: usize = c.parse().ok().filter(|c| (1..=3).contains(c))?;
            return Some(spin(x, c));
        }
        let ij = rest.strip_suffix("_dot")?.as_bytes();
        let digit = |b: u8| (b'1'..=b'3').contains(&b).then(|| usize::from(b - b'0'));
        match ij {
            [i, j] => Some(tangent_velocity(x, digit(*i)?, digit(*j)?)),
            _ => None,
        }
    })
}

/// `expr` with each rotation's X_w1 … X_w3 and X11_dot … X33_dot written out, plus the
/// regularising term.
///
/// # Example
/// ```
/// let text = femvi_cli::problem::rotations::embed("0.5*R_w3^2", &["R".to_string()]);
/// assert!(text.starts_with("(0.5*(0.5*((R12*R11_dot") && !text.contains("R_w3"));
/// // A velocity of an entry becomes its tangent part: (R skew(RᵀṘ))_13.
/// let text = femvi_cli::problem::rotations::embed("R13_dot^2", &["R".to_string()]);
/// assert!(text.starts_with("((0.5*(R11*((R11*R13_dot") && !text.starts_with("(R13_dot"));
/// ```
pub fn embed(expr: &str, rotations: &[String]) -> String {
    let out = substitute(expr, rotations);
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
