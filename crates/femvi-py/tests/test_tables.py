"""Problems with [forces] and [constraints] through femvi.solve: the same runs as `femvi run`
(every trajectory.csv column bit for bit, summary.json's balance), what the tables add
(work, multipliers, constraint residuals) checked against the physics, and the options these
runs do not take refused with a message."""

import numpy as np
import pytest

import femvi
from conftest import EXAMPLES


def same(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and (a.view(np.uint64) == b.view(np.uint64)).all()


def columns(rows):
    header, body = rows[0], rows[1:]
    table = np.array([[float(x) for x in r] for r in body])
    return {name: table[:, i] for i, name in enumerate(header)}


@pytest.mark.parametrize("name", [
    "forces/damped-oscillator", "forces/forced-duffing", "constrained/spherical-pendulum",
    "constrained/damped-spherical-pendulum",
])
def test_equals_cli(name, run_cli):
    path = EXAMPLES / f"{name}.toml"
    code, summary, rows, err = run_cli(path)
    assert code == 0, err
    sol = femvi.solve(path)
    assert sol.error is None and sol.steps == summary["steps"]
    col = columns(rows)
    assert same(col["t"], sol.t)
    for i, c in enumerate(sol.coordinates):
        assert same(col[c], sol.q[:, i]) and same(col[f"p_{c}"], sol.p[:, i])
    assert same(col["energy"], sol.energy)
    if "work" in col:
        assert same(col["work"], sol.work)
        assert sol.max_rel_energy_balance_error == summary["max_rel_energy_balance_error"]
    else:
        assert sol.work is None
    if "residual" in col:
        assert same(col["residual"], sol.constraint_residual)
        m = sol.multipliers.shape[1]
        for k in range(m):
            assert same(col[f"lambda_{k + 1}"], sol.multipliers[:, k])
    else:
        assert sol.multipliers is None


def test_what_the_tables_add_holds():
    # The damped, driven spherical pendulum (m = l = 1, g = 9.81, friction c = 0.3, drive
    # f0 cos(w t) along x): on the sphere at every node, H − H0 − W small against W.
    sol = femvi.solve(EXAMPLES / "constrained" / "damped-spherical-pendulum.toml")
    assert sol.error is None
    assert np.abs(np.linalg.norm(sol.q, axis=1) - 1.0).max() <= 1e-13
    assert sol.max_constraint_residual <= 1e-13
    balance = np.abs(sol.energy - sol.energy[0] - sol.work).max()
    assert balance <= sol.max_energy_balance_error  # kept nodes are a subset of every node
    assert balance <= 1e-4 * np.abs(sol.work).max()
    # The multiplier of g = |q|² − 1 (constraint force −Gᵀλ = −2λq): differentiating |q|² = 1
    # twice along q̈ = −g e_z − 2λq + F gives λ = (|v|² − g z + q·F) / 2, and q·F is the
    # drive's f0 cos(w t) x (the friction −c v is tangent: q·v = 0).
    g, f0, w = 9.81, 0.5, 2.5
    x, z = sol.q[:, 0], sol.q[:, 2]
    expected = 0.5 * ((sol.v ** 2).sum(axis=1) - g * z + f0 * np.cos(w * sol.t) * x)
    lam = sol.multipliers[:, 0]
    assert np.abs(lam - expected).max() <= 1e-12 * np.abs(expected).max()


def test_options_these_runs_do_not_take_are_refused():
    path = EXAMPLES / "forces" / "damped-oscillator.toml"
    with pytest.raises(femvi.InputError, match="saveat"):
        femvi.solve(path, saveat=[1.0])
    with pytest.raises(femvi.InputError, match="events"):
        femvi.solve(path, events=[lambda t, q, v: q[0]])
    with pytest.raises(femvi.InputError, match="forces"):
        femvi.ensemble(path, {"q": [[0.1], [0.2]], "v": [[0.0], [0.0]]})
    # max_steps and every are taken.
    sol = femvi.solve(path, max_steps=10, every=2)
    assert sol.steps == 10 and len(sol.t) == 6
