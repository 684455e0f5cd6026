#!/usr/bin/env bash
# Byte-for-byte comparison of two tumble binaries' outputs (a refactoring must not change a byte).
#
#   bash scripts/compare_outputs.sh OLD_BINARY NEW_BINARY [WORK_DIR]
#
# Runs, with each binary: every bundled scene (models/*.toml, the dataset specs dataset*.toml and
# *_dataset.toml aside; the swarm for 1 s) with every
# format (mcap, rrd, parquet, ros2); the bundled dataset spec; a trade sweep; a stability --scene
# sweep. Then compares every file. Files that hold wall-clock timings are compared with their timing
# fields removed: trade's table/CSV/JSON (seconds per step), the dataset manifest (wall_secs).
# Prints one line per file and exits 1 if any differs.
set -uo pipefail
old=$(realpath "$1"); new=$(realpath "$2")
work=${3:-$(mktemp -d)}
cd "$(dirname "$0")/.."
rm -rf "$work/old" "$work/new"; mkdir -p "$work/old" "$work/new"

produce() { # BINARY DIR
  local bin=$1 dir=$2
  for f in models/*.toml; do
    local n; n=$(basename "$f" .toml)
    case $n in dataset* | *_dataset) continue ;; esac
    # The 10 000-body swarm for 1 s of its 10 (its four files are 1.5 GB at 10 s).
    local extra=(); [[ $n == swarm ]] && extra=(--duration 1)
    "$bin" simulate "$f" "${extra[@]}" --out "$dir/sim/$n" --format mcap,rrd,parquet,ros2 --threads 2 >"$dir/sim/$n.stdout" 2>&1 \
      || echo "simulate $f failed (exit $?)" >>"$dir/failures"
  done
  "$bin" simulate models/chain7.urdf --out "$dir/sim/chain7_urdf" --duration 0.5 >/dev/null 2>&1 \
    || echo "simulate chain7.urdf failed" >>"$dir/failures"
  "$bin" dataset models/dataset.toml --out "$dir/dataset" --quiet --threads 2 >/dev/null 2>&1 \
    || echo "dataset failed (exit $?)" >>"$dir/failures"
  "$bin" trade models/trade.toml --out "$dir/trade" --repeats 1 --dt 0.01,0.005 >/dev/null 2>&1 \
    || echo "trade failed (exit $?)" >>"$dir/failures"
  "$bin" trade models/chain7.toml --out "$dir/trade_chain" --repeats 1 --dt 0.002 --duration 0.2 >/dev/null 2>&1 \
    || echo "trade chain7 failed (exit $?)" >>"$dir/failures"
  "$bin" stability --scene models/default.toml --out "$dir/stability" >/dev/null 2>&1 \
    || echo "stability --scene failed (exit $?)" >>"$dir/failures"
}
mkdir -p "$work/old/sim" "$work/new/sim"
produce "$old" "$work/old"
produce "$new" "$work/new"

status=0
for d in old new; do
  if [[ -s $work/$d/failures ]]; then echo "$d binary:"; cat "$work/$d/failures"; status=1; fi
done
# Timing fields: numbers in columns or keys that name seconds of wall or CPU time.
strip_timing() {
  case $1 in
    *.json) python3 - "$1" <<'PY'
import json, sys
def walk(v):
    if isinstance(v, dict):
        return {k: walk(x) for k, x in v.items()
                if not any(t in k for t in ("secs_per", "wall", "per_sec", "ns_per", "_ns", "time_s", "elapsed", "cost"))}
    if isinstance(v, list):
        return [walk(x) for x in v]
    return v
print(json.dumps(walk(json.load(open(sys.argv[1]))), sort_keys=True))
PY
    ;;
    *.csv) python3 - "$1" <<'PY'
import csv, sys
rows = list(csv.reader(open(sys.argv[1])))
keep = [i for i, h in enumerate(rows[0]) if not any(t in h for t in ("secs", "wall", "per_sec", "ns", "cost", "time_per"))]
for r in rows:
    print(",".join(r[i] for i in keep if i < len(r)))
PY
    ;;
    *) sed -E -e "s#$work/(old|new)#WORK#g" -e 's/in [0-9.]+ s wall time/in <t> wall time/' -e '/^peak memory/d' "$1" ;;
  esac
}
count=0
while IFS= read -r rel; do
  count=$((count + 1))
  a=$work/old/$rel; b=$work/new/$rel
  if [[ ! -e $b ]]; then echo "MISSING in new: $rel"; status=1; continue; fi
  case $rel in
    *.png|*.svg) ;;  # plots of timings; their data is compared through the CSV/JSON
    trade*/*.csv|trade*/*.json|trade*/*.txt|trade*/*.md|*/manifest.json|stability/*.json|stability/*.csv|*.stdout)
      if ! diff -q <(strip_timing "$a") <(strip_timing "$b") >/dev/null; then echo "DIFFERS (timings removed): $rel"; status=1; fi ;;
    *)
      if ! cmp -s "$a" "$b"; then echo "DIFFERS: $rel"; status=1; fi ;;
  esac
done < <(cd "$work/old" && find . -type f ! -name failures | sed 's|^\./||' | sort)
extra=$(comm -13 <(cd "$work/old" && find . -type f | sort) <(cd "$work/new" && find . -type f | sort))
if [[ -n $extra ]]; then echo "ONLY in new:"; echo "$extra"; status=1; fi
echo "compared $count files in $work: $([[ $status == 0 ]] && echo 'all identical' || echo 'DIFFERENCES')"
# The files are kept for a look when something differs; removed otherwise.
[[ $status == 0 ]] && rm -rf "$work/old" "$work/new"
exit $status
