"""MuJoCo side of scripts/bench_mechanism.sh: the same URDFs through MuJoCo's own URDF importer.

Usage: bench_mechanism.py MODELS_DIR SECS TIMED_STEPS CASES DTS   (JSON lines, below)
       bench_mechanism.py --table < rows.jsonl                    (the table of both engines)

For each case (a tumble scene under models/, whose URDF, placement, joint positions and
velocities it mirrors) and each step size and MuJoCo integrator, prints one JSON line:

  {"case", "integrator", "dt", "steps", "ns_per_step", "energy_err_max", "momentum_err_max",
   "linear_momentum_err_max", "timing", "diverged_at_secs"}

with the errors defined as `tumble bench --errors-over` defines them (relative to the initial
value, the largest over every step; potential energy zero at the world origin, as in tumble):
  energy_err_max           max |E - E0| / |E0|, E = data.energy[0] + data.energy[1]
  momentum_err_max         (floating models) max |L - L0| / |L0|, L about the model's centre of
                           mass (data.subtree_angmom of the world body after mj_subtreeVel)
  linear_momentum_err_max  (floating models, no gravity) max |p - p0| / |p0|
Cost per step: the bare mj_step loop run in C by mujoco.rollout (no energy, no Python per
step), median of REPEATS runs; "timing" says "rollout". A run that MuJoCo flags unstable
(mjWARN_BADQACC: it then resets the state itself) has its errors set to inf and
"diverged_at_secs" to the time; the timed rollout then includes those resets.

The models are made to match tumble's: contacts and joint limits disabled, damping,
armature, friction loss and stiffness zeroed (the URDFs declare none; this enforces it).
"""

import json
import math
import sys
import time

import mujoco
import numpy as np
from mujoco import rollout

REPEATS = 5

# Each case mirrors models/<name>.toml: urdf, base pose, joints, joint velocities, root twist.
CASES = {
    "double_pendulum": {
        "urdf": "double_pendulum.urdf",
        "floating": False,
        "position": [0.0, 0.0, 2.0],
        "joints": {"shoulder": 2.0, "elbow": 0.5},
        "joint_velocities": {},
        "gravity": [0.0, 0.0, -9.81],
    },
    "chain7": {
        "urdf": "chain7.urdf",
        "floating": False,
        "position": [0.0, 0.0, 4.0],
        "joints": {"j1": math.pi / 2},
        "joint_velocities": {},
        "gravity": [0.0, 0.0, -9.81],
    },
    "chain3_free": {
        "urdf": "chain3_free.urdf",
        "floating": True,
        "position": [0.0, 0.0, 0.0],
        "linvel": [0.1, 0.0, 0.05],
        "angvel": [0.0, 0.3, 0.5],
        "joints": {"j1": 0.4, "j2": -0.3},
        "joint_velocities": {"j1": 2.0, "j2": -3.0},
        "gravity": [0.0, 0.0, 0.0],
    },
}

INTEGRATORS = {
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
}


def build(models_dir, case, integrator, dt):
    spec = mujoco.MjSpec.from_file(f"{models_dir}/{case['urdf']}")
    root = spec.worldbody.first_body()
    root.pos = case["position"]
    if case["floating"]:
        root.add_freejoint()
    model = spec.compile()
    model.opt.timestep = dt
    model.opt.integrator = integrator
    model.opt.gravity[:] = case["gravity"]
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_LIMIT)
    model.dof_damping[:] = 0.0
    model.dof_armature[:] = 0.0
    model.dof_frictionloss[:] = 0.0
    model.jnt_stiffness[:] = 0.0
    data = mujoco.MjData(model)
    for name, q in case["joints"].items():
        data.qpos[model.joint(name).qposadr[0]] = q
    for name, v in case["joint_velocities"].items():
        data.qvel[model.joint(name).dofadr[0]] = v
    if case["floating"]:
        free = next(j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE)
        adr = model.jnt_dofadr[free]
        # Free joint: world linear velocity of the body frame's origin, then the angular
        # velocity in the body frame (the root starts unrotated: the world one).
        data.qvel[adr : adr + 3] = case["linvel"]
        data.qvel[adr + 3 : adr + 6] = case["angvel"]
    mujoco.mj_forward(model, data)
    return model, data


def observe(model, data):
    """Energy (J) and, for a floating model, linear and angular momentum about its com."""
    mujoco.mj_energyPos(model, data)
    mujoco.mj_energyVel(model, data)
    mujoco.mj_subtreeVel(model, data)
    energy = data.energy[0] + data.energy[1]
    mass = model.body_subtreemass[0]
    return energy, data.subtree_linvel[0] * mass, data.subtree_angmom[0].copy()


def errors(models_dir, case, integrator, dt, secs):
    model, data = build(models_dir, case, integrator, dt)
    model.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    steps = round(secs / dt)
    e0, p0, l0 = observe(model, data)
    de = dl = dp = 0.0
    bad = int(mujoco.mjtWarning.mjWARN_BADQACC)
    for k in range(steps):
        mujoco.mj_step(model, data)
        # MuJoCo resets the state when it goes unstable (and warns): that is a divergence.
        if data.warning[bad].number > 0:
            return steps, math.inf, math.inf, math.inf, (k + 1) * dt
        mujoco.mj_forward(model, data)
        e, p, l = observe(model, data)
        de = max(de, abs(e - e0) / abs(e0))
        if case["floating"]:
            dl = max(dl, float(np.linalg.norm(l - l0) / np.linalg.norm(l0)))
            dp = max(dp, float(np.linalg.norm(p - p0) / np.linalg.norm(p0)))
    if not case["floating"]:
        dl = dp = math.nan
    return steps, de, dl, dp, None


def cost(models_dir, case, integrator, dt, steps):
    model, data = build(models_dir, case, integrator, dt)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    samples = []
    with rollout.Rollout(nthread=0) as r:
        for _ in range(REPEATS + 1):
            started = time.perf_counter()
            r.rollout(model, data, state[None, :], nstep=steps)
            samples.append((time.perf_counter() - started) * 1e9 / steps)
    return float(np.median(samples[1:]))


def table(lines):
    """The table of scripts/bench_mechanism.sh from the JSON lines of both engines."""
    rows = [json.loads(line) for line in lines if line.strip()]
    base = {
        (r["case"], r["dt"]): float(r["ns_per_step"])
        for r in rows
        if r["integrator"] == "tumble-variational"
    }
    num = lambda v: float(v)  # tumble prints "nan"/"inf" as text, MuJoCo as JSON numbers
    fmt = lambda v: "-" if math.isnan(num(v)) else ("diverged" if math.isinf(num(v)) else f"{num(v):.1e}")
    print(
        f"{'case':<16} {'dt [s]':>7} {'engine / integrator':<22} {'us/step':>8} {'x tumble':>8} "
        f"{'energy err':>10} {'L err':>8} {'p err':>8}"
    )
    for r in rows:
        ref = base.get((r["case"], r["dt"]))
        ratio = f"{float(r['ns_per_step']) / ref:.2f}" if ref else "-"
        print(
            f"{r['case']:<16} {r['dt']:>7} {r['integrator']:<22} {float(r['ns_per_step']) / 1e3:>8.2f} "
            f"{ratio:>8} {fmt(r['energy_err_max']):>10} {fmt(r['momentum_err_max']):>8} "
            f"{fmt(r['linear_momentum_err_max']):>8}"
            + (f"  (unstable at t = {r['diverged_at_secs']:.2f} s)" if r.get("diverged_at_secs") else "")
        )


def main():
    if sys.argv[1:] == ["--table"]:
        table(sys.stdin)
        return
    models_dir, secs, timed_steps = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
    cases = sys.argv[4].split(",")
    dts = [float(x) for x in sys.argv[5].split(",")]
    for name in cases:
        for dt in dts:
            for iname, integ in INTEGRATORS.items():
                steps, de, dl, dp, diverged = errors(models_dir, CASES[name], integ, dt, secs)
                ns = cost(models_dir, CASES[name], integ, dt, timed_steps)
                print(
                    json.dumps(
                        {
                            "case": name,
                            "integrator": f"mujoco-{iname}",
                            "dt": dt,
                            "steps": steps,
                            "ns_per_step": ns,
                            "energy_err_max": de,
                            "momentum_err_max": dl,
                            "linear_momentum_err_max": dp,
                            "timing": "rollout",
                            "diverged_at_secs": diverged,
                        }
                    ),
                    flush=True,
                )


if __name__ == "__main__":
    main()
