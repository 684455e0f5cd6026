//! The orientation of any torque-free rigid body in closed form (plus one quadrature): the exact
//! reference of the accuracy model ([`crate::sim::accuracy`]).
//!
//! - Isotropic body (three equal moments): `R(t) = exp(t ω^) R_0`.
//! - Two equal moments: [`Axisymmetric`], after a cyclic relabelling of the axes that puts the
//!   odd moment last (a cyclic permutation is a proper rotation).
//! - Three distinct moments: the angular velocity `Ω(t)` is Jacobi elliptic ([`Asymmetric`]);
//!   the orientation follows from it (Landau & Lifshitz, *Mechanics*, §37). Label the body axes
//!   `(a, b, c)` cyclically with `c` the axis the angular momentum circles
//!   ([`Asymmetric::circled_axis`]), and take the world `Z` axis along the conserved spatial
//!   momentum `π`. With ZXZ Euler angles, `R = W Rz(φ) Rx(θ) Rz(ψ) P`, where `P` maps body
//!   coordinates to `(a, b, c)` and `W` is constant, the body-frame unit momentum is
//!   `M/|M| = (sin θ sin ψ, sin θ cos ψ, cos θ)`, so `θ(t)` and `ψ(t)` are read off `M(t) = J Ω(t)`;
//!   the body angular velocity of ZXZ angles, `Ω_a = φ' sin θ sin ψ + θ' cos ψ`,
//!   `Ω_b = φ' sin θ cos ψ - θ' sin ψ`, gives `Ω_a sin ψ + Ω_b cos ψ = φ' sin θ`, i.e.
//!
//!   `φ' = |M| (Ω_a M_a + Ω_b M_b) / (M_a^2 + M_b^2)`,
//!
//!   a smooth periodic function of time (period `4K/λ`, that of `Ω`), integrated by adaptive
//!   Gauss–Legendre quadrature ([`super::quadrature`]) over one period once, then over the
//!   remainder of `t`. `W = R_0 P^T (Rx(θ_0) Rz(ψ_0))^T` makes `φ(0) = 0`.
//!
//! Accuracy: the elliptic functions to a few ulp, `φ` to 1e-15 relative per period, so the
//! orientation is good to about `1e-15 (1 + t/period)` rad (`tests/integrator/accuracy.rs` checks it against
//! [`super::high_accuracy`] and by finite differences). Orbits within `1e-14` of the separatrix
//! are refused by [`Asymmetric::new`]; [`TorqueFree::new`] then returns `None`.

use super::quadrature::integrate;
use super::{Asymmetric, Axisymmetric};
use crate::sim::BodyInit;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// The exact torque-free rotation of one body.
#[derive(Debug, Clone, PartialEq)]
pub enum TorqueFree {
    Isotropic {
        world_from_body_0: UnitQuaternion<f64>,
        angvel_world: Vector3<f64>,
    },
    Axisymmetric {
        motion: Axisymmetric,
        /// Body coordinates to the relabelled ones (odd moment last).
        perm_from_body: UnitQuaternion<f64>,
    },
    Asymmetric(AsymmetricOrientation),
}

/// Moments equal within this relative difference are treated as equal.
const EQUAL_MOMENTS: f64 = 1e-12;

/// The proper rotation taking body axis `(c + 1) % 3` to x, `(c + 2) % 3` to y and `c` to z.
fn cyclic_to_z(c: usize) -> UnitQuaternion<f64> {
    let a = (c + 1) % 3;
    let b = (c + 2) % 3;
    let rows = Matrix3::from_rows(&[
        Vector3::ith(a, 1.0).transpose(),
        Vector3::ith(b, 1.0).transpose(),
        Vector3::ith(c, 1.0).transpose(),
    ]);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(rows))
}

impl TorqueFree {
    /// The exact motion of `init`'s rotation (translation is ignored: uniform gravity exerts no
    /// torque about the centre of mass). `None` only for asymmetric bodies within `1e-14` of
    /// the separatrix (the intermediate-axis spin and the orbits through it).
    pub fn new(init: &BodyInit) -> Option<Self> {
        let j = init.principal_moments;
        let q0 = init.world_from_body.rotation;
        let omega_body = q0.inverse_transform_vector(&init.angvel_world);
        let close = |x: f64, y: f64| (x - y).abs() <= EQUAL_MOMENTS * j.max();
        let equal = [close(j[1], j[2]), close(j[2], j[0]), close(j[0], j[1])];
        if equal.iter().all(|&e| e) || omega_body == Vector3::zeros() {
            return Some(Self::Isotropic {
                world_from_body_0: q0,
                angvel_world: init.angvel_world,
            });
        }
        // `equal[c]`: the two moments other than `c` are equal, so `c` is the odd axis.
        if let Some(c) = equal.iter().position(|&e| e) {
            let perm_from_body = cyclic_to_z(c);
            let omega_perm = perm_from_body * omega_body;
            let ip = 0.5 * (j[(c + 1) % 3] + j[(c + 2) % 3]);
            return Some(Self::Axisymmetric {
                motion: Axisymmetric {
                    ip,
                    i3: j[c],
                    world_from_body_0: q0 * perm_from_body.inverse(),
                    omega_body_0: omega_perm,
                },
                perm_from_body,
            });
        }
        AsymmetricOrientation::new(j, q0, omega_body).map(Self::Asymmetric)
    }

    /// Orientation `world_from_body` at `t_secs >= 0`.
    pub fn orientation(&self, t_secs: f64) -> UnitQuaternion<f64> {
        match self {
            Self::Isotropic {
                world_from_body_0,
                angvel_world,
            } => UnitQuaternion::from_scaled_axis(angvel_world * t_secs) * world_from_body_0,
            Self::Axisymmetric {
                motion,
                perm_from_body,
            } => motion.orientation(t_secs) * perm_from_body,
            Self::Asymmetric(a) => a.orientation(t_secs),
        }
    }
}

/// The orientation of a torque-free body with three distinct moments (see the module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct AsymmetricOrientation {
    motion: Asymmetric,
    moments: Vector3<f64>,
    /// `P`: body coordinates to `(a, b, c)`.
    abc_from_body: UnitQuaternion<f64>,
    /// `W`: constant, `W e_Z = π / |π|`.
    world_from_z: UnitQuaternion<f64>,
    /// `|M|`, kg m^2/s.
    angmom: f64,
    /// The period of `Ω`, s, and `φ` gained over one period, rad (computed when first needed).
    period_secs: f64,
    phi_per_period: std::sync::OnceLock<f64>,
}

impl AsymmetricOrientation {
    /// `None` on the separatrix (see [`Asymmetric::new`]).
    pub fn new(
        moments: Vector3<f64>,
        world_from_body_0: UnitQuaternion<f64>,
        omega_body_0: Vector3<f64>,
    ) -> Option<Self> {
        let motion = Asymmetric::new(moments, omega_body_0)?;
        let abc_from_body = cyclic_to_z(motion.circled_axis());
        let m0 = moments.component_mul(&omega_body_0);
        let angmom = m0.norm();
        let (theta, psi) = theta_psi(&(abc_from_body * m0));
        let e0 = euler_zxz(0.0, theta, psi);
        Some(Self {
            motion,
            moments,
            abc_from_body,
            world_from_z: world_from_body_0 * abc_from_body.inverse() * e0.inverse(),
            angmom,
            period_secs: motion.period_secs(),
            phi_per_period: std::sync::OnceLock::new(),
        })
    }

    /// `φ'(t)`, rad/s (module doc).
    fn phi_rate(&self, t_secs: f64) -> f64 {
        let omega_body = self.motion.angvel_body(t_secs);
        let omega = self.abc_from_body * omega_body;
        let m = self.abc_from_body * self.moments.component_mul(&omega_body);
        let transverse = m.x * m.x + m.y * m.y;
        if transverse == 0.0 {
            // A steady spin about `c`: φ' = Ω_c sign(M_c) = |Ω|.
            return omega.z * m.z.signum();
        }
        self.angmom * (omega.x * m.x + omega.y * m.y) / transverse
    }

    fn phi_between(&self, a: f64, b: f64) -> f64 {
        // φ' is at most |M| / J_min: 1e-15 of that over the interval.
        let scale = self.angmom / self.moments.min() * (b - a).abs();
        integrate(&|t| self.phi_rate(t), a, b, 1e-15 * scale)
    }

    /// `φ(t)`, rad.
    fn phi(&self, t_secs: f64) -> f64 {
        let periods = (t_secs / self.period_secs).floor();
        if periods == 0.0 {
            return self.phi_between(0.0, t_secs);
        }
        let rest = t_secs - periods * self.period_secs;
        let per_period = *self
            .phi_per_period
            .get_or_init(|| self.phi_between(0.0, self.period_secs));
        periods * per_period + self.phi_between(0.0, rest)
    }

    /// Orientation `world_from_body` at `t_secs >= 0`.
    pub fn orientation(&self, t_secs: f64) -> UnitQuaternion<f64> {
        let m = self.abc_from_body * self.moments.component_mul(&self.motion.angvel_body(t_secs));
        let (theta, psi) = theta_psi(&m);
        self.world_from_z * euler_zxz(self.phi(t_secs), theta, psi) * self.abc_from_body
    }

    /// Body angular momentum `M(t)`, kg m^2/s.
    pub fn angmom_body(&self, t_secs: f64) -> Vector3<f64> {
        self.motion.angmom_body(t_secs)
    }
}

/// `(θ, ψ)` with `m / |m| = (sin θ sin ψ, sin θ cos ψ, cos θ)`.
fn theta_psi(m: &Vector3<f64>) -> (f64, f64) {
    (m.x.hypot(m.y).atan2(m.z), m.x.atan2(m.y))
}

/// `Rz(φ) Rx(θ) Rz(ψ)`.
fn euler_zxz(phi: f64, theta: f64, psi: f64) -> UnitQuaternion<f64> {
    let z = Vector3::z_axis();
    let x = Vector3::x_axis();
    UnitQuaternion::from_axis_angle(&z, phi)
        * UnitQuaternion::from_axis_angle(&x, theta)
        * UnitQuaternion::from_axis_angle(&z, psi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::IntegratorKind;
    use crate::sim::reference::high_accuracy;
    use nalgebra::Isometry3;

    fn init(moments: Vector3<f64>, q0: UnitQuaternion<f64>, omega_body: Vector3<f64>) -> BodyInit {
        BodyInit {
            mass: 1.0,
            principal_moments: moments,
            world_from_body: Isometry3::from_parts(Default::default(), q0),
            linvel_world: Vector3::zeros(),
            angvel_world: q0 * omega_body,
        }
    }

    /// Bodies of every kind: isotropic, axisymmetric with the odd axis in each place,
    /// asymmetric on both sides of the separatrix, near it, near a steady spin, and a rod.
    fn cases() -> Vec<BodyInit> {
        let q0 = UnitQuaternion::from_euler_angles(0.3, -1.1, 2.0);
        let mut v = Vec::new();
        for (j, w) in [
            ((2.0, 2.0, 2.0), (0.3, -1.0, 0.7)),
            ((1.0, 2.0, 2.0), (1.5, 0.4, -0.3)),
            ((2.0, 1.0, 2.0), (1.5, 0.4, -0.3)),
            ((2.0, 2.0, 0.5), (0.4, -0.2, 3.0)),
            ((1.0, 2.0, 3.0), (0.3, 0.8, 2.0)),
            ((1.0, 2.0, 3.0), (-2.0, 0.5, -0.4)),
            ((3.0, 1.0, 2.0), (0.05, 0.03, 3.0)),
            ((1.0, 2.0, 3.0), (0.01, 1.0, 0.01)),
            ((1.0, 2.0, 3.0), (1e-6, 1e-6, 1.0)),
            ((1e-3, 0.9995, 1.0), (0.5, 0.002, 0.001)),
        ] {
            v.push(init(
                Vector3::new(j.0, j.1, j.2),
                q0,
                Vector3::new(w.0, w.1, w.2),
            ));
        }
        v
    }

    fn omega_body_of(b: &BodyInit) -> Vector3<f64> {
        b.world_from_body
            .rotation
            .inverse_transform_vector(&b.angvel_world)
    }

    /// `R(0) = R_0`; `R(t) J Ω(t)` stays the initial spatial momentum; the body angular velocity
    /// `(R^T R')^∨` by central differences of `R(t)` is `J^-1 M(t)`, with `M(t)` from `R(t)^T π`.
    #[test]
    fn orientation_solves_the_kinematics() {
        for b in cases() {
            let r = TorqueFree::new(&b).unwrap();
            let q0 = b.world_from_body.rotation;
            // Measured ≤ 3e-16.
            assert!(r.orientation(0.0).angle_to(&q0) < 1e-14, "{b:?}");
            let j = b.principal_moments;
            let pi = q0 * j.component_mul(&omega_body_of(&b));
            for t in [0.37, 1.9, 7.3, 55.0] {
                let q = r.orientation(t);
                let eps = 1e-5;
                let dq = r.orientation(t - eps).inverse() * r.orientation(t + eps);
                let omega_fd = dq.scaled_axis() / (2.0 * eps);
                let omega = (q.inverse() * pi).component_div(&j);
                // Central differences: O(eps^2 |Ω|^3) plus 1e-16 / eps; measured ≤ 2e-9 |Ω|
                // (the rod spins at 500 rad/s about its axis).
                assert!(
                    (omega_fd - omega).norm() < 1e-7 * omega.norm().max(1.0),
                    "{b:?} t = {t}: {omega_fd} vs {omega}"
                );
            }
        }
    }

    /// Against an independent numerical reference (`rk4`, Richardson estimate), at 20 s.
    /// Measured ≤ 1.6e-13 rad for every case but the one near the separatrix, `J = (3, 1, 2)`,
    /// `Ω ≈ 3 rad/s` about the intermediate axis, `(L^2 - 2 E J_mid) / L^2 = 1.8e-4`: 1.9e-11
    /// rad, where `rk4` and `variational6` at `h|Ω| = 1e-3` disagree by 5.9e-11 between
    /// themselves (the orbit amplifies round-off: its period depends on the energy like
    /// `log(1 / (1 - m))`).
    #[test]
    fn orientation_matches_high_accuracy() {
        for b in cases() {
            let r = TorqueFree::new(&b).unwrap();
            let speed = b.angvel_world.norm();
            let ha = high_accuracy(&b, 20.0, 2e-3 / speed, IntegratorKind::Rk4);
            let err = r.orientation(20.0).angle_to(&ha.world_from_body);
            assert!(
                err < 1e-10,
                "{b:?}: {err:e} (estimate {:e})",
                ha.rotation_error_estimate
            );
        }
    }
}
