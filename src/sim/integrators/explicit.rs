//! First-order explicit schemes: explicit Euler and semi-implicit (symplectic) Euler.
//!
//! Both integrate the torque-free Euler equations in the body frame, `dM/dt = M × Ω` with
//! `Ω = J^-1 M` (equivalently `J dΩ/dt = JΩ × Ω`), the quaternion kinematics
//! `dq/dt = q ⊗ (0, Ω) / 2` (body-frame angular velocity, `world_from_body` convention) and
//! `dc/dt = v`, `dv/dt = g`. Neither conserves anything exactly: both are here to show what the
//! schemes of common engines do (see `/work/shared/design/numerics.md`, "Other schemes").
//!
//! - [`ExplicitEuler`]: every derivative at the start of the step. Since
//!   `|M + h M × Ω|^2 = |M|^2 + h^2 |M × Ω|^2`, `|M|` grows every step: the energy drifts
//!   upwards. Translation `c += h v; v += h g` gives `c_n = c0 + v0 t + g t (t - h)/2`
//!   (the parabola minus `t h g / 2`).
//! - [`SemiImplicitEuler`]: velocities first (`v += h g`, `M += h M × Ω`), then positions with
//!   the new velocities (`c += h v_new`, `q ← q ⊗ exp(h Ω_new)`): the velocity-then-position
//!   order of MuJoCo's `Euler` integrator and of Rapier (without their gyroscopic corrections). Translation gives `c_n = c0 + v0 t + g t (t + h)/2`
//!   (the parabola plus `t h g / 2`).
//!
//! Both are of order 1. [`StepStats`] is always the default (no iterations). Applied loads
//! ([`Loads::forced_step`]) act as two half kicks around the step, at its start and end times.

use super::{EnergyFlow, Integrator, StepStats};
use crate::sim::Bodies;
use crate::sim::loads::{KickLedger, Loads};
use nalgebra::{Quaternion, UnitQuaternion};

/// Explicit (forward) Euler on `(q, M, c, v)`, quaternion renormalised after each step. Order 1.
#[derive(Debug, Clone)]
pub struct ExplicitEuler {
    dt_secs: f64,
    /// The work of the applied loads.
    ledger: KickLedger,
}

impl ExplicitEuler {
    pub fn new(dt_secs: f64) -> Self {
        Self {
            dt_secs,
            ledger: KickLedger::default(),
        }
    }
}

impl Integrator for ExplicitEuler {
    /// `c += h v` (explicit) or `c += h (v + h g)` (semi-implicit).
    fn gravity_drift(&self) -> f64 {
        0.0
    }

    fn name(&self) -> &'static str {
        "euler"
    }

    fn dt(&self) -> f64 {
        self.dt_secs
    }

    fn init(&mut self, _bodies: &Bodies) {}

    fn step(&mut self, bodies: &mut Bodies, loads: &Loads) -> StepStats {
        let h = self.dt_secs;
        let mut ledger = std::mem::take(&mut self.ledger);
        loads.forced_step(bodies, &(0..bodies.len()), h, &mut ledger, |b| {
            Self::unforced(b, loads, h)
        });
        self.ledger = ledger;
        StepStats::default()
    }

    fn energy_flow(&self) -> EnergyFlow {
        EnergyFlow {
            input_work: self.ledger.work,
            dissipated: 0.0,
            ..Default::default()
        }
    }
}

impl ExplicitEuler {
    /// The step without applied loads.
    fn unforced(bodies: &mut Bodies, loads: &Loads, h: f64) {
        for i in 0..bodies.len() {
            let m = bodies.angmom_body[i];
            let omega = bodies.angvel_body(i);
            let q = bodies.world_from_body[i].into_inner();
            let dq = q * Quaternion::from_imag(omega) * (0.5 * h);
            bodies.world_from_body[i] = UnitQuaternion::new_normalize(q + dq);
            bodies.angmom_body[i] = m + m.cross(&omega) * h;
        }
        let dv = loads.gravity() * h;
        for (c, v) in bodies
            .com_world
            .iter_mut()
            .zip(bodies.linvel_world.iter_mut())
        {
            *c += *v * h;
            *v += dv;
        }
    }
}

/// Semi-implicit (symplectic) Euler: velocities, then positions with the new velocities. Order 1.
#[derive(Debug, Clone)]
pub struct SemiImplicitEuler {
    dt_secs: f64,
    /// The work of the applied loads.
    ledger: KickLedger,
}

impl SemiImplicitEuler {
    pub fn new(dt_secs: f64) -> Self {
        Self {
            dt_secs,
            ledger: KickLedger::default(),
        }
    }
}

impl Integrator for SemiImplicitEuler {
    /// `c += h v` (explicit) or `c += h (v + h g)` (semi-implicit).
    fn gravity_drift(&self) -> f64 {
        1.0
    }

    fn name(&self) -> &'static str {
        "semi-implicit"
    }

    fn dt(&self) -> f64 {
        self.dt_secs
    }

    fn init(&mut self, _bodies: &Bodies) {}

    fn step(&mut self, bodies: &mut Bodies, loads: &Loads) -> StepStats {
        let h = self.dt_secs;
        let mut ledger = std::mem::take(&mut self.ledger);
        loads.forced_step(bodies, &(0..bodies.len()), h, &mut ledger, |b| {
            Self::unforced(b, loads, h)
        });
        self.ledger = ledger;
        StepStats::default()
    }

    fn energy_flow(&self) -> EnergyFlow {
        EnergyFlow {
            input_work: self.ledger.work,
            dissipated: 0.0,
            ..Default::default()
        }
    }
}

impl SemiImplicitEuler {
    /// The step without applied loads.
    fn unforced(bodies: &mut Bodies, loads: &Loads, h: f64) {
        for i in 0..bodies.len() {
            let m = bodies.angmom_body[i];
            let omega = bodies.angvel_body(i);
            bodies.angmom_body[i] = m + m.cross(&omega) * h;
            let omega_new = bodies.angvel_body(i);
            let q = &mut bodies.world_from_body[i];
            *q *= UnitQuaternion::from_scaled_axis(omega_new * h);
            q.renormalize();
        }
        let dv = loads.gravity() * h;
        for (c, v) in bodies
            .com_world
            .iter_mut()
            .zip(bodies.linvel_world.iter_mut())
        {
            *v += dv;
            *c += *v * h;
        }
    }
}
