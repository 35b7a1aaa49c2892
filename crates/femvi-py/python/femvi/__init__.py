"""femvi: variational integrators from finite elements, from Python.

Problems are femvi problem files (the ``femvi run`` format): a path, a TOML string or a dict
of the same structure, with overrides of any value by dotted path::

    import femvi
    sol = femvi.solve("examples/kepler.toml", **{"time.step": 0.01})
    sol.t, sol.q, sol.p, sol.energy          # NumPy arrays
    ens = femvi.ensemble("examples/kepler.toml", initial_states=states)   # all cores

Results equal the command's (``femvi run``) bit for bit.
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence

import numpy as np

from . import _core
from ._core import InputError
from ._problem import apply_overrides, dumps, problem_file, problem_text, to_dict
from ._solution import EnsembleResult, Event, NumericalError, Solution

__version__ = _core.__version__
__all__ = [
    "solve", "ensemble", "models", "model_problem", "check", "convergence", "bvp", "Solution",
    "EnsembleResult", "Event", "InputError", "NumericalError", "problem_text", "dumps",
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
    if not isinstance(coords, list) or not coords or not all(isinstance(c, str) for c in coords):
        raise InputError("<problem>: with potential=, [system] needs `coordinates` (a list of names)")
    system["lagrangian"] = " + ".join(f"0.5*{c}_dot^2" for c in coords)
    return d


def solve(problem: Any, overrides: Optional[Mapping[str, Any]] = None, *, every: Optional[int] = None,
          saveat: Optional[Sequence[float]] = None, dense: bool = False, max_steps: Optional[int] = None,
          events: Optional[Sequence[Any]] = None, raise_on_error: bool = True,
          potential: Optional[Callable[[np.ndarray], float]] = None,
          force: Optional[Callable[[np.ndarray], np.ndarray]] = None,
          masses: Optional[Sequence[float]] = None, **kw: Any) -> Solution:
    """Integrates a problem as ``femvi run`` does and returns a :class:`Solution`.

    ``problem``: a problem file's path, TOML text, or a dict of the same structure.
    ``overrides`` / keyword arguments: values by dotted path, e.g. ``**{"time.step": 0.01}``.
    ``every``: keep every k-th node (default: the file's ``[output] every``); ``saveat``: times
    at which to report the state (``sol.saved``); ``dense``: keep the dense output
    (``sol.q_at(t)``); ``max_steps``: stop after this many steps; ``events``: :class:`Event`s
    or plain callables g(t, q, v) (located zeros in ``sol.events``).

    ``potential``, ``force``, ``masses``: a system written in Python, for prototyping:
    L = ½ Σ m_i v_i² − V(q) with V = ``potential(q)`` and the force −∇V = ``force(q)`` (both
    take a 1-D NumPy array; ``masses`` default 1); the problem's ``[system]`` then gives only
    ``coordinates``. Each call costs 3–4 µs with NumPy inside (``examples/callable_cost.py``
    measures it); an exception raised by either stops the run and is re-raised. Time steps as
    variables are refused (they need second derivatives), and with ``method = "newton"`` the
    force Jacobian is taken by central differences.

    Raises :class:`InputError` for a bad problem (the command's message) and
    :class:`NumericalError` when a step fails or a node's energy is not finite (unless
    ``raise_on_error=False``, which returns
    the partial solution with ``sol.error`` set). The GIL is released during the run.
    """
    evs = [e if isinstance(e, Event) else Event(e) for e in (events or [])]
    merged = _merge(overrides, kw)
    system = None
    if potential is not None or force is not None:
        if potential is None or force is None:
            raise TypeError("potential= and force= go together (V(q) and -grad V(q))")
        problem, merged = _python_system(problem, merged), {}
        system = (potential, force, None if masses is None else [float(m) for m in masses])
    with problem_file(problem, merged) as (path, shown):
        try:
            raw = _core.solve_file(str(path), every=every, saveat=None if saveat is None else
                                   [float(x) for x in saveat], dense=dense, max_steps=max_steps,
                                   events=[e.spec() for e in evs] or None, potential=system)
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
    """
    bar = _progress_bar(progress)
    times = None if saveat is None else [float(t) for t in saveat]
    states, velocity = _states(initial_states)
    merged = _merge(overrides, kw)
    params = {k: np.asarray(v, dtype=np.float64).reshape(-1) for k, v in (parameters or {}).items()}
    sizes = {len(v) for v in params.values()} | ({len(states)} if states is not None else set())
    if len(sizes) > 1:
        raise InputError(f"initial_states and parameters give different numbers of members: {sorted(sizes)}")
    with problem_file(problem, merged) as (path, shown):
        try:
            if not params:
                raw = _core.ensemble_file(str(path), None, states, velocity, count or 1, workers, bar, times)
            else:
                raw = _parameter_ensemble(problem, merged, params, states, velocity, workers, path, bar, times)
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


def _parameter_ensemble(problem, merged, params, states, velocity, workers, path, bar, times):
    d, _ = to_dict(problem)
    apply_overrides(d, merged)
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
    symmetries."""
    return _core.models()


def model_problem(name: str) -> str:
    """The complete problem file of a built-in model (what ``femvi models NAME`` prints)."""
    return _core.model_problem(name)


def check(problem: Any, overrides: Optional[Mapping[str, Any]] = None, **kw: Any) -> Dict[str, Any]:
    """``femvi check``'s report (symplecticity, energy and momentum drift, ...) as a dict."""
    with problem_file(problem, _merge(overrides, kw)) as (path, shown):
        try:
            return json.loads(_core.check_file(str(path)))
        except InputError as e:
            raise _input_error(e, path, shown) from None


def convergence(problem: Any, steps: Sequence[float], reference: Optional[str] = None, l2: bool = False,
                overrides: Optional[Mapping[str, Any]] = None, **kw: Any) -> Dict[str, Any]:
    """``femvi convergence``'s report as a dict: final errors at each step in ``steps``, the
    fitted orders; ``reference`` as ``--reference`` ("exact", "finest" or a step), ``l2`` as
    ``--l2``."""
    with problem_file(problem, _merge(overrides, kw)) as (path, shown):
        try:
            return json.loads(_core.convergence_file(str(path), [float(h) for h in steps],
                                                     None if reference is None else str(reference), l2))
        except InputError as e:
            raise _input_error(e, path, shown) from None


def bvp(problem: Any, directory: Optional[str] = None, overrides: Optional[Mapping[str, Any]] = None,
        **kw: Any) -> Dict[str, Any]:
    """``femvi bvp``'s summary as a dict; its files go to ``directory`` (default: a temporary
    directory that is removed)."""
    with problem_file(problem, _merge(overrides, kw)) as (path, shown):
        with tempfile.TemporaryDirectory(prefix="femvi-bvp-") as tmp:
            try:
                return json.loads(_core.bvp_file(str(path), str(directory or tmp)))
            except InputError as e:
                raise _input_error(e, path, shown) from None
