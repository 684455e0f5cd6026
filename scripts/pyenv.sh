#!/usr/bin/env bash
# Creates (once) the Python virtual environment used by the interoperability tests and prints its python path.
# Readers nobody on this team wrote: the `mcap` reader with protobuf and ROS 2 (CDR) decoding, rosbags,
# and rerun-sdk 0.36.3.
# Idempotent and safe to call from several test processes at once (flock).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${TUMBLE_VENV:-$here/target/pyenv}"
req="$here/scripts/requirements.txt"
mkdir -p "$(dirname "$venv")"
exec 9>"$venv.lock"
flock 9
stamp="$venv/.installed"
if [ ! -f "$stamp" ] || ! cmp -s "$req" "$stamp"; then
  rm -rf "$venv"
  python3 -m venv "$venv" >&2
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$req" >&2
  cp "$req" "$stamp"
fi
echo "$venv/bin/python"
