#!/usr/bin/env bash
# Contact side by side with MuJoCo (issue 31; docs/contact.md, "Side by side with MuJoCo"): the same scenes in
# tumble and in MuJoCo 4 (its default contact, dt = 1 ms, the variants in INTEGRATORS), each measured quantity
# against its closed form (scripts/contact_vs_mujoco.py: the cases, the bodies, how each quantity is measured):
#   slope creep   a 0.2 m cube at rest on a 20 deg slope, mu = 0.5 (below the friction angle), 10 s: 0 exact
#   ball sink     a ball (r = 0.1 m) resting on the ground 10 s: penetration r - z, 0 exact
#   sliding stop  a cube sliding at 2 m/s, mu = 0.5: distance v0^2/(2 mu g) and time v0/(mu g)
#   hops          steps of that slide in which the cube is off the ground: 0 exact
#   rebound       a ball dropped from 1 m with restitution 0.5: apexes e^(2k) h, k = 1..3 (MuJoCo: solref (-k, -b))
#   stack         4 cubes stacked, mu = 0.5, 10 s: how far the top one moved, 0 exact
# and the cost per step and per body-step of each case in both engines, over COST_STEPS steps (tumble: the wall
# time `simulate --threads 1` prints, recording two frames; MuJoCo: its C rollout, one thread; medians of REPEATS
# runs). Prints one table (Markdown) and writes it as CSV (OUT, default target/contact_vs_mujoco.csv).
# Exits non-zero only when something fails to run (a tumble exit status, MuJoCo unstable, a missing file).
# Usage: bash scripts/contact_vs_mujoco.sh [TUMBLE_BINARY]
#   Without TUMBLE_BINARY: `cargo build --release` and target/release/tumble. With it: that binary, as it is.
#   INTEGRATORS=euler,implicitfast,implicitfast:elliptic:noslip (also implicit, rk4, discrete; NAME:elliptic for
#     the elliptic cone, NAME:noslip for 10 noslip iterations; euler with neither is MuJoCo's default)
#   REPEATS=5  COST_STEPS=200000  OUT=target/contact_vs_mujoco.csv
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
repo="$PWD"
integrators="${INTEGRATORS:-euler,implicitfast,implicitfast:elliptic:noslip}"
out="${OUT:-$repo/target/contact_vs_mujoco.csv}"
source scripts/benchenv.sh
if [ $# -ge 1 ]; then
  T="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"
else
  cargo build --release --quiet
  T="$repo/target/release/tumble"
fi
[ -x "$T" ] || { echo "error: $T is not an executable tumble binary" >&2; exit 1; }
py="$repo/$venv/bin/python"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$(dirname "$out")"
# MuJoCo writes MUJOCO_LOG.TXT into its working directory when a model goes unstable: the temp one.
(cd "$work" && "$py" "$repo/scripts/contact_vs_mujoco.py" "$T" "$work" "$out" "$integrators")
echo "table written to $out" >&2
