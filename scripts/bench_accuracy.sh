#!/usr/bin/env bash
# The mixed batch of docs/accuracy.md (999 slow boxes, one fast T-handle): wall time of
# `simulate --accuracy TOL` against the uniform step meeting the same TOL (dt / k of the fastest
# body, every body substepped alike, recording at the same rate), and the ratio.
# Usage: scripts/bench_accuracy.sh [TOL [DURATION]]   (defaults 1e-3, 200 s; builds the release binary first)
set -euo pipefail
cd "$(dirname "$0")/.."
tol="${1:-1e-3}"
duration="${2:-200}"   # s; long enough for the stepping to outweigh the recording
log=20                # recorded every 20 steps of 0.05 s (1 Hz)
scene=models/accuracy_mixed.toml
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
cargo build --release --quiet
bin=target/release/tumble
wall() { # prints the run's wall time from tumble's summary line
  sed -n 's/.* in \([0-9.]*\) s wall time.*/\1/p'
}
t_acc=$("$bin" simulate "$scene" --accuracy "$tol" --duration "$duration" --log-every "$log" --threads 1 --format mcap --out "$out/acc" | tee "$out/acc.txt" | wall)
k=$(python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(max(b['substeps'] for b in d['bodies']))" "$out/acc.accuracy.json")
dt=$(python3 -c "import sys; print(float(sys.argv[1]) / int(sys.argv[2]))" 0.05 "$k")
t_uni=$("$bin" simulate "$scene" --dt "$dt" --duration "$duration" --log-every $((log * k)) --threads 1 --format mcap --out "$out/uni" | wall)
grep -E "accuracy|substep factor|a posteriori" "$out/acc.txt"
echo "mixed batch (1000 bodies, $duration s), TOL $tol rad: --accuracy ${t_acc} s; uniform dt = 0.05/$k = $dt s: ${t_uni} s; ratio $(python3 -c "print(f'{$t_uni / $t_acc:.1f}')")x"
