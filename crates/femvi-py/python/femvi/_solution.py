"""The result of :func:`femvi.solve` and the errors of a run."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any, Dict, List, Optional, Sequence

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
    A problem with rotations names them in ``rotations``; :meth:`rotation` gives each one's
    matrices, body angular velocity and momentum.

    >>> import femvi
    >>> sol = femvi.solve(femvi.model_problem("harmonic"), t_span=(0.0, 1.0), dt=0.5)
    >>> sol.t, sol.q.shape, sol.coordinates
    (array([0. , 0.5, 1. ]), (3, 1), ['x'])
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
        #: The names of the problem's rotations (``[system] rotations``; see :meth:`rotation`).
        self.rotations: List[str] = list(raw.get("rotations", []))

    def __len__(self) -> int:
        return len(self.t)

    def __repr__(self) -> str:
        state = "ok" if self.error is None else f"error: {self.error}"
        return f"<femvi.Solution {self.name!r} {self.scheme}: {len(self)} nodes, {self.steps} steps, {state}>"

    @property
    def final_q(self) -> np.ndarray:
        """q at the last node.

        >>> import femvi
        >>> femvi.solve(femvi.model_problem("harmonic"), t_span=(0.0, 1.0), dt=0.5).final_q.shape
        (1,)
        """
        return self.q[-1]

    @property
    def final_p(self) -> np.ndarray:
        """p at the last node.

        >>> import femvi
        >>> sol = femvi.solve(femvi.model_problem("harmonic"), t_span=(0.0, 1.0), dt=0.5)
        >>> bool((sol.final_p == sol.p[-1]).all())
        True
        """
        return self.p[-1]

    def rotation(self, name: str) -> SimpleNamespace:
        """Rotation ``name`` at the kept nodes: ``R`` (N, 3, 3), body to space; ``w`` (N, 3),
        the body angular velocity vee(RᵀṘ) from the nodes' velocities; ``pi`` (N, 3), the body
        angular momentum 2 vee(RᵀP) of the nodes' momenta P = ½ R Π̂; ``axes`` (N, 3, 3), the
        body axes in space (``axes[:, :, a]`` = R e_a).

        >>> import femvi, numpy as np
        >>> sol = femvi.solve(femvi.model_problem("rigid-body"), t_span=(0.0, 1.0), dt=0.01)
        >>> body = sol.rotation("R")
        >>> bool(np.abs(np.einsum("nji,njk->nik", body.R, body.R) - np.eye(3)).max() < 1e-14)
        True
        >>> bool(np.abs(np.linalg.norm(body.pi, axis=1) - np.linalg.norm(body.pi[0])).max() < 1e-13)
        True
        """
        if name not in self.rotations:
            raise KeyError(f"no rotation {name!r}; the problem's rotations: {self.rotations}")
        o = 9 * self.rotations.index(name)
        r = self.q[:, o:o + 9].reshape(-1, 3, 3)

        def vee(a: np.ndarray) -> np.ndarray:
            return 0.5 * np.stack([a[:, 2, 1] - a[:, 1, 2], a[:, 0, 2] - a[:, 2, 0], a[:, 1, 0] - a[:, 0, 1]], axis=1)

        rt = np.transpose(r, (0, 2, 1))
        w = vee(rt @ self.v[:, o:o + 9].reshape(-1, 3, 3))
        pi = 2.0 * vee(rt @ self.p[:, o:o + 9].reshape(-1, 3, 3))
        return SimpleNamespace(R=r, w=w, pi=pi, axes=r)

    def _state(self, t: Any):
        if self._dense is None:
            raise ValueError("no dense output: solve with dense=True")
        ts = np.asarray(t, dtype=np.float64)
        q, v = self._dense.state_at(np.ascontiguousarray(ts.reshape(-1)))
        if ts.ndim == 0:
            return q[0], v[0]
        return q.reshape(ts.shape + (q.shape[1],)), v.reshape(ts.shape + (v.shape[1],))

    def q_at(self, t: Any) -> np.ndarray:
        """q of the finite element solution at time(s) t: (n,) for a scalar, (len(t), n) else.

        >>> import math, femvi
        >>> sol = femvi.solve(femvi.model_problem("harmonic"), t_span=(0.0, 2.0), dt=0.01, dense=True)
        >>> bool(abs(sol.q_at(1.234)[0] - math.cos(1.234)) < 1e-6), sol.q_at([0.5, 1.5]).shape
        (True, (2, 1))
        """
        return self._state(t)[0]

    def v_at(self, t: Any) -> np.ndarray:
        """q̇ of the finite element solution at time(s) t.

        >>> import math, femvi
        >>> sol = femvi.solve(femvi.model_problem("harmonic"), t_span=(0.0, 2.0), dt=0.01, dense=True)
        >>> bool(abs(sol.v_at(1.234)[0] + math.sin(1.234)) < 1e-5)
        True
        """
        return self._state(t)[1]

    def __call__(self, t: Any) -> np.ndarray:
        return self.q_at(t)

    def to_pandas(self, which: str = "nodes") -> Any:
        """The solution as a pandas DataFrame (pandas is imported here: ``pip install pandas``).

        ``which``: ``"nodes"`` (the kept nodes, indexed by t: a column per coordinate,
        ``NAME_dot`` its velocity, ``p_NAME`` its momentum, ``energy``, ``node``, and ``work``,
        ``lambda_i``, ``constraint_residual``, ``s`` where the run has them), ``"saved"`` (the
        ``saveat`` states, indexed by t) or ``"events"`` (one row per located event: ``name``,
        ``event``, ``step``, ``t`` and the state).

        >>> import femvi
        >>> sol = femvi.solve(femvi.model_problem("harmonic"), t_span=(0.0, 1.0), dt=0.25)
        >>> df = sol.to_pandas()
        >>> list(df.columns), df.index.name, len(df)
        (['x', 'x_dot', 'p_x', 'energy', 'node'], 't', 5)
        """
        import pandas as pd

        names = self.coordinates
        if which == "nodes":
            cols = self._state_columns(self.q, self.v, self.p)
            cols["energy"] = self.energy
            cols["node"] = self.node
            if self.work is not None:
                cols["work"] = self.work
            if self.multipliers is not None:
                for i in range(self.multipliers.shape[1]):
                    cols[f"lambda_{i}"] = self.multipliers[:, i]
            if self.constraint_residual is not None:
                cols["constraint_residual"] = self.constraint_residual
            if self.s is not None:
                cols["s"] = self.s
            return pd.DataFrame(cols, index=pd.Index(self.t, name="t"))
        if which == "saved":
            return pd.DataFrame(self._state_columns(self.saved.q, self.saved.v, self.saved.p),
                                index=pd.Index(self.saved.t, name="t"))
        if which == "events":
            rows = []
            for e in self.events:
                row: Dict[str, Any] = {k: e[k] for k in ("name", "event", "step", "t") if k in e}
                for key, fmt in (("q", "{}"), ("v", "{}_dot"), ("p", "p_{}")):
                    for name, x in zip(names, e.get(key, [])):
                        row[fmt.format(name)] = float(x)
                rows.append(row)
            return pd.DataFrame(rows, columns=["name", "event", "step", "t"] + [
                fmt.format(c) for fmt in ("{}", "{}_dot", "p_{}") for c in names])
        raise ValueError(f'which must be "nodes", "saved" or "events", not {which!r}')

    def _state_columns(self, q: np.ndarray, v: np.ndarray, p: np.ndarray) -> Dict[str, np.ndarray]:
        cols: Dict[str, np.ndarray] = {}
        for fmt, a in (("{}", q), ("{}_dot", v), ("p_{}", p)):
            for i, c in enumerate(self.coordinates):
                cols[fmt.format(c)] = a[:, i]
        return cols

    def plot(self, coordinates: Optional[List[str]] = None) -> Any:
        """A matplotlib figure of the run (matplotlib is imported here): the coordinates
        against t, the phase portraits (q_i, p_i), and the relative energy error
        (H − H0)/|H0| against t (with forces, the balance error (H − H0 − W)/|H0|).
        ``coordinates``: the names to draw (default: all, up to four). Returns the figure.

        >>> import femvi, matplotlib
        >>> matplotlib.use("Agg")
        >>> sol = femvi.solve(femvi.model_problem("harmonic"), t_span=(0.0, 10.0), dt=0.1)
        >>> fig = sol.plot()
        >>> [ax.get_title() for ax in fig.axes]
        ['coordinates', 'phase portrait', 'relative energy error']
        """
        import matplotlib.pyplot as plt

        names = list(coordinates) if coordinates is not None else self.coordinates[:4]
        index = []
        for n in names:
            if n not in self.coordinates:
                raise ValueError(f"no coordinate {n!r}: the coordinates are {self.coordinates}")
            index.append(self.coordinates.index(n))
        fig, (a, b, c) = plt.subplots(1, 3, figsize=(13, 3.8), layout="constrained")
        for i, n in zip(index, names):
            a.plot(self.t, self.q[:, i], label=n)
            b.plot(self.q[:, i], self.p[:, i], lw=0.8, label=n)
        a.set(title="coordinates", xlabel="t", ylabel="q")
        b.set(title="phase portrait", xlabel="q", ylabel="p")
        for ax in (a, b):
            ax.legend(fontsize="small")
        h0 = self.energy[0]
        scale = abs(h0) if h0 != 0 else 1.0
        err = self.energy - h0 - (self.work if self.work is not None else 0.0)
        c.plot(self.t, err / scale, lw=0.8)
        title = "relative energy error" if self.work is None else "relative energy balance error"
        c.set(title=title, xlabel="t", ylabel="(H - H0 - W)/|H0|" if self.work is not None else "(H - H0)/|H0|")
        fig.suptitle(f"{self.name}: {self.scheme}")
        return fig

    @property
    def span(self):
        """(t_start, t_end) of the dense output.

        >>> import femvi
        >>> femvi.solve(femvi.model_problem("harmonic"), t_span=(0.0, 2.0), dt=0.5, dense=True).span
        (0.0, 2.0)
        """
        if self._dense is None:
            raise ValueError("no dense output: solve with dense=True")
        return self._dense.span()


class Event:
    """An event for :func:`femvi.solve`: the zeros of g(t, q, v), located on the finite
    element solution. ``g``: a callable ``g(t, q, v) -> float`` (q and v NumPy arrays), or an
    expression — a femvi expression string or a SymPy expression in t, the coordinates and
    their velocities (``NAME_dot``, or q(t).diff(t) for dynamicsymbols) — which runs compiled,
    as a problem file's ``[[events]]`` (``when``), without a Python call per node.
    ``direction``: "rising", "falling" or "both"; ``stop``: end the run at the first one.
    Located events are ``sol.events`` (dicts with name, event index, step, t, q, v, p;
    ``sol.to_pandas("events")`` as a table).

    >>> import math, femvi
    >>> down = femvi.Event(lambda t, q, v: q[0], direction="falling", stop=True, name="down")
    >>> sol = femvi.solve(femvi.model_problem("harmonic"), t_span=(0.0, 5.0), dt=0.01, events=[down])
    >>> bool(abs(sol.events[0]["t"] - math.pi / 2) < 1e-8), bool(sol.t[-1] < 5.0)
    (True, True)
    >>> up = femvi.Event("x_dot", direction="falling", name="top")   # compiled: x at its maximum
    >>> sol = femvi.solve(femvi.model_problem("harmonic"), t_span=(0.0, 7.0), dt=0.01, events=[up])
    >>> [round(e["t"], 6) for e in sol.events]                        # t = 2 pi
    [6.283185]
    """

    def __init__(self, g: Any, direction: str = "both", stop: bool = False, name: Optional[str] = None):
        from ._sympy import is_sympy

        self.expression = isinstance(g, str) or is_sympy(g)
        if not callable(g) and not self.expression:
            raise TypeError("an event needs a callable g(t, q, v), a femvi expression string or a SymPy expression")
        self.g = g
        self.direction = direction
        self.stop = bool(stop)
        self.name = name if name is not None else ("event" if self.expression else getattr(g, "__name__", "event"))

    def _table(self, coordinates: Sequence[Any], name: str) -> Dict[str, Any]:
        """The event as a problem file's ``[[events]]`` table (an expression event)."""
        from ._sympy import to_expression

        when = to_expression(self.g, coordinates, f"event {name!r}")
        return {"name": name, "when": when, "direction": self.direction, "stop": self.stop}

    def _spec(self):
        return (self.name, self.g, self.direction, self.stop)

    def __repr__(self) -> str:
        return f"Event({self.name!r}, direction={self.direction!r}, stop={self.stop})"


class NumericalError(RuntimeError):
    """A run that failed on a step, or reached a node whose energy is not finite: ``.step``
    and ``.t`` say where (the node the failed step started from, or the node whose energy is
    not finite), ``.solution`` holds the nodes computed before the failure, all finite.

    >>> import femvi
    >>> problem = {"system": {"model": "harmonic"}, "initial": {"q": [1.0], "p": [0.0]},
    ...            "scheme": {"degree": 1, "quadrature": "trapezoid"}, "time": {"step": 2.5, "end": 5000.0}}
    >>> try:
    ...     femvi.solve(problem)          # h = 2.5 > 2: Störmer-Verlet is unstable
    ... except femvi.NumericalError as e:
    ...     print(e.solution.error is not None, len(e.solution) > 1)
    True True
    """

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
    ``saved_q``, ``saved_p`` (N, len(saveat), n); for a problem with rotations, ``body``
    (N, 6 per rotation): each rotation's body angular velocity w and momentum Π at the last
    node (the ``X_w1`` … ``p_X3`` columns of ``femvi ensemble``; NaN for a member that did not
    start).

    >>> import femvi
    >>> ens = femvi.ensemble(femvi.model_problem("harmonic"), count=3, t_span=(0.0, 1.0), dt=0.1,
    ...                      progress=False)
    >>> ens.final_q.shape, ens.ok.tolist()
    ((3, 1), [True, True, True])
    """

    def __getattr__(self, name: str) -> Any:
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None

    @property
    def ok(self) -> np.ndarray:
        """Which members finished without an error (a boolean array).

        >>> import femvi
        >>> femvi.ensemble(femvi.model_problem("harmonic"), count=2, t_span=(0.0, 1.0), dt=0.1,
        ...                progress=False).ok
        array([ True,  True])
        """
        return np.array([e is None for e in self["errors"]], dtype=bool)
