"""Python results equal `femvi run`'s bit for bit: summary.json and every trajectory.csv row."""

import numpy as np
import pytest

import femvi
from conftest import EXAMPLES, same

PROBLEMS = [
    "kepler", "pendulum", "henon-heiles", "double-pendulum", "variable-steps",
    "energy-henon-heiles", "harmonic-q1-start", "kepler-accuracy", "henon-heiles-section",
    "relativistic-kepler",
]


@pytest.mark.parametrize("name", PROBLEMS)
def test_equals_cli(name, run_cli):
    path = EXAMPLES / f"{name}.toml"
    code, summary, rows, _ = run_cli(path)
    assert code == 0
    sol = femvi.solve(path)
    assert sol.error is None and summary["error"] is None
    assert sol.steps == summary["steps"]
    assert same(sol.q[-1], summary["final_q"]) and same(sol.p[-1], summary["final_p"])
    assert sol.t[-1] == summary["final_t"]
    assert sol.max_rel_energy_error == summary["max_rel_energy_error"]
    assert sol.energy_nodes == summary["energy_nodes"]
    assert sol.mean_iterations == summary["mean_solver_iterations"]
    header, body = rows[0], rows[1:]
    n = len(sol.coordinates)
    assert header[2:2 + n] == sol.coordinates
    table = np.array([[float(x) for x in r] for r in body])
    assert len(table) == len(sol.t)
    assert (table[:, 0].astype(np.int64) == sol.node).all()
    assert same(table[:, 1], sol.t)
    assert same(table[:, 2:2 + n], sol.q)
    assert same(table[:, 2 + n:2 + 2 * n], sol.p)
    assert same(table[:, 2 + 2 * n], sol.energy)
    if "events_located" in summary:  # [[events]] in the file: located as the command does
        assert len(sol.events) == summary["events_located"] and all(e["from_file"] for e in sol.events)


def test_overrides_equal_edited_file(run_cli, tmp_path):
    text = (EXAMPLES / "kepler.toml").read_text().replace("step = 0.05", "step = 0.1").replace(
        "end = 62.83185307179586", "end = 10.0")
    edited = tmp_path / "kepler.toml"
    edited.write_text(text)
    _, summary, _, _ = run_cli(edited)
    a = femvi.solve(EXAMPLES / "kepler.toml", **{"time.step": 0.1, "time.end": 10.0})
    b = femvi.solve(str(EXAMPLES / "kepler.toml"), overrides={"time.step": 0.1}, **{"time.end": 10.0})
    assert same(a.q[-1], summary["final_q"]) and same(b.q, a.q) and same(b.p, a.p)
