"""Ensembles over a ``dask.distributed`` cluster: the members are split into chunks, each
chunk runs as one Rust ensemble (:func:`femvi.ensemble`) in a task, and the results are
gathered into the same arrays a local ensemble gives. Needs ``pip install femvi[dask]``;
dask is imported only when a task graph is built.
"""

from __future__ import annotations

from typing import Any, Dict, Mapping, Optional, Sequence

import numpy as np

from ._problem import problem_text, split_run
from ._solution import EnsembleResult


def _chunk(text: str, states: Optional[np.ndarray], velocity: bool, parameters: Optional[dict],
           workers: Optional[int], saveat: Optional[list] = None) -> dict:
    import femvi

    init = None
    if states is not None:
        n = states.shape[1] // 2
        init = {"q": states[:, :n], ("v" if velocity else "p"): states[:, n:]}
    return dict(femvi.ensemble(text, initial_states=init, parameters=parameters, workers=workers,
                               saveat=saveat, progress=False))


def ensemble(client: Any, problem: Any, initial_states: Any = None,
             parameters: Optional[Mapping[str, Any]] = None, chunks: int = 1000,
             workers: Optional[int] = None, overrides: Optional[Mapping[str, Any]] = None,
             saveat: Optional[Sequence[float]] = None, **kw: Any) -> EnsembleResult:
    """:func:`femvi.ensemble` mapped over a ``dask.distributed`` client in chunks of ``chunks``
    members (``workers``: Rust threads per task, default all cores of the worker).

    >>> import numpy as np, femvi, femvi.dask
    >>> from dask.distributed import Client
    >>> client = Client(processes=False, n_workers=1, dashboard_address=None)
    >>> states = np.tile([1.0, 0.0], (10, 1))
    >>> ens = femvi.dask.ensemble(client, femvi.model_problem("harmonic"), initial_states=states, chunks=4,
    ...                           t_span=(0.0, 1.0), dt=0.01)
    >>> ens.final_q.shape, bool(np.all(ens.final_q == femvi.solve(femvi.model_problem("harmonic"),
    ...                                 t_span=(0.0, 1.0), dt=0.01).q[-1]))
    ((10, 1), True)
    >>> client.close()
    """
    from femvi import _states

    merged = dict(overrides or {})
    merged.update(kw)
    run = split_run(merged)
    text = problem_text(problem, merged, **run)
    states, velocity = _states(initial_states)
    params = {k: np.asarray(v, dtype=np.float64).reshape(-1) for k, v in (parameters or {}).items()}
    sizes = {len(v) for v in params.values()} | ({len(states)} if states is not None else set())
    if len(sizes) != 1:
        raise ValueError("give initial_states and/or parameters with one number of members")
    size = sizes.pop()
    futures = []
    for a in range(0, size, max(1, int(chunks))):
        b = min(size, a + max(1, int(chunks)))
        s = None if states is None else states[a:b]
        p = {k: v[a:b] for k, v in params.items()} or None
        times = None if saveat is None else [float(t) for t in saveat]
        futures.append(client.submit(_chunk, text, s, velocity, p, workers, times, pure=False))
    parts = client.gather(futures)
    out: Dict[str, Any] = {
        key: np.concatenate([part[key] for part in parts])
        for key in ("final_t", "final_q", "final_p", "energy_error", "steps")
    }
    out["errors"] = [e for part in parts for e in part["errors"]]
    if "body" in parts[0]:
        out["body"] = np.concatenate([part["body"] for part in parts])
    if saveat is not None:
        out["saved_t"] = parts[0]["saved_t"]
        out["saved_q"] = np.concatenate([part["saved_q"] for part in parts])
        out["saved_p"] = np.concatenate([part["saved_p"] for part in parts])
    return EnsembleResult(out)
