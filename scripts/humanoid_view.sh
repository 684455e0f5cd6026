#!/usr/bin/env bash
# A floating humanoid (TALOS, example-robot-data's talos_reduced.urdf, from the test venv
# target/pyenv that `bash scripts/test.sh` creates) falling under gravity for 2 s, limp, from
# 1.1 m: writes the scene to target/humanoid/talos_fall.toml and runs it into
# logs/humanoid_fall.{mcap,rrd} and logs/humanoid_fall.foxglove.json (the layout that follows
# the robot). The screenshots docs/viewers/humanoid_{rerun,foxglove}.png are these files on
# first open (docs/recordings.md, "Robots in viewers"): the Rerun viewer opens at the end of the
# run, 20 m below the start, and still shows the robot; Foxglove opens at the start.
# Usage: bash scripts/humanoid_view.sh [DURATION_SECS]
set -euo pipefail
cd "$(dirname "$0")/.."
duration="${1:-2}"
py=target/pyenv/bin/python
[ -x "$py" ] || { echo "no target/pyenv: run bash scripts/test.sh once (it installs example-robot-data)" >&2; exit 2; }
share=$("$py" -c 'import sysconfig, os; print(os.path.join(sysconfig.get_paths()["purelib"], "cmeel.prefix", "share"))')
urdf="$share/example-robot-data/robots/talos_data/robots/talos_reduced.urdf"
[ -f "$urdf" ] || { echo "$urdf not found: pip install example-robot-data into target/pyenv" >&2; exit 2; }
mkdir -p target/humanoid logs
scene=target/humanoid/talos_fall.toml
{
  printf '# TALOS falling, floating base, limp joints (scripts/humanoid_view.sh; docs/recordings.md)\n'
  printf '[sim]\ndt = 0.001\nduration = %s\ngravity = [0.0, 0.0, -9.81]\nlog_every = 10\n\n' "$duration"
  printf '[[model]]\nurdf = "%s"\npackage_paths = ["%s"]\nallow_mesh_paths = ["%s"]\n' "$urdf" "$share" "$share"
  printf 'bodies = "articulated"\nbase = "floating"\nposition = [0.0, 0.0, 1.1]\n'
} > "$scene"
cargo run --release --quiet -- simulate "$scene" --out logs/humanoid_fall --force
