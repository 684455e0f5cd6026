#!/usr/bin/env bash
# The Python package's figures (docs/python.md, README): builds the binary and the package, then
# runs scripts/python_bench.py (rollout against `tumble bench`, the controller loop's overhead,
# two Python threads stepping at once).
#   bash scripts/python_bench.sh [rollout|controller|gil ...]
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
cargo build --release --locked --bin tumble >&2
py="$(bash scripts/pyenv.sh)"
"$py" -m pip install --quiet --disable-pip-version-check ./python >&2
"$py" scripts/python_bench.py "$@"
