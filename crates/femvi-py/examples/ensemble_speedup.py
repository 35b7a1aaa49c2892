"""Ensemble speed-up: 10⁴ Kepler members (eccentricities 0.3-0.7) of 10³ steps (degree 4,
h = 0.05) with 1 and with 2 worker threads, alternating, median of ROUNDS:
`python ensemble_speedup.py [ROUNDS] [MEMBERS]`."""

import statistics
import sys
import time

import numpy as np

import femvi

ROUNDS = int(sys.argv[1]) if len(sys.argv) > 1 else 3
M = int(sys.argv[2]) if len(sys.argv) > 2 else 10_000
e = np.linspace(0.3, 0.7, M)
states = np.column_stack([1 - e, np.zeros(M), np.zeros(M), np.sqrt((1 + e) / (1 - e))])
problem = femvi.model_problem("kepler")
over = {"scheme.degree": 4, "scheme.quadrature": "gauss-legendre", "time.step": 0.05, "time.end": 50.0}
times = {1: [], 2: []}
results = {}
for _ in range(ROUNDS):
    for w in (1, 2):
        clock = time.perf_counter()
        results[w] = femvi.ensemble(problem, initial_states=states, workers=w, **over)
        times[w].append(time.perf_counter() - clock)
assert all(x is None for x in results[1].errors) and (results[1].steps == 1000).all()
assert np.array_equal(results[1].final_q, results[2].final_q)
t1, t2 = statistics.median(times[1]), statistics.median(times[2])
print(f"{M} members x 1000 steps: 1 thread {t1:.3f} s, 2 threads {t2:.3f} s, speed-up {t1 / t2:.2f}")
