"""Problems with [forces] and [constraints] through femvi.solve: the same runs as `femvi run`
(every trajectory.csv column bit for bit, summary.json's balance), what the tables add
(work, multipliers, constraint residuals) checked against the physics, and the options these
runs do not take refused with a message."""

import numpy as np
import pytest

import femvi
from conftest import EXAMPLES, columns, same


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


def damped(t, c=0.3, k=1.0):
    """x'' + c x' + k x = 0 from (1, 0): x = e^{-ct/2} (cos wt + c/(2w) sin wt)."""
    w = np.sqrt(k - c * c / 4)
    return np.exp(-c * t / 2) * (np.cos(w * t) + c / (2 * w) * np.sin(w * t))


def test_forced_saveat_dense_and_events():
    # The damped oscillator of the example (k = 1, c = 0.3, degree 2 Gauss, h = 0.05) sampled
    # from the forced element polynomials, against the closed form; the nodes, the work and
    # the balance are those of the run without samples, bit for bit.
    path = EXAMPLES / "forces" / "damped-oscillator.toml"
    plain = femvi.solve(path)
    times = [0.33, 1.0, 7.77, 19.99]
    sol = femvi.solve(path, saveat=times, dense=True, events=[femvi.Event(lambda t, q, v: q[0], direction="falling")])
    assert sol.error is None
    assert same(sol.t, plain.t) and same(sol.q, plain.q) and same(sol.p, plain.p)
    assert same(sol.work, plain.work)
    assert sol.max_rel_energy_balance_error == plain.max_rel_energy_balance_error
    assert np.allclose(sol.saved.t, times)
    assert np.abs(sol.saved.q[:, 0] - damped(np.array(times))).max() <= 1e-6
    grid = np.linspace(0.0, 20.0, 401)
    assert np.abs(sol(grid)[:, 0] - damped(grid)).max() <= 1e-6
    # x falls through 0 where wt = pi/2 + atan(c/(2w)) + 2 j pi.
    w = np.sqrt(1 - 0.3 ** 2 / 4)
    ts = np.array([e["t"] for e in sol.events])
    exact = (np.pi / 2 + np.arctan(0.15 / w) + 2 * np.pi * np.arange(len(ts))) / w
    assert len(ts) == int((20.0 * w - np.pi / 2 - np.arctan(0.15 / w)) // (2 * np.pi)) + 1
    assert np.abs(ts - exact).max() <= 1e-6


def test_forced_energy_mode_saveat_dense_events_and_ensemble():
    # Issue 33: forces in the energy mode are a term of the one integrator, so the run takes
    # saveat, dense output and events with the nodes of the plain solve bit for bit, and runs
    # as ensemble members. Against the closed form of the damped oscillator (c = 0.3, degree
    # 2): halving the first step (the energy equation scales every step with it) divides the
    # nodal error by about 2^4 and the element polynomials' error by about 2^3.
    path = EXAMPLES / "forces" / "damped-oscillator-energy.toml"
    times = np.array([0.33, 1.0, 7.77, 19.99])
    grid = np.linspace(0.0, 20.0, 401)
    w = np.sqrt(1 - 0.3 ** 2 / 4)
    errors = []
    for dt in (0.05, 0.025):
        plain = femvi.solve(path, dt=dt)
        assert plain.error is None and np.ptp(np.diff(plain.t)) > 0.01 * dt  # the steps vary
        falling = femvi.Event(lambda t, q, v: q[0], direction="falling")
        sol = femvi.solve(path, dt=dt, saveat=list(times), dense=True, events=[falling])
        assert sol.error is None
        assert same(sol.t, plain.t) and same(sol.q, plain.q) and same(sol.p, plain.p)
        assert same(sol.work, plain.work)
        ts = np.array([e["t"] for e in sol.events])
        exact = (np.pi / 2 + np.arctan(0.15 / w) + 2 * np.pi * np.arange(len(ts))) / w
        assert len(ts) == int((20.0 * w - np.pi / 2 - np.arctan(0.15 / w)) // (2 * np.pi)) + 1
        errors.append((
            np.abs(sol.q[:, 0] - damped(sol.t)).max(),
            max(np.abs(sol(grid)[:, 0] - damped(grid)).max(), np.abs(sol.saved.q[:, 0] - damped(times)).max()),
            np.abs(ts - exact).max(),
        ))
    (nodal, between, event), (nodal2, between2, event2) = errors
    assert nodal / nodal2 >= 12 and nodal2 <= 1e-7, errors
    assert between / between2 >= 6 and between2 <= 1e-6, errors
    assert event / event2 >= 3 and event2 <= 5e-6, errors
    ens = femvi.ensemble(path, {"q": [[1.0], [0.5]], "v": [[0.0], [0.0]]})
    single = femvi.solve(path)
    assert all(e is None for e in ens.errors)
    assert ens.final_q[0, 0] == single.q[-1, 0] and ens.final_p[0, 0] == single.p[-1, 0]
    assert abs(ens.final_q[1, 0] - 0.5 * damped(ens.final_t[1])) <= 1e-5


def test_options_these_runs_do_not_take_are_refused():
    path = EXAMPLES / "forces" / "damped-oscillator.toml"
    with pytest.raises(femvi.InputError, match="fixed"):
        femvi.convergence(EXAMPLES / "forces" / "damped-oscillator-energy.toml", steps=[0.1, 0.05])
    # max_steps and every are taken.
    sol = femvi.solve(path, max_steps=10, every=2)
    assert sol.steps == 10 and len(sol.t) == 6
    # ... with saveat too: the work at the last node kept (the step limit's).
    cut = femvi.solve(path, max_steps=10, every=3, saveat=[0.2])
    full = femvi.solve(path, every=1)
    assert list(cut.t) == [full.t[k] for k in (0, 3, 6, 9, 10)]
    assert same(cut.work, full.work[[0, 3, 6, 9, 10]])


def test_constrained_saveat_dense_and_events():
    # Issue 33: a constrained run is the one integrator with the constraints as its term, so
    # it takes saveat, dense output and events (on its element polynomials); its nodes, the
    # multipliers and the residuals are those of the plain solve, bit for bit.
    for name in ("spherical-pendulum", "damped-spherical-pendulum"):
        path = EXAMPLES / "constrained" / f"{name}.toml"
        plain = femvi.solve(path, t_span=(0.0, 4.0), every=3)
        cross = femvi.Event(lambda t, q, v: q[0], name="cross")
        sol = femvi.solve(path, t_span=(0.0, 4.0), every=3, saveat=[0.5, 1.5, 3.25], dense=True, events=[cross])
        assert same(sol.t, plain.t) and same(sol.q, plain.q) and same(sol.p, plain.p)
        assert same(sol.energy, plain.energy)
        assert same(sol.multipliers, plain.multipliers) and same(sol.constraint_residual, plain.constraint_residual)
        assert sol.max_constraint_residual == plain.max_constraint_residual
        if plain.work is not None:
            assert same(sol.work, plain.work)
            assert sol.max_rel_energy_balance_error == plain.max_rel_energy_balance_error
        assert len(sol.events) >= 2
        for e in sol.events:
            assert abs(e["q"][0]) < 1e-12 and abs(np.linalg.norm(e["q"]) - 1.0) < 1e-5
        assert np.abs(np.linalg.norm(sol.saved.q, axis=1) - 1.0).max() < 1e-5
        ts = np.linspace(0.0, 4.0, 41)
        assert np.abs(np.linalg.norm(sol.q_at(ts), axis=1) - 1.0).max() < 1e-5
        assert same(sol.q_at(sol.t), sol.q)


def test_forced_ensemble_members_meet_the_closed_form():
    # Two members of the damped oscillator, (1, 0) and (0.5, 0), with saveat: the samples and
    # the final states against the closed form, member 0 the single solve bit for bit, and
    # the energy error is the balance's.
    path = EXAMPLES / "forces" / "damped-oscillator.toml"
    ens = femvi.ensemble(path, {"q": [[1.0], [0.5]], "v": [[0.0], [0.0]]}, saveat=[2.5, 7.5])
    assert all(e is None for e in ens.errors)
    for i, x0 in enumerate([1.0, 0.5]):
        assert np.abs(ens.saved_q[i, :, 0] - x0 * damped(np.array([2.5, 7.5]))).max() <= 1e-6 * x0
        assert abs(ens.final_q[i, 0] - x0 * damped(20.0)) <= 1e-6 * x0
    single = femvi.solve(path)
    assert ens.final_q[0, 0] == single.q[-1, 0] and ens.final_p[0, 0] == single.p[-1, 0]
    assert ens.energy_error[0] == single.max_rel_energy_balance_error
