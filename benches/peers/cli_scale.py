"""`femvi run` against the size of the system (issue 15, "O(n) set-up"): the FPUT chain
(alpha = 0.25, lowest mode, h = 0.1) at n = 10^3 ... 10^6 and the n-body problem (dim 3, unit
masses on a jittered cubic lattice, h = 10^-3) at 100 ... 10 000 bodies, degree 1 with the
trapezoid rule, only the first and last nodes written, --quiet. Each problem runs with 1 step
and with S + 1 steps (S = max(100, 2·10^7 / n) for the chain, 2·10^8 / bodies² for n-body, at least 2); set-up = the 1-step run minus one
step, the per-step cost = the difference / S. Process CPU time (user + system) and peak
resident memory of each run (os.wait4), K rounds alternating the sizes, medians. With the C
FPU loop (fpu.c, gcc -O2) at the same sizes for the per-step cost per degree of freedom.

Usage: python3 cli_scale.py [K] [fpu] (FEMVI=path/to/femvi, default target/release/femvi; several
paths separated by ':' are run in turn within each round, one table each, for A/B comparisons;
"fpu" leaves out the n-body cases). By hand, not CI; the machine is shared: repeat and read the
ranges.
"""

import math
import os
import random
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
FEMVIS = os.environ.get("FEMVI", os.path.join(HERE, "..", "..", "target", "release", "femvi")).split(":")


def fpu_file(path, n, steps):
    v = ",".join(repr(math.sin(math.pi * i / (n + 1))) for i in range(1, n + 1))
    write(path, "fpu", f"n = {n}, alpha = 0.25, beta = 0.0", ",".join(["0.0"] * n), v, 0.1, steps)


def nbody_file(path, bodies, steps):
    rng = random.Random(1)
    side = math.ceil(bodies ** (1 / 3) - 1e-9)
    q = []
    for b in range(bodies):
        q += [c + rng.uniform(-0.1, 0.1) for c in (b % side, (b // side) % side, b // (side * side))]
    qs = ",".join(repr(x) for x in q)
    write(path, "n-body", f"bodies = {bodies}, dim = 3, G = 1.0", qs, ",".join(["0.0"] * len(q)), 1e-3, steps)


def write(path, model, params, q, v, h, steps):
    with open(path, "w") as f:
        f.write(
            f'name = "scale"\n[system]\nmodel = "{model}"\nparameters = {{ {params} }}\n'
            f"[initial]\nq = [{q}]\nv = [{v}]\n"
            f'[scheme]\ndegree = 1\nquadrature = "trapezoid"\n'
            f"[time]\nstep = {h}\nend = {h * steps!r}\n"
            f'[output]\ndirectory = "{path}.out"\nevery = 1000000000\n'
        )


def run(cmd):
    """CPU seconds and peak RSS (MiB, from /usr/bin/time: a forked child's own ru_maxrss
    would count this script's memory) of one run."""
    proc = subprocess.Popen(["/usr/bin/time", "-f", "%M"] + cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, ru = os.wait4(proc.pid, 0)
    err = proc.stderr.read().decode()
    if status != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({status}): {err}")
    return ru.ru_utime + ru.ru_stime, int(err.strip().splitlines()[-1]) / 1024


def main():
    k = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    work = tempfile.mkdtemp()
    cloop = os.path.join(work, "fpu")
    subprocess.run(["gcc", "-O2", "-o", cloop, os.path.join(HERE, "fpu.c"), "-lm"], check=True)
    # About 2·10^7 degrees of freedom × steps (fpu) and 2·10^8 pairs × steps (n-body) between
    # the two runs of a problem.
    cases = [("fpu", n, max(100, 20_000_000 // n)) for n in (1000, 10_000, 100_000, 1_000_000)]
    if "fpu" not in sys.argv[2:]:
        cases += [("n-body", b, max(2, 200_000_000 // (b * b))) for b in (100, 1000, 10_000)]
    files = {}
    for kind, size, extra in cases:
        for steps in (1, 1 + extra):
            path = os.path.join(work, f"{kind}{size}_{steps}.toml")
            (fpu_file if kind == "fpu" else nbody_file)(path, size, steps)
            files[(kind, size, steps)] = path
    res = {(exe, key): [] for key in files for exe in FEMVIS}
    cres = {n: [] for _, n, _ in cases[:4]}
    for r in range(k):
        for key, path in files.items():
            for exe in FEMVIS:
                res[(exe, key)].append(run([exe, "run", "--quiet", path]))
        for n in cres:
            out = subprocess.run([cloop, str(n)], capture_output=True, text=True, check=True).stdout
            cres[n].append(float(out.strip().split(",")[-1]))
        print(f"round {r + 1} done", file=sys.stderr, flush=True)
    for exe in FEMVIS:
        if len(FEMVIS) > 1:
            print(f"\n{exe}\n")
        table(exe, cases, res, cres)


def table(exe, cases, res, cres):
    print("| system | size | set-up (s) | step (s) | step per dof (ns) | C loop per dof (ns) | peak RSS (MiB) |")
    print("|---|---|---|---|---|---|---|")
    for kind, size, extra in cases:
        one = statistics.median(t for t, _ in res[(exe, (kind, size, 1))])
        more = statistics.median(t for t, _ in res[(exe, (kind, size, 1 + extra))])
        step = (more - one) / extra
        rss = max(m for _, m in res[(exe, (kind, size, 1 + extra))])
        dof = size if kind == "fpu" else 3 * size
        c = f"{statistics.median(cres[size]):.2f}" if kind == "fpu" else "-"
        print(f"| {kind} | {size} | {one - step:.3f} | {step:.2e} | {step / dof * 1e9:.2f} | {c} | {rss:.0f} |")

if __name__ == "__main__":
    main()
