//! A numerical reference for free bodies without a closed form, with its own error estimated.
//!
//! [`high_accuracy`] integrates one body twice with a scheme of known order `p`, at steps `h` and
//! `h/2`, and returns the finer result. In the asymptotic regime the error is `e(h) ≈ C h^p`, so
//! `X_h - X_{h/2} ≈ C h^p (1 - 2^-p) = (2^p - 1) e(h/2)` (Richardson), and the finer result's own
//! error is estimated as `|X_h - X_{h/2}| / (2^p - 1)`. A caller measuring a scheme against this
//! reference shows the estimate is far below what it measures.
//!
//! The estimate is only meaningful when `h` is in the asymptotic regime (take `h |Ω| <= 1e-2`) and
//! above the round-off floor (about `sqrt(steps) · 1e-16` rad); below that floor the estimate is
//! round-off noise of the same size as the true error.

use crate::sim::integrators::{IntegratorKind, VariationalSettings};
use crate::sim::loads::Loads;
use crate::sim::{Bodies, BodyInit};
use nalgebra::{UnitQuaternion, Vector3};

/// The finer of two integrations, and the estimated error of it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HighAccuracy {
    /// Orientation at `t_end`.
    pub world_from_body: UnitQuaternion<f64>,
    /// Body angular momentum at `t_end`, kg m^2/s.
    pub angmom_body: Vector3<f64>,
    /// Richardson estimate of the rotation error of `world_from_body`, rad.
    pub rotation_error_estimate: f64,
    /// Richardson estimate of `|angmom_body - M(t_end)|`, kg m^2/s.
    pub angmom_error_estimate: f64,
    /// The finer step actually used (`t_end / steps`), s.
    pub dt_secs: f64,
}

/// Orientation and body angular momentum of `init` (torque-free: gravity does not rotate a free
/// body) at `t_end_secs`, integrated by `kind` at about `dt_secs` and at half of it. The step is
/// adjusted to `t_end_secs / n` for a whole number `n` of coarse steps. The variational family runs
/// with Newton tolerance `1e-15` (cap 50 iterations). Recommended: [`IntegratorKind::Rk4`] (which
/// shares no code with the variational family) with `dt_secs |Ω| ≈ 1e-3`.
pub fn high_accuracy(
    init: &BodyInit,
    t_end_secs: f64,
    dt_secs: f64,
    kind: IntegratorKind,
) -> HighAccuracy {
    assert!(t_end_secs >= 0.0 && dt_secs > 0.0);
    let n = (t_end_secs / dt_secs).ceil().max(1.0) as u64;
    let coarse_dt = t_end_secs / n as f64;
    let run = |dt: f64, steps: u64| {
        let settings = VariationalSettings {
            newton_tol: 1e-15,
            newton_max_iters: 50,
            ..Default::default()
        };
        let mut bodies = Bodies::new(std::slice::from_ref(init));
        let mut integrator = kind.build(dt, &settings);
        integrator.init(&bodies);
        let g = Loads::none();
        for _ in 0..steps {
            integrator.step(&mut bodies, &g);
        }
        (bodies.world_from_body[0], bodies.angmom_body[0])
    };
    let (q_coarse, m_coarse) = run(coarse_dt, n);
    let (q_fine, m_fine) = run(coarse_dt / 2.0, 2 * n);
    let richardson = 2f64.powi(kind.order() as i32) - 1.0;
    HighAccuracy {
        world_from_body: q_fine,
        angmom_body: m_fine,
        rotation_error_estimate: q_coarse.angle_to(&q_fine) / richardson,
        angmom_error_estimate: (m_coarse - m_fine).norm() / richardson,
        dt_secs: coarse_dt / 2.0,
    }
}
