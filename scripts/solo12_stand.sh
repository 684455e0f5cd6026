#!/usr/bin/env bash
# Solo12 (example-robot-data, from the test venv target/pyenv that `bash scripts/test.sh`
# creates) dropped onto a level ground, standing on position servos: writes the scene to
# target/solo12/stand.toml and runs it into logs/solo12_stand.{mcap,rrd} (the README's
# screenshot). Usage: bash scripts/solo12_stand.sh [DURATION_SECS]
set -euo pipefail
cd "$(dirname "$0")/.."
duration="${1:-10}"
py=target/pyenv/bin/python
[ -x "$py" ] || { echo "no target/pyenv: run bash scripts/test.sh once (it installs example-robot-data)" >&2; exit 2; }
share=$("$py" -c 'import sysconfig, os; print(os.path.join(sysconfig.get_paths()["purelib"], "cmeel.prefix", "share"))')
urdf="$share/example-robot-data/robots/solo_description/robots/solo12.urdf"
[ -f "$urdf" ] || { echo "$urdf not found: pip install example-robot-data into target/pyenv" >&2; exit 2; }
mkdir -p target/solo12 logs
scene=target/solo12/stand.toml
{
  printf '# Solo12 standing on its servos (scripts/solo12_stand.sh; docs/contact.md, "Robots")\n'
  printf '[sim]\ndt = 0.001\nduration = %s\ngravity = [0.0, 0.0, -9.81]\nlog_every = 10\n\n' "$duration"
  printf '[ground]\nheight = 0.0\nfriction = 0.8\n\n'
  printf '[[model]]\nurdf = "%s"\npackage_paths = ["%s"]\nallow_mesh_paths = ["%s"]\n' "$urdf" "$share" "$share"
  printf 'bodies = "articulated"\nposition = [0.0, 0.0, 0.25]\ncollisions = "urdf"\n'
  printf 'joints = { FL_HAA = 0.0, FL_HFE = 0.8, FL_KFE = -1.6, FR_HAA = 0.0, FR_HFE = 0.8, FR_KFE = -1.6, HL_HAA = 0.0, HL_HFE = -0.8, HL_KFE = 1.6, HR_HAA = 0.0, HR_HFE = -0.8, HR_KFE = 1.6 }\n'
  for jq in FL_HAA:0.0 FL_HFE:0.8 FL_KFE:-1.6 FR_HAA:0.0 FR_HFE:0.8 FR_KFE:-1.6 HL_HAA:0.0 HL_HFE:-0.8 HL_KFE:1.6 HR_HAA:0.0 HR_HFE:-0.8 HR_KFE:1.6; do
    printf '\n[[model.actuator]]\njoint = "%s"\nkind = "position"\ntarget = %s\nkp = 20.0\nkd = 0.5\n' "${jq%%:*}" "${jq##*:}"
  done
} > "$scene"
cargo run --release --quiet -- simulate "$scene" --out logs/solo12_stand --force
