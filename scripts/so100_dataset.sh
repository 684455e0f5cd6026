#!/usr/bin/env bash
# 1000 randomized driven runs of the SO-100 arm (example-robot-data's so100.urdf, the arm of
# LeRobot's tutorials; from the test venv target/pyenv that `bash scripts/test.sh` creates) as a
# LeRobot v3.0 dataset: writes the spec to target/so100/so100_dataset.toml and the dataset to
# logs/so100_dataset (docs/datasets.md, "Datasets of robots"). Six position servos (kp 20 N m/rad,
# kd 0.5 N m s/rad; the URDF's 35 N m limit) follow random smooth targets about a mid-range pose,
# from random initial joints, 1 s at 1 ms, 50 frames/s.
# Usage: bash scripts/so100_dataset.sh [RUNS]
set -euo pipefail
cd "$(dirname "$0")/.."
runs="${1:-1000}"
py=target/pyenv/bin/python
[ -x "$py" ] || { echo "no target/pyenv: run bash scripts/test.sh once (it installs example-robot-data)" >&2; exit 2; }
share=$("$py" -c 'import sysconfig, os; print(os.path.join(sysconfig.get_paths()["purelib"], "cmeel.prefix", "share"))')
urdf="$share/example-robot-data/robots/so_arm_description/urdf/so100.urdf"
[ -f "$urdf" ] || { echo "$urdf not found: pip install example-robot-data into target/pyenv" >&2; exit 2; }
mkdir -p target/so100 logs
spec=target/so100/so100_dataset.toml
{
  printf '# scripts/so100_dataset.sh: %s randomized driven runs of the SO-100 arm\n' "$runs"
  printf '[dataset]\nruns = %s\nseed = 7\nruns_per_file = 100\n\n' "$runs"
  printf '[scene.sim]\ndt = 0.001\nduration = 1.0\ngravity = [0.0, 0.0, -9.81]\nlog_every = 20\n\n'
  printf '[[scene.model]]\nurdf = "%s"\npackage_paths = ["%s"]\nallow_mesh_paths = ["%s"]\n' "$urdf" "$share" "$share"
  printf 'name = "so100"\nbodies = "articulated"\nbase = "fixed"\n'
  # The servos' poses: mid-range, away from the stops.
  for jq in shoulder_pan:0.0 shoulder_lift:1.5 elbow_flex:-1.5 wrist_flex:-0.5 wrist_roll:0.0 gripper:0.5; do
    printf '\n[[scene.model.actuator]]\njoint = "%s"\nkind = "position"\ntarget = %s\nkp = 20.0\nkd = 0.5\n' "${jq%%:*}" "${jq##*:}"
  done
  printf '\n[vary]\njoints = { shoulder_lift = { uniform = [1.0, 2.0] }, elbow_flex = { uniform = [-2.0, -1.0] }, wrist_flex = { uniform = [-1.0, 0.0] } }\n'
  printf 'actuators = { smooth = { amplitude = 0.4, cutoff_hz = 1.0 } }\n'
} > "$spec"
cargo run --release --quiet -- dataset "$spec" --out logs/so100_dataset --format lerobot --force --quiet
