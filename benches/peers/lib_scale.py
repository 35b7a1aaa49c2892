"""The library's explicit step against the size of the system (issue 15: per-step cost per
degree of freedom from n = 10^3 to 10^6 against the C loop's): the FPUT chain (alpha = 0.25,
lowest mode, h = 0.1) through `Integrator::advance` (examples/setup_scale: the median over
five timed calls of S steps each) and the C loop benches/peers/fpu.c (gcc -O2), plain and
with compensated sums, at n = 10^3, 10^4, 10^5, 10^6, with S = max(MIN, 2*10^7 / n) steps.
K rounds; within a round every size runs every program in turn (alternating, as the host is
shared). Prints the medians (ns per step per degree of freedom) and the growth from 10^3 to
10^6.

Usage: python3 lib_scale.py [K] [MIN]  (K rounds, default 5; MIN steps per call, default 300)
SETUP_SCALE=path[:path...] (default target/release/examples/setup_scale; several paths for
A/B comparisons, one row each). Build first: cargo build --release -p femvi --example
setup_scale. By hand, not CI.
"""

import os
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
SIZES = [1_000, 10_000, 100_000, 1_000_000]


def steps_for(n, least):
    return max(least, 20_000_000 // n)


def femvi(path, n, steps):
    out = subprocess.run([path, "fpu", str(n), str(steps)], check=True, capture_output=True, text=True).stdout
    # | fpu | n | load | new | first | step | per dof (ns) | rss |
    return float(out.strip().split("|")[7])


def c_loop(path, n, steps, compensated):
    args = [path, str(n), str(steps), "1"] + (["c"] if compensated else [])
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    return float(out.strip().split(",")[-1])


def main():
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    least = int(sys.argv[2]) if len(sys.argv) > 2 else 300
    default = os.path.join(ROOT, "target", "release", "examples", "setup_scale")
    builds = os.environ.get("SETUP_SCALE", default).split(":")
    tmp = tempfile.mkdtemp()
    fpu_c = os.path.join(tmp, "fpu")
    subprocess.run(["gcc", "-O2", "-o", fpu_c, os.path.join(HERE, "fpu.c"), "-lm"], check=True)
    rows = [(f"femvi {b}", lambda n, s, b=b: femvi(b, n, s)) for b in builds]
    rows += [("C loop", lambda n, s: c_loop(fpu_c, n, s, False))]
    rows += [("C loop, compensated", lambda n, s: c_loop(fpu_c, n, s, True))]
    times = {(name, n): [] for name, _ in rows for n in SIZES}
    for r in range(rounds):
        for n in SIZES:
            for name, f in rows:
                times[(name, n)].append(f(n, steps_for(n, least)))
        print(f"round {r + 1} of {rounds} done", file=sys.stderr)
    print(f"steps per call: max({least}, 2e7/n); {rounds} rounds, medians (ranges), ns per step per dof\n")
    print("| program | " + " | ".join(f"{n:.0e}" for n in SIZES) + " | growth |")
    print("|---|" + "---|" * (len(SIZES) + 1))
    for name, _ in rows:
        med = [statistics.median(times[(name, n)]) for n in SIZES]
        cells = [f"{m:.2f} ({min(times[(name, n)]):.2f}-{max(times[(name, n)]):.2f})" for m, n in zip(med, SIZES)]
        print(f"| {name} | " + " | ".join(cells) + f" | x{med[-1] / med[0]:.2f} |")


if __name__ == "__main__":
    main()
