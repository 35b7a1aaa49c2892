"""Input forms, options, errors, models."""

import numpy as np
import pytest

import femvi
from conftest import EXAMPLES

HARMONIC = {
    "system": {"model": "harmonic", "parameters": {"m": 1.0, "k": 1.0}},
    "initial": {"q": [1.0], "p": [0.0]},
    "scheme": {"degree": 1, "quadrature": "trapezoid"},
    "time": {"step": 0.1, "end": 10.0},
}


def test_dict_and_text_and_path_agree(tmp_path):
    text = femvi.dumps(HARMONIC)
    f = tmp_path / "h.toml"
    f.write_text(text)
    a, b, c = femvi.solve(HARMONIC), femvi.solve(text), femvi.solve(f)
    for s in (b, c):
        assert np.array_equal(a.q, s.q) and np.array_equal(a.p, s.p) and np.array_equal(a.energy, s.energy)
    assert a.q.shape == (101, 1) and a.t.shape == (101,) and a.v.shape == (101, 1)
    assert a.coordinates == ["x"] or len(a.coordinates) == 1


def test_toml_round_trip_of_floats():
    import tomllib
    values = [0.1, 1 / 3, 1e-300, 2.5e16, -0.0, 123456789.123456789]
    back = tomllib.loads(femvi.dumps({"a": {"x": values, "s": 'q"uote\\'}}))
    assert back["a"]["x"] == values and back["a"]["s"] == 'q"uote\\'


def test_every_saveat_dense():
    sol = femvi.solve(HARMONIC, every=10, saveat=[0.05, 1.0, 2.55], dense=True)
    assert len(sol) == 11 and list(sol.node[:3]) == [0, 10, 20]
    assert np.allclose(sol.saved.t, [0.05, 1.0, 2.55])
    assert np.allclose(sol.saved.q[:, 0], np.cos(sol.saved.t), atol=1e-2)
    assert np.allclose(sol(sol.saved.t), sol.saved.q)
    assert sol.q_at(2.55).shape == (1,)
    assert sol.q_at(np.zeros((2, 3))).shape == (2, 3, 1)
    with pytest.raises(ValueError):
        femvi.solve(HARMONIC).q_at(0.5)


def test_max_steps():
    sol = femvi.solve(HARMONIC, max_steps=7)
    assert sol.steps == 7 and sol.node[-1] == 7 and sol.stopped


def test_input_error_message_is_the_commands(run_cli, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(femvi.dumps({**HARMONIC, "time": {"stp": 0.1, "end": 1.0}}))
    code, _, _, stderr = run_cli(bad)
    assert code == 2
    with pytest.raises(femvi.InputError) as e:
        femvi.solve(bad)
    assert stderr.strip() == f"error: {e.value}"
    with pytest.raises(femvi.InputError, match="did you mean 'kepler'"):
        femvi.solve({**HARMONIC, "system": {"model": "keplr"}})
    with pytest.raises(femvi.InputError, match="<problem>"):
        femvi.solve({**HARMONIC, "time": {"step": -1.0, "end": 1.0}})


def test_numerical_error_has_step_and_partial_solution():
    unstable = {**HARMONIC, "time": {"step": 2.5, "end": 5000.0}}
    with pytest.raises(femvi.NumericalError) as e:
        femvi.solve(unstable)
    err = e.value
    assert err.step is not None and err.step > 0 and err.t == pytest.approx(2.5 * err.step)
    assert err.solution is not None and err.solution.error == str(err)
    # |q| grows until q² overflows: the energy of node `step` is infinite while q is not yet,
    # and the run ends there, as `femvi run` does; the nodes before it are kept, all finite.
    assert str(err).startswith(f"non-finite energy at step {err.step}")
    assert len(err.solution) == err.step
    assert np.isfinite(err.solution.q).all() and np.isfinite(err.solution.energy).all()
    sol = femvi.solve(unstable, raise_on_error=False)
    assert sol.error == str(err)


def test_models_and_model_problem():
    names = [m["name"] for m in femvi.models()]
    assert "kepler" in names and "outer-solar-system" in names
    kepler = next(m for m in femvi.models() if m["name"] == "kepler")
    assert "mu" in kepler["parameters"] and kepler["coordinates"] == ["x", "y"]
    text = femvi.model_problem("kepler")
    assert text == (EXAMPLES / "models" / "kepler.toml").read_text()
    assert femvi.solve(text).error is None
    with pytest.raises(femvi.InputError, match="did you mean"):
        femvi.model_problem("keplr")


def test_check_and_bvp():
    report = femvi.check(EXAMPLES / "kepler.toml", **{"time.end": 5.0})
    assert report["steps"] == 100 and report["max_rel_energy_error"] < 1e-8
    s = femvi.bvp(EXAMPLES / "bvp-pendulum.toml")
    assert s.get("error") is None


def test_check_of_a_forced_problem_reports_its_energy_balance():
    # One check for every kind of problem: with [forces] the flow is not symplectic, and the
    # report is the energy balance H - H0 = W (friction only: W < 0, and H falls by it).
    report = femvi.check(EXAMPLES / "forces" / "damped-oscillator.toml")
    assert "symplecticity_defect" not in report and report["error"] is None
    assert report["final_work"] < 0 and report["energy_last"] < report["energy_first"]
    change = report["energy_last"] - report["energy_first"]
    assert abs(change - report["final_work"]) <= report["max_energy_balance_error"] + 1e-15
    assert report["max_rel_energy_balance_error"] < 1e-6


def test_events_from_python():
    def x_zero(t, q, v):
        return q[0]

    sol = femvi.solve(HARMONIC, events=[femvi.Event(x_zero, direction="falling"), lambda t, q, v: t - 3.0])
    falling = [e for e in sol.events if e["name"] == "x_zero"]
    assert [round(e["t"], 2) for e in falling] == [1.57, 7.85]  # cos t falls through 0 at π/2, 5π/2
    assert all(abs(e["q"][0]) < 1e-12 for e in falling)
    assert [e["t"] for e in sol.events if e["event"] == 1] == [pytest.approx(3.0)]
    stopped = femvi.solve(HARMONIC, events=[femvi.Event(x_zero, stop=True)])
    assert stopped.stopped and stopped.t[-1] < 2.0

    def broken(t, q, v):
        raise KeyError("inside g")

    with pytest.raises(KeyError, match="inside g"):
        femvi.solve(HARMONIC, events=[broken])
    with pytest.raises(femvi.InputError, match="direction"):
        femvi.solve(HARMONIC, events=[femvi.Event(x_zero, direction="up")])


def test_first_element_failure_is_numerical(run_cli, tmp_path):
    q1 = {"system": {"model": "kepler"}, "initial": {"q": [1.0, 0.0], "q1": [-1.0, 0.0]},
          "scheme": {"degree": 3}, "time": {"step": 0.5, "end": 1.0}}
    f = tmp_path / "q1.toml"
    f.write_text(femvi.dumps(q1))
    code, summary, _, _ = run_cli(f)
    with pytest.raises(femvi.NumericalError) as e:
        femvi.solve(f)
    assert code == 1 and str(e.value) == summary["error"] and str(e.value).startswith("first element")
    assert e.value.step == 0 and len(e.value.solution) == 0


def test_unreadable_problems_are_input_errors(tmp_path):
    with pytest.raises(femvi.InputError, match="cannot read the problem file"):
        femvi.solve(tmp_path / "missing.toml", **{"time.end": 1.0})
    with pytest.raises(femvi.InputError, match="<problem>"):
        femvi.solve("[system\nmodel = 1\n", **{"time.end": 1.0})
    with pytest.raises(TypeError):
        femvi.solve(42)


def test_adaptive_runs_equal_the_command(run_cli, tmp_path):
    f = tmp_path / "ecc.toml"
    f.write_text(femvi.problem_text(EXAMPLES / "kepler-eccentric.toml", {"time.end": 20.0}))
    sol = femvi.solve(f)
    code, summary, rows, err = run_cli(f)
    assert code == 0, err
    assert list(sol.q[-1]) == summary["final_q"] and list(sol.p[-1]) == summary["final_p"]
    assert sol.max_rel_energy_error == summary["max_rel_energy_error"]
    assert sol.s is not None and np.all(np.diff(sol.s) > 0) and np.all(np.diff(sol.t) > 0)
    # The physical steps shrink near pericentre (e = 0.99): adaptive, not fixed.
    dt = np.diff(sol.t)
    assert dt.max() / dt.min() > 100
    # Uniform physical times as the command's output_step rows.
    times = [float(r[1]) for r in rows[1:]]
    again = femvi.solve(f, saveat=times)
    assert np.array_equal(again.saved.t, times)
    assert np.array_equal(again.saved.q, np.array([[float(x) for x in r[2:4]] for r in rows[1:]]))
    assert np.array_equal(again.saved.p, np.array([[float(x) for x in r[4:6]] for r in rows[1:]]))


def test_adaptive_events_from_python():
    # Pericentre passages of the e = 0.99 orbit (y = 0 rising) at t = 2πk by the closed form.
    period = 2 * np.pi
    sol = femvi.solve(EXAMPLES / "kepler-eccentric.toml", events=[femvi.Event(lambda t, q, v: q[1], direction="rising")],
                      **{"time.end": 3.5 * period})
    assert [e["event"] for e in sol.events] == [0, 0, 0]
    for k, e in enumerate(sol.events, start=1):
        assert abs(e["t"] - k * period) < 1e-9 and abs(e["q"][0] - 0.01) < 1e-9
    stopped = femvi.solve(EXAMPLES / "kepler-eccentric.toml",
                          events=[femvi.Event(lambda t, q, v: q[1], direction="falling", stop=True)])
    assert stopped.stopped and np.pi <= stopped.t[-1] < np.pi + 0.2

    def broken(t, q, v):
        raise KeyError("inside g")

    with pytest.raises(KeyError, match="inside g"):
        femvi.solve(EXAMPLES / "kepler-eccentric.toml", events=[broken], **{"time.end": 1.0})


def test_adaptive_ensembles_are_the_single_runs(tmp_path):
    # Members of the e = 0.99 Kepler problem in adaptive mode: each the adaptive solve of its
    # start (final node, energy error, the states at saveat) bit for bit.
    f = tmp_path / "ecc.toml"
    f.write_text(femvi.problem_text(EXAMPLES / "kepler-eccentric.toml", {"time.end": 10.0}))
    starts = np.array([[0.01, 0, 0, 14.106735979665885], [1.0, 0.0, 0.0, 1.0]])
    times = [2.5, 7.5]
    ens = femvi.ensemble(f, initial_states=starts, saveat=times)
    assert all(e is None for e in ens.errors)
    for i, s in enumerate(starts):
        single = femvi.solve(femvi.problem_text(f, {"initial.q": list(s[:2]), "initial.p": list(s[2:])}),
                             saveat=times)
        assert np.array_equal(ens.final_q[i], single.q[-1]) and np.array_equal(ens.final_p[i], single.p[-1])
        assert ens.energy_error[i] == single.max_rel_energy_error
        assert np.array_equal(ens.saved_q[i], single.saved.q)


def test_problem_files_are_read_with_a_bound(tmp_path, monkeypatch):
    """A problem file with a NUL byte is refused as not text, and one past the size limit
    (lowered here, the module's constant) as too large, both as InputError (issue 34)."""
    import femvi._problem as problem

    nul = tmp_path / "nul.toml"
    nul.write_bytes(femvi.dumps(HARMONIC).encode() + b"\0")
    with pytest.raises(femvi.InputError, match="NUL byte"):
        femvi.solve(nul)
    big = tmp_path / "big.toml"
    big.write_text(femvi.dumps(HARMONIC) + "# padding\n" * 1000)
    # The Python reader (used when a file is read into a dict, e.g. for overrides); the
    # command's loader behind a plain path has its own bound (femvi_cli::bounded).
    monkeypatch.setattr(problem, "MAX_PROBLEM_BYTES", 4096)
    with pytest.raises(femvi.InputError, match="limit of"):
        problem.to_dict(big)
    monkeypatch.setattr(problem, "MAX_PROBLEM_BYTES", 1 << 20)
    assert problem.to_dict(big)[0]["time"]["step"] == 0.1
    assert femvi.solve(big).steps == 100
