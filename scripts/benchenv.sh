# Sourced by the scripts that put MuJoCo beside tumble (bench_free.sh, bench_mechanism.sh,
# bench_servo.sh, contact_vs_mujoco.sh): sets `venv` to target/benchenv, made (or remade when
# scripts/bench_requirements.txt changed) with the pinned peers. Not a test dependency.
venv=target/benchenv
req=scripts/bench_requirements.txt
if [ ! -f "$venv/.installed" ] || ! cmp -s "$req" "$venv/.installed"; then
  rm -rf "$venv"
  python3 -m venv "$venv" >&2
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$req" >&2
  cp "$req" "$venv/.installed"
fi
