#!/usr/bin/env bash
# Builds the Python package's wheel for this machine's platform (abi3: one wheel for CPython >= 3.9)
# into target/wheels/, through its PEP 517 backend (maturin, fetched by pip) and the shared
# Cargo build in target/. Prints the wheel's path.
#   bash scripts/python_wheel.sh
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
py="$(bash scripts/pyenv.sh)"
mkdir -p target/wheels
"$py" -m pip wheel --quiet --disable-pip-version-check --no-deps -w target/wheels ./python >&2
ls -t target/wheels/tumble-*.whl | head -1
