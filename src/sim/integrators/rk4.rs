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

use super::translation::{Potential, step_translation};
use super::{Integrator, StepStats};
use crate::sim::Bodies;
use crate::sim::loads::Loads;
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

/// Classic RK4 over a batch. Order 4.
#[derive(Debug, Clone)]
pub struct Rk4 {
    dt_secs: f64,
}

impl Rk4 {
    pub fn new(dt_secs: f64) -> Self {
        Self { dt_secs }
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
        StepStats::default()
    }
}
