"""Ensembles: members equal single solves bit for bit; errors stay per member; Dask."""

import numpy as np
import pytest

import femvi
from conftest import EXAMPLES

KEPLER = EXAMPLES / "kepler.toml"
SHORT = {"time.end": 3.0}


def states(m, seed=1):
    rng = np.random.default_rng(seed)
    q = np.column_stack([0.4 + 0.1 * rng.random(m), np.zeros(m)])
    p = np.column_stack([np.zeros(m), 1.8 + 0.2 * rng.random(m)])
    return np.hstack([q, p])


def test_members_equal_single_solves():
    s = states(6)
    ens = femvi.ensemble(KEPLER, initial_states=s, workers=2, **SHORT)
    assert ens.final_q.shape == (6, 2) and ens.final_t.shape == (6,) and ens.errors == [None] * 6
    for i in range(6):
        sol = femvi.solve(KEPLER, **SHORT, **{"initial.q": s[i, :2].tolist(), "initial.p": s[i, 2:].tolist()})
        assert np.array_equal(sol.q[-1], ens.final_q[i]) and np.array_equal(sol.p[-1], ens.final_p[i])
        assert sol.max_rel_energy_error == ens.energy_error[i] and sol.t[-1] == ens.final_t[i]


def test_dict_states_velocity_and_parameters():
    s = states(4)
    a = femvi.ensemble(KEPLER, initial_states={"q": s[:, :2], "p": s[:, 2:]}, **SHORT)
    b = femvi.ensemble(KEPLER, initial_states=s, workers=1, **SHORT)
    assert np.array_equal(a.final_q, b.final_q)
    v = femvi.ensemble(KEPLER, initial_states={"q": s[:, :2], "v": s[:, 2:]}, **SHORT)
    assert np.array_equal(v.final_q, b.final_q)  # kepler: v = p
    mu = np.array([0.9, 1.0, 1.1])
    c = femvi.ensemble(KEPLER, parameters={"mu": mu}, **SHORT)
    for i in range(3):
        sol = femvi.solve(KEPLER, **SHORT, **{"system.parameters.mu": float(mu[i])})
        assert np.array_equal(sol.q[-1], c.final_q[i])


def test_errors_per_member():
    h = {
        "system": {"model": "harmonic", "parameters": {"m": 1.0, "k": 1.0}},
        "initial": {"q": [1.0], "p": [0.0]},
        "scheme": {"degree": 1, "quadrature": "trapezoid"},
        "time": {"step": 1.0, "end": 5000.0},
    }
    k = np.array([1.0, 6.25, 2.0])  # h·ω = 2.5 is unstable
    ens = femvi.ensemble(h, parameters={"k": k})
    assert ens.errors[0] is None and ens.errors[2] is None
    assert ens.errors[1] is not None and "step" in ens.errors[1]
    assert list(ens.ok) == [True, False, True]
    assert np.isfinite(ens.final_q[[0, 2]]).all()


def test_bad_ensemble_input():
    with pytest.raises(femvi.InputError, match="columns"):
        femvi.ensemble(KEPLER, initial_states=np.zeros((3, 3)), **SHORT)
    with pytest.raises(femvi.InputError, match="numbers of members"):
        femvi.ensemble(KEPLER, initial_states=states(3), parameters={"mu": [1.0, 2.0]}, **SHORT)


def test_dask_ensemble_equals_local():
    distributed = pytest.importorskip("dask.distributed", reason="dask[distributed] is not installed")
    import femvi.dask

    s = states(10)
    local = femvi.ensemble(KEPLER, initial_states=s, saveat=[0.5, 1.5], **SHORT)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        remote = femvi.dask.ensemble(client, KEPLER, initial_states=s, chunks=3, workers=1,
                                     saveat=[0.5, 1.5], **SHORT)
    for key in ("final_t", "final_q", "final_p", "energy_error", "steps", "saved_q", "saved_p"):
        assert np.array_equal(local[key], remote[key]), key
    assert remote.errors == local.errors


@pytest.mark.parametrize("call", ["solve", "ensemble"])
def test_gil_released_during_runs(call):
    """A run of about a second in a thread; this thread, which needs the GIL for every
    loop iteration, must never wait nearly that long."""
    import threading
    import time

    def work():
        if call == "solve":
            femvi.solve(KEPLER, every=0, **{"time.end": 100000.0})
        else:
            femvi.ensemble(KEPLER, initial_states=states(1200), workers=1, **{"time.end": 100.0})

    thread = threading.Thread(target=work)
    start = last = time.perf_counter()
    gap = 0.0
    thread.start()
    while thread.is_alive():
        now = time.perf_counter()
        gap, last = max(gap, now - last), now
    thread.join()
    assert last - start > 0.3, "the run was too short to tell"
    assert gap < min(0.15, (last - start) / 3), f"this thread waited {gap:.3f} s for the GIL"


def test_progress_reaches_the_total(capsys):
    seen = []
    states = np.tile([0.4, 0.0, 0.0, 2.0], (50, 1))
    ens = femvi.ensemble(EXAMPLES / "kepler.toml", initial_states=states, workers=2, progress=False,
                         **{"time.end": 20.0})
    assert len(ens.final_q) == 50
    # The Rust side calls the callback with (done, total) and at the end with (total, total).
    raw = femvi._core.ensemble_file(str(EXAMPLES / "kepler.toml"), None, states, False, 1, 2,
                                    lambda done, total: seen.append((done, total)))
    assert seen and seen[-1] == (50, 50) and all(0 <= d <= t == 50 for d, t in seen)
    assert raw["final_q"].shape == (50, 2)
    femvi.ensemble(EXAMPLES / "kepler.toml", initial_states=states[:3], progress=True, **{"time.end": 1.0})
    out = capsys.readouterr()
    assert "3/3" in out.err or "femvi ensemble" in out.err


def test_saveat_rows_equal_single_solves():
    s = states(4)
    times = [0.25, 1.0, 2.5, 50.0]  # the last one is past the end: NaN
    ens = femvi.ensemble(KEPLER, initial_states=s, saveat=times, **SHORT)
    plain = femvi.ensemble(KEPLER, initial_states=s, **SHORT)
    assert ens.saved_q.shape == (4, 4, 2) and list(ens.saved_t) == times
    for key in ("final_t", "final_q", "final_p", "energy_error", "steps"):
        assert np.array_equal(ens[key], plain[key]), key
    for i in range(4):
        start = {"initial.q": [float(x) for x in s[i, :2]], "initial.p": [float(x) for x in s[i, 2:]]}
        one = femvi.solve(KEPLER, saveat=times[:3], **start, **SHORT)
        assert np.array_equal(ens.saved_q[i, :3], one.saved.q) and np.array_equal(ens.saved_p[i, :3], one.saved.p)
        assert np.isnan(ens.saved_q[i, 3]).all()


@pytest.mark.parametrize(
    "scheme",
    [{"degree": 1, "quadrature": "trapezoid"}, {"degree": 2, "quadrature": "gauss-legendre"}],
    ids=["verlet", "fixed-point"],
)
def test_members_in_lanes_equal_member_by_member_runs(scheme):
    # Störmer–Verlet (degree 1, trapezoid) and the fixed-point step of degree 2: the members
    # go eight at a time in SIMD lanes. Hénon–Heiles, 19 members (a full chunk of 16 and a
    # partial one) with energies across the escape energy 1/6: those above it leave the well
    # and fail mid-run (Verlet: their energy overflows; the fixed-point iteration stalls
    # first). Against the member-by-member path (saveat takes it) and, for members that do
    # not fail, against single solves.
    hh = {
        "system": {"model": "henon-heiles"},
        "initial": {"q": [0.0, 0.1], "p": [0.2, 0.0]},
        "scheme": scheme,
        "time": {"step": 0.05, "end": 100.0},
    }
    e = 0.02 + 0.02 * np.arange(19)
    s = np.column_stack([np.zeros(19), np.full(19, 0.1), np.sqrt(2 * e), np.zeros(19)])
    lanes = femvi.ensemble(hh, initial_states=s, workers=2)
    one_by_one = femvi.ensemble(hh, initial_states=s, workers=2, saveat=[1.0])
    for name in ["final_t", "final_q", "final_p", "energy_error", "steps"]:
        a, b = getattr(lanes, name), getattr(one_by_one, name)
        assert np.array_equal(a, b, equal_nan=True), name
    assert lanes.errors == one_by_one.errors
    failed = [i for i, err in enumerate(lanes.errors) if err]
    assert 2 <= len(failed) < 15
    if scheme["degree"] == 1:
        assert all("non-finite energy" in lanes.errors[i] for i in failed)
    assert all(0 < lanes.steps[i] < 2000 and lanes.final_t[i] < 100.0 for i in failed)
    for i in [0, 3, 7]:
        sol = femvi.solve(hh, **{"initial.q": s[i, :2].tolist(), "initial.p": s[i, 2:].tolist()})
        assert np.array_equal(sol.q[-1], lanes.final_q[i]) and np.array_equal(sol.p[-1], lanes.final_p[i])
        assert sol.max_rel_energy_error == lanes.energy_error[i]
