"""Type stubs of the Rust extension (femvi._core); the public API is in femvi/__init__.py."""

from os import PathLike
from typing import Callable, Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

class InputError(ValueError):
    """A bad problem: the message is the one `femvi run` prints."""

class Dense:
    """The dense output of a run."""

    def span(self) -> Tuple[float, float]: ...
    def state_at(self, t: npt.NDArray[np.float64]) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...

_Path = Union[str, "PathLike[str]"]

def solve_file(
    path: _Path,
    every: Optional[int] = None,
    saveat: Optional[Sequence[float]] = None,
    dense: bool = False,
    max_steps: Optional[int] = None,
    events: Optional[List[Tuple[str, Any, str, bool]]] = None,
    potential: Optional[Tuple[Any, Any, Optional[List[float]]]] = None,
) -> Dict[str, Any]: ...
def ensemble_file(
    path: _Path,
    member_files: Optional[List[str]] = None,
    states: Optional[npt.NDArray[np.float64]] = None,
    velocity: bool = False,
    count: int = 1,
    workers: Optional[int] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
    saveat: Optional[List[float]] = None,
) -> Dict[str, Any]: ...
def models() -> List[Dict[str, Any]]: ...
def model_problem(name: str) -> str: ...
def check_file(path: _Path) -> str: ...
def bvp_file(path: _Path, dir: _Path) -> str: ...
def optimize_file(path: _Path, dir: _Path) -> Tuple[str, Dict[str, Any]]: ...
def convergence_file(path: _Path, steps: List[float], reference: Optional[str] = None, l2: bool = False) -> str: ...
