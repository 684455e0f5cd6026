"""Figures of the Python package (issue 33), printed for the README: run with the venv that has
`pip install ./python` (bash scripts/python_bench.sh does both).

1. rollout: 1000 free bodies (rolls of a one-body scene from random states) x 1000 steps,
   sampled every step, against `tumble bench --bodies 1000 --steps 1000` (the CLI's bare
   guarded stepping of a 1000-body batch) on the same threads: the ratio of wall times.
2. A controller loop at 1 kHz on a 7-link arm (models/chain7.urdf, a motor on each joint): a
   Python PD reading `joint_state()` and calling `set_efforts` then `step()` every step, against
   the same steps taken by one `step(n)` call with the efforts held: the overhead per step.
3. The GIL: two Python threads each stepping its own simulation, against the same two one after
   the other.
Medians of 5 repeats."""

import os
import statistics
import subprocess
import sys
import threading
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # numpy's BLAS threads spin beside the timed work
import numpy as np

import tumble

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("TUMBLE_BIN", os.path.join(ROOT, "target", "release", "tumble"))
THREADS = int(os.environ.get("THREADS", os.cpu_count() or 1))
REPEATS = 5

ONE_BODY = """
[sim]
dt = 0.001
duration = 1.0
gravity = [0.0, 0.0, 0.0]
integrator = "variational"

[[model]]
urdf = "t_handle.urdf"
bodies = "rigid"
"""

ARM = """
[sim]
dt = 0.001
duration = 30.0
gravity = [0.0, 0.0, -9.81]
integrator = "variational"
log_every = 10

[[model]]
urdf = "chain7.urdf"
name = "arm"
bodies = "articulated"
base = "fixed"
position = [0.0, 0.0, 4.0]
"""


def arm_scene():
    text = ARM
    for j in range(1, 8):
        text += f'\n[[model.actuator]]\njoint = "j{j}"\nkind = "motor"\neffort = 0.0\n'
    return tumble.Scene.from_toml(text, base_dir=os.path.join(ROOT, "models"))


def rollout_ratio():
    scene = tumble.Scene.from_toml(ONE_BODY, base_dir=os.path.join(ROOT, "models"))
    rng = np.random.default_rng(1)
    rolls = 1000
    q = rng.normal(size=(rolls, 1, 4))
    q /= np.linalg.norm(q, axis=2, keepdims=True)
    states = {
        "orientation": q,
        "angular_velocity": rng.uniform(-5, 5, size=(rolls, 1, 3)),
    }
    for threads in sorted({1, THREADS}):
        # Warm-up: the first calls also pay the kernel's compaction of huge pages for 104 MB of
        # fresh output (measured 0.4-0.5 s each on this machine, then 35 ms).
        for _ in range(3):
            out = tumble.rollout(scene, states, steps=1000, threads=threads)
        fresh, reused, once = [], [], []
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            tumble.rollout(scene, states, steps=1000, threads=threads)
            fresh.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            tumble.rollout(scene, states, steps=1000, threads=threads, out=out)
            reused.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            tumble.rollout(scene, states, steps=1000, threads=threads, every=1000)
            once.append(time.perf_counter() - t0)
        assert out["position"].shape == (1000, 1000, 1, 3) and out["batched"]
        per = lambda ts: statistics.median(ts) * 1e9 / (rolls * 1000)
        text = subprocess.run(
            [BIN, "bench", "--bodies", "1000", "--steps", "1000", "--threads", str(threads)],
            check=True, capture_output=True, text=True,
        ).stdout
        bench = float(text.strip().splitlines()[-1].split("=")[1])
        print(f"rollout, 1000 rolls of a free body x 1000 steps, every step sampled, {threads} "
              f"thread(s): {per(fresh):.1f} ns per body-step (new arrays), {per(reused):.1f} "
              f"(out= reused), {per(once):.1f} (sampled once: the stepping alone); tumble bench "
              f"--bodies 1000 --threads {threads}: {bench:.1f} ns; ratios {per(fresh) / bench:.2f}, "
              f"{per(reused) / bench:.2f}, {per(once) / bench:.2f}")


def controller_overhead():
    kp, kd = 200.0, 20.0
    steps = 2000
    loop, bare = [], []
    for _ in range(REPEATS):
        sim = tumble.Simulation(arm_scene(), threads=1)
        names = [f"arm/j{j}" for j in range(1, 8)]
        assert sim.motors == names
        t0 = time.perf_counter()
        for _ in range(steps):
            q, v = sim.joint_state()
            sim.set_efforts(-kp * q - kd * v)  # in the order of sim.motors
            sim.step()
        loop.append((time.perf_counter() - t0) / steps)
        sim.finish()
        sim = tumble.Simulation(arm_scene(), threads=1)
        sim.set_efforts([0.1] * 7)
        t0 = time.perf_counter()
        sim.step(steps)
        bare.append((time.perf_counter() - t0) / steps)
        sim.finish()
    lo, ba = statistics.median(loop) * 1e6, statistics.median(bare) * 1e6
    print(f"controller loop, 7-link arm at 1 kHz: {lo:.2f} us per step, the steps alone "
          f"{ba:.2f} us: overhead {lo - ba:.2f} us per step")


def gil():
    def run():
        sim = tumble.Simulation(arm_scene(), threads=1)
        sim.step(3000)
        sim.finish()

    seq, par = [], []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        run()
        run()
        seq.append(time.perf_counter() - t0)
        threads = [threading.Thread(target=run) for _ in range(2)]
        t0 = time.perf_counter()
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        par.append(time.perf_counter() - t0)
    s, p = statistics.median(seq), statistics.median(par)
    print(f"two simulations, 3000 steps each: one after the other {s:.3f} s, two Python threads "
          f"{p:.3f} s: speed-up {s / p:.2f} (2 = perfectly parallel)")


if __name__ == "__main__":
    which = sys.argv[1:] or ["rollout", "controller", "gil"]
    for name in which:
        {"rollout": rollout_ratio, "controller": controller_overhead, "gil": gil}[name]()
