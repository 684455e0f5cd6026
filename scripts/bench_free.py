"""MuJoCo side of scripts/bench_free.sh: N free rigid bodies stepped by MuJoCo's Euler integrator.

Usage: bench_free.py BODIES STEPS REPEATS   (prints ns_per_body_step=<median>)

The bodies mirror models/swarm.toml: boxes (0.4 x 0.2 x 0.1 m, 1 kg: three distinct moments) at
random positions and orientations, angular velocities drawn from N(0, 3 rad/s) per axis, linear
velocities from N(0, 0.1 m/s), no gravity, dt = 1 ms. Contacts are disabled (each geom's contype
and conaffinity are 0 and the contact flag is off), so a step is MuJoCo's free-body pipeline:
forward kinematics, the mass matrix and its factorization, the bias forces, Euler's update.
One thread (mj_step with nstep in C: no Python per step), median of REPEATS runs.
"""

import sys
import time

import mujoco
import numpy as np


def build(n, seed=1):
    rng = np.random.default_rng(seed)
    spec = mujoco.MjSpec()
    spec.memory = 512 << 20  # the arena for 10 000 free bodies (the default is too small)
    spec.option.timestep = 0.001
    spec.option.gravity = [0.0, 0.0, 0.0]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    for i in range(n):
        body = spec.worldbody.add_body(name=f"b{i}", pos=rng.uniform(-10, 10, 3).tolist())
        body.add_freejoint()
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[0.2, 0.1, 0.05],
            mass=1.0,
            contype=0,
            conaffinity=0,
        )
    model = spec.compile()
    data = mujoco.MjData(model)
    for i in range(n):
        q = rng.normal(size=4)
        data.qpos[7 * i + 3 : 7 * i + 7] = q / np.linalg.norm(q)
        data.qvel[6 * i : 6 * i + 3] = rng.normal(0.0, 0.1, 3)
        data.qvel[6 * i + 3 : 6 * i + 6] = rng.normal(0.0, 3.0, 3)
    return model, data


def main():
    n, steps, repeats = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    model, data = build(n)
    mujoco.mj_step(model, data, nstep=10)  # warm up
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        mujoco.mj_step(model, data, nstep=steps)
        times.append(time.perf_counter() - t0)
    ns = float(np.median(times)) / (steps * n) * 1e9
    print(f"mujoco {mujoco.__version__} euler: {n} free bodies, {steps} steps x {repeats}: "
          f"{[round(t / (steps * n) * 1e9, 2) for t in times]} ns per body-step")
    print(f"ns_per_body_step={ns:.2f}")


if __name__ == "__main__":
    main()
