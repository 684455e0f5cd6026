#!/usr/bin/env bash
# The dataset benchmark quoted in README "Datasets": models/dataset_bench.toml (10 000 runs of
# 100 steps) generated with 1 and 2 threads, REPEATS times each (default 3); prints every run's
# summary line, then the medians of runs/s and body-steps/s and the 2-thread speedup, and a
# control: two 1-thread generations at once against one alone (wall-time ratio near 1.0: two
# free cores; near 2.0: the machine had one, so no thread count can scale there).
# Usage: bash scripts/bench_dataset.sh [REPEATS]   (builds the release binary first)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
repeats="${1:-3}"
cargo build --release --quiet
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
median() { sort -g | awk '{a[NR] = $1} END {print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2}'; }
declare -A runs steps
for threads in 1 2; do
  runs[$threads]=""
  steps[$threads]=""
  for _ in $(seq "$repeats"); do
    line="$(target/release/tumble dataset models/dataset_bench.toml --out "$out/d" --threads "$threads" --force --quiet | tail -1)"
    echo "$line"
    runs[$threads]+="$(sed -E 's/.*runs_per_sec=([^ ]+).*/\1/' <<<"$line")"$'\n'
    steps[$threads]+="$(sed -E 's/.*body_steps_per_sec=([^ ]+).*/\1/' <<<"$line")"$'\n'
  done
done
r1="$(printf '%s' "${runs[1]}" | median)"
r2="$(printf '%s' "${runs[2]}" | median)"
s1="$(printf '%s' "${steps[1]}" | median)"
s2="$(printf '%s' "${steps[2]}" | median)"
echo "median of $repeats: threads=1 runs_per_sec=$r1 body_steps_per_sec=$s1"
echo "median of $repeats: threads=2 runs_per_sec=$r2 body_steps_per_sec=$s2"
awk -v a="$r1" -v b="$r2" 'BEGIN {printf "speedup 1 -> 2 threads: %.2fx\n", b / a}'
wall() { sed -E 's/.*wall_secs=([^ ]+).*/\1/'; }
alone=""
pair=""
for _ in $(seq "$repeats"); do
  alone+="$(target/release/tumble dataset models/dataset_bench.toml --out "$out/a" --threads 1 --force --quiet | tail -1 | wall)"$'\n'
  target/release/tumble dataset models/dataset_bench.toml --out "$out/b" --threads 1 --force --quiet | tail -1 | wall >"$out/b.txt" &
  pair+="$(target/release/tumble dataset models/dataset_bench.toml --out "$out/c" --threads 1 --force --quiet | tail -1 | wall)"$'\n'
  wait
  pair+="$(cat "$out/b.txt")"$'\n'
done
a="$(printf '%s' "$alone" | median)"
p="$(printf '%s' "$pair" | median)"
awk -v a="$a" -v p="$p" 'BEGIN {printf "control: two 1-thread generations at once took %.3f s each, one alone %.3f s: ratio %.2f (1.0 = two free cores)\n", p, a, p / a}'
