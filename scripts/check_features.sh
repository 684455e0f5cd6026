#!/usr/bin/env bash
# Fails when `cargo build --release` and `cargo test --release` would build a shared crate with
# different features (the test command would then recompile most dependencies; see Cargo.toml,
# "Feature unification"). Compares cargo's resolved features without and with the
# dev-dependencies: every crate of the plain build must have exactly the same feature sets (one
# per build unit) in the test build.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
plain="$(mktemp)"; dev="$(mktemp)"
trap 'rm -f "$plain" "$dev"' EXIT
cargo tree --locked -e no-dev -f '{p} {f}' --prefix none | sed 's/ (\*)$//' | sort -u >"$plain"
cargo tree --locked -f '{p} {f}' --prefix none | sed 's/ (\*)$//' | sort -u >"$dev"
python3 - "$plain" "$dev" <<'PY'
import sys
from collections import defaultdict

def units(path):
    crates = defaultdict(set)
    for line in open(path):
        parts = line.split()
        crates[" ".join(parts[:2])].add(" ".join(parts[2:]))
    return crates

plain, dev = units(sys.argv[1]), units(sys.argv[2])
bad = [(k, plain[k], dev.get(k, set())) for k in sorted(plain) if plain[k] != dev.get(k, set())]
for crate, a, b in bad:
    print(f"  {crate}: binary build {sorted(a)}, test build {sorted(b)}", file=sys.stderr)
if bad:
    sys.exit("error: the tests build these crates with other features than the binary does; "
             "add the test build's features to Cargo.toml's feature-unification lines")
print(f"feature sets of the binary and the test build agree ({len(plain)} crates)")
PY
