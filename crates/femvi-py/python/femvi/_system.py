"""A mechanical system written in Python: :class:`System`, the ``[system]``, ``[forces]`` and
``[constraints]`` tables of a problem file as an object, with expressions as strings or SymPy.

A System is a problem file without its run settings: :func:`femvi.solve` (and ``ensemble``,
``check``, ``convergence``, ``problem_text``) takes it with keywords for the start, the time
span, the step and the scheme (:func:`run_overrides`), and writes the same TOML text that
:meth:`System.to_toml` prints, which the command's own loader reads. So a System's run and
``femvi run`` of its file are the same computation, bit for bit.
"""

from __future__ import annotations

from typing import Any, Dict, List, Mapping, Optional, Sequence

from ._core import InputError
from ._problem import apply_run, dumps
from ._sympy import coordinate_name, is_sympy, to_expression


def _name_of(key: Any) -> str:
    if isinstance(key, str):
        return key
    if is_sympy(key) and getattr(key, "is_Symbol", False):
        return key.name
    raise InputError(f"a parameter's name must be a string or a SymPy Symbol, not {key!r}")


def _float(v: Any, what: str) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a number, not {v!r}") from None
    return x


class System:
    """A Lagrangian system L(t, q, q̇) with optional forces and constraints.

    ``coordinates``: names, SymPy Symbols, or ``sympy.physics.mechanics.dynamicsymbols``.
    ``lagrangian``: a femvi expression string (``"0.5*x_dot^2 - 0.5*k*x^2"``, velocities
    named ``NAME_dot``) or a SymPy expression in the coordinates, their velocities (Symbols
    ``NAME_dot``, or q(t).diff(t) for dynamicsymbols), ``t`` and the parameters.
    ``parameters``: name (or Symbol) -> value. ``forces``: a generalized force per
    coordinate (``[forces] generalized``); ``dissipation``: a Rayleigh function R(t, q, q̇)
    whose force is −∂R/∂q̇; ``constraints``: holonomic g(q) = 0 (``[constraints]``) with
    ``enforcement``; ``monitor``: the g(q) of adaptive steps (written to ``[time]`` when a run
    has ``mode="adaptive"``). ``name``: the problem's name.
    Expressions are converted when the System is made (:func:`femvi.expression`); an
    unsupported SymPy function raises :class:`femvi.InputError` naming it.

    >>> import sympy as sp
    >>> import femvi
    >>> x, x_dot, k = sp.symbols("x x_dot k")
    >>> osc = femvi.System([x], x_dot**2 / 2 - k * x**2 / 2, parameters={k: 4.0}, name="oscillator")
    >>> osc
    System('oscillator', coordinates=['x'], lagrangian='-k*x^2/2 + x_dot^2/2')
    >>> sol = femvi.solve(osc, q0=[1.0], v0=[0.0], t_span=(0.0, 3.0), dt=0.01, order=4)
    >>> bool(abs(sol.q[-1, 0] - __import__("math").cos(6.0)) < 1e-8)
    True
    """

    def __init__(self, coordinates: Sequence[Any], lagrangian: Any, parameters: Optional[Mapping[Any, Any]] = None,
                 *, forces: Optional[Sequence[Any]] = None, dissipation: Any = None,
                 constraints: Optional[Sequence[Any]] = None, enforcement: Optional[str] = None,
                 monitor: Any = None, name: str = "system"):
        if isinstance(coordinates, (str, bytes)) or not isinstance(coordinates, Sequence):
            raise InputError("coordinates must be a list (names, Symbols or dynamicsymbols)")
        self._given = list(coordinates)
        self.coordinates: List[str] = [coordinate_name(c) for c in coordinates]
        self.name = str(name)
        self.parameters: Dict[str, float] = {
            _name_of(k): _float(v, f"parameter {_name_of(k)!r}") for k, v in (parameters or {}).items()
        }
        self.lagrangian: str = self._expr(lagrangian, "lagrangian")
        self.forces: Optional[List[str]] = None
        if forces is not None:
            if isinstance(forces, (str, bytes)):
                raise InputError("forces must be a list with one expression per coordinate")
            items = list(forces)
            if len(items) != len(self.coordinates):
                raise InputError(f"forces has {len(items)} expressions for {len(self.coordinates)} coordinates")
            self.forces = [self._expr(f, f"force on {c}") for f, c in zip(items, self.coordinates)]
        self.dissipation: Optional[str] = None if dissipation is None else self._expr(dissipation, "dissipation")
        self.constraints: Optional[List[str]] = None
        if constraints is not None:
            items = [constraints] if is_sympy(constraints) or isinstance(constraints, str) else list(constraints)
            self.constraints = [self._expr(g, f"constraint {i}") for i, g in enumerate(items)]
        self.enforcement = enforcement
        self.monitor: Optional[str] = None if monitor is None else self._expr(monitor, "monitor")

    def _expr(self, e: Any, what: str) -> str:
        return to_expression(e, self._given, what)

    def to_dict(self, adaptive: bool = False) -> Dict[str, Any]:
        """The problem file's tables as a dict (without ``[initial]`` and ``[time]``, but for
        the ``monitor`` of adaptive steps with ``adaptive=True``).

        >>> import femvi
        >>> femvi.System(["x"], "0.5*x_dot^2 - 0.5*x^2", name="osc").to_dict()
        {'name': 'osc', 'system': {'coordinates': ['x'], 'lagrangian': '0.5*x_dot^2 - 0.5*x^2'}}
        """
        system: Dict[str, Any] = {"coordinates": list(self.coordinates)}
        if self.parameters:
            system["parameters"] = dict(self.parameters)
        system["lagrangian"] = self.lagrangian
        d: Dict[str, Any] = {"name": self.name, "system": system}
        forces: Dict[str, Any] = {}
        if self.forces is not None:
            forces["generalized"] = list(self.forces)
        if self.dissipation is not None:
            forces["dissipation"] = self.dissipation
        if forces:
            d["forces"] = forces
        if self.constraints is not None:
            d["constraints"] = {"holonomic": list(self.constraints)}
            if self.enforcement is not None:
                d["constraints"]["enforcement"] = self.enforcement
        if self.monitor is not None and adaptive:
            d["time"] = {"monitor": self.monitor}
        return d

    def _problem_tables(self, adaptive: bool = False) -> Dict[str, Any]:
        """The hook by which the problem-file layer (``_problem.py``) reads a System."""
        return self.to_dict(adaptive=adaptive)

    def to_toml(self, **run: Any) -> str:
        """The system's problem file. With :func:`femvi.solve`'s keywords (``q0``, ``v0`` or
        ``p0``, ``t_span``, ``dt``, ``degree`` or ``order``, ...) it is a complete file that
        ``femvi run`` runs to the same bits as ``femvi.solve(system, **run)``.

        >>> import femvi
        >>> osc = femvi.System(["x"], "0.5*x_dot^2 - 0.5*x^2", name="osc")
        >>> print(osc.to_toml(q0=[1.0], v0=[0.0], t_span=(0.0, 10.0), dt=0.1))
        name = "osc"
        <BLANKLINE>
        [system]
        coordinates = ["x"]
        lagrangian = "0.5*x_dot^2 - 0.5*x^2"
        <BLANKLINE>
        [initial]
        t = 0.0
        q = [1.0]
        v = [0.0]
        <BLANKLINE>
        [time]
        end = 10.0
        step = 0.1
        <BLANKLINE>
        """
        d = self.to_dict(adaptive=run.get("mode") == "adaptive")
        apply_run(d, **run)
        return dumps(d)

    def __repr__(self) -> str:
        return f"System({self.name!r}, coordinates={self.coordinates!r}, lagrangian={self.lagrangian!r})"
