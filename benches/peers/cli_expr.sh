#!/usr/bin/env bash
# Expressions against the built-in models through `femvi run` (issue 15's first Must-show):
# the README pendulum example (examples/pendulum.toml, degree 2, Gauss 3, h = 0.01) with its
# expression against `model = "pendulum"`, 2·10⁶ steps; Kepler (e = 0.6, h = 2π/1000) as the
# expression 0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2) against `model = "kepler"`, degree 2
# with Gauss 2 and degree 4 with Gauss 4, 10⁶ steps; relativistic Kepler (a general
# Lagrangian: Newton, and an inverse Legendre transform per node for the energy) as the
# expression 0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2) + (x_dot^2 + y_dot^2)^2/800
# (c = 10), same schemes, against the same Kepler model runs, with the energy at the written
# nodes (the default for it) and at every node (_every). Every 10 000th node written, --quiet.
# Process CPU time, K alternating rounds (default 5), medians (alternate.py); the ratios to
# read are each expression's median over its model's. FEMVI=path/to/femvi skips the build;
# EXTRA=label=/other/femvi adds that build's three expression runs (A/B, e.g. a build with
# --no-default-features, whose expressions are interpreted).
# Run by hand, not by CI.
set -euo pipefail
cd "$(dirname "$0")"
k=${1:-5}
source ./femvi_env.sh
sed -e 's/^coordinates = .*$//' -e 's/^lagrangian = .*$/model = "pendulum"/' \
  -e 's/^parameters = .*$/parameters = { m = 1.0, g = 9.81, l = 1.0 }/' \
  "$root/examples/pendulum.toml" > "$work/pendulum_model.toml"
kepler() {
  cat <<TOML
name = "kepler"
[system]
$1
[initial]
q = [0.4, 0.0]
p = [0.0, 2.0]
[scheme]
degree = 2
quadrature = "gauss-legendre"
points = 2
[time]
step = 0.006283185307179587
end = 6283.185307179586
[output]
every = 10000
TOML
}
kepler 'coordinates = ["x", "y"]
lagrangian = "0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2)"' > "$work/kepler_expr.toml"
kepler 'model = "kepler"
parameters = { mu = 1.0 }' > "$work/kepler_model.toml"
kepler 'coordinates = ["x", "y"]
lagrangian = "0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2) + (x_dot^2 + y_dot^2)^2/800"' > "$work/relkepler_expr.toml"
run="run --quiet --set time.end=20000.0 --set output.every=10000"
deg4="--set scheme.degree=4 --set scheme.points=4"
# The energy at every node (the default for relativistic Kepler is the written nodes only).
every="--set output.energy_nodes=every"
extra=()
if [ -n "${EXTRA:-}" ]; then
  label=${EXTRA%%=*}
  other=${EXTRA#*=}
  extra=("pendulum_expr_$label=$other $run --out $work/o7 $root/examples/pendulum.toml"
    "kepler2_expr_$label=$other run --quiet --out $work/o8 $work/kepler_expr.toml"
    "kepler4_expr_$label=$other run --quiet $deg4 --out $work/o9 $work/kepler_expr.toml"
    "relkepler2_expr_$label=$other run --quiet --out $work/o12 $work/relkepler_expr.toml"
    "relkepler4_expr_$label=$other run --quiet $deg4 --out $work/o13 $work/relkepler_expr.toml")
fi
python3 alternate.py "$k" \
  "pendulum_model=$FEMVI $run --out $work/o1 $work/pendulum_model.toml" \
  "pendulum_expr=$FEMVI $run --out $work/o2 $root/examples/pendulum.toml" \
  "kepler2_model=$FEMVI run --quiet --out $work/o3 $work/kepler_model.toml" \
  "kepler2_expr=$FEMVI run --quiet --out $work/o4 $work/kepler_expr.toml" \
  "kepler4_model=$FEMVI run --quiet $deg4 --out $work/o5 $work/kepler_model.toml" \
  "kepler4_expr=$FEMVI run --quiet $deg4 --out $work/o6 $work/kepler_expr.toml" \
  "relkepler2_expr=$FEMVI run --quiet --out $work/o10 $work/relkepler_expr.toml" \
  "relkepler4_expr=$FEMVI run --quiet $deg4 --out $work/o11 $work/relkepler_expr.toml" \
  "relkepler2_expr_every=$FEMVI run --quiet $every --out $work/o14 $work/relkepler_expr.toml" \
  "relkepler4_expr_every=$FEMVI run --quiet $deg4 $every --out $work/o15 $work/relkepler_expr.toml" \
  "${extra[@]}"
