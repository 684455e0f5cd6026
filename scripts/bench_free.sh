#!/usr/bin/env bash
# Free bodies, one thread: tumble's guarded variational step of models/swarm.toml (10 000 bodies) on
# every vector unit this machine has (TUMBLE_SIMD caps the unit; the bits are the same on each),
# beside MuJoCo's Euler stepping 10 000 free boxes in the same run (scripts/bench_free.py, its own
# venv target/benchenv). Rounds alternate the engines, so a slow spell of the shared host hits both;
# prints each round's figures and the medians, and the ratio MuJoCo / tumble (issue 34).
#   bash scripts/bench_free.sh            (ROUNDS=3 STEPS=1000)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
rounds="${ROUNDS:-3}"
steps="${STEPS:-1000}"
source scripts/benchenv.sh
cargo build --release --quiet --bin tumble
T=target/release/tumble
flags=$(grep -m1 '^flags' /proc/cpuinfo)
levels=sse2
[[ " $flags " == *" avx2 "* ]] && levels="$levels avx2"
[[ " $flags " == *" avx512f "* ]] && levels="$levels avx512"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
for r in $(seq "$rounds"); do
  for l in $levels; do
    ns=$(TUMBLE_SIMD=$l "$T" bench --scene models/swarm.toml --threads 1 --steps "$steps" --repeats 3 |
      sed -n 's/^ns_per_body_step=//p')
    echo "round $r tumble $l: $ns ns per body-step"
    echo "$ns" >>"$work/$l"
  done
  ns=$("$venv/bin/python" scripts/bench_free.py 10000 $((steps / 10)) 3 | tee /dev/stderr | sed -n 's/^ns_per_body_step=//p')
  echo "round $r mujoco euler: $ns ns per body-step"
  echo "$ns" >>"$work/mujoco"
done
median() { sort -g "$1" | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2}'; }
mj=$(median "$work/mujoco")
echo "medians over $rounds rounds (10 000 free bodies, one thread, dt = 1 ms):"
echo "  mujoco euler: $mj ns per body-step"
for l in $levels; do
  m=$(median "$work/$l")
  echo "  tumble $l: $m ns per body-step, MuJoCo Euler / tumble = $(awk -v a="$mj" -v b="$m" 'BEGIN {printf "%.1f", a / b}')x"
done
