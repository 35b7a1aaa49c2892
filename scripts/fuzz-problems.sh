#!/usr/bin/env bash
# Problem-file fuzzing through the real binary: writes FEMVI_FUZZ_CASES (default 5000) mutated
# copies of the bundled example problems (the mutator of crates/femvi-cli/tests/all/fuzz_problems.rs)
# and runs `femvi run` on each with a 20 s timeout, then reports the counts by exit code,
# crashes (killed by a signal), panics ("panicked at" on stderr) and hangs (timeouts).
#
#   bash scripts/fuzz-problems.sh                 # 5000 cases
#   FEMVI_FUZZ_CASES=300 bash scripts/fuzz-problems.sh
#   FEMVI_FUZZ_CASES=20000 FEMVI_FUZZ_SEED=3 bash scripts/fuzz-problems.sh --in-process
#                                                 # the same mutator, loaded and stepped in
#                                                 # process (the test CI runs with 300 cases)
#
# Each case writes into its own temporary directory, removed afterwards; files are limited to
# 64 MB (SIGXFSZ ignored, so a run that writes more gets an I/O error instead of a signal).
# A case stopped at the timeout is a long run if it had written rows, else a hang; both are
# kept in $WORK/timeouts for inspection. Exit status: 1 if any case
# crashed, panicked or hung. FEMVI_BIN names a built binary (else it is built); CARGO_WRAP
# prefixes the cargo commands (e.g. CARGO_WRAP="flock /tmp/some.lock").
set -u
cd "$(dirname "$0")/.."
if [ "${1:-}" = "--in-process" ]; then
  exec ${CARGO_WRAP:-} cargo test --release -p femvi-cli --test all -- fuzz_problems::
fi
CASES=${FEMVI_FUZZ_CASES:-5000}
TIMEOUT=${FEMVI_FUZZ_TIMEOUT:-20}
WORK=${FEMVI_FUZZ_WORK:-$(mktemp -d)}
BIN=${FEMVI_BIN:-}
if [ -z "$BIN" ]; then
  ${CARGO_WRAP:-} cargo build --release -p femvi-cli >&2 || exit 2
  BIN="${CARGO_TARGET_DIR:-target}/release/femvi"
fi
mkdir -p "$WORK/cases" "$WORK/timeouts" "$WORK/failures"
FEMVI_FUZZ_CASES=$CASES FEMVI_FUZZ_WRITE="$WORK/cases" \
  ${CARGO_WRAP:-} cargo test --release -p femvi-cli --test all -- --ignored fuzz_problems::write_cases >&2 || exit 2
declare -A codes
crashes=0; panics=0; hangs=0; long=0; total=0
for f in "$WORK"/cases/*.toml; do
  out="$WORK/out"
  rm -rf "$out"
  (trap '' XFSZ; ulimit -f 131072; exec timeout -k 5 "$TIMEOUT" "$BIN" run "$f" --quiet --out "$out") \
    > /dev/null 2> "$WORK/stderr"
  rc=$?
  total=$((total + 1))
  codes[$rc]=$(( ${codes[$rc]:-0} + 1 ))
  if grep -q "panicked at" "$WORK/stderr"; then
    panics=$((panics + 1)); cp "$f" "$WORK/failures/"; cp "$WORK/stderr" "$WORK/failures/$(basename "$f").stderr"
  fi
  if [ "$rc" = 124 ] || [ "$rc" = 137 ]; then
    # Killed at the timeout: a long run if it was writing rows (trajectory.csv past its
    # header), else a hang.
    rows=$(wc -l < "$out/trajectory.csv" 2>/dev/null || echo 0)
    if [ "$rows" -gt 1 ]; then
      long=$((long + 1)); cp "$f" "$WORK/timeouts/long-$(basename "$f")"
    else
      hangs=$((hangs + 1)); cp "$f" "$WORK/timeouts/"
    fi
  elif [ "$rc" -ge 128 ]; then
    crashes=$((crashes + 1)); cp "$f" "$WORK/failures/"; cp "$WORK/stderr" "$WORK/failures/$(basename "$f").stderr"
  fi
done
rm -rf "$WORK/out"
echo "cases: $total"
for rc in $(printf '%s\n' "${!codes[@]}" | sort -n); do echo "exit $rc: ${codes[$rc]}"; done
echo "crashes (signals): $crashes"
echo "panics: $panics"
echo "long runs (stopped at ${TIMEOUT} s while writing rows): $long"
echo "hangs (stopped at ${TIMEOUT} s with no row written): $hangs (kept in $WORK/timeouts)"
[ $crashes = 0 ] && [ $panics = 0 ] && [ $hangs = 0 ]
