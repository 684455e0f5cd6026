"""scripts/bench_servo.sh's Python side: the servoed 7-link chain in tumble's scene form, the tumble
recordings read back, MuJoCo on the same URDF, and the table.

Usage: bench_servo.py scene KP DT SECS URDF          (prints the tumble scene)
       bench_servo.py compare MODELS_DIR WORK SECS TIMED_STEPS KPS DTS   (JSON lines, below)
       bench_servo.py --table < rows.jsonl

The case: models/chain7.urdf (seven uniform rods, 0.5 kg, 0.5 m, hinges about y) welded at 4 m,
gravity -9.81 z, every joint j on a position servo tau = kp (r_j(t) - q_j) - kd_j q_j' tracking

  r_j(t) = A sin(2 pi f t + j pi/4),  A = 0.4 rad, f = 0.5 Hz, j = 0..6,

started on its trajectory (q_j = r_j(0), q_j' = r_j'(0)). One kp for every joint; kd_j critical on
the diagonal of the mass matrix of the straight chain: kd_j = 2 sqrt(kp M_jj), M_jj the inertia of
the rods below joint j about it (closed form, `diagonal_inertia`: 14.29 kg m^2 at j1 down to
0.0420 at j7), so that every joint alone would be critically damped. Coupled, every mode of the
straight chain is damped (damping ratio 0.53 and up) and the fastest are heavily over-damped: the
largest eigenvalue of M^-1 D is 3.6e3 sqrt(kp / 10) 1/s, against 56 sqrt(kp / 10) rad/s for the
fastest spring (M^-1 K). A stiff system: explicit damping needs h below 2 / 3.6e3 s at kp = 10.

`compare` writes one JSON line per engine setting, for each kp in KPS and dt in DTS:

  {"kp", "dt", "integrator", "ns_per_step", "stable", "tracking_rms", "ref_rms", "kinetic_max",
   "note"}

  tracking_rms  RMS over the joints and the samples (every 10 ms, t > 0) of r_j(t) - q_j(t), rad
  ref_rms       RMS of q_j(t) - q_ref_j(t), rad: q_ref is MuJoCo's RK4 (rolled out in C) at a step
                h <= min(0.1 ms, 1 / the fastest rate) (`reference`: 3 us at kp = 1e5), the target
                held at each step's midpoint (second order in h); its row prints its largest
                change from a run at 2 h (1e-8 rad or less: far below the figures compared)
  kinetic_max   largest kinetic energy at the samples, J
  stable        finite, no MuJoCo instability warning, the tumble run not stopped by its guard,
                and kinetic_max at most 10 times the reference's (bounded energy); the cost of
                an unstable setting is not printed (MuJoCo's rollout resets a diverged state)

tumble's rows come from WORK/tumble-<integrator>-<kp>-<dt>.mcap (its /joints and /mechanisms
topics, every 10 ms) and WORK/tumble-<integrator>-<kp>-<dt>.json ({"ns_per_step", "exit", "log"}:
`tumble bench`'s cost, `tumble simulate`'s exit status and output),
written by bench_servo.sh. MuJoCo runs its own URDF importer with contacts and limits off, one
position actuator per joint (`set_to_position(kp, kv = kd_j)`, no control or force range), and
holds the control constant over a step: it is given r(t_k + h/2), the target at the step's
midpoint (the start value would lag by h/2, a first-order error that is not the integrator's).
MuJoCo's Euler integrates joint damping implicitly but not an actuator's kv; the row "euler, kd as
damping" gives it kd_j as the joint's damping (dof_damping) and kv = 0: the same effort.
Cost per step: MuJoCo's C rollout of TIMED_STEPS steps with those controls, median of 5.
"""

import json
import math
import sys
import time

import mujoco
import numpy as np
from mujoco import rollout

A, F, N = 0.4, 0.5, 7
L, M, R = 0.5, 0.5, 0.02
SAMPLE = 0.01
REPEATS = 5
REF_DT = 1e-4
# name: (integrator, kd as the joints' damping instead of the actuators' kv)
INTEGRATORS = {
    "euler": (mujoco.mjtIntegrator.mjINT_EULER, False),
    "euler, kd as damping": (mujoco.mjtIntegrator.mjINT_EULER, True),
    "implicitfast": (mujoco.mjtIntegrator.mjINT_IMPLICITFAST, False),
    "implicit": (mujoco.mjtIntegrator.mjINT_IMPLICIT, False),
    "rk4": (mujoco.mjtIntegrator.mjINT_RK4, False),
    "discrete": (mujoco.mjtIntegrator.mjINT_DISCRETE, False),
}


def diagonal_inertia(j):
    """Inertia of rods j..6 about joint j, the chain straight (kg m^2)."""
    icm = M * (3 * R * R + L * L) / 12
    return sum(icm + M * ((k - j) * L + L / 2) ** 2 for k in range(j, N))


def kd(kp):
    return [2.0 * math.sqrt(kp * diagonal_inertia(j)) for j in range(N)]


def phase(j):
    return j * math.pi / 4


def target(t):
    """r_j(t); t a number (one row) or an array of times (one row per time)."""
    phases = np.array([phase(j) for j in range(N)])
    return A * np.sin(2 * math.pi * F * np.asarray(t, dtype=float)[..., None] + phases)


def target_rate(t):
    w = 2 * math.pi * F
    return np.array([A * w * math.cos(w * t + phase(j)) for j in range(N)])


def scene(kp, dt, secs, urdf):
    q0, v0 = target(0.0), target_rate(0.0)
    names = [f"j{j + 1}" for j in range(N)]
    lines = [
        "[sim]",
        f"dt = {dt!r}",
        f"duration = {secs!r}",
        "gravity = [0.0, 0.0, -9.81]",
        f"log_every = {round(SAMPLE / dt)}",
        "[[model]]",
        f"urdf = {json.dumps(urdf)}",
        'bodies = "articulated"',
        'base = "fixed"',
        "position = [0.0, 0.0, 4.0]",
        "joints = { " + ", ".join(f"{n} = {float(q)!r}" for n, q in zip(names, q0)) + " }",
        "joint_velocities = { " + ", ".join(f"{n} = {float(v)!r}" for n, v in zip(names, v0)) + " }",
    ]
    for j, (name, d) in enumerate(zip(names, kd(kp))):
        lines += [
            "[[model.actuator]]",
            f'joint = "{name}"',
            'kind = "position"',
            f"target = {{ sine = {{ amplitude = {A!r}, frequency_hz = {F!r}, "
            f"phase = {phase(j)!r}, offset = 0.0 }} }}",
            f"kp = {float(kp)!r}",
            f"kd = {d!r}",
        ]
    return "\n".join(lines) + "\n"


def build(models_dir, kp, integrator, dt, damping=False):
    """The chain in MuJoCo; `damping`: kd_j as joint j's damping (dof_damping, which MuJoCo's
    Euler integrates implicitly) and the actuators' kv zero, the same effort -kd_j q_j'."""
    spec = mujoco.MjSpec.from_file(f"{models_dir}/chain7.urdf")
    spec.worldbody.first_body().pos = [0.0, 0.0, 4.0]
    for j, d in enumerate(kd(kp)):
        act = spec.add_actuator()
        act.name = f"servo{j + 1}"
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.target = f"j{j + 1}"
        act.set_to_position(kp=float(kp), kv=0.0 if damping else d)
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE
    model = spec.compile()
    model.opt.timestep = dt
    model.opt.integrator = integrator
    model.opt.gravity[:] = [0.0, 0.0, -9.81]
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_LIMIT)
    model.dof_damping[:] = 0.0
    if damping:
        for j, d in enumerate(kd(kp)):
            model.dof_damping[model.joint(f"j{j + 1}").dofadr[0]] = d
    model.dof_armature[:] = 0.0
    model.dof_frictionloss[:] = 0.0
    model.jnt_stiffness[:] = 0.0
    data = mujoco.MjData(model)
    adr = [model.joint(f"j{j + 1}").qposadr[0] for j in range(N)]
    dof = [model.joint(f"j{j + 1}").dofadr[0] for j in range(N)]
    act = [model.actuator(f"servo{j + 1}").id for j in range(N)]
    data.qpos[adr] = target(0.0)
    data.qvel[dof] = target_rate(0.0)
    mujoco.mj_forward(model, data)
    return model, data, adr, act


def controls(model, act, dt, steps):
    """The targets at the steps' midpoints, one row per step (actuator order)."""
    u = np.zeros((steps, model.nu))
    u[:, act] = target((np.arange(steps) + 0.5) * dt)
    return u


def kinetic(model, data):
    mujoco.mj_forward(model, data)
    mujoco.mj_energyVel(model, data)
    return float(data.energy[1])


def fastest_rate(models_dir, kp):
    """The largest |eigenvalue| of M^-1 D and sqrt of M^-1 K at the initial state, 1/s: the
    stiffness of the servoed chain's equations (D = diag kd_j, K = kp I)."""
    model, data, _, _ = build(models_dir, kp, mujoco.mjtIntegrator.mjINT_RK4, REF_DT)
    m = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, m)
    damping = max(abs(np.linalg.eigvals(np.linalg.solve(m, np.diag(kd(kp))))))
    spring = math.sqrt(max(abs(np.linalg.eigvals(np.linalg.solve(m, kp * np.eye(model.nv))))))
    return float(max(damping, spring))


def reference_run(models_dir, kp, secs, per_sample):
    """MuJoCo RK4 at SAMPLE / per_sample, the target held at each step's midpoint, rolled out in
    C one sample at a time: joint positions at the samples (rows) and the largest kinetic energy."""
    h = SAMPLE / per_sample
    model, data, adr, act = build(models_dir, kp, mujoco.mjtIntegrator.mjINT_RK4, h)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    q, ke = [], 0.0
    with rollout.Rollout(nthread=0) as r:
        for s in range(round(secs / SAMPLE)):
            u = np.zeros((1, per_sample, model.nu))
            u[0][:, act] = target(s * SAMPLE + (np.arange(per_sample) + 0.5) * h)
            states, _ = r.rollout(model, data, state[None, :], u, nstep=per_sample)
            state = states[0, -1].copy()
            # FULLPHYSICS state: time, qpos, qvel, ...
            q.append(state[1 : 1 + model.nq][adr])
            mujoco.mj_setState(model, data, state, spec)
            ke = max(ke, kinetic(model, data))
    return np.array(q), ke


def reference(models_dir, kp, secs):
    """The reference: RK4 at h <= min(REF_DT, 1 / fastest rate) (h times the fastest rate at
    most 1, inside RK4's stability interval 2.78), and its change from a run at 2 h."""
    rate = fastest_rate(models_dir, kp)
    per_sample = 2 * math.ceil(SAMPLE * max(rate, 1.0 / REF_DT) / 2)
    q, ke = reference_run(models_dir, kp, secs, per_sample)
    coarse, _ = reference_run(models_dir, kp, secs, per_sample // 2)
    return q, ke, SAMPLE / per_sample, float(np.max(np.abs(coarse - q)))


def run_mujoco(models_dir, kp, integrator, dt, secs, damping):
    """Joint positions at the samples, largest kinetic energy, the time MuJoCo went unstable."""
    model, data, adr, act = build(models_dir, kp, integrator, dt, damping)
    steps, every = round(secs / dt), round(SAMPLE / dt)
    bad = int(mujoco.mjtWarning.mjWARN_BADQACC)
    q, ke = [], 0.0
    for k in range(steps):
        data.ctrl[act] = target((k + 0.5) * dt)
        mujoco.mj_step(model, data)
        if data.warning[bad].number > 0 or not np.all(np.isfinite(data.qpos)):
            return None, math.inf, (k + 1) * dt
        if (k + 1) % every == 0:
            q.append(data.qpos[adr].copy())
            ke = max(ke, kinetic(model, data))
    return np.array(q), ke, None


def cost_mujoco(models_dir, kp, integrator, dt, steps, damping):
    model, data, _, act = build(models_dir, kp, integrator, dt, damping)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    u = controls(model, act, dt, steps)[None]
    samples = []
    with rollout.Rollout(nthread=0) as r:
        for _ in range(REPEATS + 1):
            started = time.perf_counter()
            r.rollout(model, data, state[None, :], u, nstep=steps)
            samples.append((time.perf_counter() - started) * 1e9 / steps)
    return float(np.median(samples[1:]))


def read_tumble(path):
    """tumble's joint positions at the samples (rows, t > 0) and its largest kinetic energy."""
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    joints, ke = {}, 0.0
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(
            topics=["/joints", "/mechanisms"]
        ):
            if message.log_time == 0:
                continue
            if channel.topic == "/joints":
                for j in decoded.joints:
                    joints.setdefault(j.name, []).append(j.position)
            else:
                ke = max(ke, max(m.kinetic_energy for m in decoded.mechanisms))
    return np.array([joints[f"j{j + 1}"] for j in range(N)]).T, ke


def rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


def row(kp, dt, integrator, ns, q, ke, ref_q, ref_ke, note):
    stable = q is not None and bool(np.all(np.isfinite(q))) and ke <= 10 * ref_ke
    if q is not None and len(q) != len(ref_q):
        stable, note = False, note or f"{len(q)} samples of {len(ref_q)}"
    times = SAMPLE * np.arange(1, len(ref_q) + 1)
    targets = target(times)
    ok = q is not None and len(q) == len(ref_q) and bool(np.all(np.isfinite(q)))
    return {
        "kp": kp,
        "dt": dt,
        "integrator": integrator,
        "ns_per_step": ns,
        "stable": stable,
        "tracking_rms": rms(targets - q) if ok else math.inf,
        "ref_rms": rms(q - ref_q) if ok else math.inf,
        "kinetic_max": ke,
        "note": note,
    }


def compare(models_dir, work, secs, timed, kps, dts):
    for kp in kps:
        ref_q, ref_ke, ref_h, ref_change = reference(models_dir, kp, secs)
        times = SAMPLE * np.arange(1, len(ref_q) + 1)
        ref_track = rms(target(times) - ref_q)
        print(
            json.dumps(
                {"kp": kp, "dt": ref_h, "integrator": "reference: mujoco-rk4",
                 "ns_per_step": math.nan, "stable": True, "tracking_rms": ref_track,
                 "ref_rms": 0.0, "kinetic_max": ref_ke,
                 "note": f"max change from 2 dt {ref_change:.1e} rad"}
            ),
            flush=True,
        )
        for dt in dts:
            for name in ("variational", "variational4"):
                stem = f"{work}/tumble-{name}-{kp:g}-{dt:g}"
                with open(stem + ".json") as f:
                    info = json.load(f)
                q, ke, note = None, math.inf, ""
                if info["exit"] != 0:
                    # The guard's stop (exit 3) or another failure: the log's first line saying so.
                    said = [l for l in info["log"].splitlines() if "stop" in l or "rror" in l]
                    note = f"exit {info['exit']}: " + (said[0][:70] if said else "")
                try:
                    q, ke = read_tumble(stem + ".mcap")
                except (OSError, KeyError, ValueError) as e:
                    note = f"{note}; no recording ({type(e).__name__})"
                print(json.dumps(row(kp, dt, f"tumble-{name}", info["ns_per_step"], q, ke,
                                     ref_q, ref_ke, note)), flush=True)
            for name, (integ, damping) in INTEGRATORS.items():
                q, ke, unstable = run_mujoco(models_dir, kp, integ, dt, secs, damping)
                note = f"unstable at t = {unstable:.2f} s" if unstable is not None else ""
                ns = cost_mujoco(models_dir, kp, integ, dt, timed, damping)
                print(json.dumps(row(kp, dt, f"mujoco-{name}", ns, q, ke, ref_q, ref_ke, note)),
                      flush=True)


def table(lines):
    rows = [json.loads(line) for line in lines if line.strip()]
    fmt = lambda v: "-" if math.isnan(v) else ("inf" if math.isinf(v) else f"{v:.1e}")
    print(
        f"{'kp':>7} {'dt [s]':>7} {'engine / integrator':<30} {'stable':>6} {'us/step':>8} "
        f"{'track rms':>9} {'vs ref':>8} {'KE max J':>8}  note"
    )
    for r in rows:
        ns = r["ns_per_step"]
        unknown = ns is None or math.isnan(float(ns)) or not r["stable"]
        us = "-" if unknown else f"{float(ns) / 1e3:.2f}"
        print(
            f"{r['kp']:>7g} {r['dt']:>7g} {r['integrator']:<30} {'yes' if r['stable'] else 'NO':>6} "
            f"{us:>8} {fmt(r['tracking_rms']):>9} {fmt(r['ref_rms']):>8} "
            f"{fmt(r['kinetic_max']):>8}  {r['note']}"
        )


def main():
    args = sys.argv[1:]
    if args == ["--table"]:
        table(sys.stdin)
    elif len(args) == 5 and args[0] == "scene":
        sys.stdout.write(scene(float(args[1]), float(args[2]), float(args[3]), args[4]))
    elif len(args) == 7 and args[0] == "compare":
        compare(args[1], args[2], float(args[3]), int(args[4]),
                [float(x) for x in args[5].split(",")], [float(x) for x in args[6].split(",")])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
