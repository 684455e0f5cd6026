//! The orientation reference of `tumble trade`: every body's orientation at the end of the
//! measurement horizon, with an estimate of the reference's own error.
//!
//! Uniform gravity exerts no torque about the centre of mass, so each body's rotation is a
//! torque-free free-body motion, independent of its translation (whose reference is the exact
//! parabola). No closed form gives the orientation of an asymmetric body, so the reference
//! integrates it at a step far below the measured ones and estimates its own error by Richardson
//! extrapolation ([`high_accuracy`]): for a method of order p, `err(h/2) ≈ |x(h) - x(h/2)| / (2^p - 1)`.

use crate::sim::reference::high_accuracy;
use crate::sim::{BodyInit, IntegratorKind};
use nalgebra::{UnitQuaternion, Vector3};

pub use crate::sim::reference::rotation_error;

/// Orientations at the end of the horizon.
#[derive(Debug, Clone, PartialEq)]
pub struct Reference {
    /// Per body, at `t_end_secs`.
    pub world_from_body: Vec<UnitQuaternion<f64>>,
    /// Per body, the centre of mass at `t_end_secs`, m: `None` for free bodies, whose exact
    /// parabola is the reference ([`crate::trade::measure`]); set on articulated scenes
    /// ([`crate::trade::articulated::reference`]).
    pub com_world: Option<Vec<Vector3<f64>>>,
    pub t_end_secs: f64,
    /// Estimated error of the reference itself (largest over bodies), rad.
    pub own_error_rad: f64,
    /// Estimated error of `com_world` (largest over bodies), m; 0 for the exact parabola.
    pub own_error_m: f64,
    /// How it was computed, in words.
    pub method: String,
}

/// Coarse step of the reference in radians turned per step (`dt |Ω|`); the finer run halves it.
pub const REFERENCE_TURN_PER_STEP: f64 = 1e-3;

impl Reference {
    /// Every body's torque-free orientation at `t_end_secs` by [`high_accuracy`] with `rk4`
    /// (which shares no code with the variational family) at `dt |Ω0| = 1e-3` and half that.
    pub fn compute(init: &[BodyInit], t_end_secs: f64) -> Self {
        let kind = IntegratorKind::Rk4;
        let mut own_error_rad: f64 = 0.0;
        let mut dt_min = f64::INFINITY;
        let world_from_body = init
            .iter()
            .map(|b| {
                let speed = b.angvel_world.norm();
                let dt = if speed > 0.0 {
                    REFERENCE_TURN_PER_STEP / speed
                } else {
                    t_end_secs.max(1e-3)
                };
                let r = high_accuracy(b, t_end_secs, dt.min(t_end_secs.max(1e-9)), kind);
                own_error_rad = own_error_rad.max(r.rotation_error_estimate);
                dt_min = dt_min.min(r.dt_secs);
                r.world_from_body
            })
            .collect();
        Self {
            world_from_body,
            com_world: None,
            t_end_secs,
            own_error_rad,
            own_error_m: 0.0,
            method: format!(
                "{} at dt |Ω0| = {REFERENCE_TURN_PER_STEP:e} rad and half that (finest dt {dt_min:.2e} s), Richardson error estimate",
                kind.name()
            ),
        }
    }
}
