#!/usr/bin/env bash
# tumble against MuJoCo on the same URDFs (docs/mechanisms.md), one thread each:
#   double_pendulum, chain7, chain3_free (free-floating, no gravity)   the first cases, at dt = 1 ms and 10 ms
#   chain7_driven                  chain7 with a sine motor on each of its 7 joints
#   chain25, chain30, chain100     serial chains of 0.1 m, 1 kg links (models/, scripts/make_chains.py),
#                                  every joint started at 0.3 rad
#   chain30_driven                 chain30 with a sine motor on every joint
#   ur5_servo, panda_servo         example-robot-data's UR5 and Panda (from the test venv target/pyenv,
#                                  scripts/pyenv.sh), fixed base, every arm joint on a position servo holding
#                                  a pose against gravity (the scenes are written into a temp folder by
#                                  scripts/bench_mechanism.py, the gains' reasons there)
# the new cases at dt = 1 ms. For each engine setting: cost per step (tumble: `tumble bench --scene
# --threads 1`, median of 5 runs of TIMED_STEPS bare steps, TIMED_STEPS_LONG for chain25 and chain100; MuJoCo: its C
# rollout of the same count on one thread), over SECS seconds (default 100) the largest relative energy
# error of the passive cases, and for the floating chain the angular momentum (about its centre of mass)
# and linear momentum errors; over the first second, the RMS difference of each row's joint positions from
# tumble variational's (`tumble simulate`'s recording, every 10 ms) and, for the servos, the tracking
# error. MuJoCo runs its own URDF importer (scripts/bench_mechanism.py), contacts, limits, armature off,
# Euler, implicitfast and RK4. Prints one table, the ratio column each row's cost over MuJoCo Euler's on
# the same case and dt (one run, one machine: ratios, not absolute figures, are the point), then sanity
# lines and the requirement's checks as `check: <text> <measured> <bar> PASS|FAIL|SKIP` (reported, not
# asserted: the script exits 0 whatever they say).
# Usage: bash scripts/bench_mechanism.sh
#   (SECS=100 TIMED_STEPS=10000 TIMED_STEPS_LONG=1000 CASES=a,b DTS=0.001,0.01 TUMBLE=/path/to/tumble)
#   DTS, when set, applies to every case; unset, the first three cases run at 0.001,0.01 and the others
#   at 0.001. TUMBLE: the binary to measure (default target/release/tumble, built first; set, no build).
#   SECS=10 runs the whole script in about 5-10 minutes on a 2-core machine.
set -euo pipefail
tumble_bin="${TUMBLE:-}"
[ -n "$tumble_bin" ] && [[ $tumble_bin != /* ]] && tumble_bin="$PWD/$tumble_bin"
cd "$(dirname "${BASH_SOURCE[0]}")/.."
secs="${SECS:-100}"
timed="${TIMED_STEPS:-10000}"
timed_long="${TIMED_STEPS_LONG:-1000}"
first_cases="double_pendulum,chain7,chain3_free"
new_cases="chain7_driven,chain25,chain30,chain30_driven,chain100,ur5_servo,panda_servo"
cases="${CASES:-$first_cases,$new_cases}"
source scripts/benchenv.sh
if [ -z "$tumble_bin" ]; then
  cargo build --release --quiet
  T=target/release/tumble
else
  T="$tumble_bin"
fi
repo="$PWD"
py="$repo/$venv/bin/python"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
rows="$work/rows.jsonl"
IFS=, read -r -a case_list <<<"$cases"
# The servo robots' scenes: example-robot-data's URDFs where the test venv has them.
for c in "${case_list[@]}"; do
  case $c in
  ur5_servo | panda_servo)
    if [ -z "${share:-}" ]; then
      testpy="$(bash scripts/pyenv.sh)"
      share="$("$testpy" -c 'import sysconfig, os; print(os.path.join(sysconfig.get_paths()["purelib"], "cmeel.prefix", "share"))')"
    fi
    "$py" scripts/bench_mechanism.py scene "$c" "$share" >"$work/$c.toml"
    ;;
  esac
done
for c in "${case_list[@]}"; do
  if [ -n "${DTS:-}" ]; then
    dts="$DTS"
  elif [[ ",$first_cases," == *",$c,"* ]]; then
    dts="0.001,0.01"
  else
    dts="0.001"
  fi
  scene="models/$c.toml"
  [ -f "$work/$c.toml" ] && scene="$work/$c.toml"
  steps="$timed"
  # chain100 steps ~1 ms each: it and chain25 (which the check compares it with, over the same stretch of
  # motion) are timed over TIMED_STEPS_LONG steps.
  case $c in chain25 | chain100) steps="$timed_long" ;; esac
  IFS=, read -r -a dt_list <<<"$dts"
  for dt in "${dt_list[@]}"; do
    # Samples every 10 ms of the first second (as the MuJoCo side samples).
    every="$("$py" -c 'import sys; print(max(1, round(0.01 / float(sys.argv[1]))))' "$dt")"
    traj_secs="$("$py" -c 'import sys; print(min(1.0, float(sys.argv[1])))' "$secs")"
    for integrator in variational variational4; do
      stem="$work/traj-$c-$dt-$integrator"
      status=0
      "$T" simulate "$scene" --integrator "$integrator" --dt "$dt" --duration "$traj_secs" \
        --log-every "$every" --out "$stem" --format mcap --no-ellipsoids --force >"$stem.log" 2>&1 || status=$?
      # A setting whose first second already fails (Newton not converging even in 1024 substeps) is not
      # timed: its bench would take minutes of substeps. Its row says so (status -1).
      if [ "$status" -eq 0 ]; then
        "$T" bench --scene "$scene" --integrator "$integrator" --dt "$dt" --errors-over "$secs" \
          --steps "$steps" --repeats 5 --threads 1 >"$work/bench.out" 2>&1 || status=$?
      else
        status=-1
        : >"$work/bench.out"
      fi
      "$py" scripts/bench_mechanism.py tumble-row "$scene" "$c" "$dt" "$integrator" "$secs" "$status" \
        "$stem.log" <"$work/bench.out" >>"$rows"
    done
  done
  # MuJoCo writes MUJOCO_LOG.TXT into its working directory when a model goes unstable: a temp one.
  # Its warnings go to a log (shown if the MuJoCo side fails; the table notes an unstable run).
  (cd "$work" && "$py" "$repo/scripts/bench_mechanism.py" "$repo/models" "$secs" "$steps" "$c" "$dts" \
    "$work") >>"$rows" 2>>"$work/mujoco.log" || { cat "$work/mujoco.log" >&2; exit 1; }
done
"$py" scripts/bench_mechanism.py --table <"$rows"
