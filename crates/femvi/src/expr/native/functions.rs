//! The Rust functions machine code calls: the tape interpreter's (`dag::eval_un`,
//! `eval_bin`) and the postfix program's (`program::unary`, `binary` in f64), so that code and
//! interpreter agree bit for bit.

use super::super::dag::{eval_bin, eval_un, Bin, Un};
use super::super::program::{self, Op, F1, F2};

/// The Rust functions the code calls, each the interpreter's own evaluation of that operation
/// (so the two agree bit for bit).
macro_rules! un_fns {
    ($($name:ident => $f:ident),* $(,)?) => {
        $(pub(super) extern "C" fn $name(x: f64) -> f64 {
            eval_un(Un::F(F1::$f), x)
        })*
    };
}
un_fns!(sin => Sin, cos => Cos, tan => Tan, exp => Exp, ln => Ln, sinh => Sinh, cosh => Cosh,
    tanh => Tanh, asin => Asin, acos => Acos, atan => Atan);

/// The program's own f64 functions (`program::unary` / `binary`), for the value code.
macro_rules! program_fns {
    ($($name:ident => $f:ident),* $(,)?) => {
        $(extern "C" fn $name(x: f64) -> f64 {
            program::unary::<f64>(Op::Call1(F1::$f), x)
        })*
        pub(super) fn program_fn1(f: F1) -> extern "C" fn(f64) -> f64 {
            match f { $(F1::$f => $name,)* }
        }
    };
}
program_fns!(program_sin => Sin, program_cos => Cos, program_tan => Tan, program_exp => Exp,
    program_ln => Ln, program_sqrt => Sqrt, program_abs => Abs, program_sinh => Sinh,
    program_cosh => Cosh, program_tanh => Tanh, program_asin => Asin, program_acos => Acos,
    program_atan => Atan);

pub(super) fn program_fn2(f: F2) -> extern "C" fn(f64, f64) -> f64 {
    extern "C" fn atan2(x: f64, y: f64) -> f64 {
        program::binary::<f64>(Op::Call2(F2::Atan2), x, y)
    }
    extern "C" fn pow(x: f64, y: f64) -> f64 {
        program::binary::<f64>(Op::Call2(F2::Pow), x, y)
    }
    extern "C" fn min(x: f64, y: f64) -> f64 {
        program::binary::<f64>(Op::Call2(F2::Min), x, y)
    }
    extern "C" fn max(x: f64, y: f64) -> f64 {
        program::binary::<f64>(Op::Call2(F2::Max), x, y)
    }
    match f {
        F2::Atan2 => atan2,
        F2::Pow => pow,
        F2::Min => min,
        F2::Max => max,
    }
}

pub(super) extern "C" fn program_powf(x: f64, e: f64) -> f64 {
    program::unary::<f64>(Op::PowF(e), x)
}

pub(super) extern "C" fn powf(x: f64, y: f64) -> f64 {
    eval_bin(Bin::Pow, x, y)
}

pub(super) extern "C" fn atan2(x: f64, y: f64) -> f64 {
    eval_bin(Bin::Atan2, x, y)
}
