//! The body-frame orbit of a torque-free body's angular momentum under a perturbed Hamiltonian
//! `H_ε = H + ε K`, and its two frequencies: the period of the momentum's loop and the
//! precession about the spatial momentum gained per loop. The error model
//! ([`super::model`]) differentiates them in `ε`.
//!
//! Body coordinates are relabelled cyclically as `(a, b, c)` with `c` the axis the momentum
//! circles (the largest-moment axis when `L^2 > 2 E J_mid`, else the smallest; the odd axis of an
//! axisymmetric body). With `A = J^-1` and `M = G (sin θ sin ψ, sin θ cos ψ, cos θ)`, `G = |M|`
//! (a Casimir: every scheme of the variational family keeps it exactly), any Hamiltonian `H_ε`
//! moves `M` by `M' = M × W` and the orientation by `R' = R W^`, `W = ∇H_ε`. Then
//!
//! - `ψ' = W_c - M_c (M_a W_a + M_b W_b) / (M_a^2 + M_b^2)` (from `ψ = atan2(M_a, M_b)`), of one
//!   sign on the orbit, so `ψ` parametrises it;
//! - `φ' = G (M_a W_a + M_b W_b) / (M_a^2 + M_b^2)`, the rate of the precession angle about `π`
//!   ([`crate::sim::reference::torque_free`], with `Ω` replaced by `W`);
//! - on the level set `H_ε = H_ε(M_0)`, `θ(ψ)` is found by Newton from the unperturbed
//!   `sin^2 θ = (2E/G^2 - A_c) / (A_ψ - A_c)`, `A_ψ = A_a sin^2 ψ + A_b cos^2 ψ`;
//! - the loop's period `P = ∮ dψ / |ψ'|` and the precession per loop `Φ = ∮ φ' dψ / |ψ'|`
//!   by adaptive Gauss–Legendre quadrature.
//!
//! At `ε = 0`, `P` is the closed-form `4K(m)/λ` ([`crate::sim::reference::Asymmetric`]) and
//! `Φ` the quadrature of [`crate::sim::reference::torque_free`]; `tests` check both.

use crate::sim::reference::quadrature::integrate;
use nalgebra::Vector3;

/// The perturbation `K` of the Hamiltonian, as a value and a gradient in body coordinates.
pub trait Perturbation {
    fn value(&self, m: &Vector3<f64>) -> f64;
    fn gradient(&self, m: &Vector3<f64>) -> Vector3<f64>;
}

/// One body's momentum orbit in `(a, b, c)` coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct Orbit {
    /// `J` and `A = J^-1` in `(a, b, c)` order.
    pub j: Vector3<f64>,
    pub a: Vector3<f64>,
    /// The body axis labelled `c`; `a = (c + 1) % 3`, `b = (c + 2) % 3`.
    pub circled: usize,
    /// `M_0` in `(a, b, c)` coordinates.
    pub m0: Vector3<f64>,
    /// `G = |M|`.
    pub g: f64,
}

impl Orbit {
    /// The orbit through `angmom_body` (body axes) of a body with principal moments
    /// `inertia_body`. `None` for an isotropic body, a body at rest, a steady spin about a
    /// principal axis (these the variational family integrates exactly: `H_2` and its gradient
    /// vanish there), and an orbit within `1e-12` (relative) of a separatrix, where the loop's
    /// period is unbounded.
    pub fn new(inertia_body: &Vector3<f64>, angmom_body: &Vector3<f64>) -> Option<Self> {
        let j = *inertia_body;
        let m = *angmom_body;
        let g2 = m.norm_squared();
        let scale = j.max();
        if g2 == 0.0 || j.max() - j.min() <= 1e-12 * scale {
            return None;
        }
        // L^2 - 2 E x, without cancellation: Σ M_i^2 (1 - x / J_i).
        let l2_minus_2e = |x: f64| (0..3).map(|i| m[i] * m[i] * (1.0 - x / j[i])).sum::<f64>();
        let mut order = [0, 1, 2];
        order.sort_by(|&p, &q| j[p].total_cmp(&j[q]));
        let [lo, mid, hi] = order;
        let close = |p: usize, q: usize| (j[p] - j[q]).abs() <= 1e-12 * scale;
        let circled = if close(lo, mid) {
            hi
        } else if close(mid, hi) {
            lo
        } else {
            let d = l2_minus_2e(j[mid]);
            if d.abs() <= 1e-12 * g2 {
                return None;
            }
            if d > 0.0 { hi } else { lo }
        };
        let (ia, ib) = ((circled + 1) % 3, (circled + 2) % 3);
        let perm = |v: &Vector3<f64>| Vector3::new(v[ia], v[ib], v[circled]);
        let m0 = perm(&m);
        // A steady spin about the circled axis: exact.
        if m0.x * m0.x + m0.y * m0.y <= 1e-30 * g2 {
            return None;
        }
        let j = perm(&j);
        Some(Self {
            j,
            a: j.map(|x| 1.0 / x),
            circled,
            m0,
            g: g2.sqrt(),
        })
    }

    /// `M(θ, ψ)` in `(a, b, c)` coordinates.
    fn momentum(&self, theta: f64, psi: f64) -> Vector3<f64> {
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = psi.sin_cos();
        Vector3::new(st * sp, st * cp, ct) * self.g
    }

    /// `H = M·AM / 2`.
    pub fn energy(&self, m: &Vector3<f64>) -> f64 {
        0.5 * m.dot(&self.a.component_mul(m))
    }

    /// `θ(ψ)` on the level set `H + ε K = H(M_0) + ε K(M_0)`.
    fn theta_on_level(&self, psi: f64, eps: f64, k: &impl Perturbation) -> f64 {
        let h_eps = |m: &Vector3<f64>| self.energy(m) + eps * k.value(m);
        let target = h_eps(&self.m0);
        let (sp, cp) = psi.sin_cos();
        let a_psi = self.a.x * sp * sp + self.a.y * cp * cp;
        let two_e = 2.0 * self.energy(&self.m0) / (self.g * self.g);
        let s2 = ((two_e - self.a.z) / (a_psi - self.a.z)).clamp(0.0, 1.0);
        let mut theta = s2.sqrt().asin();
        if self.m0.z < 0.0 {
            theta = std::f64::consts::PI - theta;
        }
        if eps != 0.0 {
            for _ in 0..20 {
                let m = self.momentum(theta, psi);
                let f = h_eps(&m) - target;
                let (st, ct) = theta.sin_cos();
                let dm = Vector3::new(ct * sp, ct * cp, -st) * self.g;
                let w = self.a.component_mul(&m) + k.gradient(&m) * eps;
                let df = w.dot(&dm);
                if df == 0.0 {
                    break;
                }
                let step = f / df;
                theta -= step;
                if step.abs() <= 1e-15 {
                    break;
                }
            }
        }
        theta
    }

    /// `(1/|ψ'|, φ'/|ψ'|)` at azimuth `ψ` on the level set of `H + ε K`.
    fn rates(&self, psi: f64, eps: f64, k: &impl Perturbation) -> (f64, f64) {
        let theta = self.theta_on_level(psi, eps, k);
        let m = self.momentum(theta, psi);
        let w = self.a.component_mul(&m) + k.gradient(&m) * eps;
        let transverse = m.x * m.x + m.y * m.y;
        let along = m.x * w.x + m.y * w.y;
        let psi_rate = (w.z - m.z * along / transverse).abs();
        let phi_rate = self.g * along / transverse;
        (1.0 / psi_rate, phi_rate / psi_rate)
    }

    /// The loop's period `P` (s) and the precession per loop `Φ` (rad) under `H + ε K`.
    pub fn frequencies(&self, eps: f64, k: &impl Perturbation) -> (f64, f64) {
        let two_pi = 2.0 * std::f64::consts::PI;
        // A scale for the tolerances: the period of a spin at |Ω| = G A_max.
        let t_scale = two_pi / (self.g * self.a.max());
        let period = integrate(
            &|psi| self.rates(psi, eps, k).0,
            0.0,
            two_pi,
            1e-15 * t_scale,
        );
        let phi = integrate(
            &|psi| self.rates(psi, eps, k).1,
            0.0,
            two_pi,
            1e-15 * two_pi,
        );
        (period, phi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::BodyInit;
    use crate::sim::reference::{Asymmetric, TorqueFree};
    use nalgebra::{Isometry3, UnitQuaternion};

    struct Zero;
    impl Perturbation for Zero {
        fn value(&self, _: &Vector3<f64>) -> f64 {
            0.0
        }
        fn gradient(&self, _: &Vector3<f64>) -> Vector3<f64> {
            Vector3::zeros()
        }
    }

    /// `K = c |M|^4` (a Casimir): the momentum orbit and its period are unchanged, the precession
    /// rate grows by `∇K·M/G = 4 c G^3`, so `Φ` by `4 c G^3 P`.
    struct Casimir(f64);
    impl Perturbation for Casimir {
        fn value(&self, m: &Vector3<f64>) -> f64 {
            self.0 * m.norm_squared().powi(2)
        }
        fn gradient(&self, m: &Vector3<f64>) -> Vector3<f64> {
            m * (4.0 * self.0 * m.norm_squared())
        }
    }

    /// At `ε = 0` the period is the elliptic `4K(m)/λ` and `Φ` the precession of the exact
    /// orientation over one period; a Casimir perturbation changes only `Φ`, as predicted.
    #[test]
    fn frequencies_match_the_closed_form() {
        for (j, w) in [
            (Vector3::new(1.0, 2.0, 3.0), Vector3::new(0.3, 0.8, 2.0)),
            (Vector3::new(1.0, 2.0, 3.0), Vector3::new(-2.0, 0.5, -0.4)),
            (Vector3::new(3.0, 1.0, 2.0), Vector3::new(0.05, 0.03, 3.0)),
            (
                Vector3::new(1e-3, 0.9995, 1.0),
                Vector3::new(0.5, 0.002, 0.001),
            ),
        ] {
            let m = j.component_mul(&w);
            let orbit = Orbit::new(&j, &m).unwrap();
            let (p, phi) = orbit.frequencies(0.0, &Zero);
            let exact = Asymmetric::new(j, w).unwrap();
            // Measured ≤ 3e-15 relative.
            assert!(
                (p - exact.period_secs()).abs() < 1e-12 * p,
                "{j} {w}: {p} vs {}",
                exact.period_secs()
            );
            let init = BodyInit {
                mass: 1.0,
                principal_moments: j,
                world_from_body: Isometry3::identity(),
                linvel_world: Vector3::zeros(),
                angvel_world: w,
            };
            // After one period M is back: R(P) R(0)^T is a rotation about π by Φ.
            let r = TorqueFree::new(&init).unwrap();
            let turn = r.orientation(p) * UnitQuaternion::identity().inverse();
            let axis_angle = turn.scaled_axis();
            let pi_dir = m.normalize();
            let signed = axis_angle.dot(&pi_dir);
            let wrapped = (phi + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI)
                - std::f64::consts::PI;
            // Measured ≤ 2e-13 rad.
            assert!(
                (signed - wrapped).abs() < 1e-10,
                "{j} {w}: {signed} vs {wrapped}"
            );
            let c = 1e-3;
            let (p_c, phi_c) = orbit.frequencies(1.0, &Casimir(c));
            assert!((p_c - p).abs() < 1e-12 * p);
            let g = m.norm();
            let want = phi + 4.0 * c * g.powi(3) * p;
            assert!(
                (phi_c - want).abs() < 1e-10 * want.abs(),
                "{phi_c} vs {want}"
            );
        }
    }
}
