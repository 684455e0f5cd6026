//! What acts on the bodies during a step: [`Loads`].

use nalgebra::Vector3;

/// The loads acting on a batch of bodies during a step, passed as `&Loads` to every integrator
/// ([`crate::sim::Integrator::step`]), mechanism step, reference and energy in `sim/`.
///
/// Today it holds uniform gravity only ([`Loads::uniform_gravity`], read with
/// [`Loads::gravity`]): every body gets the force `m g` at its centre of mass, and the
/// potential energy `V = -m g · c`.
///
/// How it grows (the next issue), without changing any signature that takes `&Loads`:
/// - applied forces and torques per body of the batch (world frame, indexed like
///   [`crate::sim::Bodies`]), as fields beside `gravity`;
/// - joint efforts per mechanism coordinate (indexed like a mechanism's coordinates);
/// - loads that depend on time: a field holding a schedule, read at the step's time.
///
/// A partition stepping bodies `first..first + n` of the batch gets its own `Loads` for its
/// local body indices (a view re-based like [`crate::sim::partition::rebase`] re-bases
/// mechanisms); with gravity only, that is a copy. The type is deliberately not `Copy`, so that
/// fields holding per-body data can be added.
#[derive(Debug, Clone, PartialEq)]
pub struct Loads {
    /// Uniform gravitational acceleration, world frame, m/s².
    gravity: Vector3<f64>,
}

impl Loads {
    /// Uniform gravity `g` (m/s², world frame) and nothing else.
    pub fn uniform_gravity(gravity: Vector3<f64>) -> Self {
        Self { gravity }
    }

    /// No loads: zero gravity (torque-free, force-free motion).
    pub fn none() -> Self {
        Self::uniform_gravity(Vector3::zeros())
    }

    /// The uniform gravitational acceleration `g`, m/s², world frame.
    #[inline(always)]
    pub fn gravity(&self) -> &Vector3<f64> {
        &self.gravity
    }
}

impl Default for Loads {
    /// [`Loads::none`].
    fn default() -> Self {
        Self::none()
    }
}
