"""Overhead of femvi.solve against the Rust library's solve on the same problem, alternating
runs: `python overhead.py OVERHEAD_BINARY [ROUNDS]` (the binary: `cargo build --release
--example overhead` in crates/femvi-py). The Rust time of a round is the last of three runs in
one process (warm, as the Python process is). Prints the median times and the ratios."""

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import femvi

BIN = sys.argv[1]
ROUNDS = int(sys.argv[2]) if len(sys.argv) > 2 else 5
KEPLER = {
    "system": {"model": "kepler", "parameters": {"mu": 1.0}},
    "initial": {"q": [0.4, 0.0], "p": [0.0, 2.0]},
}
CASES = {
    "degree 1 trapezoid, h = 0.01": {"scheme": {"degree": 1, "quadrature": "trapezoid"},
                                      "time": {"step": 0.01, "end": 1000.0}},
    "degree 4 Gauss-Legendre, h = 0.05": {"scheme": {"degree": 4, "quadrature": "gauss-legendre"},
                                           "time": {"step": 0.05, "end": 5000.0}},
}

with tempfile.TemporaryDirectory() as tmp:
    for label, extra in CASES.items():
        f = Path(tmp) / "kepler.toml"
        f.write_text(femvi.dumps({**KEPLER, **extra}))
        py, rs, rse = [], [], []
        for _ in range(ROUNDS):
            out = subprocess.run([BIN, str(f), "3"], capture_output=True, text=True, check=True)
            rs.append(float(out.stdout.split()[-1]))
            out = subprocess.run([BIN, str(f), "3"], capture_output=True, text=True, check=True,
                                 env={**os.environ, "NO_ENERGY": "1"})
            rse.append(float(out.stdout.split()[-1]))
            clock = time.perf_counter()
            sol = femvi.solve(f)
            py.append(time.perf_counter() - clock)
            assert sol.steps == 100_000, sol.steps
        p, r, re = statistics.median(py), statistics.median(rs), statistics.median(rse)
        print(f"{label}: 10^5 steps, python {p:.4f} s, rust solve {r:.4f} s (ratio {p / r:.3f}), "
              f"rust solve without energy tracking {re:.4f} s (ratio {p / re:.3f})")
