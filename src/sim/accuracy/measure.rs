//! The achieved orientation error of one body, against its exact torque-free motion
//! ([`TorqueFree`]): what the error model ([`super::model`]) is fitted to and validated on, and
//! what `tests/integrator/accuracy.rs` checks the chosen substep factors with.

use super::substeps::Substepped;
use crate::sim::integrators::VariationalSettings;
use crate::sim::loads::Loads;
use crate::sim::reference::TorqueFree;
use crate::sim::{Bodies, BodyInit, Integrator, IntegratorKind};

/// Orientation samples taken over a run (at least; every step when the run is shorter).
pub const SAMPLES: u64 = 256;

/// The largest angle (rad) between `init`'s orientation stepped by `kind` with `k` substeps of
/// `dt_secs / k` per step and the exact one, over `steps` steps, sampled at about [`SAMPLES`]
/// evenly spaced steps and the last. `None` when the exact motion is not available (an orbit
/// within 1e-14 of the separatrix, [`TorqueFree::new`]).
pub fn achieved_error(
    kind: IntegratorKind,
    settings: &VariationalSettings,
    init: &BodyInit,
    dt_secs: f64,
    k: u32,
    steps: u64,
) -> Option<f64> {
    let exact = TorqueFree::new(init)?;
    let mut bodies = Bodies::new(std::slice::from_ref(init));
    let mut integrator = Substepped::uniform(kind, dt_secs, k, settings);
    integrator.init(&bodies);
    let every = (steps / SAMPLES).max(1);
    let mut worst: f64 = 0.0;
    for s in 1..=steps {
        integrator.step(&mut bodies, &Loads::none());
        if s % every == 0 || s == steps {
            let t = s as f64 * dt_secs;
            worst = worst.max(bodies.world_from_body[0].angle_to(&exact.orientation(t)));
        }
    }
    Some(worst)
}
