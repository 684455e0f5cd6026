//! The orientation reference of `tumble trade`: every body's orientation at the end of the
//! measurement horizon, with an estimate of the reference's own error.
//!
//! Uniform gravity exerts no torque about the centre of mass, so each body's rotation is a
//! torque-free free-body motion, independent of its translation (whose reference is the exact
//! parabola). No closed form gives the orientation of an asymmetric body, so the reference
//! integrates it at a step far below the measured ones and estimates its own error by Richardson
//! extrapolation: for a method of order p, `err(h) ≈ |x(h) - x(h/2)| · 2^p / (2^p - 1)`.

use crate::sim::integrators::VariationalSettings;
use crate::sim::{Bodies, BodyInit, IntegratorKind};
use nalgebra::{UnitQuaternion, Vector3};

pub use crate::sim::reference::rotation_error;

/// Orientations at the end of the horizon.
#[derive(Debug, Clone, PartialEq)]
pub struct Reference {
    /// Per body, at `t_end_secs`.
    pub world_from_body: Vec<UnitQuaternion<f64>>,
    pub t_end_secs: f64,
    /// Estimated error of the reference itself (largest over bodies), rad.
    pub own_error_rad: f64,
    /// How it was computed, in words.
    pub method: String,
}

/// Step of the reference's finer run, s.
pub const REFERENCE_DT: f64 = 1e-5;

impl Reference {
    /// Integrates every body's rotation to `t_end_secs` (gravity off: it does not turn bodies).
    pub fn compute(init: &[BodyInit], t_end_secs: f64) -> Self {
        let kind = IntegratorKind::Variational;
        let order = 2;
        let settings = VariationalSettings {
            newton_tol: 1e-15,
            newton_max_iters: 50,
            ..Default::default()
        };
        let run = |dt: f64| -> Vec<UnitQuaternion<f64>> {
            let mut bodies = Bodies::new(init);
            let mut integrator = kind.build(dt, &settings);
            integrator.init(&bodies);
            let steps = (t_end_secs / dt).round() as u64;
            for _ in 0..steps {
                integrator.step(&mut bodies, &Vector3::zeros());
            }
            bodies.world_from_body
        };
        let coarse = run(2.0 * REFERENCE_DT);
        let fine = run(REFERENCE_DT);
        let factor = f64::from(1u32 << order);
        let own_error_rad = coarse
            .iter()
            .zip(&fine)
            .map(|(c, f)| rotation_error(c, f) / (factor - 1.0))
            .fold(0.0, f64::max);
        Self {
            world_from_body: fine,
            t_end_secs,
            own_error_rad,
            method: format!(
                "{} at dt = {REFERENCE_DT:e} s, error estimated against dt = {:e} s (Richardson, order {order})",
                kind.name(),
                2.0 * REFERENCE_DT
            ),
        }
    }
}
