"""MuJoCo side of scripts/bench_mechanism.sh: the same URDFs through MuJoCo's own URDF importer.

Usage: bench_mechanism.py MODELS_DIR SECS TIMED_STEPS CASES DTS [WORK]   (MuJoCo's JSON lines, below)
       bench_mechanism.py scene ROBOT SHARE             (prints the servo scene ROBOT: ur5_servo, panda_servo)
       bench_mechanism.py tumble-row SCENE CASE DT INTEGRATOR SECS STATUS LOG < `tumble bench` output
                                                        (tumble's row; LOG: its 1 s `tumble simulate` run's output)
       bench_mechanism.py --table < rows.jsonl          (the table of both engines, then the checks)

Cases. The first three are written out in CASES below (each mirrors models/<name>.toml: urdf, base pose, joint
positions and velocities, root twist). Every other case is read from its tumble scene, WORK/<name>.toml if the
shell wrote one there (the servo robots), else MODELS_DIR/<name>.toml (`scene_case`): one [[model]], a fixed
base at `position`, `joints`, `joint_velocities`, `locked_joints` (at 0: made fixed joints for MuJoCo), its
[[model.actuator]]s (motors and position servos, constant or sine signals). For these the URDF is given to
MuJoCo without its <visual> and <collision> elements (contact is off; it spares MuJoCo the meshes), its
locked joints fixed.

For each case, step size and MuJoCo integrator (Euler, implicitfast, RK4), one JSON line:

  {"case", "integrator", "dt", "steps", "ns_per_step", "energy_err_max", "momentum_err_max",
   "linear_momentum_err_max", "timing", "diverged_at_secs", "q_rms", "tracking_rms", "note"}

with the errors defined as `tumble bench --errors-over` defines them (relative to the initial
value, the largest over every step; potential energy zero at the world origin, as in tumble):
  energy_err_max           max |E - E0| / |E0|, E = data.energy[0] + data.energy[1] (passive cases only: a
                           driven case's energy is not conserved, NaN)
  momentum_err_max         (floating models) max |L - L0| / |L0|, L about the model's centre of
                           mass (data.subtree_angmom of the world body after mj_subtreeVel)
  linear_momentum_err_max  (floating models, no gravity) max |p - p0| / |p0|
  q_rms                    RMS over the joints and the samples (every 10 ms, 0 < t <= 1 s) of MuJoCo's joint
                           positions minus tumble variational's (WORK/traj-CASE-DT-variational.mcap, written by
                           the shell with `tumble simulate`): the two engines run the same physics
  tracking_rms             (servo cases) RMS over the servoed joints and the samples of target - q
Cost per step: the bare mj_step loop run in C by mujoco.rollout on one thread (no energy, no Python
per step; a driven case's controls precomputed), median of REPEATS runs; "timing" says "rollout". A
run that MuJoCo flags unstable (mjWARN_BADQACC: it then resets the state itself) has its errors set to
inf and "diverged_at_secs" to the time; the timed rollout then includes those resets.

The models are made to match tumble's: contacts and joint limits disabled, armature, friction loss and
stiffness zeroed, damping zeroed too (the URDFs of the first three declare none; a scene case keeps the URDF's
damping when the scene keeps it, `joint_damping`, true by default). Actuators: a motor is MuJoCo's motor
(gain 1), its control each step the mean of the effort at the step's two ends (tumble's step effort, the
trapezoid average of the input: src/sim/mechanism/drive.rs). A position servo tau = kp (r - q) - kd qdot
is MuJoCo's position actuator of gain kp with kv = 0 and kd added to the joint's damping (dof_damping):
the same law, and MuJoCo's Euler integrates joint damping implicitly where it would integrate an
actuator's kv explicitly (the Panda's joint 7, kd / M_77 = 2.2e3 1/s, would then be unstable at 1 ms);
no control, force or actuator-force range (the URDF's <limit effort> is imported as one: cleared), as
the scenes set effort_limit = 0.
"""

import json
import math
import os
import re
import sys
import time
import tomllib
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
from mujoco import rollout

REPEATS = 5
SAMPLE = 0.01  # s between the compared samples of both engines' joint positions
TRAJ_SECS = 1.0  # compared over the first second

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

# The servo robots of example-robot-data (pip, in the test venv target/pyenv: scripts/pyenv.sh), welded at
# the origin, gravity on, every arm joint on a position servo holding `pose` from rest at `pose` (it sags
# under gravity by about tau_g / kp and settles). Joint limits, URDF damping and friction off in both
# engines, no effort clamp: the same physics. Gains, per joint:
ROBOTS = {
    # UR5: kp = 1000 N m/rad, kd = 50 N m s/rad on every joint. Stiff enough to hold the pose within
    # 0.04 rad against gravity (tau_g at this pose: 39 N m at the shoulder lift, 15 N m at the elbow);
    # with the diagonal of the mass matrix at the pose (M_jj = 2.5, 3.1, 0.84, 0.24, 0.25, 0.017 kg m^2)
    # kd = 50 damps the shoulder and the elbow at a ratio of 0.45-0.86 (a firm, slightly underdamped
    # servo, 3-5 Hz) and over-damps the light wrists (1.6-6): every joint settles within ~0.5 s.
    "ur5_servo": {
        "urdf": "ur_description/urdf/ur5_robot.urdf",
        "pose": {
            "shoulder_pan_joint": 0.0,
            "shoulder_lift_joint": -1.0,
            "elbow_joint": 1.2,
            "wrist_1_joint": -0.5,
            "wrist_2_joint": 1.0,
            "wrist_3_joint": 0.0,
        },
        "kp": [1000.0] * 6,
        "kd": [50.0] * 6,
        "locked": [],
    },
    # Panda: libfranka's joint impedance example gains, kp = 600, 600, 600, 600, 250, 150, 50 and
    # kd = 50, 50, 50, 50, 30, 25, 15: what Franka runs this arm with. At its "ready" pose they hold it
    # within 0.04 rad (joint 4, tau_g = 22 N m); the URDF leaves out the motors' inertia, so the wrist
    # (M_77 = 0.0067 kg m^2) is over-damped (ratio 13), which a servo with implicit damping handles.
    # The two finger joints (prismatic, the second mimicking the first) are locked shut at 0: tumble's
    # locked_joints names the leader (the follower follows it; tumble refuses to lock a follower), and
    # both are fixed joints for MuJoCo. A servo cannot drive a mimic follower.
    "panda_servo": {
        "urdf": "panda_description/urdf/panda.urdf",
        "pose": {
            "panda_joint1": 0.0,
            "panda_joint2": -math.pi / 4,
            "panda_joint3": 0.0,
            "panda_joint4": -3 * math.pi / 4,
            "panda_joint5": 0.0,
            "panda_joint6": math.pi / 2,
            "panda_joint7": math.pi / 4,
        },
        "kp": [600.0, 600.0, 600.0, 600.0, 250.0, 150.0, 50.0],
        "kd": [50.0, 50.0, 50.0, 50.0, 30.0, 25.0, 15.0],
        "locked": ["panda_finger_joint1"],
    },
}


def robot_scene(name, share):
    """The tumble scene of the servo robot `name`, its URDF under SHARE/example-robot-data/robots."""
    r = ROBOTS[name]
    urdf = os.path.join(share, "example-robot-data", "robots", r["urdf"])
    if not os.path.isfile(urdf):
        sys.exit(f"{urdf} not found: example-robot-data is installed in target/pyenv by scripts/pyenv.sh")
    pose = ", ".join(f"{j} = {q!r}" for j, q in r["pose"].items())
    lines = [
        f"# {name}: written by scripts/bench_mechanism.py (scripts/bench_mechanism.sh), the gains' reasons there.",
        "[sim]",
        "dt = 0.001",
        "duration = 10.0",
        "gravity = [0.0, 0.0, -9.81]",
        'integrator = "variational"',
        "log_every = 10",
        "",
        "[[model]]",
        f"urdf = {json.dumps(urdf)}",
        f"package_paths = [{json.dumps(share)}]",
        f"allow_mesh_paths = [{json.dumps(share)}]",
        'bodies = "articulated"',
        'base = "fixed"',
        "joint_limits = false",
        "joint_damping = false",
        "joint_friction = false",
        f"joints = {{ {pose} }}",
    ]
    if r["locked"]:
        lines.append("locked_joints = [" + ", ".join(json.dumps(j) for j in r["locked"]) + "]")
    for (joint, q), kp, kd in zip(r["pose"].items(), r["kp"], r["kd"]):
        lines += [
            "",
            "[[model.actuator]]",
            f'joint = "{joint}"',
            'kind = "position"',
            f"target = {q!r}",
            f"kp = {kp!r}",
            f"kd = {kd!r}",
            "effort_limit = 0.0",
        ]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------- scene cases


def signal(value, where):
    """A tumble signal (scene key) as a function of t: a constant or a sine; others are not mirrored."""
    if isinstance(value, (int, float)):
        return lambda t: np.full_like(np.asarray(t, dtype=float), float(value))
    if isinstance(value, dict) and set(value) == {"sine"}:
        s = value["sine"]
        a, f = float(s["amplitude"]), float(s["frequency_hz"])
        p, c = float(s.get("phase", 0.0)), float(s.get("offset", 0.0))
        return lambda t: c + a * np.sin(2 * math.pi * f * np.asarray(t, dtype=float) + p)
    sys.exit(f"{where}: only constant and sine signals are mirrored in MuJoCo (got {value!r})")


def scene_case(path):
    """The case of a tumble scene (one fixed-base [[model]]), in the form build() takes."""
    with open(path, "rb") as f:
        scene = tomllib.load(f)
    models = scene.get("model", [])
    if len(models) != 1:
        sys.exit(f"{path}: one [[model]] expected (got {len(models)})")
    m = models[0]
    if m.get("base", "floating") != "fixed" or m.get("bodies") != "articulated":
        sys.exit(f'{path}: only bodies = "articulated", base = "fixed" scenes are mirrored')
    if any(float(x) != 0.0 for x in m.get("rpy", [0.0, 0.0, 0.0])):
        sys.exit(f"{path}: rpy is not mirrored")
    joints = {k: float(v) for k, v in m.get("joints", {}).items()}
    locked = list(m.get("locked_joints", []))
    for j in locked:
        if joints.get(j, 0.0) != 0.0:
            sys.exit(f"{path}: locked joint {j} must be at 0 (it becomes a fixed joint for MuJoCo)")
    actuators = []
    for k, a in enumerate(m.get("actuator", [])):
        where = f"{path}: actuator[{k}]"
        if float(a.get("effort_limit", 0.0)) != 0.0:
            sys.exit(f"{where}: effort_limit is not mirrored (set 0)")
        if a["kind"] == "motor":
            actuators.append({"joint": a["joint"], "kind": "motor", "u": signal(a["effort"], where)})
        elif a["kind"] == "position":
            if "effort_limit" not in a:
                sys.exit(f"{where}: set effort_limit = 0 (tumble clamps to the URDF's <limit effort>)")
            actuators.append({"joint": a["joint"], "kind": "position", "u": signal(a["target"], where),
                              "kp": float(a["kp"]), "kd": float(a.get("kd", 0.0))})
        else:
            sys.exit(f"{where}: kind {a['kind']!r} is not mirrored")
    sim = scene.get("sim", {})
    return {
        "urdf": os.path.join(os.path.dirname(os.path.abspath(path)), m["urdf"]),
        "scene": True,
        "floating": False,
        "position": [float(x) for x in m.get("position", [0.0, 0.0, 0.0])],
        "joints": joints,
        "joint_velocities": {k: float(v) for k, v in m.get("joint_velocities", {}).items()},
        "gravity": [float(x) for x in sim.get("gravity", [0.0, 0.0, -9.81])],
        "locked": locked,
        "joint_damping": bool(m.get("joint_damping", True)),
        "actuators": actuators,
    }


def resolve(models_dir, work, name):
    if name in CASES:
        return CASES[name]
    for folder in (work, models_dir):
        if folder and os.path.isfile(os.path.join(folder, f"{name}.toml")):
            return scene_case(os.path.join(folder, f"{name}.toml"))
    sys.exit(f"case {name}: no scene {name}.toml in {work or '-'} or {models_dir}")


def urdf_for_mujoco(path, locked):
    """The URDF's text without <visual> and <collision>, the locked joints fixed (at 0)."""
    root = ET.parse(path).getroot()
    for link in root.iter("link"):
        for tag in ("visual", "collision"):
            for e in link.findall(tag):
                link.remove(e)
    # A mimic follower of a locked joint is locked with it (tumble locks the leader; the follower follows).
    locked = set(locked)
    for joint in root.iter("joint"):
        mimic = joint.find("mimic")
        if mimic is not None and mimic.get("joint") in locked:
            locked.add(joint.get("name"))
    found = set()
    for joint in root.iter("joint"):
        if joint.get("name") in locked and joint.get("type") is not None:
            found.add(joint.get("name"))
            joint.set("type", "fixed")
            for e in list(joint):
                if e.tag not in ("parent", "child", "origin"):
                    joint.remove(e)
    if locked - found:
        sys.exit(f"{path}: no joints {sorted(locked - found)}")
    return ET.tostring(root, encoding="unicode")


# ---------------------------------------------------------------------------------------- MuJoCo


def build(models_dir, case, integrator, dt):
    if case.get("scene"):
        spec = mujoco.MjSpec.from_string(urdf_for_mujoco(case["urdf"], case["locked"]))
        # The URDF's root is welded to the world at `position`: every body on the world moves by it.
        body = spec.worldbody.first_body()
        while body is not None:
            body.pos = np.asarray(body.pos) + case["position"]
            body = spec.worldbody.next_body(body)
        for a in case["actuators"]:
            act = spec.add_actuator()
            act.name = f"act_{a['joint']}"
            act.trntype = mujoco.mjtTrn.mjTRN_JOINT
            act.target = a["joint"]
            if a["kind"] == "motor":
                act.set_to_motor()
            else:
                act.set_to_position(kp=a["kp"], kv=0.0)
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE
    else:
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
    if not case.get("joint_damping", False):
        model.dof_damping[:] = 0.0
    model.dof_armature[:] = 0.0
    model.dof_frictionloss[:] = 0.0
    model.jnt_stiffness[:] = 0.0
    model.jnt_actfrclimited[:] = 0
    for a in case.get("actuators", []):
        if a["kind"] == "position":
            model.dof_damping[model.joint(a["joint"]).dofadr[0]] += a["kd"]
    data = mujoco.MjData(model)
    for name, q in case["joints"].items():
        if name not in case.get("locked", []):
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


def controls(model, case, dt, steps):
    """The control of every step (rows), actuator order: the mean of the signal at the step's ends."""
    u = np.zeros((steps, model.nu))
    ends = np.arange(steps + 1) * dt
    for a in case.get("actuators", []):
        s = a["u"](ends)
        u[:, model.actuator(f"act_{a['joint']}").id] = 0.5 * (s[:-1] + s[1:])
    return u


def observe(model, data):
    """Energy (J) and, for a floating model, linear and angular momentum about its com."""
    mujoco.mj_energyPos(model, data)
    mujoco.mj_energyVel(model, data)
    mujoco.mj_subtreeVel(model, data)
    energy = data.energy[0] + data.energy[1]
    mass = model.body_subtreemass[0]
    return energy, data.subtree_linvel[0] * mass, data.subtree_angmom[0].copy()


def hinge_names(model):
    kinds = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
    return [model.joint(j).name for j in range(model.njnt) if int(model.jnt_type[j]) in kinds]


def errors(models_dir, case, integrator, dt, secs):
    """Errors over secs, the time MuJoCo went unstable, and the joint positions at the samples of the
    first TRAJ_SECS ({step: {joint: q}})."""
    model, data = build(models_dir, case, integrator, dt)
    model.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    steps = round(secs / dt)
    u = controls(model, case, dt, steps)
    passive = not case.get("actuators")
    every, last = max(1, round(SAMPLE / dt)), round(TRAJ_SECS / dt)
    names = hinge_names(model)
    adr = [model.joint(n).qposadr[0] for n in names]
    samples = {}
    e0, p0, l0 = observe(model, data)
    de = dl = dp = 0.0
    bad = int(mujoco.mjtWarning.mjWARN_BADQACC)
    for k in range(steps):
        data.ctrl[:] = u[k]
        mujoco.mj_step(model, data)
        # MuJoCo resets the state when it goes unstable (and warns): that is a divergence.
        if data.warning[bad].number > 0 or not np.all(np.isfinite(data.qpos)):
            return steps, math.inf, math.inf, math.inf, (k + 1) * dt, samples
        if (k + 1) % every == 0 and k + 1 <= last:
            samples[k + 1] = dict(zip(names, data.qpos[adr].tolist()))
        if passive or case["floating"]:
            mujoco.mj_forward(model, data)
            e, p, l = observe(model, data)
            de = max(de, abs(e - e0) / abs(e0))
            if case["floating"]:
                dl = max(dl, float(np.linalg.norm(l - l0) / np.linalg.norm(l0)))
                dp = max(dp, float(np.linalg.norm(p - p0) / np.linalg.norm(p0)))
    if not passive:
        de = math.nan
    if not case["floating"]:
        dl = dp = math.nan
    return steps, de, dl, dp, None, samples


def cost(models_dir, case, integrator, dt, steps):
    model, data = build(models_dir, case, integrator, dt)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    u = controls(model, case, dt, steps)[None] if model.nu else None
    samples = []
    with rollout.Rollout(nthread=0) as r:
        for _ in range(REPEATS + 1):
            started = time.perf_counter()
            r.rollout(model, data, state[None, :], u, nstep=steps)
            samples.append((time.perf_counter() - started) * 1e9 / steps)
    return float(np.median(samples[1:]))


# ---------------------------------------------------------------------------------------- comparisons


def read_tumble(path):
    """tumble's recorded joint positions: {step: {joint: q}} (t > 0), or None without a recording."""
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    if not os.path.isfile(path):
        return None
    out = {}
    try:
        with open(path, "rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for _, _, _, decoded in reader.iter_decoded_messages(topics=["/joints"]):
                if decoded.step > 0:
                    out[int(decoded.step)] = {j.name: j.position for j in decoded.joints}
    except Exception as e:  # a recording cut short by a stopped run: compare what is there
        print(f"bench_mechanism.py: {path}: {type(e).__name__}: {e}", file=sys.stderr)
    return out


def q_rms(a, b):
    """RMS of a - b over the joints and steps both have (NaN when none)."""
    d = [a[s][j] - b[s][j] for s in sorted(set(a) & set(b)) for j in a[s] if j in b[s]]
    return float(np.sqrt(np.mean(np.square(d)))) if d else math.nan


def tracking_rms(case, samples, dt):
    servos = [a for a in case.get("actuators", []) if a["kind"] == "position"]
    if not servos or not samples:
        return math.nan
    d = [float(a["u"](s * dt)) - samples[s][a["joint"]] for s in samples for a in servos
         if a["joint"] in samples[s]]
    return float(np.sqrt(np.mean(np.square(d)))) if d else math.nan


def traj_path(work, name, dt_text, integrator):
    return os.path.join(work, f"traj-{name}-{dt_text}-{integrator}.mcap")


def sanitize(v):
    return v if not isinstance(v, float) or math.isfinite(v) else str(v)


def compare(models_dir, secs, timed, names, dts, work):
    for name in names:
        case = resolve(models_dir, work, name)
        for dt_text in dts:
            dt = float(dt_text)
            ref = read_tumble(traj_path(work, name, dt_text, "variational")) if work else None
            # The tumble rows' comparison figures (merged into their rows by --table).
            for integ in ("variational", "variational4"):
                mine = read_tumble(traj_path(work, name, dt_text, integ)) if work else None
                if mine is None:
                    continue
                print(json.dumps({"case": name, "integrator": f"tumble-{integ}", "dt": dt, "merge": True,
                                  "q_rms": sanitize(q_rms(mine, ref) if integ != "variational" else 0.0),
                                  "tracking_rms": sanitize(tracking_rms(case, mine, dt)),
                                  "traj_samples": len(mine)}), flush=True)
            for iname, integ in INTEGRATORS.items():
                steps, de, dl, dp, diverged, samples = errors(models_dir, case, integ, dt, secs)
                ns = cost(models_dir, case, integ, dt, timed)
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
                            "timed_steps": timed,
                            "diverged_at_secs": diverged,
                            "q_rms": sanitize(q_rms(samples, ref) if ref else math.nan),
                            "tracking_rms": sanitize(tracking_rms(case, samples, dt)),
                        }
                    ),
                    flush=True,
                )


def tumble_row(scene_path, name, dt_text, integrator, secs, status, text):
    """One tumble row from `tumble bench --errors-over` output (text) and its exit status."""
    fields = dict(re.findall(r"^(\w+)=(\S+)$", text, re.M))
    fails = [int(n) for n in re.findall(r"\((\d+) non-converged solves\)", text)]
    with open(scene_path, "rb") as f:
        actuated = any(m.get("actuator") for m in tomllib.load(f).get("model", []))
    dt = float(dt_text)
    notes = []
    if status == -1:
        notes.append("not timed: its 1 s run failed")
    elif status != 0:
        said = [l for l in text.splitlines() if "rror" in l or "stop" in l]
        notes.append(f"bench exit {status}: " + (said[0][:100] if said else ""))
    if fails and max(fails) > 0:
        notes.append(f"{max(fails)} non-converged solves in a timed run")
    return {
        "case": name,
        "integrator": f"tumble-{integrator}",
        "dt": dt,
        "steps": round(secs / dt),
        "ns_per_step": fields.get("ns_per_step", "nan"),
        "energy_err_max": "nan" if actuated else fields.get("energy_err_max", "nan"),
        "momentum_err_max": fields.get("momentum_err_max", "nan"),
        "linear_momentum_err_max": fields.get("linear_momentum_err_max", "nan"),
        "newton_fails": max(fails) if fails else None,
        "note": "; ".join(notes),
    }


def traj_note(log_path):
    """What `tumble simulate` said about its 1 s trajectory run: substeps, failures, warnings."""
    if not os.path.isfile(log_path):
        return ""
    text = open(log_path).read()
    notes = []
    m = re.search(r"(\d+) non-converged solves; (\d+) body-steps substepped \(largest split (\d+)x\)", text)
    if m and (int(m.group(1)) or int(m.group(2))):
        notes.append(f"1 s run: {m.group(1)} non-converged, {m.group(2)} body-steps substepped (up to {m.group(3)}x)")
    for l in text.splitlines():
        if l.startswith("error") or "stopped" in l:
            notes.append("1 s run: " + l[:100])
            break
    return "; ".join(notes)


# ---------------------------------------------------------------------------------------- the table


def num(v):
    """tumble prints "nan"/"inf" as text, MuJoCo as JSON numbers; None is NaN."""
    return math.nan if v is None else float(v)


def table(lines):
    """The table of scripts/bench_mechanism.sh from the JSON lines of both engines, then the checks."""
    rows, index = [], {}
    for line in lines:
        if not line.strip():
            continue
        r = json.loads(line)
        key = (r["case"], float(r["dt"]), r["integrator"])
        if key in index:
            index[key].update({k: v for k, v in r.items() if k != "merge"})
        elif not r.get("merge"):
            index[key] = r
            rows.append(r)
    # Grouped by case and step size in order of appearance, tumble's rows first.
    groups = {}
    for r in rows:
        groups.setdefault((r["case"], float(r["dt"])), []).append(r)
    euler = {
        (r["case"], float(r["dt"])): num(r["ns_per_step"]) for r in rows if r["integrator"] == "mujoco-euler"
    }
    fmt = lambda v: "-" if math.isnan(num(v)) else ("diverged" if math.isinf(num(v)) else f"{num(v):.1e}")
    print(
        f"{'case':<16} {'dt [s]':>7} {'engine / integrator':<22} {'us/step':>8} {'x mj euler':>10} "
        f"{'energy err':>10} {'L err':>8} {'p err':>8} {'q rms 1s':>8} {'track rms':>9}  note"
    )
    for (case, dt), group in groups.items():
        for r in sorted(group, key=lambda r: not r["integrator"].startswith("tumble")):
            ref = euler.get((case, dt))
            ns = num(r["ns_per_step"])
            ratio = f"{ns / ref:.2f}" if ref and not math.isnan(ns) else "-"
            notes = [r.get("note") or ""]
            if r.get("diverged_at_secs"):
                notes.append(f"unstable at t = {r['diverged_at_secs']:.2f} s")
            q = r.get("q_rms")
            if r["integrator"] == "tumble-variational" and q is not None:
                qtext = "ref"
            else:
                qtext = fmt(q)
            print(
                f"{case:<16} {dt:>7g} {r['integrator']:<22} {ns / 1e3:>8.2f} {ratio:>10} "
                f"{fmt(r['energy_err_max']):>10} {fmt(r['momentum_err_max']):>8} "
                f"{fmt(r['linear_momentum_err_max']):>8} {qtext:>8} {fmt(r.get('tracking_rms')):>9}  "
                + "; ".join(n for n in notes if n)
            )
    print()
    print("q rms 1s: RMS over the joints and the samples (every 10 ms, 0 < t <= 1 s) of the row's joint positions")
    print("minus tumble variational's (ref), rad. track rms: RMS of target - q over the same samples (servo cases).")
    print("x mj euler: the row's cost per step over MuJoCo Euler's on the same case and dt.")
    print()
    sanity(rows)
    checks(rows)


def pick(rows, case, dt, integrator):
    for r in rows:
        if r["case"] == case and float(r["dt"]) == dt and r["integrator"] == integrator:
            return r
    return None


def sanity(rows):
    """What says the rows can be trusted: servo tracking alike in both engines, no Newton failures."""
    for r in rows:
        if r["integrator"] == "tumble-variational" and not math.isnan(num(r.get("tracking_rms"))):
            mine = num(r["tracking_rms"])
            for other in ("mujoco-euler", "mujoco-implicitfast"):
                o = pick(rows, r["case"], float(r["dt"]), other)
                if o is None or math.isnan(num(o.get("tracking_rms"))):
                    continue
                rel = abs(num(o["tracking_rms"]) - mine) / mine
                print(f"sanity: {r['case']} dt={float(r['dt']):g} servo tracking rms, {other} against tumble "
                      f"variational (relative difference) {rel:.1e} 0.05 {'PASS' if rel <= 0.05 else 'FAIL'}")
    fails = [r for r in rows if r["integrator"].startswith("tumble") and (r.get("newton_fails") or 0) > 0]
    print(f"sanity: tumble rows with non-converged Newton solves in the timed runs {len(fails)} 0 "
          f"{'PASS' if not fails else 'FAIL'}" + (" (" + ", ".join(f"{r['case']} {r['integrator']}" for r in fails) + ")" if fails else ""))
    diverged = [r for r in rows if r.get("diverged_at_secs")]
    print(f"sanity: MuJoCo rows that went unstable {len(diverged)} 0 {'PASS' if not diverged else 'FAIL'}"
          + (" (" + ", ".join(f"{r['case']} dt={float(r['dt']):g} {r['integrator']}" for r in diverged) + ")" if diverged else ""))


def checks(rows):
    """The requirement's three checks, reported (not asserted)."""
    for r in rows:
        if r["integrator"] != "tumble-variational":
            continue
        o = pick(rows, r["case"], float(r["dt"]), "mujoco-euler")
        if o is None:
            continue
        ratio = num(r["ns_per_step"]) / num(o["ns_per_step"])
        caveat = ""
        div = o.get("diverged_at_secs")
        if div and div < o.get("timed_steps", math.inf) * float(o["dt"]):
            caveat = f" (MuJoCo Euler unstable at t = {div:.2f} s, inside its timed run: its cost includes its resets)"
        print(f"check: {r['case']} dt={float(r['dt']):g} tumble variational / MuJoCo Euler per step "
              f"{ratio:.2f} 1.00 {'PASS' if ratio <= 1.0 else 'FAIL'}{caveat}")

    def ratio_check(text, a, b, bar):
        ra, rb = pick(rows, a, 0.001, "tumble-variational"), pick(rows, b, 0.001, "tumble-variational")
        if ra is None or rb is None:
            print(f"check: {text} - {bar:.2f} SKIP (not run: CASES needs {a} and {b} at dt 0.001)")
            return
        ratio = num(ra["ns_per_step"]) / num(rb["ns_per_step"])
        print(f"check: {text} {ratio:.2f} {bar:.2f} {'PASS' if ratio <= bar else 'FAIL'}")

    ratio_check("chain100 / chain25 tumble variational per step (linear in the links)", "chain100", "chain25", 4.0)
    ratio_check("chain30_driven / chain30 tumble variational per step", "chain30_driven", "chain30", 1.2)
    ratio_check("chain7_driven / chain7 tumble variational per step", "chain7_driven", "chain7", 1.2)


def main():
    args = sys.argv[1:]
    if args == ["--table"]:
        table(sys.stdin)
    elif len(args) == 3 and args[0] == "scene":
        sys.stdout.write(robot_scene(args[1], args[2]))
    elif len(args) == 8 and args[0] == "tumble-row":
        scene, name, dt_text, integrator, secs, status, log = args[1:]
        r = tumble_row(scene, name, dt_text, integrator, float(secs), int(status), sys.stdin.read())
        extra = traj_note(log)
        r["note"] = "; ".join(n for n in (r["note"], extra) if n)
        print(json.dumps(r))
    elif len(args) in (5, 6):
        models_dir, secs, timed_steps = args[0], float(args[1]), int(args[2])
        work = args[5] if len(args) == 6 else None
        compare(models_dir, secs, timed_steps, args[3].split(","), args[4].split(","), work)
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
