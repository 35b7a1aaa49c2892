//! The colours of a plot's series (a palette that never repeats within a plot) and the step
//! of a run as plot titles show it.

use plotters::style::RGBColor;

/// The palette: ten well-separated colours (Tableau 10), then hues spaced by the golden
/// angle, so that no two series of a plot share a colour however many there are.
pub fn color(i: usize) -> RGBColor {
    const TAB10: [RGBColor; 10] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(127, 127, 127),
        RGBColor(188, 189, 34),
        RGBColor(23, 190, 207),
    ];
    if let Some(c) = TAB10.get(i) {
        return *c;
    }
    let k = (i - TAB10.len()) as f64;
    let hue = (0.05 + k * 0.618_033_988_749_895).fract();
    let lightness = [0.35, 0.5, 0.65][(i - TAB10.len()) % 3];
    hsl_to_rgb(hue, 0.75, lightness)
}

/// An HSL colour (all in [0, 1]) as RGB.
fn hsl_to_rgb(h: f64, s: f64, l: f64) -> RGBColor {
    let c = (1.0 - (2.0 * l - 1.0).abs()) * s;
    let hp = h * 6.0;
    let x = c * (1.0 - (hp % 2.0 - 1.0).abs());
    let (r, g, b) = match hp as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = l - c / 2.0;
    let to = |v: f64| ((v + m) * 255.0).round().clamp(0.0, 255.0) as u8;
    RGBColor(to(r), to(g), to(b))
}

/// The step of a run as titles show it: `h = 0.01`, the cycle of steps, or energy mode's
/// first step.
pub fn step_label(problem: &crate::problem::Problem) -> String {
    match &problem.steps {
        femvi::Steps::Fixed(h) => format!("{h}"),
        femvi::Steps::Cycle(list) => {
            let l: Vec<String> = list.iter().map(|h| format!("{h}")).collect();
            format!("cycle [{}]", l.join(", "))
        }
        femvi::Steps::Energy { step, .. } => format!("{step} (first; energy mode)"),
    }
}
