//! What drives a mechanism's joints: actuators (motor, position servo, velocity servo) and
//! joint damping, per joint coordinate ([`JointDrive`]).
//!
//! Continuous-time efforts (MuJoCo's actuator semantics; URDF `<dynamics damping>`):
//!
//! ```text
//! motor:     τ_a = u(t)
//! position:  τ_a = kp (r(t) − θ) − kd θ̇
//! velocity:  τ_a = kd (w(t) − θ̇)
//! clamp:     τ_a ← min(max(τ_a, −τ_max), τ_max)      (when an effort limit τ_max > 0 is set)
//! damping:   τ_b = −b θ̇                              (passive, never clamped)
//! ```
//!
//! In the variational step the effort of a step `[t_k, t_{k+1}]` is evaluated symmetrically
//! ([`JointDrive::step_effort`]): the inputs at the trapezoid average of the two ends, the
//! position at the midpoint `(θ_k + θ_{k+1})/2` and the rate as the difference quotient
//! `(θ_{k+1} − θ_k)/h`. Swapping the ends and the sign of `h` leaves it unchanged, so the
//! step stays symmetric (orders 4 and 6 by composition); its dependence on `θ_{k+1}` is solved
//! implicitly in the step's Newton iteration (`∂τ̄/∂θ_{k+1}`, [`StepEffort::slope`]), which
//! keeps stiff servos and dampers stable at any step (see `docs/forces.md`).

use crate::sim::signal::Signal;

/// An actuator's law.
#[derive(Debug, Clone, PartialEq)]
pub enum ActuatorKind {
    /// `τ = u(t)` (N m, or N for a prismatic joint).
    Motor { effort: Signal },
    /// `τ = kp (r(t) − θ) − kd θ̇`.
    Position { target: Signal, kp: f64, kd: f64 },
    /// `τ = kd (w(t) − θ̇)`.
    Velocity { target: Signal, kd: f64 },
}

/// One actuator on a joint coordinate.
#[derive(Debug, Clone, PartialEq)]
pub struct Actuator {
    pub kind: ActuatorKind,
    /// `|τ_a| ≤ limit` when `Some` (a positive number).
    pub effort_limit: Option<f64>,
}

impl Actuator {
    /// The actuator's signal (a servo's target, a motor's effort) when it is a constant.
    pub fn constant_signal(&self) -> Option<f64> {
        let signal = match &self.kind {
            ActuatorKind::Motor { effort } => effort,
            ActuatorKind::Position { target, .. } | ActuatorKind::Velocity { target, .. } => target,
        };
        match signal {
            Signal::Constant(c) => Some(*c),
            _ => None,
        }
    }

    /// Replaces the actuator's signal: a servo's target, a motor's effort (a dataset's drawn
    /// input, `crate::dataset::joint_vary`).
    pub fn set_signal(&mut self, signal: Signal) {
        match &mut self.kind {
            ActuatorKind::Motor { effort } => *effort = signal,
            ActuatorKind::Position { target, .. } | ActuatorKind::Velocity { target, .. } => {
                *target = signal
            }
        }
    }
}

/// What acts on one joint coordinate: an actuator, damping, or both.
#[derive(Debug, Clone, PartialEq)]
pub struct JointDrive {
    /// The mechanism coordinate it acts on (index into `MechanismModel::coordinates`).
    pub coordinate: usize,
    pub actuator: Option<Actuator>,
    /// Viscous damping `b ≥ 0` (N m s/rad or N s/m): `τ_b = −b θ̇`.
    pub damping: f64,
}

/// The effort at an instant, split as the recording and the energy balance need it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Effort {
    /// The actuator's effort after the clamp (0 without an actuator).
    pub actuator: f64,
    /// `−b θ̇`.
    pub damping: f64,
    /// Whether the clamp acted.
    pub saturated: bool,
}

impl Effort {
    /// The total effort on the joint, `τ_a + τ_b`.
    pub fn total(&self) -> f64 {
        self.actuator + self.damping
    }
}

/// The symmetric effort of one step and its slope with respect to `θ_{k+1}`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepEffort {
    pub effort: Effort,
    /// `∂(τ_a + τ_b)/∂θ_{k+1}` (≤ 0: stiffness and damping only resist).
    pub slope: f64,
    /// The sum of the absolute values of the terms the effort was computed from (its
    /// round-off is of the order of `ε` times this: a stiff servo's `kp r` and `kp θ` nearly
    /// cancel at rest), for the Newton stopping rule.
    pub magnitude: f64,
}

impl Actuator {
    fn clamp(&self, effort: f64) -> (f64, bool) {
        match self.effort_limit {
            Some(limit) if effort.abs() > limit => (limit.copysign(effort), true),
            _ => (effort, false),
        }
    }

    /// The commanded target at `t_secs` (position or velocity; `None` for a motor).
    pub fn target(&self, t_secs: f64) -> Option<f64> {
        match &self.kind {
            ActuatorKind::Motor { .. } => None,
            ActuatorKind::Position { target, .. } | ActuatorKind::Velocity { target, .. } => {
                Some(target.at(t_secs))
            }
        }
    }
}

impl JointDrive {
    /// The actuator's commanded target at `t_secs`, if it has one.
    pub fn target(&self, t_secs: f64) -> Option<f64> {
        self.actuator.as_ref().and_then(|a| a.target(t_secs))
    }

    /// The continuous-time effort at `t_secs` with the joint at `theta` moving at `theta_dot`
    /// (what a recording reports at a sample).
    pub fn effort(&self, t_secs: f64, theta: f64, theta_dot: f64) -> Effort {
        let (actuator, saturated) = match &self.actuator {
            None => (0.0, false),
            Some(a) => {
                let raw = match &a.kind {
                    ActuatorKind::Motor { effort } => effort.at(t_secs),
                    ActuatorKind::Position { target, kp, kd } => {
                        kp * (target.at(t_secs) - theta) - kd * theta_dot
                    }
                    ActuatorKind::Velocity { target, kd } => kd * (target.at(t_secs) - theta_dot),
                };
                a.clamp(raw)
            }
        };
        Effort {
            actuator,
            damping: -self.damping * theta_dot,
            saturated,
        }
    }

    /// The effort of the step from `(t0, θ0)` to `(t0 + h, θ1)` (see the module doc):
    /// inputs averaged over the two ends, `θ` at the midpoint, `θ̇ = (θ1 − θ0)/h`.
    pub fn step_effort(&self, t0_secs: f64, h: f64, theta0: f64, theta1: f64) -> StepEffort {
        let rate = (theta1 - theta0) / h;
        let t1 = t0_secs + h;
        let mut slope = -self.damping / h;
        let rate_terms = (theta1.abs() + theta0.abs()) / h.abs();
        let mut magnitude = self.damping * rate_terms;
        let (actuator, saturated) = match &self.actuator {
            None => (0.0, false),
            Some(a) => {
                let (raw, raw_slope) = match &a.kind {
                    ActuatorKind::Motor { effort } => {
                        let u = 0.5 * (effort.at(t0_secs) + effort.at(t1));
                        magnitude += u.abs();
                        (u, 0.0)
                    }
                    ActuatorKind::Position { target, kp, kd } => {
                        let r = 0.5 * (target.at(t0_secs) + target.at(t1));
                        magnitude +=
                            kp * (r.abs() + 0.5 * (theta0.abs() + theta1.abs())) + kd * rate_terms;
                        (
                            kp * (r - 0.5 * (theta0 + theta1)) - kd * rate,
                            -0.5 * kp - kd / h,
                        )
                    }
                    ActuatorKind::Velocity { target, kd } => {
                        let w = 0.5 * (target.at(t0_secs) + target.at(t1));
                        magnitude += kd * (w.abs() + rate_terms);
                        (kd * (w - rate), -kd / h)
                    }
                };
                let (effort, saturated) = a.clamp(raw);
                if !saturated {
                    slope += raw_slope;
                }
                (effort, saturated)
            }
        };
        StepEffort {
            effort: Effort {
                actuator,
                damping: -self.damping * rate,
                saturated,
            },
            slope,
            magnitude,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn servo(kp: f64, kd: f64, limit: Option<f64>) -> JointDrive {
        JointDrive {
            coordinate: 0,
            actuator: Some(Actuator {
                kind: ActuatorKind::Position {
                    target: Signal::Constant(1.0),
                    kp,
                    kd,
                },
                effort_limit: limit,
            }),
            damping: 0.5,
        }
    }

    /// The laws of the module doc, at an instant.
    #[test]
    fn continuous_efforts_follow_the_laws() {
        let d = servo(80.0, 4.0, None);
        let e = d.effort(0.0, 0.25, 2.0);
        assert_eq!(e.actuator, 80.0 * 0.75 - 4.0 * 2.0);
        assert_eq!(e.damping, -1.0);
        assert!(!e.saturated);
        assert_eq!(e.total(), 52.0 - 1.0);
        let v = JointDrive {
            coordinate: 0,
            actuator: Some(Actuator {
                kind: ActuatorKind::Velocity {
                    target: Signal::Constant(1.0),
                    kd: 2.0,
                },
                effort_limit: None,
            }),
            damping: 0.0,
        };
        assert_eq!(v.effort(0.0, 9.0, 3.0).actuator, -4.0);
        assert_eq!(v.target(0.0), Some(1.0));
        let m = JointDrive {
            coordinate: 0,
            actuator: Some(Actuator {
                kind: ActuatorKind::Motor {
                    effort: Signal::Constant(0.5),
                },
                effort_limit: None,
            }),
            damping: 0.0,
        };
        assert_eq!(m.effort(3.0, 1.0, 1.0).actuator, 0.5);
        assert_eq!(m.target(0.0), None);
    }

    /// The clamp keeps the sign, flags saturation, never touches damping, and a saturated
    /// servo has no stiffness left in its slope.
    #[test]
    fn the_effort_limit_clamps_and_flags() {
        let d = servo(80.0, 4.0, Some(10.0));
        let e = d.effort(0.0, -1.0, 0.0);
        assert_eq!((e.actuator, e.saturated), (10.0, true));
        let e = d.effort(0.0, 3.0, 0.0);
        assert_eq!((e.actuator, e.saturated), (-10.0, true));
        // Exactly at the limit (80 · 0.125 = 10): not saturated.
        let e = d.effort(0.0, 0.875, 0.0);
        assert_eq!((e.actuator, e.saturated), (10.0, false));
        let s = d.step_effort(0.0, 0.01, -1.0, -1.0);
        assert!(s.effort.saturated);
        assert_eq!(s.slope, -0.5 / 0.01);
        let inside = d.step_effort(0.0, 0.01, 0.99, 0.99);
        assert!(!inside.effort.saturated);
        assert_eq!(inside.slope, -0.5 / 0.01 - 40.0 - 4.0 / 0.01);
    }

    /// The stopping rule's scale (`StepEffort::magnitude`): the sum of the sizes of the terms,
    /// by hand for each law.
    #[test]
    fn the_magnitude_sums_the_terms_sizes() {
        let (h, t0, t1) = (0.01, 0.2, 0.3);
        // rate terms (|θ0| + |θ1|)/h = 50; damping 0.5 · 50 = 25; kp (|r| + (|θ0| + |θ1|)/2) =
        // 80 · 1.25 = 100; kd · 50 = 200.
        let s = servo(80.0, 4.0, None).step_effort(0.0, h, t0, t1);
        assert!((s.magnitude - 325.0).abs() < 1e-12, "{}", s.magnitude);
        let v = JointDrive {
            coordinate: 0,
            actuator: Some(Actuator {
                kind: ActuatorKind::Velocity {
                    target: Signal::Constant(-3.0),
                    kd: 2.0,
                },
                effort_limit: None,
            }),
            damping: 0.0,
        };
        // kd (|w| + 50) = 2 · 53.
        assert!((v.step_effort(0.0, h, t0, t1).magnitude - 106.0).abs() < 1e-12);
        let m = JointDrive {
            coordinate: 0,
            actuator: Some(Actuator {
                kind: ActuatorKind::Motor {
                    effort: Signal::Constant(-0.7),
                },
                effort_limit: None,
            }),
            damping: 0.1,
        };
        // |u| + b · 50.
        assert!((m.step_effort(0.0, h, t0, t1).magnitude - 5.7).abs() < 1e-12);
    }

    /// The step efforts and slopes of each law, by hand (θ0 = 0.2, θ1 = 0.3, h = 0.01: the
    /// rate is 10).
    #[test]
    fn step_efforts_and_slopes_follow_the_laws() {
        let (h, t0, t1) = (0.01, 0.2, 0.3);
        // kp (r − θ_mid) − kd rate = 80 · 0.75 − 4 · 10 = 20; damping −0.5 · 10 = −5;
        // slope −b/h − kp/2 − kd/h = −50 − 40 − 400.
        let s = servo(80.0, 4.0, None).step_effort(0.0, h, t0, t1);
        assert!((s.effort.actuator - 20.0).abs() < 1e-12, "{s:?}");
        assert!((s.effort.damping + 5.0).abs() < 1e-12, "{s:?}");
        assert!((s.slope + 490.0).abs() < 1e-9, "{s:?}");
        let v = JointDrive {
            coordinate: 0,
            actuator: Some(Actuator {
                kind: ActuatorKind::Velocity {
                    target: Signal::Sine {
                        amplitude: 1.0,
                        frequency_hz: 25.0,
                        phase: 0.0,
                        offset: -3.0,
                    },
                    kd: 2.0,
                },
                effort_limit: None,
            }),
            damping: 0.0,
        };
        // The target averaged over the ends: −3 + (sin 0 + sin(2π · 25 · 0.01))/2 = −2.5;
        // kd (w − rate) = 2 · (−12.5); slope −kd/h = −200.
        let s = v.step_effort(0.0, h, t0, t1);
        assert!((s.effort.actuator + 25.0).abs() < 1e-12, "{s:?}");
        assert!((s.slope + 200.0).abs() < 1e-9, "{s:?}");
        // A motor: the effort averaged over the ends, no slope.
        let m = JointDrive {
            coordinate: 0,
            actuator: Some(Actuator {
                kind: ActuatorKind::Motor {
                    effort: Signal::Table {
                        times_secs: vec![0.0, 0.01],
                        values: vec![1.0, 2.0],
                    },
                },
                effort_limit: None,
            }),
            damping: 0.0,
        };
        let s = m.step_effort(0.0, h, t0, t1);
        assert_eq!((s.effort.actuator, s.slope), (1.5, 0.0));
    }

    /// The step effort is symmetric: swapping the ends and the sign of `h` gives the same
    /// effort (the property the compositions' orders rest on).
    #[test]
    fn the_step_effort_is_symmetric() {
        let d = JointDrive {
            coordinate: 0,
            actuator: Some(Actuator {
                kind: ActuatorKind::Position {
                    target: Signal::Sine {
                        amplitude: 0.5,
                        frequency_hz: 0.7,
                        phase: 0.1,
                        offset: 0.2,
                    },
                    kp: 30.0,
                    kd: 2.0,
                },
                effort_limit: None,
            }),
            damping: 0.3,
        };
        let (t0, h, a, b) = (0.3, 0.01, 0.11, 0.13);
        let fwd = d.step_effort(t0, h, a, b);
        let back = d.step_effort(t0 + h, -h, b, a);
        assert!((fwd.effort.total() - back.effort.total()).abs() < 1e-12);
    }
}
