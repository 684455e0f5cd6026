#!/usr/bin/env bash
# The whole `tumble simulate` process as a user runs it (start-up, stepping, recording MCAP and
# RRD at 100 Hz, finishing) on models/swarm.toml (10 000 free bodies), default threads, over 1 s
# and 10 s of simulated time, against the bare guarded stepping of the same batch on the same
# threads (`tumble bench --scene models/swarm.toml`, no recording): prints both ratios (issue 34).
#   bash scripts/end_to_end.sh
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
cargo build --release --locked --bin tumble >&2
bin=target/release/tumble
out=target/end_to_end
mkdir -p "$out"
for secs in 1 10; do
    steps=$((secs * 1000))
    # The previous run's files are removed (and the removal synced) before the clock starts:
    # replacing 2.4 GB with --force costs the unlink, not the run.
    rm -f "$out"/swarm.*
    sync
    start=$(date +%s.%N)
    "$bin" simulate models/swarm.toml --duration "$secs" --out "$out/swarm" --force >"$out/simulate_$secs.txt"
    end=$(date +%s.%N)
    ns=$("$bin" bench --scene models/swarm.toml --steps "$steps" --repeats 1 | sed -n 's/^ns_per_step=//p')
    bytes=$(cat "$out"/swarm.mcap "$out"/swarm.rrd | wc -c)
    python3 - "$secs" "$start" "$end" "$ns" "$steps" "$bytes" <<'PY'
import sys
secs, start, end, ns, steps, size = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6])
wall = end - start
bare = ns * steps / 1e9
print(f"{secs} s of models/swarm.toml (10 000 bodies): simulate {wall:.2f} s wall (MCAP + RRD at 100 Hz, "
      f"start-up and finish included, {size / 1e6:.0f} MB written), bare guarded stepping {bare:.2f} s: "
      f"ratio {wall / bare:.2f}")
PY
done
