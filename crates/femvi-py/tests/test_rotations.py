"""Problems with rotations through femvi.solve and femvi.ensemble (issue 37): the same runs as
`femvi run` (every trajectory.csv column of the nodes bit for bit), the body quantities of
`Solution.rotation` against the command's columns, saveat, dense output and events on SO(3)
(the element's path R_k exp(zeta(tau))), torques with their work, and ensembles."""

import numpy as np
import pytest

import femvi
from conftest import EXAMPLES, columns, same


def defect(r):
    """max |R^T R - 1| over a stack of matrices."""
    r = np.asarray(r).reshape(-1, 3, 3)
    return np.abs(np.einsum("nji,njk->nik", r, r) - np.eye(3)).max()


@pytest.mark.parametrize("name", ["rigid/free-body", "rigid/damped-body", "rigid/heavy-top-expression"])
def test_equals_cli(name, run_cli):
    path = EXAMPLES / f"{name}.toml"
    code, summary, rows, err = run_cli(path)
    assert code == 0, err
    sol = femvi.solve(path)
    assert sol.error is None and sol.steps == summary["steps"] and sol.rotations == ["R"]
    col = columns(rows)
    assert same(col["t"], sol.t)
    for i, c in enumerate(sol.coordinates):
        assert same(col[c], sol.q[:, i]) and same(col[f"p_{c}"], sol.p[:, i])
    assert same(col["energy"], sol.energy)
    body = sol.rotation("R")
    for k in range(3):
        assert np.abs(col[f"p_R{k + 1}"] - body.pi[:, k]).max() < 1e-14  # summation order
        assert np.abs(col[f"R_w{k + 1}"] - body.w[:, k]).max() < 1e-12
    if "work" in col:
        assert same(col["work"], sol.work)
        assert sol.max_rel_energy_balance_error < 1e-10


def test_saveat_dense_and_events_stay_on_so3():
    path = EXAMPLES / "rigid" / "free-body.toml"
    times = np.linspace(0.0, 10.0, 101) + 0.0037
    sol = femvi.solve(path, {"time.end": 10.5, "time.step": 0.05}, saveat=times[:-1], dense=True,
                      events=[femvi.Event("R33 - 0.9")])
    assert defect(sol.saved.q[:, :9]) < 1e-14
    assert defect(sol.q_at(times[:-1])[:, :9]) < 1e-14
    assert sol.events and all(defect(np.array(e["q"][:9])) < 1e-14 for e in sol.events)
    # The samples between nodes converge to a finer run's at the interpolation order s + 1 = 3.
    errors = []
    for h in [0.1, 0.05, 0.025]:
        coarse = femvi.solve(path, {"time.end": 10.5, "time.step": h}, saveat=times[:-1])
        fine = femvi.solve(path, {"time.end": 10.5, "time.step": h / 16}, saveat=times[:-1])
        errors.append(np.abs(coarse.saved.q - fine.saved.q).max())
    order = np.log(errors[0] / errors[2]) / np.log(4.0)
    assert order > 2.7, (errors, order)


def test_ensemble_members_are_single_runs():
    path = EXAMPLES / "rigid" / "free-body.toml"
    one = femvi.solve(path, {"time.end": 2.0})
    # Start rows (R, R w-hat): the file's start, and a body turned by a quarter about z.
    w = np.array([0.5, 1.0, 0.3])
    hat = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    turns = [np.eye(3), np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])]
    states = {"q": [r.reshape(-1) for r in turns], "v": [(r @ hat).reshape(-1) for r in turns]}
    res = femvi.ensemble(path, states, overrides={"time.end": 2.0}, progress=False)
    assert same(res.final_q[0], one.final_q) and same(res.final_p[0], one.final_p)
    assert defect(res.final_q[1]) < 1e-14
    # The body columns: w and Pi at the last node, against the solution's own (NumPy) ones.
    body = one.rotation("R")
    assert res.body.shape == (2, 6)
    assert np.abs(res.body[0, :3] - body.w[-1]).max() < 1e-13 * np.abs(body.w[-1]).max()
    assert np.abs(res.body[0, 3:] - body.pi[-1]).max() < 1e-13 * np.abs(body.pi[-1]).max()
