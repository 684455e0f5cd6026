#!/usr/bin/env bash
# Runs every check: formatting, lints, the Python venv for interoperability tests, all tests.
# This is the README's test command and what CI runs (.ci/run).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
echo "== cargo fmt --check (the library and the Python extension)"
cargo fmt --all --check
echo "== layering: no import cycle between top-level modules or folders (scripts/import_cycles.py)"
python3 scripts/import_cycles.py
echo "== one build for the binary and the tests (scripts/check_features.sh)"
bash scripts/check_features.sh
echo "== cargo clippy (release profile, all targets, -D warnings)"
cargo clippy --release --all-targets --locked -- -D warnings
cargo clippy --release --locked -p tumble-python -- -D warnings
echo "== Python venv for interoperability tests (mcap, mcap-protobuf-support, rerun-sdk==0.36.3)"
bash scripts/pyenv.sh
echo "== cargo test --release"
cargo test --release --locked
echo "== Python package (python/): pip install ./python (maturin, the same build) and its pytest tests"
py="$(bash scripts/pyenv.sh)"
"$py" -m pip install --quiet --disable-pip-version-check "pytest==9.2.0" ./python
"$py" -m pytest -q python/tests
