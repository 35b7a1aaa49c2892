#!/usr/bin/env bash
# P3's cheapest femvi configurations at 1e-6 and 1e-10 (work_precision p3-best), run K times
# (default 7) alternately with the C Verlet loop, each time the least of 3 runs; prints each
# femvi time against GNI_IRK2's figure scaled by the Verlet loop of the same repetition (0.11 s
# at 1e-6 and 0.12 s at 1e-10 on a machine whose loop took 34 ns per step), and the median and
# range of those ratios.
# Run by hand (not by CI); see README.md here.
set -euo pipefail
cd "$(dirname "$0")"
root=../..
k=${1:-7}
gcc -O2 -o verlet verlet.c -lm
cargo build --release -q -p femvi --example work_precision --manifest-path "$root/Cargo.toml"
wp="$root/target/release/examples/work_precision"
out=$(mktemp)
for i in $(seq "$k"); do
  ./verlet p3 2>/dev/null | sed "s/^/$i,/"
  "$wp" p3-best | sed "s/^/$i,/"
done > "$out"
rm -f verlet
python3 - "$out" <<'PY'
import csv, statistics, sys
rows = list(csv.reader(open(sys.argv[1])))
ns = {r[0]: float(r[7]) for r in rows if r[1] == "verlet"}
ratios = {}
for r in rows:
    if r[1] != "femvi":
        continue
    err = float(r[7])
    level = "1e-10" if err <= 1e-10 else "1e-6" if err <= 1e-6 else None
    if level is None:
        print(f"run {r[0]}: {r[3]} h = {r[4]} missed 1e-6 ({err:.2g})")
        continue
    gni = {"1e-6": 0.11, "1e-10": 0.12}[level] * ns[r[0]] / 34.0  # brief's figure, scaled
    ratios.setdefault((r[3], r[4], level), []).append((gni / float(r[6]), float(r[6]), err))
print(f"Verlet loop on P3: {min(ns.values()):.1f}-{max(ns.values()):.1f} ns per step over {len(ns)} runs")
print("| configuration | step | level | error | CPU s (median) | GNI_IRK2 scaled / femvi: median (min-max) |")
print("|---|---|---|---|---|---|")
for (cfg, h, level), v in ratios.items():
    q = [x[0] for x in v]
    print(f"| {cfg} | {float(h):g} | {level} | {v[0][2]:.2g} | {statistics.median(x[1] for x in v):.4f} "
          f"| {statistics.median(q):.2f} ({min(q):.2f}-{max(q):.2f}) |")
PY
rm -f "$out"
