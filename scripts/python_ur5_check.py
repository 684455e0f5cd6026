"""A real robot driven from Python against Pinocchio (issue 33): example-robot-data's UR5 with a motor on
each joint, held at a pose by Pinocchio's gravity torques set with set_efforts (it must stay at rest), a PD
loop with Pinocchio's gravity compensation, and rollout of the same efforts bit for bit.
    target/pyenv/bin/python scripts/python_ur5_check.py   (after bash scripts/test.sh: the venv, the package)"""
import os, numpy as np, tumble, pinocchio as pin
share = os.path.abspath("target/pyenv/lib/python3.11/site-packages/cmeel.prefix/share")
urdf = f"{share}/example-robot-data/robots/ur_description/urdf/ur5_robot.urdf"
joints = ["shoulder_pan_joint","shoulder_lift_joint","elbow_joint","wrist_1_joint","wrist_2_joint","wrist_3_joint"]
text = (f'[sim]\ndt = 0.001\nduration = 1.0\ngravity = [0.0, 0.0, -9.81]\n[[model]]\nurdf = "{urdf}"\n'
        f'bodies = "articulated"\nbase = "fixed"\njoint_limits = false\njoint_damping = false\npackage_paths = ["{share}"]\nallow_mesh_paths = ["/"]\n')
for j in joints:
    text += f'[[model.actuator]]\njoint = "{j}"\nkind = "motor"\neffort = 0.0\n'
scene = tumble.Scene.from_toml(text, base_dir="/tmp")
# Pinocchio's gravity torque at q0 as the held efforts: the arm must stay at rest (a static balance
# against an independent reference), then a PD controller in Python.
model = pin.buildModelFromUrdf(urdf); data = model.createData()
sim = tumble.Simulation(scene, threads=1)
names = sim.state()["joint_names"]; assert names == joints, names
q0 = np.array([0.0, -1.0, 1.2, -0.5, 1.0, 0.0])
sc = tumble.Scene.from_toml(text.replace('base = "fixed"\n', 'base = "fixed"\njoints = { ' + ", ".join(f"{j} = {v}" for j, v in zip(joints, q0)) + ' }\n'), base_dir="/tmp")
sim = tumble.Simulation(sc, threads=1)
g = pin.computeGeneralizedGravity(model, data, q0)
sim.set_efforts(g)
sim.step(1000)
q, v = sim.joint_state()
print("UR5 held at q0 by Pinocchio's gravity torques, 1 s: |q - q0| max", np.abs(q - q0).max(), "|v| max", np.abs(v).max())
s = sim.finish(); print("energy change", s["energy_final"] - s["energy_initial"], "work", s["input_work"])
# PD + Pinocchio gravity compensation toward a target, then rollout of the same efforts bit for bit
sim = tumble.Simulation(sc, threads=1); target = q0 + 0.3; us = []
for k in range(1000):
    q, v = sim.joint_state(); u = pin.computeGeneralizedGravity(model, data, q) + 200*(target - q) - 20*v
    sim.set_efforts(u); us.append(u); sim.step()
q, v = sim.joint_state(); print("PD with gravity compensation: |q - target| max", np.abs(q - target).max())
us = np.array(us)
out = tumble.rollout(sc, steps=1000, inputs={j: us[:, i][None, :] for i, j in enumerate(joints)}, threads=1)
print("rollout of the same efforts equals the loop:", np.array_equal(out["joint_position"][0, -1], q))
