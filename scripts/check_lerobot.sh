#!/usr/bin/env bash
# LeRobot's own reader on a tumble dataset: `lerobot.datasets.lerobot_dataset.LeRobotDataset`
# loads the 1000-run driven-arm dataset of models/arm_dataset.toml written with --format lerobot
# (docs/datasets.md, "LeRobot v3"). Not part of scripts/test.sh: `lerobot` pulls torch and the
# CUDA wheels from PyPI, about 8 GB installed and 6 minutes here; the test venv's pandas and polars
# check the same folder in `cargo test --test recordings lerobot::`.
#
#   scripts/check_lerobot.sh [OUT_DIR]      (default target/lerobot-check/arm)
#
# Creates (once) the venv target/lerobot-venv with lerobot==$LEROBOT_VERSION, builds tumble
# (--release), writes the dataset, loads it offline (HF_HUB_OFFLINE=1, root=OUT_DIR) and runs
# tests/py/load_lerobot_dataset.py: len(ds) == total_frames, the episode count, frames equal to
# the Parquet rows, episode index ranges, a delta_timestamps window. Then, when target/pyenv has
# rerun-sdk, Rerun's LeRobot loader reads the folder into OUT_DIR.rrd.
# Exit 0 when every check passed.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"
LEROBOT_VERSION="${LEROBOT_VERSION:-0.4.4}"
venv="$here/target/lerobot-venv"
out="${1:-$here/target/lerobot-check/arm}"

if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c "import lerobot" 2>/dev/null; then
  echo "== installing lerobot==$LEROBOT_VERSION into $venv (torch and CUDA wheels: several GB)"
  start=$(date +%s)
  python3 -m venv "$venv"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check "lerobot==$LEROBOT_VERSION"
  echo "installed in $(( $(date +%s) - start )) s; venv size $(du -sh "$venv" | cut -f1)"
fi
"$venv/bin/python" -c "import importlib.metadata as m; print('lerobot', m.version('lerobot'), '| torch', m.version('torch'), '| datasets', m.version('datasets'))"

echo "== tumble dataset models/arm_dataset.toml --format lerobot"
cargo build --release --quiet
mkdir -p "$(dirname "$out")"
target/release/tumble dataset models/arm_dataset.toml --out "$out" --format lerobot --force --quiet

echo "== LeRobotDataset"
HF_HUB_OFFLINE=1 HF_LEROBOT_HOME="$here/target/lerobot-check/hf_home" \
  "$venv/bin/python" tests/py/load_lerobot_dataset.py "$out"

if [ -x target/pyenv/bin/python ] && target/pyenv/bin/python -c "import rerun" 2>/dev/null; then
  echo "== Rerun's LeRobot loader"
  target/pyenv/bin/python - "$out" "$out.rrd" <<'PY'
import sys
import rerun as rr
rr.init("tumble_lerobot", spawn=False)
rr.save(sys.argv[2])
rr.log_file_from_path(sys.argv[1])
rr.disconnect()
PY
  target/pyenv/bin/rerun rrd stats "$out.rrd" 2>/dev/null | sed -n '/Num chunks per entity/,/^$/p'
  echo "wrote $out.rrd"
fi
echo "OK"
