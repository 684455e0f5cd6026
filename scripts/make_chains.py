"""Writes the long serial chains of scripts/bench_mechanism.sh: models/chain{25,30,100}.urdf, their scenes
models/chain{25,30,100}.toml and the driven twin models/chain30_driven.toml (a sine motor on every joint).

Usage: python3 scripts/make_chains.py [MODELS_DIR]   (default: models/ beside this script; rewrites the files)

Every link is a solid box 0.03 x 0.02 x 0.1 m (x, y, z), m = 1 kg, hanging along -z from its joint, every
joint a continuous hinge about y (the same horizontal axis), the base a massless frame welded to the world (base =
"fixed") at L_total + 0.5 m, so the chain never reaches the ground (no scene here has one; contact is off).
The scenes start every joint at 0.3 rad, at rest, dt = 1 ms: the chain coils up and unwinds under gravity.

"""

import math
import os
import sys

A, B, L, M = 0.03, 0.02, 0.1, 1.0  # box sides along x, y, z (m), mass (kg)
IXX = M * (B * B + L * L) / 12
IYY = M * (A * A + L * L) / 12  # about the hinge axis (through the centre)
IZZ = M * (A * A + B * B) / 12  # about the link's own axis
Q0 = 0.3
LENGTHS = (25, 30, 100)
DRIVEN = {30: dict(amplitude=0.2, frequency_hz=1.0)}


def urdf(n):
    out = [
        '<?xml version="1.0"?>',
        "<!--",
        f"  A {n}-link chain (written by scripts/make_chains.py; do not edit by hand): {n} uniform links hanging",
        f"  from a pivot, joints j1..j{n} turning about the y axis (planar). For tumble's articulated mode",
        '  (base = "fixed") and MuJoCo\'s URDF importer (scripts/bench_mechanism.py).',
        "",
        "  base: a massless frame at the pivot (welded by base = \"fixed\").",
        f"  link1..link{n}: solid boxes a x b x L = {A} x {B} x {L} m (x, y, z), m = {M} kg, hanging along -z",
        f"    from their joint: com = (0, 0, {-L / 2!r})",
        f"    ixx = m (b^2 + L^2) / 12 = {IXX!r} kg m^2",
        f"    iyy = m (a^2 + L^2) / 12 = {IYY!r} kg m^2",
        f"    izz = m (a^2 + b^2) / 12 = {IZZ!r} kg m^2",
        f"  j1 at the pivot; j(k+1) at (0, 0, {-L!r}) of link k. All continuous (no range).",
        "-->",
        f'<robot name="chain{n}">',
        '  <material name="blue">',
        '    <color rgba="0.2 0.4 0.9 1.0"/>',
        "  </material>",
        '  <link name="base">',
        "    <visual>",
        "      <geometry>",
        '        <sphere radius="0.02"/>',
        "      </geometry>",
        "    </visual>",
        "  </link>",
    ]
    for k in range(1, n + 1):
        parent = "base" if k == 1 else f"link{k - 1}"
        offset = "0 0 0" if k == 1 else f"0 0 {-L!r}"
        out += [
            f'  <joint name="j{k}" type="continuous">',
            f'    <parent link="{parent}"/>',
            f'    <child link="link{k}"/>',
            f'    <origin xyz="{offset}" rpy="0 0 0"/>',
            '    <axis xyz="0 1 0"/>',
            "  </joint>",
            f'  <link name="link{k}">',
            "    <inertial>",
            f'      <origin xyz="0 0 {-L / 2!r}" rpy="0 0 0"/>',
            f'      <mass value="{M!r}"/>',
            f'      <inertia ixx="{IXX!r}" ixy="0" ixz="0" iyy="{IYY!r}" iyz="0" izz="{IZZ!r}"/>',
            "    </inertial>",
            "    <visual>",
            f'      <origin xyz="0 0 {-L / 2!r}" rpy="0 0 0"/>',
            "      <geometry>",
            f'        <box size="{A!r} {B!r} {L!r}"/>',
            "      </geometry>",
            '      <material name="blue"/>',
            "    </visual>",
            "  </link>",
        ]
    out.append("</robot>")
    return "\n".join(out) + "\n"


def height(n):
    return round(n * L + 0.5, 6)


def scene(n, driven=None):
    joints = ", ".join(f"j{k} = {Q0!r}" for k in range(1, n + 1))
    if driven:
        head = [
            f"# The {n}-link chain of models/chain{n}.toml started as it is, with a motor on every joint driving a",
            f"# small sine effort ({driven['amplitude']} N m at {driven['frequency_hz']} Hz, each joint a quarter period",
            "# after the previous), as models/chain7_driven.toml does for chain7: its cost per step against the passive",
            "# chain's (scripts/bench_mechanism.sh). Written by scripts/make_chains.py.",
        ]
    else:
        head = [
            f"# A {n}-link chain (models/chain{n}.urdf: 0.1 m, 1 kg boxes, hinges about y) welded at {height(n)} m, every",
            f"# joint started at {Q0} rad, at rest: it coils and unwinds under gravity (scripts/bench_mechanism.sh).",
            "# Written by scripts/make_chains.py.",
        ]
    out = head + [
        "[sim]",
        "dt = 0.001",
        "duration = 10.0",
        'integrator = "variational"',
        "log_every = 10",
        "",
        "[[model]]",
        f'urdf = "chain{n}.urdf"',
        'bodies = "articulated"',
        'base = "fixed"',
        f"position = [0.0, 0.0, {height(n)!r}]",
        f"joints = {{ {joints} }}",
    ]
    if driven:
        for k in range(1, n + 1):
            out += [
                "",
                "[[model.actuator]]",
                f'joint = "j{k}"',
                'kind = "motor"',
                f"effort = {{ sine = {{ amplitude = {driven['amplitude']!r}, frequency_hz = "
                f"{driven['frequency_hz']!r}, phase = {(k - 1) * math.pi / 2!r} }} }}",
            ]
    return "\n".join(out) + "\n"


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    models = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "models")
    files = {}
    for n in LENGTHS:
        files[f"chain{n}.urdf"] = urdf(n)
        files[f"chain{n}.toml"] = scene(n)
        if n in DRIVEN:
            files[f"chain{n}_driven.toml"] = scene(n, DRIVEN[n])
    for name, text in files.items():
        with open(os.path.join(models, name), "w") as f:
            f.write(text)
        print(os.path.join(models, name))


if __name__ == "__main__":
    main()
