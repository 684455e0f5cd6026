//! Solutions used to measure integration error: closed forms where they exist, a numerical
//! reference with its own error estimate where they do not.
//!
//! - [`Axisymmetric`]: orientation of a torque-free body with two equal moments (closed form).
//! - [`Asymmetric`]: body angular velocity of a torque-free body with distinct moments (Jacobi
//!   elliptic functions, [`elliptic`]).
//! - [`high_accuracy()`]: orientation and momentum of any free body by a fine integration, with a
//!   Richardson estimate of its own error.
//! - [`TorqueFree`]: orientation of any torque-free body (the two closed forms above, plus one
//!   quadrature for the precession angle of the asymmetric body).
//! - [`parabola`]: the centre of mass in uniform gravity.

pub mod asymmetric;
pub mod elliptic;
pub mod high_accuracy;
pub mod quadrature;
pub mod torque_free;

pub use asymmetric::Asymmetric;
pub use high_accuracy::{HighAccuracy, high_accuracy};
pub use torque_free::TorqueFree;

use crate::sim::loads::Loads;
use nalgebra::{UnitQuaternion, Vector3};

/// Torque-free axisymmetric body: principal moments `(ip, ip, i3)`, initial orientation
/// `world_from_body_0` and body angular velocity `omega_body_0`.
///
/// `R(t) = exp(t (L/ip)^) R0 exp(t c e3^)`, with the spatial angular momentum
/// `L = R0 J Ω0` and `c = Ω3 (1 - i3/ip)` (Landau & Lifshitz, Mechanics, §33: the symmetry axis
/// precesses about `L` at `|L|/ip` while the body spins about it at `c` relative to the precession).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Axisymmetric {
    pub ip: f64,
    pub i3: f64,
    pub world_from_body_0: UnitQuaternion<f64>,
    pub omega_body_0: Vector3<f64>,
}

impl Axisymmetric {
    /// Spatial angular momentum `L = R0 J Ω0`.
    pub fn angmom_world(&self) -> Vector3<f64> {
        let j = Vector3::new(self.ip, self.ip, self.i3);
        self.world_from_body_0 * j.component_mul(&self.omega_body_0)
    }

    /// Orientation `world_from_body` at time `t_secs`.
    pub fn orientation(&self, t_secs: f64) -> UnitQuaternion<f64> {
        let l = self.angmom_world();
        let c = self.omega_body_0.z * (1.0 - self.i3 / self.ip);
        let precession = UnitQuaternion::from_scaled_axis(l * (t_secs / self.ip));
        let spin = UnitQuaternion::from_scaled_axis(Vector3::z() * (c * t_secs));
        precession * self.world_from_body_0 * spin
    }

    /// Rotational kinetic energy (constant).
    pub fn energy(&self) -> f64 {
        let j = Vector3::new(self.ip, self.ip, self.i3);
        0.5 * j.component_mul(&self.omega_body_0).dot(&self.omega_body_0)
    }
}
/// Uniform gravity `g` (`loads.gravity()`): `c(t) = c0 + v0 t + g t^2 / 2`, `v(t) = v0 + g t`.
/// Uniform gravity: `c(t) = c0 + v0 t + g t^2 / 2`, `v(t) = v0 + g t`.
pub fn parabola(
    c0: &Vector3<f64>,
    v0: &Vector3<f64>,
    loads: &Loads,
    t_secs: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    (
        c0 + v0 * t_secs + loads.gravity() * (0.5 * t_secs * t_secs),
        v0 + loads.gravity() * t_secs,
    )
}

/// The angle of the rotation taking `a` to `b`, rad (geodesic distance on SO(3)).
pub fn rotation_error(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    a.angle_to(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed form satisfies Euler's equations: its angular momentum in the world is
    /// constant (checked through `R(t) J Ω(t)` with Ω from a central difference of R).
    #[test]
    fn axisymmetric_closed_form_conserves_spatial_momentum() {
        let r = Axisymmetric {
            ip: 2.0,
            i3: 0.5,
            world_from_body_0: UnitQuaternion::from_euler_angles(0.3, -0.2, 1.0),
            omega_body_0: Vector3::new(0.7, -0.4, 3.0),
        };
        let l = r.angmom_world();
        let j = Vector3::new(r.ip, r.ip, r.i3);
        for t in [0.0, 0.37, 1.9, 7.3] {
            let eps = 1e-6;
            let dq = r.orientation(t).inverse() * r.orientation(t + eps);
            let dq0 = r.orientation(t - eps).inverse() * r.orientation(t);
            let omega_body = (dq.scaled_axis() + dq0.scaled_axis()) / (2.0 * eps);
            let l_t = r.orientation(t) * j.component_mul(&omega_body);
            // Finite-difference error O(eps^2 |Ω|^3) + round-off 1e-16/1e-6: measured ~2e-10.
            assert!((l_t - l).norm() < 1e-8 * l.norm(), "t = {t}: {l_t} vs {l}");
        }
    }
}
