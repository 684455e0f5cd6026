"""Joint positions of a driven, fixed-base robot in continuous time, integrated with Pinocchio's
articulated-body algorithm: the reference for tumble's driven mechanisms
(tests/mechanism/pinocchio_driven.rs, docs/forces.md).

Usage: pin_driven.py SPEC_JSON

SPEC_JSON is one JSON object (the text itself, not a file):

  urdf        path of the URDF; the model is Pinocchio's fixed-base build
              `buildModelFromUrdf(urdf)` (its root link welded to the world, world = root link axes)
  gravity     [gx, gy, gz], m/s^2 (model.gravity)
  q0, v0      {joint: value}: initial positions (rad, m) and rates (rad/s, m/s); other joints 0
  actuators   list of {"joint", "kind", ...} with the laws of docs/forces.md, in continuous time:
                motor     tau = u(t)                         keys: effort
                position  tau = kp (r(t) - q) - kd qdot      keys: target, kp, kd (default 0)
                velocity  tau = kd (w(t) - qdot)             keys: target, kd
              optional "effort_limit" (> 0) clamps that actuator's tau to [-limit, limit]
  damping     true: every joint also gets -b qdot with b Pinocchio's model.damping (read by
              Pinocchio from the URDF's <dynamics damping>); false: none
  duration    s;  every: the sample interval, s (a whole number of steps h)
  h           RK4 step, s (default 1e-4)

A signal is a number or {"sine": {"amplitude", "frequency_hz", "phase", "offset"}}, valued
offset + amplitude sin(2 pi frequency_hz t + phase).

The state is (theta, theta_dot), one angle (or slider position) per joint, every joint having
one degree of freedom (revolute, continuous, prismatic); Pinocchio's configuration is built from
the angles at each evaluation (a continuous joint's (cos, sin)), so the integration is the plain
classical fourth-order Runge-Kutta method in R^2n of

  theta_ddot = ABA(q(theta), theta_dot, tau(t, theta, theta_dot)).

It is run twice, at h and at h/2; the h/2 run is printed, and `rk4_change` is the largest
difference of a sampled position between the two runs: about 15 times the h/2 run's own error
(fourth order: e(h) ~ 16 e(h/2)), so the printed positions are within rk4_change / 15.

Prints one JSON object: {"times": [...], "q": {joint: [...]}, "v": {joint: [...]},
"rk4_change": float, "h": float, "damping": {joint: b}, "pinocchio": version}.
"""

import json
import math
import sys

import numpy as np
import pinocchio as pin


def signal(spec):
    """A function of t from a signal's JSON."""
    if isinstance(spec, (int, float)):
        value = float(spec)
        return lambda t: value
    sine = spec["sine"]
    a = float(sine["amplitude"])
    w = 2.0 * math.pi * float(sine["frequency_hz"])
    p = float(sine.get("phase", 0.0))
    c = float(sine.get("offset", 0.0))
    return lambda t: c + a * math.sin(w * t + p)


class Robot:
    def __init__(self, spec):
        self.model = pin.buildModelFromUrdf(spec["urdf"])
        self.model.gravity.linear = np.array(spec["gravity"], dtype=float)
        self.data = self.model.createData()
        m = self.model
        # Every moving joint: one velocity coordinate each.
        self.names = list(m.names)[1:]
        self.n = m.nv
        if len(self.names) != self.n:
            sys.exit(f"{spec['urdf']}: {len(self.names)} joints but nv = {self.n}")
        self.idx_q = []
        self.nq = []
        for k, name in enumerate(self.names):
            joint = m.joints[m.getJointId(name)]
            if joint.nv != 1 or joint.idx_v != k:
                sys.exit(f"{name}: nv = {joint.nv}, idx_v = {joint.idx_v}")
            self.idx_q.append(joint.idx_q)
            self.nq.append(joint.nq)
        self.damping = np.array(m.damping, dtype=float) if spec["damping"] else np.zeros(self.n)
        self.laws = [self.law(a) for a in spec["actuators"]]

    def index(self, name):
        if name not in self.names:
            sys.exit(f"Pinocchio's model has no joint {name} (joints: {self.names})")
        return self.names.index(name)

    def law(self, a):
        """(k, tau(t, theta_k, rate_k)) of one actuator."""
        k = self.index(a["joint"])
        kind = a["kind"]
        if kind == "motor":
            u = signal(a["effort"])
            tau = lambda t, q, v: u(t)
        elif kind == "position":
            r, kp, kd = signal(a["target"]), float(a["kp"]), float(a.get("kd", 0.0))
            tau = lambda t, q, v: kp * (r(t) - q) - kd * v
        elif kind == "velocity":
            w, kd = signal(a["target"]), float(a["kd"])
            tau = lambda t, q, v: kd * (w(t) - v)
        else:
            sys.exit(f"unknown actuator kind {kind}")
        limit = float(a.get("effort_limit", 0.0))
        if limit > 0.0:
            return k, lambda t, q, v: min(max(tau(t, q, v), -limit), limit)
        return k, tau

    def configuration(self, theta):
        q = np.zeros(self.model.nq)
        for k, value in enumerate(theta):
            i = self.idx_q[k]
            if self.nq[k] == 1:
                q[i] = value
            else:  # continuous: (cos, sin)
                q[i] = math.cos(value)
                q[i + 1] = math.sin(value)
        return q

    def rate(self, t, x):
        """d/dt (theta, theta_dot)."""
        theta, v = x[: self.n], x[self.n :]
        tau = -self.damping * v
        for k, law in self.laws:
            tau[k] += law(t, theta[k], v[k])
        a = pin.aba(self.model, self.data, self.configuration(theta), v, tau)
        return np.concatenate([v, a])


def integrate(robot, x0, h, duration, every):
    """RK4 at step h; the state at every multiple of `every` up to `duration`."""
    per_sample = round(every / h)
    samples = round(duration / every)
    if abs(per_sample * h - every) > 1e-9 * every or abs(samples * every - duration) > 1e-9 * duration:
        sys.exit(f"h = {h} does not divide every = {every}, or every does not divide duration")
    x = x0.copy()
    out = [x.copy()]
    step = 0
    for _ in range(samples):
        for _ in range(per_sample):
            t = step * h
            k1 = robot.rate(t, x)
            k2 = robot.rate(t + h / 2, x + (h / 2) * k1)
            k3 = robot.rate(t + h / 2, x + (h / 2) * k2)
            k4 = robot.rate(t + h, x + h * k3)
            x = x + (h / 6) * (k1 + 2 * k2 + 2 * k3 + k4)
            step += 1
        out.append(x.copy())
    return out


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    spec = json.loads(sys.argv[1])
    robot = Robot(spec)
    n = robot.n
    x0 = np.zeros(2 * n)
    for name, value in spec.get("q0", {}).items():
        x0[robot.index(name)] = value
    for name, value in spec.get("v0", {}).items():
        x0[n + robot.index(name)] = value
    h = float(spec.get("h", 1e-4))
    duration, every = float(spec["duration"]), float(spec["every"])
    coarse = integrate(robot, x0, h, duration, every)
    fine = integrate(robot, x0, h / 2, duration, every)
    change = max(float(np.max(np.abs(a[:n] - b[:n]))) for a, b in zip(coarse, fine))
    json.dump(
        {
            "times": [i * every for i in range(len(fine))],
            "q": {name: [float(x[k]) for x in fine] for k, name in enumerate(robot.names)},
            "v": {name: [float(x[n + k]) for x in fine] for k, name in enumerate(robot.names)},
            "rk4_change": change,
            "h": h / 2,
            "damping": {name: float(robot.damping[k]) for k, name in enumerate(robot.names)},
            "pinocchio": pin.__version__,
        },
        sys.stdout,
    )


if __name__ == "__main__":
    main()
