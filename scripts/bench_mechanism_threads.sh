#!/usr/bin/env bash
# Copies of mechanisms on the cores (docs/mechanisms.md "Copies and threads"): a scene of
# 100 fixed-base 7-link chains and 100 double pendulums (900 bodies), dt = 1 ms.
#   1. `tumble bench --scene` with --threads 2: the bare constrained step on 1 and 2 threads
#      (runs alternating), its median and best-run scaling;
#   2. `tumble simulate` 1 s end to end at 100 Hz on 1 and 2 threads, with MCAP only and with
#      MCAP + Rerun, wall seconds each; checks the files are the same bytes for both counts.
# Usage: bash scripts/bench_mechanism_threads.sh [REPEATS]   (default 5)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
cargo build --release --quiet
T="$PWD/target/release/tumble"
repeats="${1:-5}"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
cp models/chain7.urdf models/double_pendulum.urdf "$out/"
cat >"$out/farm.toml" <<'TOML'
[sim]
dt = 0.001
duration = 1.0
integrator = "variational"
log_every = 10

[[model]]
urdf = "chain7.urdf"
name = "chain"
bodies = "articulated"
base = "fixed"
copies = 100
seed = 1
position = { uniform = [[-20.0, -20.0, 4.0], [20.0, 20.0, 4.0]] }
joints = { j1 = 1.5707963267948966 }

[[model]]
urdf = "double_pendulum.urdf"
name = "pend"
bodies = "articulated"
base = "fixed"
copies = 100
seed = 2
position = { uniform = [[-20.0, -20.0, 2.0], [20.0, 20.0, 2.0]] }
joints = { shoulder = 2.0, elbow = 0.5 }
TOML
cd "$out"
"$T" bench --scene farm.toml --steps 200 --repeats "$repeats" --threads 2 | grep -E "^(best runs|ns_per_step )"
wall() { "$T" simulate farm.toml --force --out "$1" --threads "$2" --format "$3" | sed -nE 's/.* in ([0-9.]+) s wall time/\1/p'; }
for format in mcap mcap,rrd; do
  w1=$(wall t1 1 "$format"); w2=$(wall t2 2 "$format")
  for ext in ${format//,/ }; do cmp -s "t1.$ext" "t2.$ext" || { echo "$ext differs between 1 and 2 threads" >&2; exit 1; }; done
  awk -v f="$format" -v a="$w1" -v b="$w2" 'BEGIN {printf "simulate 1 s, --format %s: 1 thread %.2f s, 2 threads %.2f s wall (%.2fx); files identical\n", f, a, b, a / b}'
done
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
