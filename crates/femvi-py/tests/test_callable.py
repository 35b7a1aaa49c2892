"""A potential written in Python (for prototyping) against the same system built in, and
`femvi.convergence` against the command."""

import json
import subprocess

import numpy as np
import pytest

import femvi
from conftest import EXAMPLES

KEPLER = {
    "system": {"model": "kepler", "parameters": {"mu": 1.0}},
    "initial": {"q": [0.5, 0.0], "p": [0.0, 3.0 ** 0.5]},
    "scheme": {"degree": 2, "quadrature": "gauss-legendre"},
    "time": {"step": 0.05, "end": 20.0},
}


def kepler_in_python():
    d = {k: dict(v) for k, v in KEPLER.items()}
    d["system"] = {"coordinates": ["x", "y"]}
    return d


def V(q):
    return -1.0 / np.hypot(q[0], q[1])


def F(q):
    return -q / np.hypot(q[0], q[1]) ** 3


def test_a_python_potential_follows_the_built_in_model():
    ref = femvi.solve(KEPLER)
    sol = femvi.solve(kepler_in_python(), potential=V, force=F)
    assert sol.q.shape == ref.q.shape and sol.steps == ref.steps
    # The same scheme on the same system: only rounding in the force differs.
    assert np.max(np.abs(sol.q - ref.q)) < 1e-10
    assert np.max(np.abs(sol.p - ref.p)) < 1e-10
    assert np.max(np.abs(sol.energy - ref.energy)) < 1e-12
    assert abs(sol.max_rel_energy_error - ref.max_rel_energy_error) < 1e-10


def test_masses_and_newton_with_a_finite_difference_jacobian():
    # Harmonic oscillator m = 2, k = 3 (omega^2 = 3/2) against the built-in model.
    h = {"system": {"model": "harmonic", "parameters": {"m": 2.0, "k": 3.0}},
         "initial": {"q": [1.0], "p": [0.0]}, "scheme": {"degree": 3, "quadrature": "gauss-legendre"},
         "time": {"step": 0.1, "end": 10.0}}
    ref = femvi.solve(h)
    mine = {**h, "system": {"coordinates": ["x"]}}
    a = femvi.solve(mine, potential=lambda q: 1.5 * q[0] ** 2, force=lambda q: -3.0 * q, masses=[2.0])
    b = femvi.solve({**mine, "solver": {"method": "newton"}}, potential=lambda q: 1.5 * q[0] ** 2,
                    force=lambda q: -3.0 * q, masses=[2.0])
    for s in (a, b):
        assert np.max(np.abs(s.q - ref.q)) < 1e-11 and np.max(np.abs(s.p - ref.p)) < 1e-11


def test_a_python_potential_takes_the_files_forces_and_constraints():
    # The damped, driven spherical pendulum (|q| = l, friction, a drive) with gravity written in
    # Python against the file's own Lagrangian: the same terms act on both.
    # A quartic term x^4/4 besides gravity, so that the potential's Hessian is not zero (the
    # iteration matrices take it by differences of the Python force).
    f = EXAMPLES / "constrained" / "damped-spherical-pendulum.toml"
    short = {"time.end": 2.0}
    ref = femvi.solve(f, {"system.lagrangian": "0.5*m*(x_dot^2 + y_dot^2 + z_dot^2) - m*g*z - 0.25*x^4"}, **short)
    # The file's parameters stay: its [constraints] and [forces] use them.
    mine = {"system": {"coordinates": ["x", "y", "z"],
                       "parameters": {"m": 1.0, "g": 9.81, "l": 1.0, "c": 0.3, "f0": 0.5, "w": 2.5}}}
    sol = femvi.solve(f, mine, potential=lambda q: 9.81 * q[2] + 0.25 * q[0] ** 4,
                      force=lambda q: np.array([-q[0] ** 3, 0.0, -9.81]), **short)
    assert sol.q.shape == ref.q.shape and sol.steps == ref.steps
    assert np.max(np.abs(sol.q - ref.q)) < 1e-10 and np.max(np.abs(sol.p - ref.p)) < 1e-10
    # The terms' additions: the work of the forces and the multipliers, as the file's run.
    assert np.max(np.abs(sol.work - ref.work)) < 1e-10
    assert np.max(np.abs(sol.multipliers - ref.multipliers)) < 1e-8
    assert sol.max_constraint_residual < 1e-12
    # Forces alone, with dense output (the recorder's path): the damped oscillator.
    osc = EXAMPLES / "forces" / "damped-oscillator.toml"
    ref = femvi.solve(osc, dense=True)
    sol = femvi.solve(osc, {"system": {"coordinates": ["x"], "parameters": {"k": 1.0, "c": 0.3}}},
                      potential=lambda q: 0.5 * q[0] ** 2,
                      force=lambda q: -q, dense=True)
    assert np.max(np.abs(sol.q - ref.q)) < 1e-12
    t = np.linspace(0.0, 20.0, 7)
    assert np.max(np.abs(sol.q_at(t) - ref.q_at(t))) < 1e-12


def test_a_python_potential_with_adaptive_steps():
    # Kepler at e = 0.9 with the Poincare transformation, against the built-in model.
    e = 0.9
    problem = {"system": {"model": "kepler", "parameters": {"mu": 1.0}},
               "initial": {"q": [1.0 - e, 0.0], "p": [0.0, ((1.0 + e) / (1.0 - e)) ** 0.5]},
               "scheme": {"degree": 2, "quadrature": "gauss-legendre"},
               "time": {"mode": "adaptive", "monitor": "kepler", "ds": 0.02, "end": 2 * np.pi}}
    ref = femvi.solve(problem)
    sol = femvi.solve({**problem, "system": {"coordinates": ["x", "y"]}}, potential=V, force=F)
    assert sol.steps == ref.steps and sol.q.shape == ref.q.shape
    assert np.max(np.abs(sol.t - ref.t)) < 1e-10
    assert np.max(np.abs(sol.q - ref.q)) < 1e-9 and np.max(np.abs(sol.p - ref.p)) < 1e-8


def test_python_potential_errors():
    class Boom(Exception):
        pass

    def bad_force(q):
        if q[0] < 0.3:
            raise Boom("stop here")
        return F(q)

    with pytest.raises(Boom, match="stop here"):
        femvi.solve(kepler_in_python(), potential=V, force=bad_force)
    with pytest.raises(femvi.InputError, match="returned 3 values"):
        femvi.solve(kepler_in_python(), potential=V, force=lambda q: np.zeros(3))
    with pytest.raises(femvi.InputError, match="mode = \"energy\""):
        femvi.solve({**kepler_in_python(), "time": {"mode": "energy", "step": 0.05, "end": 1.0}},
                    potential=V, force=F)
    with pytest.raises(femvi.InputError, match="masses has 1 entries"):
        femvi.solve(kepler_in_python(), potential=V, force=F, masses=[1.0])
    with pytest.raises(femvi.InputError, match="not both"):
        femvi.solve(KEPLER, potential=V, force=F)
    with pytest.raises(TypeError):
        femvi.solve(kepler_in_python(), potential=V)


def test_convergence_equals_the_command(tmp_path, femvi_bin):
    f = EXAMPLES / "kepler.toml"
    steps = [0.1, 0.05, 0.025]
    mine = femvi.convergence(f, steps, reference="exact", **{"time.end": 5.0})
    out = subprocess.run([str(femvi_bin), "convergence", str(f), "--set", "time.end=5.0", "--steps",
                          ",".join(map(str, steps)), "--reference", "exact", "--json",
                          "--out", str(tmp_path / "o")],
                         capture_output=True, text=True, check=True)
    theirs = json.loads(out.stdout)
    assert [r["error"] for r in mine["runs"]] == [r["error"] for r in theirs["runs"]]
    assert mine["order"] == theirs["order"] and mine["order"] > 1.5
    with pytest.raises(femvi.InputError, match="--reference"):
        femvi.convergence(f, steps, reference="nope")
