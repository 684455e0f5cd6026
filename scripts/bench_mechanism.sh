#!/usr/bin/env bash
# tumble against MuJoCo on the same URDFs (docs/mechanisms.md): the double pendulum, the 7-link
# chain and the free-floating 3-link chain (no gravity) of models/, at dt = 1 ms and 10 ms.
# For each engine setting: cost per step (tumble: `tumble bench --scene`, median of 5 runs of
# TIMED_STEPS bare steps; MuJoCo: its C rollout of the same count) and, over SECS seconds
# (default 100), the largest relative energy error, and for the floating chain the angular
# momentum (about its centre of mass) and linear momentum errors. MuJoCo runs its own URDF
# importer (scripts/bench_mechanism.py), contacts, limits, damping and armature off.
# Prints one table; the ratio column is each row's cost over tumble variational's on the same
# case and dt (one run, one machine: ratios, not absolute figures, are the point).
# Usage: bash scripts/bench_mechanism.sh   (SECS=100 TIMED_STEPS=10000 CASES=a,b DTS=0.001,0.01)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
secs="${SECS:-100}"
timed="${TIMED_STEPS:-10000}"
cases="${CASES:-double_pendulum,chain7,chain3_free}"
dts="${DTS:-0.001,0.01}"
source scripts/benchenv.sh
cargo build --release --quiet
T=target/release/tumble
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
rows="$work/rows.jsonl"
IFS=, read -r -a case_list <<<"$cases"
IFS=, read -r -a dt_list <<<"$dts"
for c in "${case_list[@]}"; do
  for dt in "${dt_list[@]}"; do
    for integrator in variational variational4; do
      "$T" bench --scene "models/$c.toml" --integrator "$integrator" --dt "$dt" \
        --errors-over "$secs" --steps "$timed" --repeats 5 |
        awk -v c="$c" -v dt="$dt" -v i="$integrator" -v s="$secs" -F= '
          /^energy_err_max=/ {e = $2} /^momentum_err_max=/ {l = $2}
          /^linear_momentum_err_max=/ {p = $2} /^ns_per_step=/ {ns = $2}
          END {printf "{\"case\": \"%s\", \"integrator\": \"tumble-%s\", \"dt\": %s, \"steps\": %d, \"ns_per_step\": %s, \"energy_err_max\": \"%s\", \"momentum_err_max\": \"%s\", \"linear_momentum_err_max\": \"%s\"}\n", c, i, dt, s / dt + 0.5, ns, e, l, p}' >>"$rows"
    done
  done
done
# MuJoCo writes MUJOCO_LOG.TXT into its working directory when a model goes unstable: a temp one.
repo="$PWD"
(cd "$work" && "$repo/$venv/bin/python" "$repo/scripts/bench_mechanism.py" "$repo/models" \
  "$secs" "$timed" "$cases" "$dts") >>"$rows"
"$venv/bin/python" scripts/bench_mechanism.py --table <"$rows"
