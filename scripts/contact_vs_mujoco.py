"""scripts/contact_vs_mujoco.sh's Python side: issue 31's contact cases in tumble and in MuJoCo, the
measured quantities beside their closed forms, one table (Markdown, printed) and a CSV.

Usage: contact_vs_mujoco.py TUMBLE WORK CSV [INTEGRATORS]
  TUMBLE       the tumble binary
  WORK         a scratch folder: the URDFs, scenes, recordings and MJCF files are written there
  CSV          where the table is also written, one row per case and engine
  INTEGRATORS  MuJoCo variants, comma-separated (default DEFAULT_INTEGRATORS:
               "euler,implicitfast,implicitfast:elliptic:noslip"): an integrator (euler, MuJoCo's
               default; implicitfast, implicit, rk4, discrete), optionally followed by ":elliptic"
               (the elliptic friction cone instead of the default pyramidal one) and ":noslip"
               (noslip_iterations = NOSLIP = 10, MuJoCo's post-solve against slip; default 0)
Environment: REPEATS (timed runs per cost, median printed; default 5), COST_STEPS (steps of each
timed run; default 200000).

The bodies (the same numbers in both engines; URDFs written into WORK, MJCF built here):
  cube  0.2 m on a side, 1 kg, I = m a^2 / 6 = 0.0066667 kg m^2 about every axis
  ball  radius 0.1 m, 1 kg, I = (2/5) m r^2 = 0.004 kg m^2
gravity 9.81 m/s^2, dt = 1 ms in both engines; tumble with its default integrator (variational).

The cases (every body starts touching its ground: no gap, no overlap):
  slope    the cube at rest on a plane tilted by 20 deg about y, mu = 0.5 (tan 20 deg = 0.364 < mu:
           it must stay put), 10 s: its centre's displacement along the slope's downhill direction
           (exact: 0).
  rest     the ball resting on level ground, 10 s: penetration r - z of its centre at the end
           (exact: 0; MuJoCo sinks into its soft contact).
  slide    the cube sliding at v0 = 2 m/s along x on level ground, mu = 0.5, 1 s: stopping distance
           (x at 1 s) against v0^2 / (2 mu g) = 0.40775 m, and the time the horizontal speed takes to
           fall to 1 % of v0 (linearly between the two samples around it) against 0.99 v0 / (mu g) =
           0.40367 s (the time to a full stop is ill defined in MuJoCo: its regularized friction
           lets the speed decay exponentially at the end). The hops: steps while sliding
           (horizontal speed above 1e-3 m/s at the step's start) in which the cube is off the
           ground. tumble: no row for the step in STEM.contacts.parquet (the contacts with a
           non-zero impulse; a binary without that table: the centre ending the step more than
           1e-9 m above the rest height 0.1 m); MuJoCo: no contact in the step (data.ncon == 0
           after mj_step: the contacts the step used). Exact: 0. The note gives the highest the
           centre rose above 0.1 m while sliding.
  rebound  the ball dropped from rest with its bottom 1 m above level ground, restitution 0.5,
           2 s: the first three rebounds' apex heights of its bottom (z - r at the top, from the
           last rising sample z + vz^2 / (2 g): free flight is ballistic) against e^(2k) h = 0.25,
           0.0625, 0.015625 m. tumble: ground and ball
           restitution 0.5. MuJoCo has no coefficient of restitution: its contact is a spring and
           damper in acceleration units, and solref's direct format, solref = (-stiffness,
           -damping) (MuJoCo's docs, Modeling > Solver parameters; XML reference, solref), sets
           them. Chosen here: the damping ratio zeta whose linear spring-damper leaves the ground at
           e times its impact speed when its force falls to zero (a contact cannot pull;
           `released_restitution`: zeta = 0.2553, where the textbook exp(-zeta pi / sqrt(1 -
           zeta^2)) = e, which assumes the spring lets go at zero penetration, gives 0.2155 and,
           at the same time constant, a first apex 29 % too high), and the time constant of MuJoCo's default contact,
           0.02 s: k = 1 / (0.02 zeta)^2 = 38364 s^-2, b = 2 / 0.02 = 100 s^-1, solref =
           "-38364 -100" on both geoms (MuJoCo scales these by its impedance so that they act
           as given once the penetration exceeds solimp's width; the same spring as the standard
           solref = "0.02 0.2553"). The bounce still depends on the impedance ramp, gravity during
           the 17 ms contact and the step: the error is this approximation's and MuJoCo's together.
  stack    STACK = 4 cubes stacked on level ground, mu = 0.5, each touching the next, 10 s: how far
           the top cube's centre moved (exact: 0); the note splits it into down and sideways. The
           only case with contact between bodies, and the cost per body-step of a small island.
  Everything else is MuJoCo's default contact: solimp (0.9, 0.95, 0.001), solref (0.02, 1) for
  the cases without restitution, pyramidal cone, condim 3, margin 0. A pair's friction in MuJoCo
  is the larger of its two geoms' (both given mu here); in tumble the smaller (both mu).

Cost per step: each case run for COST_STEPS steps (200 s at 1 ms: the slide and the bounce are
over in the first seconds, so their cost is mostly the resting body's), REPEATS times, the median;
printed in ns per step and per body-step (the step's cost over the case's bodies).
tumble: `simulate SCENE --duration COST_STEPS*dt --threads 1 --log-every COST_STEPS --format
parquet` (two frames recorded), the wall time it prints (the stepping and the recording, not the
process start or the scene loading; printed to 10 ms, 50 ns per step at 2e5 steps) divided by the
steps. Not `tumble bench --scene`: for a scene of one partition it times the bare integrator,
without the contact phase (a cube on the slope costs 0.06 us per step there, with or without its
ground). MuJoCo: its C rollout (mujoco.rollout, one thread) of the same steps from the same
state, after one untimed run.
"""

import csv
import math
import os
import platform
import re
import subprocess
import sys
import time

import mujoco
import numpy as np
import pyarrow.compute as pc
import pyarrow.parquet as pq
from mujoco import rollout

G = 9.81
DT = 0.001
SIDE, CUBE_MASS = 0.2, 1.0
RADIUS, BALL_MASS = 0.1, 1.0
CUBE_I = CUBE_MASS * (SIDE**2 + SIDE**2) / 12.0
BALL_I = 0.4 * BALL_MASS * RADIUS**2
SLOPE_DEG, SLOPE_MU = 20.0, 0.5
SLIDE_V0, SLIDE_MU = 2.0, 0.5
DROP_H, E = 1.0, 0.5
TIMECONST = 0.02  # s: MuJoCo's default solref (0.02, 1)
MOVING = 1e-3  # m/s: sliding while the horizontal speed is above this
SLOW = 0.01  # the stopping time is measured to SLOW * v0
LIFT = 1e-9  # m: off the ground when the cube's centre is this far above its rest height
STACK = 4  # cubes in the stack case
NOSLIP = 10  # MuJoCo's noslip_iterations in a variant named with ":noslip"
REPEATS = int(os.environ.get("REPEATS", "5"))
COST_STEPS = int(os.environ.get("COST_STEPS", "200000"))
DEFAULT_INTEGRATORS = "euler,implicitfast,implicitfast:elliptic:noslip"

INTEGRATORS = {
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
    "discrete": mujoco.mjtIntegrator.mjINT_DISCRETE,
}

# name: (seconds, body, how many); the measured body is the last one (the stack's top cube)
CASES = {
    "slope": (10.0, "cube", 1),
    "rest": (10.0, "ball", 1),
    "slide": (1.0, "cube", 1),
    "rebound": (2.0, "ball", 1),
    "stack": (10.0, "cube", STACK),
}


def released_restitution(zeta):
    """Restitution of the linear spring-damper x'' = -2 zeta w x' - w^2 x (x the penetration, from
    x = 0 at speed 1) that lets go when its force w^2 x + 2 zeta w x' reaches zero (a contact
    cannot pull): the exit speed. With w = 1, x = e^(-zeta t) sin(wd t) / wd: the force vanishes
    at tan(wd t) = -2 zeta wd / (1 - 2 zeta^2), second quadrant (zeta < 1/sqrt 2)."""
    wd = math.sqrt(1.0 - zeta**2)
    t = (math.pi - math.atan2(2.0 * zeta * wd, 1.0 - 2.0 * zeta**2)) / wd
    return -math.exp(-zeta * t) * (math.cos(wd * t) - zeta / wd * math.sin(wd * t))


def bounce_zeta():
    """The damping ratio whose released restitution is E (bisection: it falls with zeta)."""
    lo, hi = 0.0, 0.7
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if released_restitution(mid) > E else (lo, mid)
    return 0.5 * (lo + hi)


def bounce_solref():
    """(k, b), acceleration units, of the bounce: damping ratio bounce_zeta(), the time constant
    of MuJoCo's default contact: k = 1 / (TIMECONST zeta)^2, b = 2 / TIMECONST (what MuJoCo's
    standard solref (TIMECONST, zeta) makes of them)."""
    zeta = bounce_zeta()
    return 1.0 / (TIMECONST * zeta) ** 2, 2.0 / TIMECONST


def slope_frame():
    """The slope's normal and its downhill direction (the plane tilted by SLOPE_DEG about y)."""
    t = math.radians(SLOPE_DEG)
    return np.array([math.sin(t), 0.0, math.cos(t)]), np.array([math.cos(t), 0.0, -math.sin(t)])


def initial(case):
    """Centre position, rotation about y (rad) and velocity of the case's body at t = 0."""
    if case == "slope":
        n, _ = slope_frame()
        return n * (SIDE / 2), math.radians(SLOPE_DEG), np.zeros(3)
    if case == "rest":
        return np.array([0.0, 0.0, RADIUS]), 0.0, np.zeros(3)
    if case == "slide":
        return np.array([0.0, 0.0, SIDE / 2]), 0.0, np.array([SLIDE_V0, 0.0, 0.0])
    if case == "rebound":
        return np.array([0.0, 0.0, DROP_H + RADIUS]), 0.0, np.zeros(3)
    if case == "stack":
        return np.array([0.0, 0.0, SIDE / 2 + (STACK - 1) * SIDE]), 0.0, np.zeros(3)
    raise ValueError(case)


def placements(case):
    """(name, centre, rotation about y, velocity) of every body of the case, bottom to top; the
    last is the one measured (initial(case))."""
    _, body, count = CASES[case]
    if count == 1:
        return [(body, *initial(case))]
    return [(f"{body}{i}", np.array([0.0, 0.0, SIDE / 2 + i * SIDE]), 0.0, np.zeros(3))
            for i in range(count)]


def friction(case):
    return {"slope": SLOPE_MU, "slide": SLIDE_MU, "stack": SLIDE_MU}.get(case, 0.8)


# ---------------------------------------------------------------------------------------------
# tumble


def urdf(kind):
    if kind == "cube":
        geometry = f'<box size="{SIDE!r} {SIDE!r} {SIDE!r}"/>'
        mass, inertia = CUBE_MASS, CUBE_I
    else:
        geometry = f'<sphere radius="{RADIUS!r}"/>'
        mass, inertia = BALL_MASS, BALL_I
    return f"""<?xml version="1.0"?>
<robot name="{kind}">
  <link name="{kind}">
    <inertial>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <mass value="{mass!r}"/>
      <inertia ixx="{inertia!r}" ixy="0" ixz="0" iyy="{inertia!r}" iyz="0" izz="{inertia!r}"/>
    </inertial>
    <visual><geometry>{geometry}</geometry></visual>
    <collision><geometry>{geometry}</geometry></collision>
  </link>
</robot>
"""


def vec(v):
    return "[" + ", ".join(repr(float(x)) for x in v) + "]"


def scene(case):
    secs, body, count = CASES[case]
    mu = friction(case)
    e = E if case == "rebound" else 0.0
    if case == "slope":
        n, _ = slope_frame()
        ground = f"normal = {vec(n)}\npoint = [0.0, 0.0, 0.0]"
    else:
        ground = "height = 0.0"
    models = "".join(f"""
[[model]]
name = "{name}"
urdf = "{body}.urdf"
position = {vec(pos)}
rpy = [0.0, {pitch!r}, 0.0]
linvel = {vec(vel)}
collisions = "urdf"
friction = {mu!r}
restitution = {e!r}
""" for name, pos, pitch, vel in placements(case))
    return f"""# contact_vs_mujoco.py, case {case}
[sim]
dt = {DT!r}
duration = {secs!r}
gravity = [0.0, 0.0, {-G!r}]
log_every = 1

[ground]
{ground}
friction = {mu!r}
restitution = {e!r}
{models}"""


def run_tumble(tumble, work, case):
    """The case's trajectory (time, position, velocity rows) and its cost per step, ns."""
    path = f"{work}/{case}.toml"
    stem = f"{work}/tumble-{case}"
    done = subprocess.run(
        [tumble, "simulate", path, "--out", stem, "--format", "parquet", "--force"],
        capture_output=True, text=True,
    )
    if done.returncode != 0:
        raise RuntimeError(f"tumble simulate {path}: exit {done.returncode}\n{done.stderr}")
    table = pq.read_table(f"{stem}.trajectories.parquet")
    # the measured body, the last placed: recorded as "NAME/LINK" (the URDF's one link is its kind)
    name, kind = placements(case)[-1][0], CASES[case][1]
    table = table.filter(pc.equal(table.column("body"), f"{name}/{kind}"))
    if table.num_rows == 0:
        raise RuntimeError(f"tumble simulate {path}: no rows for body {name}/{kind}")
    col = lambda name: table.column(name).to_numpy()
    order = np.argsort(col("step"), kind="stable")
    t = col("time_secs")[order]
    p = np.stack([col(f"position_{a}") for a in "xyz"], axis=1)[order]
    v = np.stack([col(f"linear_velocity_{a}") for a in "xyz"], axis=1)[order]
    samples = []
    for _ in range(REPEATS):
        timed = subprocess.run(
            [tumble, "simulate", path, "--duration", repr(COST_STEPS * DT), "--log-every",
             str(COST_STEPS), "--threads", "1", "--out", f"{stem}-cost", "--format", "parquet",
             "--force"],
            capture_output=True, text=True,
        )
        wall = re.search(r" in ([0-9.]+) s wall time", timed.stdout)
        if timed.returncode != 0 or wall is None:
            raise RuntimeError(f"tumble simulate {path} (timed): exit {timed.returncode}\n"
                               f"{timed.stdout}{timed.stderr}")
        samples.append(float(wall.group(1)) * 1e9 / COST_STEPS)
    # Off the ground: no row in the step's contacts table (a contact with a non-zero impulse); a
    # binary that writes no such table: the body's centre above its rest height by more than LIFT.
    contacts = f"{stem}.contacts.parquet"
    if os.path.exists(contacts):
        touching = set(pq.read_table(contacts, columns=["step"]).column("step").to_pylist())
        lifted = np.array([k not in touching for k in col("step")[order]])
        lifted[0] = False  # the initial state: no step ended there
    else:
        rest = p[0, 2]
        lifted = p[:, 2] > rest + LIFT
    return t, p, v, lifted, float(np.median(samples))


# ---------------------------------------------------------------------------------------------
# MuJoCo


def mjcf(case, integrator):
    _, body, _ = CASES[case]
    mu = friction(case)
    if case == "rebound":
        k, b = bounce_solref()
        sol = f' solref="{-k!r} {-b!r}"'
    else:
        sol = ""
    if case == "slope":
        plane_euler = f"0 {SLOPE_DEG!r} 0"
    else:
        plane_euler = "0 0 0"
    if body == "cube":
        geom = f'type="box" size="{SIDE / 2!r} {SIDE / 2!r} {SIDE / 2!r}"'
        mass, inertia = CUBE_MASS, CUBE_I
    else:
        geom = f'type="sphere" size="{RADIUS!r}"'
        mass, inertia = BALL_MASS, BALL_I
    bodies = "".join(f"""
    <body name="{name}" pos="{" ".join(repr(float(x)) for x in pos)}" euler="0 {math.degrees(pitch)!r} 0">
      <freejoint/>
      <inertial pos="0 0 0" mass="{mass!r}" diaginertia="{inertia!r} {inertia!r} {inertia!r}"/>
      <geom name="{name}" {geom} friction="{mu!r} 0.005 0.0001"{sol}/>
    </body>""" for name, pos, pitch, _ in placements(case))
    return f"""<mujoco model="{case}">
  <compiler angle="degree"/>
  <!-- integrator (cone, noslip): {integrator}, set on the compiled model (model.opt) -->
  <option timestep="{DT!r}" gravity="0 0 {-G!r}"/>
  <worldbody>
    <geom name="ground" type="plane" size="0 0 1" euler="{plane_euler}" friction="{mu!r} 0.005 0.0001"{sol}/>{bodies}
  </worldbody>
</mujoco>
"""


def run_mujoco(work, case, name):
    """The trajectory of the case's measured body (the last) at every step (t = 0 included), the
    steps without contact, cost per step. `name`: an integrator of INTEGRATORS, with ":elliptic"
    the elliptic friction cone, with ":noslip" NOSLIP noslip iterations (in any order)."""
    integrator, *options = name.split(":")
    xml = mjcf(case, name)
    with open(f"{work}/mujoco-{case}-{name.replace(':', '-')}.xml", "w") as f:
        f.write(xml)
    model = mujoco.MjModel.from_xml_string(xml)
    model.opt.integrator = INTEGRATORS[integrator]
    if "elliptic" in options:
        model.opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    if "noslip" in options:
        model.opt.noslip_iterations = NOSLIP
    data = mujoco.MjData(model)
    places = placements(case)
    for i, (_, _, _, vel) in enumerate(places):
        data.qvel[6 * i:6 * i + 3] = vel  # a free joint's qvel: linear velocity first, world frame
    q = 7 * (len(places) - 1)  # the measured body's free joint: qpos q.., qvel 6/7 q..
    u = 6 * (len(places) - 1)
    mujoco.mj_forward(model, data)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    steps = round(CASES[case][0] / DT)
    t, p, v, lifted = [0.0], [data.qpos[q:q + 3].copy()], [data.qvel[u:u + 3].copy()], [False]
    bad = int(mujoco.mjtWarning.mjWARN_BADQACC)
    for _ in range(steps):
        mujoco.mj_step(model, data)
        if data.warning[bad].number > 0:
            raise RuntimeError(f"MuJoCo {name} unstable in case {case} at t = {data.time}")
        t.append(data.time)
        p.append(data.qpos[q:q + 3].copy())
        v.append(data.qvel[u:u + 3].copy())
        lifted.append(data.ncon == 0)
    samples = []
    with rollout.Rollout(nthread=0) as r:
        for _ in range(REPEATS + 1):
            started = time.perf_counter()
            r.rollout(model, data, state[None, :], nstep=COST_STEPS)
            samples.append((time.perf_counter() - started) * 1e9 / COST_STEPS)
    return np.array(t), np.array(p), np.array(v), np.array(lifted), float(np.median(samples[1:]))


# ---------------------------------------------------------------------------------------------
# the measured quantities


def measure(case, t, p, v, lifted):
    """[(quantity, measured, exact, error, error kind, note)] of one run of the case."""
    if case == "slope":
        _, down = slope_frame()
        creep = float((p[-1] - p[0]) @ down)
        normal = float((p[-1] - p[0]) @ slope_frame()[0])
        return [("slope creep 10 s [m]", creep, 0.0, abs(creep), "abs",
                 f"moved {normal:.2e} m along the normal")]
    if case == "rest":
        sink = RADIUS - float(p[-1, 2])
        deepest = RADIUS - float(p[:, 2].min())
        return [("ball sink 10 s [m]", sink, 0.0, abs(sink), "abs",
                 f"deepest {deepest:.2e} m")]
    if case == "slide":
        speed = np.hypot(v[:, 0], v[:, 1])
        d_exact = SLIDE_V0**2 / (2 * SLIDE_MU * G)
        t_exact = SLIDE_V0 / (SLIDE_MU * G)
        t_exact = (1.0 - SLOW) * t_exact
        dist = float(p[-1, 0] - p[0, 0])
        # the first time the speed is down to SLOW v0, between the two samples around it
        slow = np.nonzero(speed <= SLOW * SLIDE_V0)[0]
        if len(slow) == 0 or slow[0] == 0:
            t_stop = math.nan
        else:
            k = int(slow[0])
            a, b = speed[k - 1], speed[k]
            t_stop = float(t[k - 1] + (a - SLOW * SLIDE_V0) / (a - b) * (t[k] - t[k - 1]))
        # steps k+1 whose start (sample k) is sliding
        sliding = speed[:-1] > MOVING
        hops = int(np.count_nonzero(lifted[1:][sliding]))
        n = int(np.count_nonzero(sliding))
        return [
            ("stop distance [m]", dist, d_exact, abs(dist - d_exact) / d_exact, "rel", ""),
            ("time to 1 % of v0 [s]", t_stop, t_exact, abs(t_stop - t_exact) / t_exact, "rel",
             f"speed {speed[-1]:.1e} m/s at {t[-1]:g} s"),
            ("hops while sliding [steps]", hops, 0, hops, "abs",
             f"of {n} sliding steps; {np.count_nonzero(lifted[1:])} of {len(t) - 1} in all; "
             f"centre up to {float(p[1:][sliding, 2].max()) - SIDE / 2:.1e} m above {SIDE / 2:g} m"
             f" (step {1 + int(np.argmax(np.where(sliding, p[1:, 2], -np.inf)))})"),
        ]
    if case == "rebound":
        z, vz = p[:, 2], v[:, 2]
        apexes = []
        k = int(np.argmax(vz > 0)) if np.any(vz > 0) else len(vz)
        while k < len(vz) and len(apexes) < 3:
            # rising from sample k: the apex from the last rising sample, ballistic
            j = k
            while j + 1 < len(vz) and vz[j + 1] > 0:
                j += 1
            if j + 1 >= len(vz):
                break
            apexes.append(float(z[j] + vz[j] ** 2 / (2 * G)) - RADIUS)
            # next bounce: falling, then rising again
            rest = np.nonzero(vz[j + 1:] > 0)[0]
            if len(rest) == 0:
                break
            k = j + 1 + int(rest[0])
        apexes += [math.nan] * (3 - len(apexes))
        deepest = RADIUS - float(z.min())
        rows = []
        for k, apex in enumerate(apexes, start=1):
            exact = E ** (2 * k) * DROP_H
            note = f"signed {(apex - exact) / exact:+.2%}"
            if k == 1:
                note += f"; deepest penetration {deepest:.2e} m"
            rows.append((f"bounce apex {k}, e^{2 * k} h [m]", apex, exact,
                         abs(apex - exact) / exact, "rel", note))
        return rows
    if case == "stack":
        moved = p[-1] - p[0]
        return [(f"stack of {STACK}: top moved 10 s [m]", float(np.linalg.norm(moved)), 0.0,
                 float(np.linalg.norm(moved)), "abs",
                 f"down {-moved[2]:.2e} m, sideways {float(np.hypot(moved[0], moved[1])):.1e} m")]
    raise ValueError(case)


def main():
    if len(sys.argv) not in (4, 5):
        sys.exit(__doc__)
    tumble, work, out = sys.argv[1:4]
    integrators = (sys.argv[4] if len(sys.argv) == 5 else DEFAULT_INTEGRATORS).split(",")
    for name in integrators:
        integrator, *options = name.split(":")
        if integrator not in INTEGRATORS or not set(options) <= {"elliptic", "noslip"}:
            sys.exit(f"unknown MuJoCo integrator {name!r} (one of {', '.join(INTEGRATORS)}, "
                     "each optionally with :elliptic and :noslip)")
    load_before = os.getloadavg()[0]
    for kind in ("cube", "ball"):
        with open(f"{work}/{kind}.urdf", "w") as f:
            f.write(urdf(kind))
    rows = []
    for case in CASES:
        with open(f"{work}/{case}.toml", "w") as f:
            f.write(scene(case))
        runs = [("tumble variational", run_tumble(tumble, work, case))]
        for name in integrators:
            runs.append((engine_label(name), run_mujoco(work, case, name)))
        bodies = CASES[case][2]
        for engine, (t, p, v, lifted, ns) in runs:
            for quantity, value, exact, error, kind, note in measure(case, t, p, v, lifted):
                rows.append({
                    "case": quantity, "engine": engine, "measured": value, "exact": exact,
                    "error": error, "error_kind": kind, "ns_per_step": ns,
                    "ns_per_body_step": ns / bodies, "bodies": bodies, "note": note,
                })
            print(f"{case}: {engine} done", file=sys.stderr, flush=True)
    order = {}
    for r in rows:
        order.setdefault(r["case"], len(order))
    rows.sort(key=lambda r: order[r["case"]])  # stable: the engines stay in their order
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"tumble {tumble_version(tumble)} (variational, --threads 1) against MuJoCo "
          f"{mujoco.__version__} (python bindings; mujoco.rollout, one thread), dt = {DT:g} s, "
          f"{platform.machine()} {platform.system()}, {time.strftime('%Y-%m-%d')}")
    print(f"cost: {COST_STEPS} steps per run, median of {REPEATS} runs; MuJoCo variants: "
          + "; ".join(f"{n} = {describe(n)}" for n in integrators)
          + f"; load average (1 min) {load_before:.2f} at the start, {os.getloadavg()[0]:.2f} at "
          f"the end on {os.cpu_count()} cores")
    print()
    table(rows)


def engine_label(name):
    integrator, *options = name.split(":")
    return f"mujoco {integrator}" + ("".join(" " + o for o in options) if options else "") + (
        " (default)" if integrator == "euler" and not options else "")


def describe(name):
    integrator, *options = name.split(":")
    cone = "elliptic" if "elliptic" in options else "pyramidal (default)"
    noslip = f"noslip_iterations {NOSLIP}" if "noslip" in options else "no noslip (default)"
    return f"integrator {integrator}, {cone} cone, {noslip}"


def tumble_version(tumble):
    done = subprocess.run([tumble, "--version"], capture_output=True, text=True)
    return done.stdout.strip().split()[-1] if done.returncode == 0 and done.stdout.strip() else "?"


def fmt(x):
    if isinstance(x, int):
        return str(x)
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if x == 0:
        return "0"
    return f"{x:.3e}"


def table(rows):
    """One Markdown table (readable as text too): per case, every engine's figure beside the
    closed form, the error (abs: in the quantity's unit; rel: relative) and the cost."""
    print("| case | engine | measured | closed form | error | ns/step | ns/body-step | note |")
    print("|---|---|---:|---:|---:|---:|---:|---|")
    for r in rows:
        print(f"| {r['case']} | {r['engine']} | {fmt(r['measured'])} | {fmt(r['exact'])} | "
              f"{fmt(r['error'])} {r['error_kind']} | {r['ns_per_step']:.0f} | "
              f"{r['ns_per_body_step']:.0f} | {r['note']} |")


if __name__ == "__main__":
    main()
