"""Overhead of femvi.solve against the Rust library's solve on the same problem, alternating
runs: `python overhead.py OVERHEAD_BINARY [ROUNDS]` (the binary: `cargo build --release
--example overhead` in crates/femvi-py). Prints the median times and the ratio."""

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
        py, rs = [], []
        for _ in range(ROUNDS):
            out = subprocess.run([BIN, str(f), "1"], capture_output=True, text=True, check=True)
            rs.append(float(out.stdout.split()[0]))
            clock = time.perf_counter()
            sol = femvi.solve(f)
            py.append(time.perf_counter() - clock)
            assert sol.steps == 100_000, sol.steps
        p, r = statistics.median(py), statistics.median(rs)
        print(f"{label}: 10^5 steps, python {p:.4f} s, rust {r:.4f} s, ratio {p / r:.3f}")
