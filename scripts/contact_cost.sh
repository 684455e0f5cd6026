#!/usr/bin/env bash
# Cost of contact per body-step (issue 31): the rain scene (models/contact_rain.toml: 10 000 bodies falling onto the
# ground, colliding) against the same scene without its [ground] table and without colliders (every model's
# collisions, friction, restitution and self_collision keys dropped: the free step), each timed by
# `tumble bench --scene` (the stepping alone: no recording, no scene loading; the median of REPEATS runs of STEPS
# steps from the scene's initial state). Prints both costs per body-step and their ratio.
# Usage: bash scripts/contact_cost.sh [TUMBLE_BINARY]   (default target/release/tumble, used as it is)
#   SCENE=models/contact_rain.toml  STEPS=2000 (the rain's whole 2 s: the fall, the landings and the rest)
#   REPEATS=1  THREADS=$(nproc) (one count: without --threads, bench also times 1 thread)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
T="${1:-target/release/tumble}"
scene="${SCENE:-models/contact_rain.toml}"
steps="${STEPS:-2000}"
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
bench() {
  "$T" bench --scene "$1" --steps "$steps" --repeats "$repeats" --threads "$threads" | tee "$work/bench.log" >&2
  awk -F= '/^ns_per_body_step=/ {print $2}' "$work/bench.log"
}
echo "== with contact: $scene" >&2
contact="$(bench "$scene")"
echo "== free step: the same bodies, no [ground], no colliders" >&2
free_ns="$(bench "$free")"
awk -v c="$contact" -v f="$free_ns" -v s="$steps" -v t="$threads" -v scene="$scene" 'BEGIN {
  printf "%s, %d steps, %d threads\n", scene, s, t
  printf "contact  %12.1f ns per body-step\n", c
  printf "free     %12.1f ns per body-step\n", f
  printf "ratio    %12.1f (contact / free)\n", c / f
}'
