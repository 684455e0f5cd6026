#!/usr/bin/env bash
# Mutation testing of the numerical core with cargo-mutants (docs/mutants.md): every mutant of
# src/sim/ (free-body code; src/sim/mechanism/ excluded), src/model/mass_properties.rs and
# src/model/geometry/mesh/ is built and tested against the fastest Rust-only test binaries; a
# mutant no test notices is "missed". Not part of CI (hours on 2 cores).
#
#   bash scripts/mutants.sh                               the whole scope
#   bash scripts/mutants.sh -f src/sim/guard.rs           other files (replaces the scope)
#   bash scripts/mutants.sh --shard 1/4                   any other cargo-mutants option
#   MUTANTS_IN_PLACE=1 bash scripts/mutants.sh ...        mutate this tree (faster; do not edit
#                                                         it meanwhile)
#   MUTANTS_OUT=dir                                       where mutants.out/ goes (default target/)
#
# Speed: release builds with incremental compilation (CARGO_PROFILE_RELEASE_INCREMENTAL) reuse
# the warm release build of every dependency and rebuild a mutated tumble in 7-30 s instead of
# 60-90 s; `--copy-target=true` gives the copy that warm build. Results: MUTANTS_OUT/mutants.out/
# (caught.txt, missed.txt, timeout.txt, unviable.txt, outcomes.json).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

VERSION=27.1.0
if ! cargo mutants --version 2>/dev/null | grep -qx "cargo-mutants $VERSION"; then
    echo "== installing cargo-mutants $VERSION"
    cargo install cargo-mutants --locked --version "$VERSION"
fi

# Test binaries (given to the build and the test step alike, so nothing else is built): the
# library's unit tests and the Rust-only integration tests of the numerics, each under 5 s. Left
# out: the CLI/input binaries (cli, urdf, policy, scene, fuzz, hostile: 2-3 s more link time per
# mutant for tests of parsing and messages) and those reading the Python venv (minutes).
# MUTANTS_TESTS="a b c" replaces the list (the before-run of docs/mutants.md left out the last two).
read -r -a TESTS <<<"${MUTANTS_TESTS:-integrator integrator_family stability mesh stress guard_check mass_properties}"
test_args=(--cargo-arg=--lib)
for t in "${TESTS[@]}"; do
    test_args+=("--cargo-arg=--test=$t")
done

scope=(-f 'src/sim/**/*.rs' -e 'src/sim/mechanism/**' -f src/model/mass_properties.rs
    -f 'src/model/geometry/mesh/*.rs')
for arg in "$@"; do
    if [[ "$arg" == -f* || "$arg" == --file* ]]; then
        scope=()
    fi
done

# One build directory at a time (-j 1: the machine has 2 cores; --in-place implies one).
mode=(--copy-target=true -j 1)
if [[ "${MUTANTS_IN_PLACE:-0}" == 1 ]]; then
    mode=(--in-place)
fi

export CARGO_PROFILE_RELEASE_INCREMENTAL=true
set -x
cargo mutants --profile release "${mode[@]}" --timeout 300 --build-timeout 900 \
    --output "${MUTANTS_OUT:-target}" "${test_args[@]}" "${scope[@]}" "$@"
