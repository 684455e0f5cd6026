"""A PD controller written in Python holding a robot arm (docs/python.md).

    python python/examples/pd_arm.py [OUT_STEM]      # default logs/pd_arm
    rerun logs/pd_arm.rrd                            # or open logs/pd_arm.mcap in Foxglove

models/arm_motors.toml welds models/arm.urdf at its base with a motor on each joint. Every
millisecond the loop reads the joints, computes tau = kp (r - q) - kd v, sets the efforts (held
over the next step; the URDF's limits, 20 and 10 N m, clamp them) and steps once. At 0.5 s the
target jumps from the zero pose to (1.0, -0.8) rad; the arm swings there and holds it, sagging
under gravity by its torque over kp (no feed-forward here). The run is recorded as
`tumble simulate` records (MCAP and RRD)."""

import os
import sys

import numpy as np

import tumble

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
KP = np.array([400.0, 800.0])  # N m / rad
KD = np.array([8.1, 11.3])  # N m s / rad: about critical for the links' inertias


def run(out_stem):
    scene = tumble.Scene.from_file(os.path.join(ROOT, "models", "arm_motors.toml"))
    target = np.zeros(2)
    errors = []
    with tumble.Simulation(scene, record=["mcap", "rrd"], out=out_stem, force=True) as sim:
        assert sim.motors == ["arm/shoulder", "arm/elbow"]
        while sim.steps < scene.steps:
            if sim.time >= 0.5:
                target = np.array([1.0, -0.8])
            q, v = sim.joint_state()
            sim.set_efforts(KP * (target - q) - KD * v)
            sim.step()
            errors.append(np.abs(target - q).max())
        summary = sim.finish()
    return np.array(errors), summary


if __name__ == "__main__":
    stem = sys.argv[1] if len(sys.argv) > 1 else os.path.join("logs", "pd_arm")
    errors, summary = run(stem)
    print(f"largest joint error in the last second: {errors[-1000:].max():.2e} rad")
    print(f"motors' work {summary['input_work']:.4f} J, energy change "
          f"{summary['energy_final'] - summary['energy_initial']:.4f} J")
    print("wrote", " ".join(str(p) for p in summary["written"]))
