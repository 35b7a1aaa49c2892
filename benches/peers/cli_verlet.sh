#!/usr/bin/env bash
# `femvi run` against the C Verlet loop (issue 15): 10^7 steps of Kepler (P1: e = 0.6,
# h = 2π/1000), degree 1 with the trapezoid rule (Störmer–Verlet, the explicit path), every
# 10 000th node written to trajectory.csv, --quiet; the C loop (verlet.c, gcc -O2) takes the
# same 10^7 steps once. Process CPU time of each, K alternating rounds (default 5), ratio of
# medians (alternate.py). FEMVI=path/to/femvi skips the build; EXTRA="label=/other/femvi"
# adds another build's `femvi run` on the same problem (A/B). Run by hand, not by CI.
set -euo pipefail
cd "$(dirname "$0")"
k=${1:-5}
source ./femvi_env.sh
gcc -O2 -o "$work/verlet" verlet.c -lm
cat > "$work/kepler.toml" <<TOML
name = "kepler-verlet"
[system]
model = "kepler"
parameters = { mu = 1.0 }
[initial]
q = [0.4, 0.0]
p = [0.0, 2.0]
[scheme]
degree = 1
quadrature = "trapezoid"
[time]
step = 0.006283185307179587
end = 62831.853071795864
[output]
directory = "$work/out"
every = 10000
TOML
extra=()
if [ -n "${EXTRA:-}" ]; then
  extra=("${EXTRA%%=*}=${EXTRA#*=} run --quiet $work/kepler.toml")
fi
python3 alternate.py "$k" "c_loop=$work/verlet p1 1 10000000" \
  "femvi_run=$FEMVI run --quiet $work/kepler.toml" "${extra[@]}"
