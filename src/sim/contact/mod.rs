//! Contact: bodies touching a ground half-space and each other (issue 31).
//!
//! What a scene asks for arrives as a [`ContactModel`]: the [`Ground`] (a half-space) and the
//! [`Collider`]s, convex shapes fixed in bodies' principal frames. Every step, before the
//! integrators step the bodies, the contact phase ([`phase::ContactPhase`]) finds the contacts
//! at the state `q_k` (a broad phase over bounding spheres, parry3d-f64's contact manifolds),
//! solves for the impulses that keep every gap non-negative at `q_{k+1}` under Coulomb's
//! friction cone, and applies them as the start impulse `f_d⁻` of the discrete
//! Lagrange-d'Alembert principle (`docs/contact.md` derives the scheme and justifies it).
//!
//! A body of an articulated mechanism answers an impulse through its joints: the mechanisms
//! with colliders are [`robots::Robot`]s, whose response and predicted motion the phase reads
//! from the mechanism's own step.
//!
//! `sim/` knows no URDF: the shapes, frictions and pairs that never collide are decided by
//! `scene/` and handed over here as plain data.

pub mod broad;
pub mod islands;
pub mod narrow;
pub mod phase;
pub mod robots;
pub mod shape;
pub mod solve;

use nalgebra::{Isometry3, Unit, Vector3};
pub use phase::ContactPhase;
pub use shape::Shape;

/// The ground: the half-space `{x : n · (x − point) ≤ 0}` (bodies stay on the side `n` points
/// to).
#[derive(Debug, Clone, PartialEq)]
pub struct Ground {
    /// Unit outward normal `n` (for a level ground: `−g / |g|`).
    pub normal: Unit<Vector3<f64>>,
    /// A point of the ground's surface, m.
    pub point: Vector3<f64>,
    /// Coulomb coefficient `μ ≥ 0`.
    pub friction: f64,
    /// Newton's coefficient of restitution `e ∈ [0, 1]`.
    pub restitution: f64,
}

impl Ground {
    /// Signed distance of `x` above the surface, m.
    pub fn height_of(&self, x: &Vector3<f64>) -> f64 {
        self.normal.dot(&(x - self.point))
    }
}

/// A convex shape fixed in a body's principal frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Collider {
    /// Batch index of the body it rides on.
    pub body: usize,
    /// The shape's pose in the body's principal frame.
    pub body_from_shape: Isometry3<f64>,
    pub shape: Shape,
    /// Coulomb coefficient `μ ≥ 0`; a pair takes the smaller of its two ([`combine_friction`]).
    pub friction: f64,
    /// Restitution `e ∈ [0, 1]`; a pair takes the larger of its two ([`combine_restitution`]).
    pub restitution: f64,
    /// Which model copy the collider belongs to: colliders of one group collide with each other
    /// only when [`Collider::self_collision`] is set, and never on the same body or on a pair
    /// listed in [`ContactModel::excluded_body_pairs`].
    pub group: u32,
    /// The model's `self_collision`.
    pub self_collision: bool,
}

/// The pair's friction: the smaller of the two coefficients (the slipperier surface decides;
/// a default of 0.8 on models never raises a ground's 0.3).
pub fn combine_friction(a: f64, b: f64) -> f64 {
    a.min(b)
}

/// The pair's restitution: the larger of the two (a bouncy ground makes everything dropped on it
/// bounce, models default to 0).
pub fn combine_restitution(a: f64, b: f64) -> f64 {
    a.max(b)
}

/// Everything a scene says about contact.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactModel {
    pub ground: Option<Ground>,
    /// Sorted by body.
    pub colliders: Vec<Collider>,
    /// Body pairs `(a, b)`, `a < b`, that never collide (a joint's parent and child), sorted.
    pub excluded_body_pairs: Vec<(usize, usize)>,
}

impl ContactModel {
    /// Whether anything can touch anything: a ground or two colliders.
    pub fn is_active(&self) -> bool {
        !self.colliders.is_empty() && (self.ground.is_some() || self.colliders.len() > 1)
    }

    /// Whether two colliders may touch: not on one body, not on an excluded pair, and within
    /// one group only with self-collision.
    pub fn may_touch(&self, a: &Collider, b: &Collider) -> bool {
        if a.body == b.body {
            return false;
        }
        if a.group == b.group && !(a.self_collision && b.self_collision) {
            return false;
        }
        let pair = (a.body.min(b.body), a.body.max(b.body));
        self.excluded_body_pairs.binary_search(&pair).is_err()
    }
}

/// Whom a contact is with.
pub const GROUND: u32 = u32::MAX;

/// One contact point of a step: what the recordings show.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactPoint {
    /// Batch index of the body the impulse acts on.
    pub body_a: u32,
    /// The other body, or [`GROUND`].
    pub body_b: u32,
    /// The contact point (on `b`'s surface), world, m.
    pub point_world: Vector3<f64>,
    /// Unit normal from `b` toward `a`, world.
    pub normal_world: Vector3<f64>,
    /// Impulse on `a` over the step (`b` gets its opposite), world, N s.
    pub impulse_world: Vector3<f64>,
    /// Signed gap at the start of the step, m (negative: penetration).
    pub gap_m: f64,
}

#[cfg(test)]
mod tests;
