#!/usr/bin/env bash
# The big-scene benchmark quoted in docs/scale.md: swarms of 1000, 10 000 and 100 000 bodies
# (models/swarm.toml's three shapes and distributions, copies scaled), dt = 1 ms, recorded at
# 100 Hz, each run 1e7 body-steps (10 s, 1 s, 0.1 s). Prints per size:
#   startup_s        wall time of `simulate --duration 0` (load and check URDFs, build, open and
#                    finish both files with one frame each: start-up plus finish)
#   bare_ns          `tumble bench --scene swarm_N.toml --threads 1`: ns per body-step of the
#                    same batch, no recording
#   e2e_ns_T1/_T2    (wall(simulate) - startup) / body-steps with both files, 1 and 2 threads
#                    (median of REPEATS runs each, default 5, the thread counts taking turns)
#   ratio_T1         median over the REPEATS rounds of e2e_T1 / bare, each round's bare timed
#                    right before its end-to-end runs (`bench --scene --threads 1`, one run of
#                    the same steps): the shared machine's speed moves by a third within
#                    minutes, and a ratio of two figures taken minutes apart moves with it
#   mcap_B, rrd_B    bytes per recorded pose (file size / (bodies x recorded steps))
#   peak_MiB         peak resident memory of the 2-thread simulate (VmHWM)
#   bench_scaling    `tumble bench --scene swarm_N.toml --threads 2 --repeats 7`: 1 -> 2 thread
#                    speedup of the bare stepping of the same batch (ratio of the medians)
# then a control: two 1-thread benches at once against one alone (ratio near 1.0: two free
# cores; near 2.0: the machine had one, so no thread count can scale there).
# Usage: bash scripts/bench_scale.sh [SIZES...]   (default 1000 10000 100000; OUT=dir for the files)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
cargo build --release --quiet
T=target/release/tumble
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(1000 10000 100000)
out="${OUT:-$(mktemp -d)}"
mkdir -p "$out"
cleanup() { [ -n "${OUT:-}" ] || rm -rf "$out"; }
trap cleanup EXIT
cp models/box.urdf models/t_handle.urdf models/disc.urdf "$out/"
secs() { awk '/ s wall time/ {for (i = 1; i <= NF; i++) if ($i == "wall") print $(i - 2)}'; }
printf '%-8s %10s %8s %10s %10s %9s %8s %8s %9s %8s\n' bodies startup_s bare_ns e2e_ns_T1 e2e_ns_T2 ratio_T1 mcap_B rrd_B peak_MiB scaling
for n in "${sizes[@]}"; do
  boxes=$((n * 4 / 10)); handles=$((n * 3 / 10)); discs=$((n - boxes - handles))
  duration=$(awk -v n="$n" 'BEGIN {print 1e4 / n}')   # 1e7 body-steps at dt = 1 ms
  sed -e "s/^copies = 4000$/copies = $boxes/" -e "0,/^copies = 3000$/s//copies = $handles/" \
      -e "0,/^copies = 3000$/s//copies = $discs/" models/swarm.toml >"$out/swarm_$n.toml"
  [ "$(grep -c '^copies = ' "$out/swarm_$n.toml")" = 3 ] && grep -q "^copies = $discs$" "$out/swarm_$n.toml"
  start0=$(date +%s.%N)
  "$T" simulate "$out/swarm_$n.toml" --duration 0 --out "$out/s0" --force --threads 1 >/dev/null
  startup=$(awk -v a="$start0" -v b="$(date +%s.%N)" 'BEGIN {printf "%.3f", b - a}')
  # The bare step of the same batch (the swarm itself, not bench's synthetic one).
  bare=$("$T" bench --scene "$out/swarm_$n.toml" --steps $((10000000 / n)) --repeats 3 --threads 1 | tail -1 | cut -d= -f2)
  scaling=$("$T" bench --scene "$out/swarm_$n.toml" --steps $((10000000 / n)) --repeats 7 --threads 2 | sed -nE 's/.*scaling 1 -> 2 threads: ([0-9.]+)x/\1/p')
  # The end-to-end runs: REPEATS (default 3) of each thread count, taking turns; the median.
  walls1=(); walls2=(); ratios=()
  for _ in $(seq "${REPEATS:-5}"); do
    round_bare=$("$T" bench --scene "$out/swarm_$n.toml" --steps $((10000000 / n)) --repeats 1 --threads 1 | tail -1 | cut -d= -f2)
    for threads in 1 2; do
      # A fresh output name, as a first run has: replacing a file of the previous run would
      # add the release of its blocks (0.08 s for 176 MB on this disk) to the timed run.
      rm -f "$out/s$threads.mcap" "$out/s$threads.rrd"
      t0=$(date +%s.%N)
      "$T" simulate "$out/swarm_$n.toml" --duration "$duration" --out "$out/s$threads" --force --threads "$threads" >"$out/log$threads"
      wall=$(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN {print b - a}')
      if [ "$threads" = 1 ]; then
        walls1+=("$wall")
        ratios+=("$(awk -v w="$wall" -v s="$startup" -v b="$round_bare" 'BEGIN {print (w - s) * 1e9 / 1e7 / b}')")
      else
        walls2+=("$wall")
      fi
    done
  done
  median() { printf '%s\n' "$@" | sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
  e2e=()
  for wall in "$(median "${walls1[@]}")" "$(median "${walls2[@]}")"; do
    e2e+=("$(awk -v w="$wall" -v s="$startup" 'BEGIN {printf "%.1f", (w - s) * 1e9 / 1e7}')")
  done
  frames=$(awk '/^wrote/ {print $2}' "$out/log2")
  mcap=$(stat -c %s "$out/s2.mcap"); rrd=$(stat -c %s "$out/s2.rrd")
  cmp -s "$out/s1.mcap" "$out/s2.mcap" && cmp -s "$out/s1.rrd" "$out/s2.rrd" || { echo "threads 1 and 2 differ" >&2; exit 1; }
  peak=$(awk '/peak memory \(VmHWM\)/ {v = $4; u = $5; if (u == "GiB") v *= 1024; if (u == "KiB") v /= 1024; print v}' "$out/log2")
  printf '%-8s %10s %8s %10s %10s %8.2fx %8.1f %8.1f %9s %8s\n' "$n" "$startup" "$bare" "${e2e[0]}" "${e2e[1]}" "$(median "${ratios[@]}")" \
    "$(awk -v b="$mcap" -v n="$n" -v f="$frames" 'BEGIN {print b / (n * f)}')" \
    "$(awk -v b="$rrd" -v n="$n" -v f="$frames" 'BEGIN {print b / (n * f)}')" "${peak:-?}" "${scaling:-?}x"
  echo "  $n bodies, e2e_T1 / bare per round (sorted): $(printf '%s\n' "${ratios[@]}" | sort -g | awk '{printf "%.2f ", $1}')"
done
alone=$( { "$T" bench --bodies 10000 --steps 300 --repeats 3 --threads 1 | tail -1 | cut -d= -f2; } )
"$T" bench --bodies 10000 --steps 300 --repeats 3 --threads 1 | tail -1 | cut -d= -f2 >"$out/pair_b" &
pair=$("$T" bench --bodies 10000 --steps 300 --repeats 3 --threads 1 | tail -1 | cut -d= -f2)
wait
awk -v a="$alone" -v p="$pair" -v q="$(cat "$out/pair_b")" 'BEGIN {printf "control: two 1-thread benches at once %.1f and %.1f ns per body-step, one alone %.1f: ratio %.2f (1.0 = two free cores)\n", p, q, a, (p + q) / 2 / a}'
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
