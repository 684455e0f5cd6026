//! Free rigid bodies the integrator tests start from, and the settings and measures they share.
#![allow(dead_code)]

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use tumble::sim::BodyInit;
use tumble::sim::integrators::VariationalSettings;
use tumble::sim::reference::{Asymmetric, Axisymmetric};

/// A 2 kg body at (0.1, -0.2, 0.3) m moving at (0.5, 0, 1) m/s, with principal moments
/// `moments`, orientation `q` and world angular velocity `angvel_world`.
pub fn body(moments: Vector3<f64>, q: UnitQuaternion<f64>, angvel_world: Vector3<f64>) -> BodyInit {
    BodyInit {
        mass: 2.0,
        principal_moments: moments,
        world_from_body: Isometry3::from_parts(Translation3::new(0.1, -0.2, 0.3), q),
        linvel_world: Vector3::new(0.5, 0.0, 1.0),
        angvel_world,
    }
}

/// An asymmetric body spinning near its intermediate axis (it flips: Dzhanibekov).
pub fn tumbling_body() -> BodyInit {
    body(
        Vector3::new(1.0, 2.0, 3.0),
        UnitQuaternion::from_euler_angles(0.2, 0.4, -0.3),
        Vector3::new(0.05, 3.0, 0.05),
    )
}

/// Newton converged as far as round-off lets it, for convergence measurements and references
/// (the Newton error must stay far below the truncation error, also for the order-6
/// composition; 1e-15 is below what round-off lets the residual reach).
pub fn tight() -> VariationalSettings {
    VariationalSettings {
        newton_tol: 1e-15,
        newton_max_iters: 50,
        ..Default::default()
    }
}

/// The asymmetric test body: moments (1, 2, 2.5), circling the minor axis (`L^2 < 2 E J_2`).
pub const ASYM_MOMENTS: [f64; 3] = [1.0, 2.0, 2.5];
/// Its initial body angular velocity direction (|.| = 2.19 rad/s).
pub const ASYM_OMEGA: [f64; 3] = [2.0, 0.8, -0.4];

/// The asymmetric body's initial orientation.
pub fn asym_q0() -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(-0.4, 0.2, 1.3)
}

/// `|ASYM_OMEGA|`, the asymmetric body's own spin rate (≈ 2.2 rad/s).
pub fn asym_spin() -> f64 {
    Vector3::from(ASYM_OMEGA).norm()
}

/// The asymmetric body with `|Ω0| = spin` (`Ω0` along [`ASYM_OMEGA`]) and its Jacobi-elliptic
/// closed form. `asymmetric(asym_spin())` is the body at [`ASYM_OMEGA`] exactly (the scale is 1).
pub fn asymmetric(spin: f64) -> (Asymmetric, BodyInit) {
    let moments = Vector3::from(ASYM_MOMENTS);
    let omega = Vector3::from(ASYM_OMEGA);
    let omega = omega * (spin / omega.norm());
    let reference = Asymmetric::new(moments, omega).unwrap();
    (reference, body(moments, asym_q0(), asym_q0() * omega))
}

/// The axisymmetric test body's initial body angular velocity direction.
pub const AXI_OMEGA: [f64; 3] = [0.6, -0.3, 2.5];

/// The axisymmetric closed form with moments (`ip`, `ip`, `i3`) and `Ω0 = omega_body`, and a
/// body starting on it.
pub fn axisymmetric_with(ip: f64, i3: f64, omega_body: Vector3<f64>) -> (Axisymmetric, BodyInit) {
    let reference = Axisymmetric {
        ip,
        i3,
        world_from_body_0: UnitQuaternion::from_euler_angles(0.3, -0.5, 0.8),
        omega_body_0: omega_body,
    };
    let init = body(
        Vector3::new(ip, ip, i3),
        reference.world_from_body_0,
        reference.world_from_body_0 * omega_body,
    );
    (reference, init)
}

/// Moments (2, 2, 0.6), `Ω0` along [`AXI_OMEGA`] scaled to `|Ω0| = spin`.
pub fn axisymmetric(spin: f64) -> (Axisymmetric, BodyInit) {
    let omega = Vector3::from(AXI_OMEGA);
    axisymmetric_with(2.0, 0.6, omega * (spin / omega.norm()))
}

/// `log2(e(h) / e(h/2))` for consecutive step sizes (errors in step order, halving).
pub fn orders(errors: &[f64]) -> Vec<f64> {
    errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect()
}
