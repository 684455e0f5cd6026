"""Whole-robot composite inertia of an example-robot-data URDF, computed by Pinocchio (ccrba).

Usage: pin_composite.py ROBOT CONFIG

ROBOT is a URDF path relative to example-robot-data's `robots/` folder (as installed by the
`example-robot-data` pip package under `cmeel.prefix/share/example-robot-data/robots/`), CONFIG
is `zero` or `nonzero`. Prints one JSON object:

  urdf       absolute path of the URDF
  joints     {joint name: position} of the single-DOF, non-mimic joints: what tumble's scene key
             `joints` is given (empty at `zero`)
  mass       total mass, kg                                   (data.Ig.mass)
  com        centre of mass in the root link frame, m         (pin.centerOfMass -> data.com[0])
  inertia    3x3 inertia about the centre of mass, root link axes, kg m^2 (data.Ig.inertia)
  lever      data.Ig.lever: the Ig centre relative to the com (zero by construction)
  fixed_base_mass, universe_mass   see below

Base: Pinocchio's fixed-base build (`buildModelFromUrdf(path)`) attaches the root link to the
universe joint 0, and `ccrba` / `computeTotalMass` sum joints 1.. only, so the root link's mass
is left out (panda: 16.822 kg instead of 17.452). The composite is therefore computed on the
free-flyer build with the free-flyer at the identity (q[:7] = 0 0 0 0 0 0 1): the root link frame
is then the world frame, and the root link is a body like the others. `fixed_base_mass` and
`universe_mass` (= model.inertias[0].mass of the fixed-base build) are printed so that this can be
seen: fixed_base_mass + universe_mass = mass.

Joint positions: at `nonzero`, every revolute, continuous or prismatic joint without <mimic> gets
a distinct value t_k in (0.1, 0.9) of its [lower, upper] range (continuous joints, or joints
without a finite range: 3 t_k - 1.5 rad). Mimic joints follow the URDF rule
q = multiplier * q_mimicked + offset (read here from the XML, not by Pinocchio: the model is built
with mimic=False, so a mimic joint is an ordinary joint whose position is set from the rule).
Continuous joints are (cos q, sin q) in Pinocchio's configuration vector.
"""

import json
import math
import os
import sys
import sysconfig
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin


def robots_dir():
    for key in ("purelib", "platlib"):
        d = os.path.join(
            sysconfig.get_paths()[key], "cmeel.prefix", "share", "example-robot-data", "robots"
        )
        if os.path.isdir(d):
            return d
    sys.exit("example-robot-data's robots/ folder not found under cmeel.prefix/share")


def urdf_joints(path):
    """Joint name -> (type, lower, upper, mimic (joint, multiplier, offset) or None)."""
    joints = {}
    for j in ET.parse(path).getroot().iter("joint"):
        if j.get("type") is None:  # <joint> inside <transmission>
            continue
        limit = j.find("limit")
        lower = float(limit.get("lower", "nan")) if limit is not None else math.nan
        upper = float(limit.get("upper", "nan")) if limit is not None else math.nan
        m = j.find("mimic")
        mimic = None
        if m is not None:
            mimic = (m.get("joint"), float(m.get("multiplier", "1")), float(m.get("offset", "0")))
        joints[j.get("name")] = (j.get("type"), lower, upper, mimic)
    return joints


def positions(joints, config):
    """The positions tumble is given (single-DOF, non-mimic) and all positions (mimic included)."""
    given = {}
    k = 0
    for name, (kind, lower, upper, mimic) in joints.items():
        if kind not in ("revolute", "continuous", "prismatic") or mimic is not None:
            continue
        k += 1
        if config == "zero":
            continue
        t = 0.5 + 0.4 * math.sin(1.3 * k + 0.5)
        if kind != "continuous" and math.isfinite(lower) and math.isfinite(upper) and upper > lower:
            given[name] = lower + t * (upper - lower)
        else:
            given[name] = 3.0 * t - 1.5
    every = dict(given)
    for name, (kind, _, _, mimic) in joints.items():
        if mimic is not None and kind in ("revolute", "continuous", "prismatic"):
            src, multiplier, offset = mimic
            every[name] = multiplier * given.get(src, 0.0) + offset
    return given, every


def composite(model, q):
    data = model.createData()
    pin.ccrba(model, data, q, np.zeros(model.nv))
    com = pin.centerOfMass(model, data, q)
    return data.Ig, com


def main():
    if len(sys.argv) != 3 or sys.argv[2] not in ("zero", "nonzero"):
        sys.exit(__doc__)
    path = os.path.join(robots_dir(), sys.argv[1])
    given, every = positions(urdf_joints(path), sys.argv[2])

    model = pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())
    q = pin.neutral(model)  # free-flyer at the identity: 0 0 0, quaternion 0 0 0 1
    assert np.array_equal(q[:7], [0, 0, 0, 0, 0, 0, 1]), q[:7]
    for name, value in every.items():
        if not model.existJointName(name):
            sys.exit(f"joint {name} is not in Pinocchio's model")
        joint = model.joints[model.getJointId(name)]
        if joint.nq == 1:
            q[joint.idx_q] = value
        elif joint.nq == 2:  # continuous: (cos, sin)
            q[joint.idx_q] = math.cos(value)
            q[joint.idx_q + 1] = math.sin(value)
        else:
            sys.exit(f"joint {name}: nq = {joint.nq}")
    ig, com = composite(model, q)

    fixed = pin.buildModelFromUrdf(path)
    print(
        json.dumps(
            {
                "urdf": path,
                "robot": model.name,
                "pinocchio": pin.__version__,
                "joints": given,
                "mass": ig.mass,
                "com": com.tolist(),
                "inertia": ig.inertia.tolist(),
                "lever": ig.lever.tolist(),
                "fixed_base_mass": pin.computeTotalMass(fixed),
                "universe_mass": fixed.inertias[0].mass,
            }
        )
    )


if __name__ == "__main__":
    main()
