//! The classic fourth-order Runge–Kutta method on `(q, M, c, v)`.
//!
//! The state is the quaternion `q` taken as a plain 4-vector, the body angular momentum `M`, the
//! centre of mass `c` and its velocity `v`, with the torque-free equations
//!
//! `dq/dt = q ⊗ (0, Ω) / 2`, `dM/dt = M × Ω` (Euler's equations), `Ω = J^-1 M`,
//! `dc/dt = v`, `dv/dt = g`,
//!
//! and the Butcher tableau of Kutta (1901) (Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.1).
//! The stages do not renormalise `q`; the step's result is renormalised (a projection that keeps
//! order 4). Translation: for constant `g`, RK4 reduces exactly to `c += h v + h^2 g / 2`,
//! `v += h g` (the solution is a quadratic polynomial), i.e. the exact parabola, so it is written in
//! that form. Neither energy nor momentum is conserved: both drift by O(h^4) per unit time.
//!
//! A body under applied loads ([`Loads::wrench_on`]: a force `F(t, q)` at a point and a torque)
//! is integrated as one system with the forcing in the stages, at the stage times `t_k`,
//! `t_k + h/2`, `t_k + h`: `dM/dt = M × Ω + τ(t, q)` (body axes), `dv/dt = g + F(t, q)/m`,
//! so the order stays 4 with time-varying loads.

use super::translation::{Potential, step_translation};
use super::{EnergyFlow, Integrator, StepStats};
use crate::sim::Bodies;
use crate::sim::loads::{KickLedger, Loads};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// The right-hand side of the rotational equations at `(q, M)`: `(dq/dt, dM/dt)`.
#[inline]
fn rotation_rate(
    inv_inertia_body: &Vector3<f64>,
    q: &Quaternion<f64>,
    m: &Vector3<f64>,
) -> (Quaternion<f64>, Vector3<f64>) {
    let omega = m.component_mul(inv_inertia_body);
    (q * Quaternion::from_imag(omega) * 0.5, m.cross(&omega))
}

/// One RK4 step of the rotational equations for one body; `q` is returned unnormalised.
#[inline]
pub fn rk4_rotation(
    inv_inertia_body: &Vector3<f64>,
    q: &Quaternion<f64>,
    m: &Vector3<f64>,
    h: f64,
) -> (Quaternion<f64>, Vector3<f64>) {
    let (kq1, km1) = rotation_rate(inv_inertia_body, q, m);
    let (kq2, km2) = rotation_rate(
        inv_inertia_body,
        &(q + kq1 * (0.5 * h)),
        &(m + km1 * (0.5 * h)),
    );
    let (kq3, km3) = rotation_rate(
        inv_inertia_body,
        &(q + kq2 * (0.5 * h)),
        &(m + km2 * (0.5 * h)),
    );
    let (kq4, km4) = rotation_rate(inv_inertia_body, &(q + kq3 * h), &(m + km3 * h));
    (
        q + (kq1 + kq2 * 2.0 + kq3 * 2.0 + kq4) * (h / 6.0),
        m + (km1 + km2 * 2.0 + km3 * 2.0 + km4) * (h / 6.0),
    )
}

/// The state of one body under applied loads: `(q, M, c, v)`.
type Forced = (Quaternion<f64>, Vector3<f64>, Vector3<f64>, Vector3<f64>);

/// The rates of a loaded body's state at `t_secs` (see the module doc).
fn forced_rate(
    loads: &Loads,
    bodies: &Bodies,
    i: usize,
    t_secs: f64,
    (q, m, _c, v): &Forced,
) -> Forced {
    let (dq, dm) = rotation_rate(&bodies.inv_inertia_body[i], q, m);
    let unit = UnitQuaternion::new_normalize(*q);
    let (f, tau) = loads.wrench_on(i, t_secs, &unit);
    (dq, dm + tau, *v, loads.gravity() + f / bodies.mass[i])
}

/// One RK4 step of a loaded body from `y` at `t_secs`.
fn rk4_forced(loads: &Loads, bodies: &Bodies, i: usize, t_secs: f64, h: f64, y: Forced) -> Forced {
    let add = |y: &Forced, k: &Forced, s: f64| -> Forced {
        (y.0 + k.0 * s, y.1 + k.1 * s, y.2 + k.2 * s, y.3 + k.3 * s)
    };
    let k1 = forced_rate(loads, bodies, i, t_secs, &y);
    let k2 = forced_rate(loads, bodies, i, t_secs + 0.5 * h, &add(&y, &k1, 0.5 * h));
    let k3 = forced_rate(loads, bodies, i, t_secs + 0.5 * h, &add(&y, &k2, 0.5 * h));
    let k4 = forced_rate(loads, bodies, i, t_secs + h, &add(&y, &k3, h));
    let sum = (
        k1.0 + k2.0 * 2.0 + k3.0 * 2.0 + k4.0,
        k1.1 + k2.1 * 2.0 + k3.1 * 2.0 + k4.1,
        k1.2 + k2.2 * 2.0 + k3.2 * 2.0 + k4.2,
        k1.3 + k2.3 * 2.0 + k3.3 * 2.0 + k4.3,
    );
    add(&y, &sum, h / 6.0)
}

/// Classic RK4 over a batch. Order 4.
#[derive(Debug, Clone)]
pub struct Rk4 {
    dt_secs: f64,
    /// The work of the applied loads (trapezoid rule over each step, [`KickLedger`]).
    ledger: KickLedger,
    /// The loaded bodies' end states of the step being taken (reused: no allocation per step).
    forced: Vec<(usize, Forced)>,
}

impl Rk4 {
    pub fn new(dt_secs: f64) -> Self {
        Self {
            dt_secs,
            ledger: KickLedger::default(),
            forced: Vec::new(),
        }
    }
}

impl Integrator for Rk4 {
    fn name(&self) -> &'static str {
        "rk4"
    }

    fn dt(&self) -> f64 {
        self.dt_secs
    }

    fn init(&mut self, _bodies: &Bodies) {}

    fn step(&mut self, bodies: &mut Bodies, loads: &Loads) -> StepStats {
        let h = self.dt_secs;
        let all = 0..bodies.len();
        if loads.loads_any(&all) {
            let t0 = loads.time_secs();
            // Kicks of zero size record the loaded bodies' poses and wrenches for the work.
            self.ledger.begin();
            loads.kick(bodies, &all, t0, 0.0, &mut self.ledger);
            let mut forced = std::mem::take(&mut self.forced);
            forced.clear();
            forced.extend(loads.loaded_bodies(&all).map(|i| {
                let y = (
                    *bodies.world_from_body[i].quaternion(),
                    bodies.angmom_body[i],
                    bodies.com_world[i],
                    bodies.linvel_world[i],
                );
                (i, rk4_forced(loads, bodies, i, t0, h, y))
            }));
            self.step_unforced(bodies, loads);
            for &(i, (q, m, c, v)) in &forced {
                bodies.world_from_body[i] = UnitQuaternion::new_normalize(q);
                bodies.angmom_body[i] = m;
                bodies.com_world[i] = c;
                bodies.linvel_world[i] = v;
            }
            self.forced = forced;
            self.ledger.end();
            loads.kick(bodies, &all, t0 + h, 0.0, &mut self.ledger);
            return StepStats::default();
        }
        self.step_unforced(bodies, loads);
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

impl Rk4 {
    /// Every body's step without applied loads.
    fn step_unforced(&self, bodies: &mut Bodies, loads: &Loads) {
        let h = self.dt_secs;
        for i in 0..bodies.len() {
            let (q, m) = rk4_rotation(
                &bodies.inv_inertia_body[i],
                bodies.world_from_body[i].quaternion(),
                &bodies.angmom_body[i],
                h,
            );
            bodies.world_from_body[i] = UnitQuaternion::new_normalize(q);
            bodies.angmom_body[i] = m;
        }
        // RK4 on c'' = g is exactly c += h v + h^2 g/2, v += h g (see the module docs).
        step_translation(
            &mut bodies.com_world,
            &mut bodies.linvel_world,
            h,
            loads,
            Potential::Symmetric,
        );
    }
}
