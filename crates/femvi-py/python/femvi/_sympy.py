"""SymPy expressions as femvi expressions: the text a problem file's ``lagrangian``,
``generalized``, ``dissipation``, ``holonomic`` and ``when`` take.

The conversion prints the expression tree, it does not evaluate it: femvi then compiles the
text with its symbolic derivatives to native code, as it does for a problem file
(``docs/src/expressions.md``), so a SymPy Lagrangian runs at the file's speed. Coordinates may
be plain Symbols (velocities are Symbols named ``NAME_dot``) or
``sympy.physics.mechanics.dynamicsymbols`` q(t), whose derivatives q(t).diff(t) become
``NAME_dot``. SymPy is imported only when a SymPy object is given.
"""

from __future__ import annotations

import re
from typing import Any, Dict, List, Sequence

from ._core import InputError

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

# SymPy's one-argument functions and femvi's names for them (docs/src/expressions.md).
_FUNCS1 = {
    "sin": "sin", "cos": "cos", "tan": "tan", "exp": "exp", "log": "ln", "Abs": "abs",
    "sinh": "sinh", "cosh": "cosh", "tanh": "tanh", "asin": "asin", "acos": "acos", "atan": "atan",
}
# Reciprocals: sec(x) is written 1/cos(x).
_RECIPROCAL = {"sec": "cos", "csc": "sin", "cot": "tan", "sech": "cosh", "csch": "sinh", "coth": "tanh"}
_SUPPORTED = sorted(set(_FUNCS1) | set(_RECIPROCAL) | {"atan2", "Min", "Max", "sqrt"})


def is_sympy(x: Any) -> bool:
    """Whether ``x`` is a SymPy object (without importing SymPy)."""
    return any((getattr(c, "__module__", None) or "").startswith("sympy") for c in type(x).__mro__)


def coordinate_name(c: Any) -> str:
    """The name of a coordinate given as a string, a Symbol or a dynamicsymbol q(t)."""
    if isinstance(c, str):
        name = c
    elif is_sympy(c) and getattr(c, "is_Symbol", False):
        name = c.name
    elif is_sympy(c) and _is_dynamic(c):
        name = c.func.__name__
    else:
        raise InputError(f"a coordinate must be a name, a SymPy Symbol or a dynamicsymbol q(t), not {c!r}")
    if not _NAME.match(name):
        raise InputError(f"coordinate {name!r}: femvi names are letters, digits and '_', not starting with a digit")
    return name


def _is_dynamic(c: Any) -> bool:
    """q(t): an undefined function applied to one symbol."""
    from sympy.core.function import AppliedUndef

    return isinstance(c, AppliedUndef) and len(c.args) == 1 and c.args[0].is_Symbol


def to_expression(expr: Any, coordinates: Sequence[Any] = (), what: str = "expression") -> str:
    """A femvi expression's text for ``expr``: a string (returned as it is), a number, or a
    SymPy expression in the ``coordinates`` (Symbols or dynamicsymbols), their velocities, t
    and parameters.

    >>> import sympy as sp
    >>> x, x_dot, k = sp.symbols("x x_dot k")
    >>> to_expression(x_dot**2 / 2 - k * x**2 / 2)
    '-k*x^2/2 + x_dot^2/2'
    >>> from sympy.physics.mechanics import dynamicsymbols
    >>> q = dynamicsymbols("q")
    >>> to_expression(sp.cos(q) * q.diff()**2, [q])
    'q_dot^2*cos(q)'
    """
    if isinstance(expr, str):
        return expr
    if isinstance(expr, bool):
        raise InputError(f"the {what} is a boolean, not an expression")
    if isinstance(expr, (int, float)):
        return _number(float(expr))
    if not is_sympy(expr):
        raise InputError(f"the {what} must be a string or a SymPy expression, not {type(expr).__name__}")
    import sympy as sp

    expr = sp.sympify(expr)
    expr = _replace_dynamic(expr, coordinates, what)
    return _Printer(what).print(expr)


def _replace_dynamic(expr: Any, coordinates: Sequence[Any], what: str) -> Any:
    """q(t) -> Symbol q and q(t).diff(t) -> Symbol q_dot, for the dynamicsymbols among the
    coordinates; a higher derivative or an unknown function of t is refused."""
    import sympy as sp

    subs: Dict[Any, Any] = {}
    for c in coordinates:
        if is_sympy(c) and _is_dynamic(c):
            name = c.func.__name__
            subs[sp.Derivative(c, c.args[0])] = sp.Symbol(name + "_dot")
    expr = expr.xreplace(subs) if subs else expr
    for d in expr.atoms(sp.Derivative):
        raise InputError(f"the {what} has the derivative {d}: femvi takes q and its first derivative "
                         "(dynamicsymbols among the coordinates), no higher derivatives")
    subs = {c: sp.Symbol(c.func.__name__) for c in coordinates if is_sympy(c) and _is_dynamic(c)}
    return expr.xreplace(subs) if subs else expr


def _number(v: float) -> str:
    if v != v or v in (float("inf"), float("-inf")):
        raise InputError(f"the number {v} is not finite")
    text = repr(v)
    return f"({text})" if v < 0 else text


class _Printer:
    """Infix text with femvi's operators (^ for powers) and just the parentheses the
    precedence needs: sums < products < unary minus < powers (femvi's grammar,
    ``crates/femvi/src/expr/parse.rs``)."""

    def __init__(self, what: str):
        self.what = what

    def print(self, e: Any) -> str:
        return self._p(e)

    # Precedence levels of the printed text: 1 sum, 2 product, 4 atom.
    def _paren(self, e: Any, level: int) -> str:
        text, own = self._with_level(e)
        return f"({text})" if own < level else text

    def _p(self, e: Any) -> str:
        return self._with_level(e)[0]

    def _with_level(self, e: Any):
        import sympy as sp

        if e.is_Symbol:
            if not _NAME.match(e.name):
                raise InputError(f"the {self.what} has the symbol {e.name!r}: femvi names are letters, digits and '_'")
            return e.name, 4
        if e is sp.pi:
            return "pi", 4
        if e is sp.E:
            return "exp(1)", 4
        if e.is_Integer:
            return (str(int(e)), 4) if e >= 0 else (str(int(e)), 1)
        if e.is_Rational:
            v = int(e.p) / int(e.q)
            return (repr(v), 4) if v >= 0 else (repr(v), 1)
        if e.is_Float:
            v = float(e)
            return (repr(v), 4) if v >= 0 else (repr(v), 1)
        if e.is_Add:
            return self._add(e), 1
        if e.is_Mul:
            return self._mul(e)
        if e.is_Pow:
            return self._pow(e)
        if isinstance(e, sp.Function) or isinstance(e, (sp.Min, sp.Max)):
            return self._call(e), 4
        if e.is_Number:  # nan, zoo, oo
            raise InputError(f"the {self.what} has the number {e}, which is not finite")
        raise InputError(f"the {self.what} has {type(e).__name__} ({e}), which femvi cannot compile; "
                         f"it takes numbers, symbols, + - * / ^ and the functions {', '.join(_SUPPORTED)}")

    def _add(self, e: Any) -> str:
        out: List[str] = []
        for term in e.as_ordered_terms():
            coeff, rest = term.as_coeff_Mul()
            if out and coeff.is_Number and coeff < 0:
                out.append(" - " + self._paren(-term, 2))
            else:
                out.append((" + " if out else "") + self._paren(term, 2 if out else 1))
        return "".join(out)

    def _mul(self, e: Any):
        coeff, rest = e.as_coeff_Mul()
        if coeff.is_Number and coeff < 0:
            inner = self._paren(-e, 2)
            return "-" + inner, 1
        num, den = [], []
        for f in rest.as_ordered_factors() if coeff == 1 else [coeff] + list(rest.as_ordered_factors()):
            if f.is_Pow and f.exp.is_Integer and f.exp < 0:
                den.append(f.base if f.exp == -1 else f.base ** (-f.exp))
            elif f.is_Rational and not f.is_Integer and f.p == 1:
                den.append(f.q)
            else:
                num.append(f)
        factors = [self._paren(f, 2) for f in num] or ["1"]
        text = "*".join(factors)
        for d in den:
            text += "/" + (str(d) if isinstance(d, int) else self._paren(d, 3))
        return text, 2

    def _pow(self, e: Any):
        import sympy as sp

        base, exp = e.base, e.exp
        if exp == sp.Rational(1, 2):
            return f"sqrt({self._p(base)})", 4
        if exp == sp.Rational(-1, 2):
            return f"1/sqrt({self._p(base)})", 2
        if exp == -1:
            return "1/" + self._paren(base, 3), 2
        b = self._paren(base, 4)
        if exp.is_Integer and exp >= 0:
            return f"{b}^{int(exp)}", 3
        return f"{b}^({self._p(exp)})", 3

    def _call(self, e: Any) -> str:
        import sympy as sp

        name = type(e).__name__
        args = e.args
        if name in _FUNCS1 and len(args) == 1:
            return f"{_FUNCS1[name]}({self._p(args[0])})"
        if name in _RECIPROCAL and len(args) == 1:
            return f"(1/{_RECIPROCAL[name]}({self._p(args[0])}))"
        if name == "atan2" and len(args) == 2:
            return f"atan2({self._p(args[0])}, {self._p(args[1])})"
        if isinstance(e, (sp.Min, sp.Max)):
            f = "min" if isinstance(e, sp.Min) else "max"
            text = self._p(args[0])
            for a in args[1:]:
                text = f"{f}({text}, {self._p(a)})"
            return text
        from sympy.core.function import AppliedUndef

        if isinstance(e, AppliedUndef):
            raise InputError(f"the {self.what} has the function {e}: a coordinate given as a dynamicsymbol "
                             f"must be among the coordinates ({name} is not)")
        raise InputError(f"the {self.what} has the function {name}, which femvi cannot compile; "
                         f"it takes {', '.join(_SUPPORTED)}")

