"""femvi.System: systems written in Python (strings or SymPy), run keywords, and results as
pandas and matplotlib objects. A System is run through the problem file it prints, so its
results are compared bit for bit with problem files written by hand and with `femvi run`."""

import math

import numpy as np
import pytest
import sympy as sp
from sympy.physics.mechanics import Lagrangian, Particle, Point, ReferenceFrame, dynamicsymbols
from sympy.parsing.sympy_parser import convert_xor, parse_expr, standard_transformations

import femvi
from conftest import EXAMPLES, same


def same_solution(a, b):
    return (a.steps == b.steps and same(a.t, b.t) and same(a.q, b.q) and same(a.p, b.p)
            and same(a.energy, b.energy))


# --- the printer -------------------------------------------------------------------------

X, Y, K = sp.symbols("x y k", real=True)
PRINTED = [
    X**2 / 2 - K * X**2 / 2,
    sp.Rational(1, 3) * X - 2 * X**-2 + sp.sqrt(X**2 + 1) + 1 / sp.sqrt(1 + X**2),
    sp.exp(-X) * sp.atan2(Y, X + 3) - sp.Max(X, K, 1) + sp.Min(X, Y),
    -X * K + (X + K)**3 * (Y**2 + 1)**sp.Rational(3, 2) + (X**2 + 2)**(-K) + sp.sec(X) + sp.log(X**2 + 1),
    sp.pi * X / (K * (X**2 + 1)) - 3 + sp.E**Y + sp.Float("1e-7") * Y - sp.Float("-2.5e22") * X,
    sp.sinh(X) * sp.cosh(Y) - sp.tanh(X * Y) + sp.asin(X / 10) + sp.acos(Y / 10) + sp.atan(X) + sp.Abs(Y),
    sp.cot(X + 2) + sp.csc(Y + 2) - sp.coth(X + 5) + sp.sech(Y) - sp.csch(X + 7) + sp.tan(X) ** 2,
    -(X - Y) ** 5 / 7 + (-X) ** 3 - (-2) * X + 1 / (X**2 + Y**2 + 1) ** 2,
]


def _parse_back(text):
    """femvi's text read by SymPy: ^ as power, ln/abs/min/max as SymPy's functions."""
    names = {"ln": sp.log, "abs": sp.Abs, "min": sp.Min, "max": sp.Max, "pi": sp.pi,
             "x": X, "y": Y, "k": K}
    return parse_expr(text, local_dict=names, transformations=standard_transformations + (convert_xor,))


@pytest.mark.parametrize("expr", PRINTED, ids=range(len(PRINTED)))
def test_printed_text_reads_back_as_the_same_function(expr):
    text = femvi.expression(expr)
    back = _parse_back(text)
    rng = np.random.default_rng(7)
    f, g = sp.lambdify((X, Y, K), expr, "math"), sp.lambdify((X, Y, K), back, "math")
    for x, y, k in rng.uniform(0.1, 2.0, size=(50, 3)):
        a, b = f(x, y, k), g(x, y, k)
        assert abs(a - b) <= 1e-13 * max(1.0, abs(a)), (text, a, b)


@pytest.mark.parametrize("bad, named", [
    (sp.besselj(0, X), "besselj"), (sp.Heaviside(X), "Heaviside"),
    (sp.Piecewise((X, X > 0), (0, True)), "Piecewise"), (sp.gamma(X), "gamma"),
    (X + sp.oo, "oo"), (sp.Function("f")(X), r"f\(x\)"),
])
def test_unsupported_sympy_is_a_clear_error_naming_it(bad, named):
    with pytest.raises(femvi.InputError, match=named):
        femvi.System([X], X**2 / 2 + bad)


def test_second_derivatives_and_unknown_dynamicsymbols_are_refused():
    q, r = dynamicsymbols("q r")
    t = dynamicsymbols._t
    with pytest.raises(femvi.InputError, match="no higher derivatives"):
        femvi.System([q], q.diff(t, 2) * q)
    with pytest.raises(femvi.InputError, match="r is not"):
        femvi.System([q], q.diff(t) ** 2 / 2 - r**2)


# --- the double pendulum from sympy.physics.mechanics ---------------------------------------

def double_pendulum_system():
    """The double pendulum derived as a textbook does it: two particles on rods from a pivot,
    L = T - V from sympy.physics.mechanics.Lagrangian."""
    q1, q2 = dynamicsymbols("q1 q2")
    m1, m2, l1, l2, g = sp.symbols("m1 m2 l1 l2 g")
    frame, pivot = ReferenceFrame("N"), Point("O")
    pivot.set_vel(frame, 0)
    p1 = pivot.locatenew("P1", l1 * sp.sin(q1) * frame.x - l1 * sp.cos(q1) * frame.y)
    p2 = p1.locatenew("P2", l2 * sp.sin(q2) * frame.x - l2 * sp.cos(q2) * frame.y)
    for p in (p1, p2):
        p.set_vel(frame, p.pos_from(pivot).dt(frame))
    a, b = Particle("a", p1, m1), Particle("b", p2, m2)
    a.potential_energy = m1 * g * p1.pos_from(pivot).dot(frame.y)
    b.potential_energy = m2 * g * p2.pos_from(pivot).dot(frame.y)
    L = sp.simplify(Lagrangian(frame, a, b))
    params = {m1: 1.0, m2: 1.0, l1: 1.0, l2: 1.0, g: 9.81}
    return femvi.System([q1, q2], L, params, name="double-pendulum")


DP_RUN = dict(q0=[1.0, 0.5], v0=[0.0, 0.0], t_span=(0.0, 10.0), dt=0.01, degree=3, nodes="lobatto",
              quadrature="gauss-lobatto", points=4)


def test_sympy_double_pendulum_equals_the_problem_file_bit_for_bit():
    system = double_pendulum_system()
    assert system.coordinates == ["q1", "q2"]
    a = femvi.solve(system, **DP_RUN)
    # The same system written by hand in the expression language (the textbook's form).
    b = femvi.solve(EXAMPLES / "double-pendulum-expression.toml")
    assert a.error is None and a.steps == 1000
    # The trajectory is the file's bit for bit: the compiled derivatives are the same. The
    # energy H = v.p - L evaluates L as each writes it (SymPy's arrangement against the
    # textbook's), so it may differ in the last bits.
    assert same(a.t, b.t) and same(a.q, b.q) and same(a.p, b.p) and same(a.v, b.v)
    assert np.abs(a.energy - b.energy).max() <= 8 * np.spacing(np.abs(b.energy).max())
    # ... and the built-in model (hand-written Rust, automatic derivatives): the same
    # trajectory to round-off.
    c = femvi.solve(EXAMPLES / "double-pendulum.toml")
    assert np.abs(a.q - c.q).max() < 1e-12 and np.abs(a.p - c.p).max() < 1e-12


def test_system_to_toml_runs_in_the_command_to_the_same_bits(run_cli, tmp_path):
    system = double_pendulum_system()
    path = tmp_path / "dp.toml"
    path.write_text(system.to_toml(**DP_RUN))
    code, summary, rows, err = run_cli(path)
    assert code == 0, err
    sol = femvi.solve(system, **DP_RUN)
    assert same(sol.q[-1], summary["final_q"]) and same(sol.p[-1], summary["final_p"])
    table = np.array([[float(x) for x in r] for r in rows[1:]])
    assert same(table[:, 2:4], sol.q) and same(table[:, 4:6], sol.p) and same(table[:, 6], sol.energy)


# --- plain Symbols, strings, forces, constraints ---------------------------------------------

def test_oscillator_from_symbols_meets_the_closed_form():
    x, x_dot, k = sp.symbols("x x_dot k")
    osc = femvi.System([x], x_dot**2 / 2 - k * x**2 / 2, parameters={k: 4.0})
    errs = []
    for h in (0.1, 0.05, 0.025):
        sol = femvi.solve(osc, q0=[1.0], v0=[0.0], t_span=(0.0, 5.0), dt=h, order=4)
        errs.append(abs(sol.q[-1, 0] - math.cos(2.0 * sol.t[-1])))
    orders = [math.log2(errs[i] / errs[i + 1]) for i in range(2)]
    assert all(3.8 < p < 4.3 for p in orders), (errs, orders)


def test_forces_equal_the_forces_example_bit_for_bit():
    x, x_dot, k, c, f0, w, t = sp.symbols("x x_dot k c f0 w t")
    system = femvi.System([x], x_dot**2 / 2 - k * x**2 / 2, {k: 1.0, c: 0.2, f0: 0.5, w: 1.3},
                          forces=["-c*x_dot + f0*cos(w*t)"], name="driven-damped-oscillator")
    a = femvi.solve(system, q0=[0.0], v0=[0.0], t_span=(0.0, 50.0), dt=0.05, order=4)
    b = femvi.solve(EXAMPLES / "forces" / "driven-damped-oscillator.toml")
    assert same_solution(a, b) and same(a.work, b.work)
    # The force as a SymPy expression: the same text after printing, the same bits.
    s2 = femvi.System([x], x_dot**2 / 2 - k * x**2 / 2, {k: 1.0, c: 0.2, f0: 0.5, w: 1.3},
                      forces=[-c * x_dot + f0 * sp.cos(w * t)])
    d = femvi.solve(s2, q0=[0.0], v0=[0.0], t_span=(0.0, 50.0), dt=0.05, order=4)
    assert np.abs(d.q - a.q).max() < 1e-12


def test_constraints_and_dissipation_equal_the_constrained_example_bit_for_bit():
    x, y, z, x_dot, y_dot, z_dot = sp.symbols("x y z x_dot y_dot z_dot")
    m, g, l, c, f0, w, t = sp.symbols("m g l c f0 w t")
    system = femvi.System(
        [x, y, z], "0.5*m*(x_dot^2 + y_dot^2 + z_dot^2) - m*g*z",
        {m: 1.0, g: 9.81, l: 1.0, c: 0.3, f0: 0.5, w: 2.5},
        dissipation="0.5*c*(x_dot^2 + y_dot^2 + z_dot^2)", forces=["f0*cos(w*t)", "0", "0"],
        constraints=["x^2 + y^2 + z^2 - l^2"], name="damped-spherical-pendulum")
    path = EXAMPLES / "constrained" / "damped-spherical-pendulum.toml"
    b = femvi.solve(path)
    a = femvi.solve(system, q0=b.q[0], v0=[0.0, 1.682941969615793, 0.0], t_span=(0.0, 20.0), dt=0.01,
                    degree=2)
    assert same_solution(a, b) and same(a.multipliers, b.multipliers)
    assert a.max_constraint_residual < 1e-12


def test_run_keywords_on_a_file_replace_what_they_set():
    path = EXAMPLES / "kepler.toml"
    a = femvi.solve(path, dt=0.1, t_span=(0.0, 10.0), order=4)
    b = femvi.solve(path, **{"time.step": 0.1, "time.end": 10.0, "scheme.order": 4, "scheme.degree": None,
                             "scheme.points": None, "scheme.quadrature": None})
    assert "order = 4" in femvi.problem_text(path, order=4)
    assert "degree" not in femvi.problem_text(path, order=4).split("[scheme]")[1].split("[")[0]
    assert same_solution(a, b)
    ens = femvi.ensemble(path, count=2, dt=0.1, t_span=(0.0, 10.0), order=4, progress=False)
    assert same(ens.final_q[0], a.q[-1]) and same(ens.final_q[1], a.q[-1])


def test_bad_run_keywords_are_input_errors():
    osc = femvi.System(["x"], "0.5*x_dot^2 - 0.5*x^2")
    with pytest.raises(femvi.InputError, match="v0 or p0"):
        femvi.solve(osc, q0=[1.0], v0=[0.0], p0=[0.0], t_span=(0, 1), dt=0.1)
    with pytest.raises(femvi.InputError, match="t_span"):
        femvi.solve(osc, q0=[1.0], v0=[0.0], t_span=(0, 1, 2), dt=0.1)
    with pytest.raises(femvi.InputError, match="q0"):
        femvi.solve(osc, q0="one", v0=[0.0], t_span=(0, 1), dt=0.1)
    with pytest.raises(femvi.InputError):  # no start: the command's own message
        femvi.solve(osc, t_span=(0, 1), dt=0.1)
    with pytest.raises(femvi.InputError, match="forces has 2"):
        femvi.System(["x"], "0.5*x_dot^2", forces=["0", "0"])
    with pytest.raises(femvi.InputError, match="coordinate"):
        femvi.System(["2x"], "0.5*x_dot^2")


# --- results out -------------------------------------------------------------------------

def test_to_pandas_nodes_saved_and_events():
    pd = pytest.importorskip("pandas")
    osc = femvi.System(["x"], "0.5*x_dot^2 - 0.5*x^2", name="osc")
    ev = femvi.Event(lambda t, q, v: q[0], direction="falling", name="zero")
    sol = femvi.solve(osc, q0=[1.0], v0=[0.0], t_span=(0.0, 10.0), dt=0.01, order=4,
                      saveat=[1.0, 2.0], events=[ev])
    df = sol.to_pandas()
    assert df.index.name == "t" and same(df.index.to_numpy(), sol.t)
    assert same(df["x"], sol.q[:, 0]) and same(df["p_x"], sol.p[:, 0]) and same(df["x_dot"], sol.v[:, 0])
    assert same(df["energy"], sol.energy)
    saved = sol.to_pandas("saved")
    assert list(saved.index) == [1.0, 2.0] and abs(saved["x"].iloc[0] - math.cos(1.0)) < 1e-9
    events = sol.to_pandas("events")
    # x = cos t falls through zero at t = pi/2 + 2 pi j: t = 1.57, 7.85.
    assert list(events["name"]) == ["zero", "zero"]
    assert np.allclose(events["t"], [math.pi / 2, 5 * math.pi / 2], atol=1e-8)
    assert np.allclose(events["x_dot"], [-1.0, -1.0], atol=1e-8)
    with pytest.raises(ValueError, match="which"):
        sol.to_pandas("everything")
    assert isinstance(df, pd.DataFrame)


def test_to_pandas_with_forces_and_constraints_has_their_columns():
    path = EXAMPLES / "constrained" / "damped-spherical-pendulum.toml"
    sol = femvi.solve(path, t_span=(0.0, 1.0))
    df = sol.to_pandas()
    assert {"work", "lambda_0", "constraint_residual"} <= set(df.columns)
    assert same(df["lambda_0"], sol.multipliers[:, 0])


def test_plot_draws_coordinates_phase_and_energy():
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sol = femvi.solve(EXAMPLES / "forces" / "damped-oscillator.toml", t_span=(0.0, 5.0))
    assert sol.energy[0] != 0
    fig = sol.plot()
    titles = [ax.get_title() for ax in fig.axes]
    assert titles == ["coordinates", "phase portrait", "relative energy balance error"]
    line = fig.axes[0].get_lines()[0]
    assert same(line.get_ydata(), sol.q[:, 0])
    balance = (sol.energy - sol.energy[0] - sol.work) / abs(sol.energy[0])
    assert same(fig.axes[2].get_lines()[0].get_ydata(), balance)
    with pytest.raises(ValueError, match="no coordinate"):
        sol.plot(coordinates=["nope"])
    plt.close("all")


def test_adaptive_steps_with_a_sympy_monitor():
    x, y, x_dot, y_dot = sp.symbols("x y x_dot y_dot")
    r = sp.sqrt(x**2 + y**2)
    kepler = femvi.System([x, y], (x_dot**2 + y_dot**2) / 2 + 1 / r, monitor=r**sp.Rational(3, 2))
    # e = 0.9 from pericentre: H = 19/2 - 10 = -1/2, a = 1, period 2 pi.
    start = dict(q0=[0.1, 0.0], v0=[0.0, math.sqrt(19.0)], t_span=(0.0, 2 * math.pi), order=4)
    sol = femvi.solve(kepler, dt=0.01, mode="adaptive", saveat=[2 * math.pi], **start)
    assert sol.t[-1] >= 2 * math.pi and np.abs(sol.saved.q[0] - [0.1, 0.0]).max() < 1e-3
    assert sol.s is not None and sol.max_rel_energy_error < 1e-8
    # The monitor is the adaptive mode's: a fixed-step run of the same System does not carry it.
    assert "monitor" not in femvi.problem_text(kepler, dt=0.001, **start)
    assert "monitor" in femvi.problem_text(kepler, dt=0.01, mode="adaptive", **start)
    fixed = femvi.solve(kepler, dt=0.001, **start)
    assert fixed.error is None and fixed.s is None


def test_expression_events_run_compiled_and_agree_with_callables():
    # The crossings of q1 = 0 upwards, written three ways: a Python callable, a femvi string
    # and a SymPy expression in the dynamicsymbols. The expressions become the problem file's
    # [[events]] (compiled); all three locate the same times.
    system = double_pendulum_system()
    q1 = system._given[0]
    run = dict(DP_RUN, t_span=(0.0, 20.0))
    by_callable = femvi.solve(system, events=[femvi.Event(lambda t, q, v: q[0], direction="rising", name="cb")], **run)
    by_string = femvi.solve(system, events=[femvi.Event("q1", direction="rising")], **run)
    t = dynamicsymbols._t
    by_sympy = femvi.solve(system, events=[femvi.Event(q1 + 0 * q1.diff(t), direction="rising", name="sym"),
                                           femvi.Event("q2 - 10", name="never")], **run)
    times = [np.array([e["t"] for e in s.events if e["name"] != "never"]) for s in (by_callable, by_string, by_sympy)]
    assert len(times[0]) >= 3 and all(len(x) == len(times[0]) for x in times)
    assert np.abs(times[1] - times[0]).max() < 1e-12 and np.abs(times[2] - times[0]).max() < 1e-12
    assert [e["name"] for e in by_string.events] == ["event1"] * len(times[1])
    assert all(e["from_file"] for e in by_string.events) and not any(e["from_file"] for e in by_callable.events)
    assert same(by_string.q, by_callable.q)  # events do not change the nodes
    with pytest.raises(TypeError, match="callable"):
        femvi.Event(3.0)
    with pytest.raises(femvi.InputError, match="besselj"):
        femvi.solve(system, events=[femvi.Event(sp.besselj(0, q1))], **run)
