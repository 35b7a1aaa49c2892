"""femvi: variational integrators from finite elements, from Python.

A problem is a :class:`System` (a Lagrangian as a string or a SymPy expression, with
parameters, forces and constraints) or a femvi problem file (the ``femvi run`` format: a
path, a TOML string or a dict of the same structure), with the run set by keywords (``q0``,
``v0``, ``t_span``, ``dt``, ``order``, ...) or by dotted paths::

    import sympy as sp, femvi
    x, x_dot = sp.symbols("x x_dot")
    osc = femvi.System([x], x_dot**2 / 2 - x**2 / 2)
    sol = femvi.solve(osc, q0=[1.0], v0=[0.0], t_span=(0, 10), dt=0.01, order=4)
    sol.t, sol.q, sol.p, sol.energy          # NumPy arrays; sol.to_pandas(), sol.plot()
    sol = femvi.solve("examples/kepler.toml", **{"time.step": 0.01})
    ens = femvi.ensemble("examples/kepler.toml", initial_states=states)   # all cores

Results equal the command's (``femvi run``) bit for bit: a System is run through the problem
file :meth:`System.to_toml` prints.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import tempfile
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence

import numpy as np

from . import _core
from ._core import InputError
from ._problem import apply_overrides, apply_run, dumps, problem_file, problem_text, split_run, to_dict
from ._solution import EnsembleResult, Event, NumericalError, Solution
from ._sympy import to_expression as expression
from ._system import System, _name_of

__version__ = _core.__version__
__all__ = [
    "System", "solve", "ensemble", "models", "model_problem", "check", "convergence", "bvp", "Solution",
    "EnsembleResult", "Event", "InputError", "NumericalError", "problem_text", "dumps", "expression",
    "optimize", "Optimum",
]


def _merge(overrides: Optional[Mapping[str, Any]], kw: Mapping[str, Any]) -> Dict[str, Any]:
    merged = dict(overrides or {})
    merged.update(kw)
    return merged


def _input_error(e: InputError, path: Path, shown: str) -> InputError:
    return InputError(str(e).replace(str(path), shown))


def _python_system(problem: Any, merged: Dict[str, Any]) -> Dict[str, Any]:
    """The problem for a Python potential: its [system] gives `coordinates` only; a
    placeholder Lagrangian lets the command's loader check everything else."""
    d, _ = to_dict(problem)
    apply_overrides(d, merged)
    system = d.get("system")
    if isinstance(system, dict) and ("lagrangian" in system or "model" in system):
        raise InputError("<problem>: give either potential= or [system] `lagrangian`/`model`, not both")
    coords = system.get("coordinates") if isinstance(system, dict) else None
    if not isinstance(system, dict) or not isinstance(coords, list) or not coords or not all(
            isinstance(c, str) for c in coords):
        raise InputError("<problem>: with potential=, [system] needs `coordinates` (a list of names)")
    system["lagrangian"] = " + ".join(f"0.5*{c}_dot^2" for c in coords)
    return d


def solve(problem: Any, overrides: Optional[Mapping[str, Any]] = None, *, every: Optional[int] = None,
          saveat: Optional[Sequence[float]] = None, dense: bool = False, max_steps: Optional[int] = None,
          events: Optional[Sequence[Any]] = None, raise_on_error: bool = True,
          potential: Optional[Callable[[np.ndarray], float]] = None,
          force: Optional[Callable[[np.ndarray], np.ndarray]] = None,
          masses: Optional[Sequence[float]] = None, q0: Any = None, v0: Any = None, p0: Any = None,
          t_span: Optional[Sequence[float]] = None, dt: Optional[float] = None, degree: Optional[int] = None,
          order: Optional[int] = None, quadrature: Optional[str] = None, points: Optional[int] = None,
          nodes: Optional[str] = None, method: Optional[str] = None, mode: Optional[str] = None,
          **kw: Any) -> Solution:
    """Integrates a problem as ``femvi run`` does and returns a :class:`Solution`.

    ``problem``: a :class:`System`, a problem file's path, TOML text, or a dict of the same
    structure. The run: ``q0`` and ``v0`` (or ``p0``) the start, ``t_span = (t0, t1)``, ``dt``
    the step (``ds`` in adaptive mode), ``degree`` (with ``quadrature``, ``points``, ``nodes``)
    or ``order`` (2s: degree s, s-point Gauss), ``method`` (``"auto"``, ``"newton"``,
    ``"fixed-point"``, ``"explicit"``), ``mode`` (``"fixed"``, ``"energy"``, ``"adaptive"``);
    each replaces what the file says (``femvi.problem_text`` shows the result).
    ``overrides`` / keyword arguments: values by dotted path, e.g. ``**{"time.step": 0.01}``.
    ``every``: keep every k-th node (default: the file's ``[output] every``); ``saveat``: times
    at which to report the state (``sol.saved``); ``dense``: keep the dense output
    (``sol.q_at(t)``); ``max_steps``: stop after this many steps; ``events``: :class:`Event`s
    or plain callables g(t, q, v) (located zeros in ``sol.events``).

    ``potential``, ``force``, ``masses``: a system written in Python, for prototyping:
    L = ½ Σ m_i v_i² − V(q) with V = ``potential(q)`` and the force −∇V = ``force(q)`` (both
    take a 1-D NumPy array; ``masses`` default 1); the problem's ``[system]`` then gives only
    ``coordinates``. Each call costs 3–4 µs with NumPy inside (``examples/callable_cost.py``
    measures it); an exception raised by either stops the run and is re-raised. The problem's
    ``[forces]``, ``[constraints]`` and adaptive steps (``[time] mode = "adaptive"``) act on it
    as on a system written in the file. Time steps as variables are refused (they need second
    derivatives), and Newton's iteration matrix takes the force Jacobian by central
    differences (``method = "newton"``, constraints, forces that need it).

    Raises :class:`InputError` for a bad problem (the command's message) and
    :class:`NumericalError` when a step fails or a node's energy is not finite (unless
    ``raise_on_error=False``, which returns
    the partial solution with ``sol.error`` set). The GIL is released during the run.

    >>> import femvi
    >>> sol = femvi.solve(femvi.model_problem("kepler"), dt=0.01, t_span=(0.0, 6.283185307179586))
    >>> sol.steps                   # ceil(2 pi / 0.01): the last step is shorter
    629
    >>> bool(abs(sol.q[-1, 0] - sol.q[0, 0]) < 1e-6)
    True
    """
    evs = [e if isinstance(e, Event) else Event(e) for e in (events or [])]
    # Expression events go into the problem file as [[events]] (compiled, located as the
    # command locates them); callables stay Python's.
    given = getattr(problem, "_given", [])
    compiled = [e._table(given, e.name if e.name != "event" else f"event{i + 1}")
                for i, e in enumerate(evs) if e.expression]
    evs = [e for e in evs if not e.expression]
    run = split_run(dict(q0=q0, v0=v0, p0=p0, t_span=t_span, dt=dt, degree=degree, order=order,
                         quadrature=quadrature, points=points, nodes=nodes, method=method, mode=mode))
    merged = _merge(overrides, kw)
    system = None
    if potential is not None or force is not None:
        if potential is None or force is None:
            raise TypeError("potential= and force= go together (V(q) and -grad V(q))")
        problem, merged = _python_system(problem, merged), {}
        system = (potential, force, None if masses is None else [float(m) for m in masses])
    if compiled:
        problem, _ = to_dict(problem, run)
        apply_overrides(problem, merged)
        problem["events"] = list(problem.get("events", [])) + compiled
        merged = {}
    with problem_file(problem, merged, run) as (path, shown):
        try:
            raw = _core.solve_file(str(path), every=every, saveat=None if saveat is None else
                                   [float(x) for x in saveat], dense=dense, max_steps=max_steps,
                                   events=[e._spec() for e in evs] or None, potential=system)
        except InputError as e:
            raise _input_error(e, path, shown) from None
    sol = Solution(raw)
    if sol.error is not None and raise_on_error:
        raise NumericalError(sol.error, raw.get("error_step"), raw.get("error_t"), sol)
    return sol


def _states(initial_states: Any, n_hint: Optional[int] = None):
    """(array (N, 2n), velocity?) from an array or a dict with "q" and "p" or "v"."""
    if initial_states is None:
        return None, False
    if isinstance(initial_states, Mapping):
        q = np.asarray(initial_states["q"], dtype=np.float64)
        velocity = "v" in initial_states
        x = np.asarray(initial_states["v" if velocity else "p"], dtype=np.float64)
        q, x = np.atleast_2d(q), np.atleast_2d(x)
        return np.ascontiguousarray(np.hstack([q, x])), velocity
    a = np.ascontiguousarray(np.atleast_2d(np.asarray(initial_states, dtype=np.float64)))
    return a, False


def ensemble(problem: Any, initial_states: Any = None, parameters: Optional[Mapping[str, Any]] = None,
             workers: Optional[int] = None, overrides: Optional[Mapping[str, Any]] = None,
             count: Optional[int] = None, progress: Optional[bool] = None,
             saveat: Optional[Sequence[float]] = None, **kw: Any) -> EnsembleResult:
    """N runs of one problem on a pool of ``workers`` Rust threads (default: all cores).

    ``initial_states``: an (N, 2n) array of rows (q0, p0), or a dict with "q" (N, n) and "p" or
    "v" (N, n). ``parameters``: a dict name -> (N,) array of ``[system] parameters``. Each
    member equals the single :func:`solve` of its problem bit for bit; a member's failure is
    recorded in ``errors`` and does not stop the others. Returns an :class:`EnsembleResult`.

    ``saveat``: times at which every member reports its state: ``saved_q`` and ``saved_p``
    (N, len(saveat), n), NaN where a member did not get there (``saved_t`` the times).
    ``progress``: show a progress bar (tqdm's, in notebooks and terminals, if tqdm is
    installed; else a line on stderr); default: when stderr is a terminal or in a notebook.
    :func:`solve`'s run keywords (``t_span``, ``dt``, ``order``, ...) set every member's run;
    a :class:`System` without ``q0`` takes the first member's state as the problem's start
    (each member then starts from its own).

    >>> import numpy as np, femvi
    >>> osc = femvi.System(["x"], "0.5*x_dot^2 - 0.5*k*x^2", {"k": 1.0})
    >>> ens = femvi.ensemble(osc, initial_states={"q": [[1.0], [2.0]], "v": [[0.0], [0.0]]},
    ...                      parameters={"k": [1.0, 4.0]}, t_span=(0.0, 1.0), dt=0.01, order=4,
    ...                      progress=False)
    >>> np.round(ens.final_q[:, 0], 6)              # cos(1), 2 cos(2)
    array([ 0.540302, -0.832294])
    """
    bar = _progress_bar(progress)
    times = None if saveat is None else [float(t) for t in saveat]
    states, velocity = _states(initial_states)
    run = split_run(kw)
    if isinstance(problem, System) and states is not None and "q0" not in run and len(states):
        n = states.shape[1] // 2
        run.update({"q0": states[0, :n], ("v0" if velocity else "p0"): states[0, n:]})
    merged = _merge(overrides, kw)
    params = {_name_of(k): np.asarray(v, dtype=np.float64).reshape(-1) for k, v in (parameters or {}).items()}
    sizes = {len(v) for v in params.values()} | ({len(states)} if states is not None else set())
    if len(sizes) > 1:
        raise InputError(f"initial_states and parameters give different numbers of members: {sorted(sizes)}")
    with problem_file(problem, merged, run) as (path, shown):
        try:
            if not params:
                raw = _core.ensemble_file(str(path), None, states, velocity, count or 1, workers, bar, times)
            else:
                raw = _parameter_ensemble(problem, merged, run, params, states, velocity, workers, path, bar,
                                          times)
        except InputError as e:
            raise _input_error(e, path, shown) from None
        finally:
            if bar is not None:
                bar.close()
    return EnsembleResult(raw)


def _in_notebook() -> bool:
    try:
        from IPython import get_ipython  # type: ignore
    except ImportError:
        return False
    shell = get_ipython()
    return shell is not None and "IPKernelApp" in getattr(shell, "config", {})


class _Progress:
    """A callable (done, total) that draws a progress bar: tqdm.auto's if available, else a
    line on stderr."""

    def __init__(self) -> None:
        self._tqdm = None
        self._shown = -1
        try:
            from tqdm.auto import tqdm  # type: ignore
            self._tqdm = tqdm(total=0, unit="member", desc="femvi ensemble")
        except ImportError:
            pass

    def __call__(self, done: int, total: int) -> None:
        if self._tqdm is not None:
            self._tqdm.total = total
            self._tqdm.update(done - self._tqdm.n)
        elif done != self._shown:
            self._shown = done
            sys.stderr.write(f"\rfemvi ensemble: {done}/{total} members ({100 * done // max(total, 1)} %)")
            sys.stderr.flush()

    def close(self) -> None:
        if self._tqdm is not None:
            self._tqdm.close()
        elif self._shown >= 0:
            sys.stderr.write("\n")


def _progress_bar(progress: Optional[bool]) -> Optional[_Progress]:
    if progress is None:
        progress = sys.stderr.isatty() or _in_notebook()
    return _Progress() if progress else None


def _parameter_ensemble(problem, merged, run, params, states, velocity, workers, path, bar, times):
    d, _ = to_dict(problem, run)
    apply_overrides(d, merged)
    apply_run(d, **run)
    size = len(next(iter(params.values())))
    with tempfile.TemporaryDirectory(prefix="femvi-ens-") as tmp:
        files = []
        for i in range(size):
            di = dict(d)
            system = dict(di.get("system", {}))
            system["parameters"] = {**system.get("parameters", {}), **{k: float(v[i]) for k, v in params.items()}}
            di["system"] = system
            f = Path(tmp) / f"{path.stem}-{i}.toml"
            f.write_text(dumps(di), encoding="utf-8")
            files.append(str(f))
        return _core.ensemble_file(str(path), files, states, velocity, size, workers, bar, times)


def models() -> List[Dict[str, Any]]:
    """The built-in systems: name, description, parameters (with defaults), coordinates,
    symmetries.

    >>> import femvi
    >>> [m["name"] for m in femvi.models()][:3]
    ['harmonic', 'pendulum', 'kepler']
    """
    return _core.models()


def model_problem(name: str) -> str:
    """The complete problem file of a built-in model (what ``femvi models NAME`` prints).

    >>> import femvi
    >>> print(femvi.model_problem("harmonic").splitlines()[1])
    name = "harmonic"
    """
    return _core.model_problem(name)


def check(problem: Any, overrides: Optional[Mapping[str, Any]] = None, **kw: Any) -> Dict[str, Any]:
    """``femvi check``'s report (symplecticity, energy and momentum drift, ...) as a dict; for a
    problem with ``[forces]``, whose flow is not symplectic, the energy balance H - H0 = W.

    >>> import femvi
    >>> report = femvi.check(femvi.model_problem("kepler"), t_span=(0.0, 10.0), dt=0.05)
    >>> bool(report["symplecticity_defect_relative"] < 1e-10), report["energy_conserved"]
    (True, True)
    """
    run = split_run(kw)
    with problem_file(problem, _merge(overrides, kw), run) as (path, shown):
        try:
            return json.loads(_core.check_file(str(path)))
        except InputError as e:
            raise _input_error(e, path, shown) from None


def convergence(problem: Any, steps: Sequence[float], reference: Optional[str] = None, l2: bool = False,
                overrides: Optional[Mapping[str, Any]] = None, **kw: Any) -> Dict[str, Any]:
    """``femvi convergence``'s report as a dict: final errors at each step in ``steps``, the
    fitted orders; ``reference`` as ``--reference`` ("exact", "finest" or a step), ``l2`` as
    ``--l2``.

    >>> import femvi
    >>> study = femvi.convergence(femvi.model_problem("harmonic"), [0.2, 0.1, 0.05], reference="exact",
    ...                           t_span=(0.0, 10.0))
    >>> round(study["order"], 1)          # degree 2, Gauss-Legendre 2 points: order 4
    4.0
    """
    run = split_run(kw)
    with problem_file(problem, _merge(overrides, kw), run) as (path, shown):
        try:
            return json.loads(_core.convergence_file(str(path), [float(h) for h in steps],
                                                     None if reference is None else str(reference), l2))
        except InputError as e:
            raise _input_error(e, path, shown) from None


@dataclasses.dataclass
class Optimum:
    """The result of :func:`optimize`: the optimum, or the best iterate with ``error`` set.

    ``t``, ``q`` and ``p`` are the element end nodes (times, positions and discrete momenta,
    one row per node); the controls live at the quadrature points: ``u`` has one row per
    point, at the times ``control_t``. ``u_nodes`` reads them off at the nodes (the columns
    of trajectory.csv: in each element the polynomial through its quadrature values at the
    element's ends, the mean of two elements at an interior node, clamped into the bounds).
    ``summary`` is ``femvi optimize``'s summary.json.

    >>> import femvi
    >>> push = femvi.System(["x"], "0.5*x_dot^2", name="push")
    >>> best = femvi.optimize(push, controls={"names": ["u"], "force": ["u"]}, objective={"running": "u^2"},
    ...                       boundary={"t0": 0.0, "t1": 1.0, "q0": [0.0], "v0": [0.0],
    ...                                 "q1": [1.0], "v1": [0.0], "elements": 10})
    >>> (best.q.shape, best.p.shape, best.u.shape, best.control_t.shape, best.u_nodes.shape)
    ((11, 1), (11, 1), (20, 1), (20,), (11, 1))
    """

    objective: float
    t1: float
    t: np.ndarray
    q: np.ndarray
    p: np.ndarray
    control_t: np.ndarray
    u: np.ndarray
    u_nodes: np.ndarray
    error: Optional[str]
    summary: Dict[str, Any]


def optimize(problem: Any, directory: Optional[str] = None, overrides: Optional[Mapping[str, Any]] = None,
             **kw: Any) -> Optimum:
    """``femvi optimize``: optimal control by discrete mechanics, as an :class:`Optimum` of
    NumPy arrays; its files go to ``directory`` (default: a temporary directory that is
    removed). A run that stops short returns its best iterate with ``error`` set.

    The double integrator x'' = u from rest at 0 to rest at 1 in unit time, minimising the
    integral of u^2 (the optimum is u = 6 - 12 t, J = 12):

    >>> import femvi
    >>> cart = femvi.System(["x"], "0.5*x_dot^2", name="push")
    >>> best = femvi.optimize(cart, controls={"names": ["u"], "force": ["u"]},
    ...                       objective={"running": "u^2"},
    ...                       boundary={"t0": 0.0, "t1": 1.0, "q0": [0.0], "v0": [0.0],
    ...                                 "q1": [1.0], "v1": [0.0], "elements": 20})
    >>> best.error is None and abs(best.objective - 12.0) < 1e-9
    True
    >>> bool(abs(best.u[:, 0] - (6.0 - 12.0 * best.control_t)).max() < 1e-9)
    True
    >>> bool(abs(best.u_nodes[:, 0] - (6.0 - 12.0 * best.t)).max() < 1e-9)
    True
    """
    run = split_run(kw)
    with problem_file(problem, _merge(overrides, kw), run) as (path, shown):
        with tempfile.TemporaryDirectory(prefix="femvi-optimize-") as tmp:
            try:
                text, arrays = _core.optimize_file(str(path), str(directory or tmp))
            except InputError as e:
                raise _input_error(e, path, shown) from None
    summary = json.loads(text)
    return Optimum(objective=summary["objective"], t1=summary["t1"], error=summary["error"], summary=summary,
                   **arrays)


def bvp(problem: Any, directory: Optional[str] = None, overrides: Optional[Mapping[str, Any]] = None,
        **kw: Any) -> Dict[str, Any]:
    """``femvi bvp``'s summary as a dict; its files go to ``directory`` (default: a temporary
    directory that is removed).

    >>> import femvi
    >>> pendulum = femvi.System(["x"], "0.5*x_dot^2 + cos(x)", name="pendulum-bvp")
    >>> summary = femvi.bvp(pendulum, **{"boundary": {"t0": 0.0, "q0": [0.0], "t1": 1.0, "q1": [0.5],
    ...                                               "elements": 50}})
    >>> summary["error"] is None and summary["scaled_residual"] < 1e-12
    True
    """
    run = split_run(kw)
    with problem_file(problem, _merge(overrides, kw), run) as (path, shown):
        with tempfile.TemporaryDirectory(prefix="femvi-bvp-") as tmp:
            try:
                return json.loads(_core.bvp_file(str(path), str(directory or tmp)))
            except InputError as e:
                raise _input_error(e, path, shown) from None
