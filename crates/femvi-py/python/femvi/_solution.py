"""The result of :func:`femvi.solve` and the errors of a run."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any, Dict, List, Optional

import numpy as np


class Solution:
    """A run's kept nodes as NumPy arrays, with its statistics.

    Attributes: ``t`` (N,), ``q``, ``p``, ``v`` (N, n), ``energy`` (N,), ``node`` (N,) the node
    indices, ``steps``, ``mean_iterations``, ``max_rel_energy_error`` (as summary.json) and
    ``energy_nodes``, the nodes it is over (``"every"``, or ``"kept"``: the kept ones, by
    default for Lagrangians without a constant mass matrix; ``output.energy_nodes`` chooses),
    ``error`` (None or the message), ``coordinates``, ``name``, ``scheme``, ``events`` (list of
    dicts), ``saved`` (``t``, ``q``, ``v``, ``p`` at the ``saveat`` times), ``energy_stats``
    (energy mode only). With ``dense=True``, ``sol.q_at(t)`` / ``sol(t)`` and ``sol.v_at(t)``.

    A problem with ``[forces]`` adds ``work`` (N,), the discrete work W of the forces at the
    kept nodes, and ``max_energy_balance_error`` / ``max_rel_energy_balance_error``, max |H − H0
    − W| over every node; one with ``[constraints]`` adds ``multipliers`` (N, m), the
    multipliers λ of the constraint force −Gᵀλ, ``constraint_residual`` (N,), max |g(q)| at each
    kept node, and ``max_constraint_residual`` over every node. Absent tables give None.
    """

    def __init__(self, raw: Dict[str, Any]):
        self.name: str = raw["name"]
        self.scheme: str = raw["scheme"]
        self.coordinates: List[str] = list(raw["coordinates"])
        self.node: np.ndarray = raw["node"]
        self.t: np.ndarray = raw["t"]
        self.q: np.ndarray = raw["q"]
        self.p: np.ndarray = raw["p"]
        self.v: np.ndarray = raw["v"]
        self.energy: np.ndarray = raw["energy"]
        self.steps: int = raw["steps"]
        self.mean_iterations: float = raw["mean_iterations"]
        self.max_rel_energy_error: float = raw["max_rel_energy_error"]
        self.energy_nodes: Optional[str] = raw.get("energy_nodes")
        self.stopped: bool = raw["stopped"]
        self.error: Optional[str] = raw["error"]
        self.events: List[Dict[str, Any]] = list(raw["events"])
        self.energy_stats: Optional[Dict[str, Any]] = raw.get("energy_stats")
        self.saved = SimpleNamespace(t=raw["saved_t"], q=raw["saved_q"], v=raw["saved_v"], p=raw["saved_p"])
        self._dense = raw.get("dense")
        #: Adaptive mode only: the fictitious time s of each kept node (t is physical).
        self.s: Optional[np.ndarray] = raw.get("s")
        self.work: Optional[np.ndarray] = raw.get("work")
        self.max_energy_balance_error: Optional[float] = raw.get("max_energy_balance_error")
        self.max_rel_energy_balance_error: Optional[float] = raw.get("max_rel_energy_balance_error")
        self.multipliers: Optional[np.ndarray] = raw.get("multipliers")
        self.constraint_residual: Optional[np.ndarray] = raw.get("constraint_residual")
        self.max_constraint_residual: Optional[float] = raw.get("max_constraint_residual")

    def __len__(self) -> int:
        return len(self.t)

    def __repr__(self) -> str:
        state = "ok" if self.error is None else f"error: {self.error}"
        return f"<femvi.Solution {self.name!r} {self.scheme}: {len(self)} nodes, {self.steps} steps, {state}>"

    @property
    def final_q(self) -> np.ndarray:
        """q at the last node."""
        return self.q[-1]

    @property
    def final_p(self) -> np.ndarray:
        """p at the last node."""
        return self.p[-1]

    def _state(self, t: Any):
        if self._dense is None:
            raise ValueError("no dense output: solve with dense=True")
        ts = np.asarray(t, dtype=np.float64)
        q, v = self._dense.state_at(np.ascontiguousarray(ts.reshape(-1)))
        if ts.ndim == 0:
            return q[0], v[0]
        return q.reshape(ts.shape + (q.shape[1],)), v.reshape(ts.shape + (v.shape[1],))

    def q_at(self, t: Any) -> np.ndarray:
        """q of the finite element solution at time(s) t: (n,) for a scalar, (len(t), n) else."""
        return self._state(t)[0]

    def v_at(self, t: Any) -> np.ndarray:
        """q̇ of the finite element solution at time(s) t."""
        return self._state(t)[1]

    def __call__(self, t: Any) -> np.ndarray:
        return self.q_at(t)

    @property
    def span(self):
        """(t_start, t_end) of the dense output."""
        if self._dense is None:
            raise ValueError("no dense output: solve with dense=True")
        return self._dense.span()


class Event:
    """An event for :func:`femvi.solve`: the zeros of ``g(t, q, v) -> float`` (q and v NumPy
    arrays), located on the finite element solution. ``direction``: "rising", "falling" or
    "both"; ``stop``: end the run at the first one. Located events are ``sol.events`` (dicts
    with name, event index, step, t, q, v, p)."""

    def __init__(self, g: Any, direction: str = "both", stop: bool = False, name: Optional[str] = None):
        if not callable(g):
            raise TypeError("an event needs a callable g(t, q, v)")
        self.g = g
        self.direction = direction
        self.stop = bool(stop)
        self.name = name if name is not None else getattr(g, "__name__", "event")

    def spec(self):
        return (self.name, self.g, self.direction, self.stop)

    def __repr__(self) -> str:
        return f"Event({self.name!r}, direction={self.direction!r}, stop={self.stop})"


class NumericalError(RuntimeError):
    """A run that failed on a step, or reached a node whose energy is not finite: ``.step``
    and ``.t`` say where (the node the failed step started from, or the node whose energy is
    not finite), ``.solution`` holds the nodes computed before the failure, all finite."""

    def __init__(self, message: str, step: Optional[int] = None, t: Optional[float] = None,
                 solution: Optional[Solution] = None):
        super().__init__(message)
        self.step = step
        self.t = t
        self.solution = solution


class EnsembleResult(dict):
    """The stacked results of an ensemble, as a dict with attribute access: ``final_t`` (N,),
    ``final_q``, ``final_p`` (N, n), ``energy_error`` (N,), ``steps`` (N,) and ``errors``
    (a list of None or the member's error message); with ``saveat``, ``saved_t`` and
    ``saved_q``, ``saved_p`` (N, len(saveat), n)."""

    def __getattr__(self, name: str) -> Any:
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None

    @property
    def ok(self) -> np.ndarray:
        """Which members finished without an error."""
        return np.array([e is None for e in self["errors"]], dtype=bool)
