#!/usr/bin/env bash
# Fails when `cargo build --release` and `cargo test --release` would build a shared crate with
# different features (the test command would then recompile most dependencies; see Cargo.toml,
# "Feature unification"). Compares cargo's resolved features without and with the
# dev-dependencies: every crate of the plain build must have exactly the same feature sets (one
# per build unit) in the test build.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
plain="$(mktemp)"; dev="$(mktemp)"; ext="$(mktemp)"
trap 'rm -f "$plain" "$dev" "$ext"' EXIT
cargo tree --locked -e no-dev -f '{p} {f}' --prefix none | sed 's/ (\*)$//' | sort -u >"$plain"
cargo tree --locked -f '{p} {f}' --prefix none | sed 's/ (\*)$//' | sort -u >"$dev"
# The Python extension (python/, built by maturin into the same target/) must build the crates
# it shares with the binary with the same features too, or it rebuilds them.
cargo tree --locked -p tumble-python -e no-dev -f '{p} {f}' --prefix none | sed 's/ (\*)$//' | sort -u >"$ext"
python3 - "$plain" "$dev" "$ext" <<'PY'
import sys
from collections import defaultdict

def units(path):
    crates = defaultdict(set)
    for line in open(path):
        parts = line.split()
        crates[" ".join(parts[:2])].add(" ".join(parts[2:]))
    return crates

plain, dev, ext = units(sys.argv[1]), units(sys.argv[2]), units(sys.argv[3])
shared = [(k, plain[k], ext[k]) for k in sorted(plain) if k in ext and plain[k] != ext[k]]
for crate, a, b in shared:
    print(f"  {crate}: binary build {sorted(a)}, Python extension {sorted(b)}", file=sys.stderr)
if shared:
    sys.exit("error: the Python extension builds these crates with other features than the binary "
             "does; add its features to Cargo.toml's feature-unification lines")
bad = [(k, plain[k], dev.get(k, set())) for k in sorted(plain) if plain[k] != dev.get(k, set())]
for crate, a, b in bad:
    print(f"  {crate}: binary build {sorted(a)}, test build {sorted(b)}", file=sys.stderr)
if bad:
    sys.exit("error: the tests build these crates with other features than the binary does; "
             "add the test build's features to Cargo.toml's feature-unification lines")
print(f"feature sets of the binary and the test build agree ({len(plain)} crates)")
PY
