"""Problems as the Rust side reads them: a problem file on disk.

A problem given as a path, a TOML string or a dict (with dotted-path overrides) becomes a
dict, then TOML text again (floats written with ``repr`` so they read back exactly), then a
file in a temporary directory that the command's own loader reads.
"""

from __future__ import annotations

import contextlib
import copy
import json
import math
import os
import re
import sys
import tempfile
from pathlib import Path
from typing import Any, Dict, Iterator, Mapping, Optional, Tuple

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    return k if _BARE.match(k) else json.dumps(k, ensure_ascii=False)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if hasattr(v, "dtype") and getattr(v, "shape", None) == ():
        v = v.item()  # NumPy scalar
        return _value(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, Path):
        return json.dumps(str(v), ensure_ascii=False)
    if isinstance(v, Mapping):
        return "{" + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + "}"
    if hasattr(v, "tolist"):
        return _value(v.tolist())
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} {v!r} to a problem file")


def dumps(d: Mapping[str, Any]) -> str:
    """TOML text of a dict of tables, arrays, strings, numbers and bools (floats written with
    ``repr``, so they read back exactly).

    >>> print(dumps({"name": "x", "time": {"step": 0.1, "end": 1e3}}))
    name = "x"
    <BLANKLINE>
    [time]
    step = 0.1
    end = 1000.0
    <BLANKLINE>
    """
    lines: list = []
    _table(d, [], lines)
    return "\n".join(lines).lstrip("\n") + "\n"


def _table(d: Mapping[str, Any], path: list, lines: list) -> None:
    tables = [(k, v) for k, v in d.items() if isinstance(v, Mapping)]
    for k, v in d.items():
        if not isinstance(v, Mapping) and v is not None:
            lines.append(f"{_key(k)} = {_value(v)}")
    for k, v in tables:
        sub = path + [k]
        lines.append("")
        lines.append("[" + ".".join(_key(p) for p in sub) + "]")
        _table(v, sub, lines)


def _looks_like_toml(s: str) -> bool:
    """Whether a string is TOML text rather than a path: a path has no newline and names an
    existing file or ends in .toml."""
    if "\n" in s:
        return True
    if s.endswith(".toml"):
        return False
    try:
        return not Path(s).is_file()
    except OSError:
        return True


# The largest problem file read, as the command's (femvi_cli::bounded::MAX_PROBLEM_BYTES).
MAX_PROBLEM_BYTES = 256 << 20


def _read_bounded(path: Path) -> str:
    """The text of a problem file, read in chunks: refused at its first NUL byte (not a text
    file: /dev/zero) or past MAX_PROBLEM_BYTES (a FIFO that never ends), with ValueError."""
    chunks, size = [], 0
    with open(path, "rb") as f:
        while True:
            chunk = f.read(1 << 20)
            if not chunk:
                break
            if b"\0" in chunk:
                raise ValueError("it contains a NUL byte: it is not a text file")
            size += len(chunk)
            if size > MAX_PROBLEM_BYTES:
                raise ValueError(f"larger than the limit of {MAX_PROBLEM_BYTES >> 20} MiB for a problem file")
            chunks.append(chunk)
    try:
        return b"".join(chunks).decode("utf-8")
    except UnicodeDecodeError as e:
        raise ValueError(f"not UTF-8 text (byte {e.start})") from None


def to_dict(problem: Any, run: Optional[Mapping[str, Any]] = None) -> Tuple[Dict[str, Any], Optional[Path]]:
    """The problem as a dict and the file it came from (None for text, a dict or a System);
    ``run``: :func:`femvi.solve`'s run keywords (a System's monitor is written in adaptive mode)."""
    from ._core import InputError

    tables = getattr(problem, "_problem_tables", None)
    if callable(tables):  # a femvi.System (which imports this module, not the other way)
        return tables(adaptive=(run or {}).get("mode") == "adaptive"), None
    if isinstance(problem, Mapping):
        return copy.deepcopy(dict(problem)), None
    if isinstance(problem, os.PathLike) or (isinstance(problem, str) and not _looks_like_toml(problem)):
        path = Path(problem)
        try:
            return tomllib.loads(_read_bounded(path)), path
        except OSError as e:
            raise InputError(f"{path}: cannot read the problem file: {e.strerror}") from None
        except ValueError as e:
            raise InputError(f"{path}: cannot read the problem file: {e}") from None
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
            raise InputError(f"{path}: {e}") from None
    if isinstance(problem, str):
        try:
            return tomllib.loads(problem), None
        except tomllib.TOMLDecodeError as e:
            raise InputError(f"<problem>: {e}") from None
    raise TypeError("problem must be a femvi.System, a path, TOML text or a dict")


def apply_overrides(d: Dict[str, Any], overrides: Mapping[str, Any]) -> None:
    """Sets each dotted path (e.g. "time.step") to its value, creating tables as needed."""
    for dotted, value in overrides.items():
        keys = dotted.split(".")
        node = d
        for k in keys[:-1]:
            nxt = node.get(k)
            if not isinstance(nxt, dict):
                nxt = {}
                node[k] = nxt
            node = nxt
        node[keys[-1]] = value


#: The keywords of :func:`femvi.solve` (and the other entry points) that set the run.
RUN_KEYWORDS = ("q0", "v0", "p0", "t_span", "dt", "degree", "order", "quadrature", "points", "nodes",
                "method", "mode")


def _floats(v: Any, what: str) -> list:
    from ._core import InputError

    try:
        xs = [float(x) for x in (v.tolist() if hasattr(v, "tolist") else v)]
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a list of numbers, not {v!r}") from None
    return xs


def apply_run(d: Dict[str, Any], q0: Any = None, v0: Any = None, p0: Any = None, t_span: Any = None,
              dt: Optional[float] = None, degree: Optional[int] = None, order: Optional[int] = None,
              quadrature: Optional[str] = None, points: Optional[int] = None, nodes: Optional[str] = None,
              method: Optional[str] = None, mode: Optional[str] = None) -> None:
    """Sets a problem's start, time span, step and scheme from :func:`femvi.solve`'s keywords,
    removing what they replace: ``q0`` -> ``[initial] q``; ``v0`` or ``p0`` -> ``[initial] v`` or
    ``p`` (the other one, and a start from ``q1``, removed); ``t_span = (t0, t1)`` ->
    ``[initial] t`` and ``[time] end``; ``dt`` -> ``[time] step`` (``ds`` in adaptive mode;
    ``steps`` and ``accuracy`` removed); ``degree`` or ``order`` -> ``[scheme]`` (``order``
    removes ``degree``, ``points`` and ``quadrature``, ``degree`` removes ``order``);
    ``quadrature``, ``points``, ``nodes`` -> ``[scheme]``; ``method`` -> ``[solver] method``;
    ``mode`` -> ``[time] mode``.

    >>> d = {"scheme": {"degree": 2}}
    >>> apply_run(d, q0=[1.0], v0=[0.0], t_span=(0.0, 5.0), dt=0.1, order=4)
    >>> d["scheme"], d["initial"], d["time"]
    ({'order': 4}, {'t': 0.0, 'q': [1.0], 'v': [0.0]}, {'end': 5.0, 'step': 0.1})
    """
    from ._core import InputError

    def table(name: str) -> Dict[str, Any]:
        t = d.get(name)
        if not isinstance(t, dict):
            t = {}
            d[name] = t
        return t

    if v0 is not None and p0 is not None:
        raise InputError("give v0 or p0, not both")
    if degree is not None and order is not None:
        raise InputError("give degree or order, not both")
    if t_span is not None:
        span = _floats(t_span, "t_span")
        if len(span) != 2:
            raise InputError(f"t_span must be (t0, t1), not {t_span!r}")
        table("initial")["t"] = span[0]
        table("time")["end"] = span[1]
    if q0 is not None:
        table("initial")["q"] = _floats(q0, "q0")
    for key, value in (("v", v0), ("p", p0)):
        if value is not None:
            init = table("initial")
            for other in ("v", "p", "q1"):
                init.pop(other, None)
            init[key] = _floats(value, f"{key}0")
    if mode is not None:
        table("time")["mode"] = str(mode)
    if dt is not None:
        time = table("time")
        for other in ("steps", "accuracy"):
            time.pop(other, None)
        time["ds" if time.get("mode") == "adaptive" else "step"] = float(dt)
    if order is not None:
        scheme = table("scheme")
        for other in ("degree", "points", "quadrature"):
            scheme.pop(other, None)
        scheme["order"] = int(order)
    if degree is not None:
        scheme = table("scheme")
        scheme.pop("order", None)
        scheme["degree"] = int(degree)
    for key, value in (("quadrature", quadrature), ("points", points), ("nodes", nodes)):
        if value is not None:
            table("scheme")[key] = value
    if method is not None:
        table("solver")["method"] = str(method)


def split_run(kw: Dict[str, Any]) -> Dict[str, Any]:
    """Takes :data:`RUN_KEYWORDS` out of ``kw`` (the rest are dotted overrides)."""
    taken = {k: kw.pop(k) for k in RUN_KEYWORDS if k in kw}
    return {k: v for k, v in taken.items() if v is not None}


@contextlib.contextmanager
def problem_file(problem: Any, overrides: Optional[Mapping[str, Any]] = None,
                 run: Optional[Mapping[str, Any]] = None) -> Iterator[Tuple[Path, str]]:
    """A problem file for the Rust side and the name its messages should show.

    A path without overrides is used as it is (messages are exactly the command's); anything
    else is written to a temporary file named after the original's stem.
    """
    overrides = dict(overrides or {})
    if not overrides and not run and (
        isinstance(problem, os.PathLike) or (isinstance(problem, str) and not _looks_like_toml(problem))
    ):
        path = Path(problem)
        yield path, str(path)
        return
    d, source = to_dict(problem, run)
    apply_overrides(d, overrides)
    apply_run(d, **dict(run or {}))
    stem = source.stem if source is not None else "problem"
    shown = str(source) if source is not None else "<problem>"
    with tempfile.TemporaryDirectory(prefix="femvi-") as tmp:
        f = Path(tmp) / f"{stem}.toml"
        f.write_text(dumps(d), encoding="utf-8")
        yield f, shown


def problem_text(problem: Any, overrides: Optional[Mapping[str, Any]] = None, **run: Any) -> str:
    """The problem (a System, a path, TOML text or a dict, with dotted ``overrides`` and
    :func:`femvi.solve`'s run keywords) as the TOML text of its problem file.

    >>> import femvi
    >>> text = femvi.problem_text(femvi.model_problem("harmonic"), {"time.end": 2.0}, dt=0.5)
    >>> "end = 2.0" in text and "step = 0.5" in text
    True
    """
    d, path = to_dict(problem, run)
    apply_overrides(d, dict(overrides or {}))
    apply_run(d, **run)
    if path is not None and "name" not in d:
        d = {"name": path.stem, **d}
    return dumps(d)
