#!/usr/bin/env bash
# Cost of contact per body-step (issue 31): the rain scene (models/contact_rain.toml: 10 000 bodies falling onto the
# ground, colliding) against the same scene without its [ground] table and without colliders (every model's
# collisions, friction, restitution and self_collision keys dropped: the free step). Each is run by
# `tumble simulate --format parquet --log-every STEPS` (two frames recorded: the recording costs next to nothing)
# and timed by the wall time simulate prints (the stepping and the recording; not the process start, not the scene
# loading), divided by steps x bodies; the median of REPEATS runs. Prints both costs and their ratio.
# Not `tumble bench --scene`: on one thread (one partition) it times the bare integrator, without the contact phase.
# Usage: bash scripts/contact_cost.sh [TUMBLE_BINARY]   (default target/release/tumble, used as it is)
#   SCENE=models/contact_rain.toml  STEPS=<the scene's duration / dt> (the rain's 2 s: the fall, the landings,
#   the rest)  REPEATS=1  THREADS=$(nproc)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
T="${1:-target/release/tumble}"
scene="${SCENE:-models/contact_rain.toml}"
repeats="${REPEATS:-1}"
threads="${THREADS:-$(nproc)}"
[ -x "$T" ] || { echo "error: $T is not an executable (build with: cargo build --release)" >&2; exit 1; }
[ -f "$scene" ] || { echo "error: no scene $scene" >&2; exit 1; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# The free scene sits beside links to the scene folder's URDFs (its paths are relative to it).
for f in "$(cd "$(dirname "$scene")" && pwd)"/*.urdf; do ln -s "$f" "$work/"; done
free="$work/free.toml"
awk '
  /^[[:space:]]*\[/ { table = $0; gsub(/[[:space:]]/, "", table) }
  table == "[ground]" { next }
  table == "[[model]]" && /^[[:space:]]*(collisions|friction|restitution|self_collision)[[:space:]]*=/ { next }
  { print }
' "$scene" >"$free"
# simulate's summary line: "simulated B bodies for S steps of ... in W s wall time"
run() {
  local walls=() line
  for _ in $(seq "$repeats"); do
    "$T" simulate "$1" --out "$work/out" --force --format parquet --threads "$threads" \
      ${STEPS:+--duration "$(awk -v s="$STEPS" -v f="$1" 'BEGIN { while ((getline l < f) > 0) if (l ~ /^dt[ ]*=/) { split(l, a, "="); dt = a[2] + 0 }; printf "%.12g", s * dt }')"} \
      --log-every 1000000000 >"$work/log" 2>&1 || { cat "$work/log" >&2; exit 1; }
    line="$(grep '^simulated ' "$work/log")"
    echo "$line" >&2
    walls+=("$line")
  done
  printf '%s\n' "${walls[@]}" | awk '{
      for (i = 1; i <= NF; i++) { if ($i == "bodies") b = $(i-1); if ($i == "steps") s = $(i-1); if ($i == "wall") w = $(i-2) }
      print w * 1e9 / (b * s), b, s
    }' | sort -g | awk '{ v[NR] = $1; b = $2; s = $3 } END { m = (NR % 2) ? v[(NR+1)/2] : (v[NR/2] + v[NR/2+1]) / 2; print m, b, s }'
}
echo "== with contact: $scene" >&2
res="$(run "$scene")"
read -r contact bodies steps <<<"$res"
echo "== free step: the same bodies, no [ground], no colliders" >&2
res="$(run "$free")"
read -r free_ns _ _ <<<"$res"
awk -v c="$contact" -v f="$free_ns" -v b="$bodies" -v s="$steps" -v t="$threads" -v scene="$scene" 'BEGIN {
  printf "%s: %d bodies, %d steps, %d threads\n", scene, b, s, t
  printf "contact  %12.1f ns per body-step\n", c
  printf "free     %12.1f ns per body-step\n", f
  printf "ratio    %12.1f (contact / free)\n", c / f
}'
