"""Link poses and total mass of a URDF as Pinocchio reads it (urdfdom underneath): the reference
for the URDFs tumble loads leniently (tests/model/corpus.rs, docs/urdf.md).

Usage: pin_poses.py URDF JOINTS_JSON

JOINTS_JSON is {joint name: position} (rad or m); the other joints are at Pinocchio's neutral
configuration (0; continuous joints: angle 0). The model is the fixed-base build
`buildModelFromUrdf(URDF)` (mimic=False, Pinocchio's default: a mimic joint is an ordinary joint),
so the root link frame is the world frame, as tumble's model frame is the root link frame.
Prints one JSON object:

  total_mass  sum of model.inertias[i].mass over every joint, universe 0 included (the fixed-base
              build attaches the root link's inertia to joint 0, which computeTotalMass skips)
  links       {link name: {"translation": [x, y, z], "rotation": 3x3 row-major}} for every
              BODY frame: the link frame's placement data.oMf in the root link frame
"""
import json
import math
import sys

import pinocchio as pin


def main():
    path, joints = sys.argv[1], json.loads(sys.argv[2])
    model = pin.buildModelFromUrdf(path)
    data = model.createData()
    q = pin.neutral(model)
    for name, value in joints.items():
        if not model.existJointName(name):
            sys.exit(f"{path}: Pinocchio has no joint {name}")
        joint = model.joints[model.getJointId(name)]
        if joint.nq == 1:
            q[joint.idx_q] = value
        elif joint.nq == 2:  # continuous: (cos, sin)
            q[joint.idx_q] = math.cos(value)
            q[joint.idx_q + 1] = math.sin(value)
        else:
            sys.exit(f"{path}: joint {name} has {joint.nq} coordinates")
    pin.framesForwardKinematics(model, data, q)
    links = {}
    for i, frame in enumerate(model.frames):
        if frame.type != pin.FrameType.BODY:
            continue
        placement = data.oMf[i]
        links[frame.name] = {
            "translation": [float(x) for x in placement.translation],
            "rotation": [[float(x) for x in row] for row in placement.rotation],
        }
    total_mass = sum(float(inertia.mass) for inertia in model.inertias)
    json.dump({"total_mass": total_mass, "links": links}, sys.stdout)


if __name__ == "__main__":
    main()
