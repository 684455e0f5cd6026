#!/usr/bin/env bash
# Runs every check: formatting, lints, the Python venv for interoperability tests, all tests.
# This is the README's test command and what CI runs (.ci/run).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
echo "== cargo fmt --check"
cargo fmt --check
echo "== layering: no import cycle between top-level modules or folders (scripts/import_cycles.py)"
python3 scripts/import_cycles.py
echo "== one build for the binary and the tests (scripts/check_features.sh)"
bash scripts/check_features.sh
echo "== cargo clippy (release profile, all targets, -D warnings)"
cargo clippy --release --all-targets --locked -- -D warnings
echo "== Python venv for interoperability tests (mcap, mcap-protobuf-support, rerun-sdk==0.36.3)"
bash scripts/pyenv.sh
echo "== cargo test --release"
cargo test --release --locked
