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
/// A partition stepping bodies `range` of the batch gets its own `Loads` for its local body
/// indices from [`Loads::part`] (as [`crate::sim::partition::rebase`] re-bases mechanisms):
/// per-body fields can be shared (`Arc`) with the range kept in the view, so that a partition's
/// view costs no copy of the data; with gravity only, it is a copy of `g`. The type is
/// deliberately not `Copy`, so that fields holding per-body data can be added.
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

    /// The loads of the bodies `_range` of the batch, indexed from `range.start` (a partition's
    /// view). Uniform gravity is the same for every part.
    pub fn part(&self, _range: std::ops::Range<usize>) -> Self {
        self.clone()
    }
}

impl Default for Loads {
    /// [`Loads::none`].
    fn default() -> Self {
        Self::none()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_gravity_is_read_back_and_the_same_in_every_part() {
        let g = Vector3::new(0.5, -1.0, -9.81);
        let loads = Loads::uniform_gravity(g);
        assert_eq!(*loads.gravity(), g);
        assert_eq!(loads.part(3..7), loads);
        assert_eq!(*Loads::default().gravity(), Vector3::zeros());
        assert_eq!(Loads::none(), Loads::default());
    }
}
