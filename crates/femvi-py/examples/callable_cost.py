"""What a potential written in Python costs: Kepler (degree 1 trapezoid and degree 2
Gauss-Legendre, 10^4 steps) with V and F as Python functions against the built-in model,
alternating runs, medians; prints the time per Python call (force and potential calls counted).

    python examples/callable_cost.py [ROUNDS]
"""

import statistics
import sys
import time

import numpy as np

import femvi

ROUNDS = int(sys.argv[1]) if len(sys.argv) > 1 else 5
BASE = {"initial": {"q": [0.5, 0.0], "p": [0.0, 3.0 ** 0.5]}, "time": {"step": 0.01, "end": 100.0}}
calls = [0]


def V(q):
    calls[0] += 1
    return -1.0 / np.hypot(q[0], q[1])


def F(q):
    calls[0] += 1
    return -q / np.hypot(q[0], q[1]) ** 3


for degree, quad in [(1, "trapezoid"), (2, "gauss-legendre")]:
    scheme = {"scheme": {"degree": degree, "quadrature": quad}}
    model = {**BASE, **scheme, "system": {"model": "kepler", "parameters": {"mu": 1.0}}}
    mine = {**BASE, **scheme, "system": {"coordinates": ["x", "y"]}}
    tm, tp = [], []
    for _ in range(ROUNDS):
        c = time.perf_counter()
        femvi.solve(model)
        tm.append(time.perf_counter() - c)
        calls[0] = 0
        c = time.perf_counter()
        femvi.solve(mine, potential=V, force=F)
        tp.append(time.perf_counter() - c)
    m, p = statistics.median(tm), statistics.median(tp)
    print(f"degree {degree} {quad}, 10^4 steps: model {m:.4f} s, Python potential {p:.4f} s "
          f"({p / m:.0f}x); {calls[0]} Python calls, {1e6 * (p - m) / calls[0]:.2f} us per call")
