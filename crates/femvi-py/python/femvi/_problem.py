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
    """TOML text of a dict of tables, arrays, strings, numbers and bools."""
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


def to_dict(problem: Any) -> Tuple[Dict[str, Any], Optional[Path]]:
    """The problem as a dict and the file it came from (None for text or a dict)."""
    from ._core import InputError

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
    raise TypeError("problem must be a path, TOML text or a dict")


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


@contextlib.contextmanager
def problem_file(problem: Any, overrides: Optional[Mapping[str, Any]] = None) -> Iterator[Tuple[Path, str]]:
    """A problem file for the Rust side and the name its messages should show.

    A path without overrides is used as it is (messages are exactly the command's); anything
    else is written to a temporary file named after the original's stem.
    """
    overrides = dict(overrides or {})
    if not overrides and (
        isinstance(problem, os.PathLike) or (isinstance(problem, str) and not _looks_like_toml(problem))
    ):
        path = Path(problem)
        yield path, str(path)
        return
    d, path = to_dict(problem)
    apply_overrides(d, overrides)
    stem = path.stem if path is not None else "problem"
    shown = str(path) if path is not None else "<problem>"
    with tempfile.TemporaryDirectory(prefix="femvi-") as tmp:
        f = Path(tmp) / f"{stem}.toml"
        f.write_text(dumps(d), encoding="utf-8")
        yield f, shown


def problem_text(problem: Any, overrides: Optional[Mapping[str, Any]] = None) -> str:
    """The problem (with overrides) as TOML text."""
    d, path = to_dict(problem)
    apply_overrides(d, dict(overrides or {}))
    if path is not None and "name" not in d:
        d = {"name": path.stem, **d}
    return dumps(d)
