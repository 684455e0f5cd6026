#!/usr/bin/env bash
# Servos side by side with MuJoCo (docs/forces.md, "Side by side with MuJoCo"): models/chain7.urdf welded at 4 m
# under gravity, every joint on a position servo tracking a sine (scripts/bench_servo.py: the targets, kd critical
# per joint), for each kp in KPS and dt in DTS: tumble variational and variational4 against MuJoCo's Euler (kd on
# the actuators, or as the joints' damping), implicitfast, implicit, RK4 and discrete integrators. Per setting:
# stable (finite, no guard stop or MuJoCo instability warning, kinetic energy at most 10 times the reference
# motion's), RMS tracking error (target - q), RMS error against a reference run (MuJoCo RK4 at a step below the
# inverse of the fastest rate, checked against twice that step), largest kinetic energy, cost per step (tumble:
# `tumble bench --scene --threads 1`, median of 5 runs of TIMED_STEPS steps; MuJoCo: its C rollout, the same).
# Prints one table (one run, one machine: compare the rows, not the absolute figures across machines).
# Usage: bash scripts/bench_servo.sh   (SECS=10 TIMED_STEPS=5000 KPS=10,100,1000,10000,100000 DTS=0.001,0.01)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
secs="${SECS:-10}"
timed="${TIMED_STEPS:-5000}"
kps="${KPS:-10,100,1000,10000,100000}"
dts="${DTS:-0.001,0.01}"
source scripts/benchenv.sh
cargo build --release --quiet
repo="$PWD"
T="$repo/target/release/tumble"
py="$repo/$venv/bin/python"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
IFS=, read -r -a kp_list <<<"$kps"
IFS=, read -r -a dt_list <<<"$dts"
for kp in "${kp_list[@]}"; do
  for dt in "${dt_list[@]}"; do
    # The names bench_servo.py reads back: %g of the numbers it is given.
    tag="$("$py" -c "import sys; print(f'{float(sys.argv[1]):g}-{float(sys.argv[2]):g}')" "$kp" "$dt")"
    scene="$work/servo-$tag.toml"
    "$py" scripts/bench_servo.py scene "$kp" "$dt" "$secs" "$repo/models/chain7.urdf" >"$scene"
    for integrator in variational variational4; do
      stem="$work/tumble-$integrator-$tag"
      status=0
      "$T" simulate "$scene" --integrator "$integrator" --out "$stem" --format mcap --no-ellipsoids \
        >"$stem.log" 2>&1 || status=$?
      ns="$("$T" bench --scene "$scene" --integrator "$integrator" --dt "$dt" --steps "$timed" \
        --repeats 5 --threads 1 2>/dev/null | awk -F= '/^ns_per_step=/ {print $2}' || true)"
      "$py" -c 'import json, sys; print(json.dumps({"ns_per_step": float(sys.argv[1] or "nan"),
"exit": int(sys.argv[2]), "log": open(sys.argv[3]).read()}))' "$ns" "$status" "$stem.log" >"$stem.json"
    done
  done
done
rows="$work/rows.jsonl"
# MuJoCo writes MUJOCO_LOG.TXT into its working directory when a model goes unstable: the temp one.
# Its warnings go to a log (shown if the comparison fails).
(cd "$work" && "$py" "$repo/scripts/bench_servo.py" compare "$repo/models" "$work" "$secs" "$timed" \
  "$kps" "$dts") >"$rows" 2>"$work/compare.log" || { cat "$work/compare.log" >&2; exit 1; }
"$py" scripts/bench_servo.py --table <"$rows"
