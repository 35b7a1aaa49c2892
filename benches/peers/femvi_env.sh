# Sourced by the `femvi run` benchmark scripts (cli_expr.sh, cli_verlet.sh): `root` (the
# repository), `FEMVI` (the binary: built in release unless already set) and `work` (a
# temporary directory, removed on exit).
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
if [ -z "${FEMVI:-}" ]; then
  cargo build --release -q -p femvi-cli --manifest-path "$root/Cargo.toml"
  FEMVI="${CARGO_TARGET_DIR:-$root/target}/release/femvi"
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
