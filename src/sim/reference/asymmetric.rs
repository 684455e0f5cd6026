//! Torque-free asymmetric rigid body: the body angular velocity `Ω(t)` in closed form.
//!
//! Euler's equations `J_1 Ω_1' = (J_2 - J_3) Ω_2 Ω_3` (and cyclic) have, for distinct moments
//! relabelled `K_1 < K_2 < K_3` and `L^2 > 2 E K_2` (Landau & Lifshitz, *Mechanics*, §37),
//!
//! `Ω_1 = a_1 cn τ`, `Ω_2 = a_2 sn τ`, `Ω_3 = a_3 dn τ`, `τ = λ t + τ_0`, parameter `m = k^2`:
//!
//! - `a_1^2 = (2 E K_3 - L^2) / (K_1 (K_3 - K_1))`, `a_2^2 = (2 E K_3 - L^2) / (K_2 (K_3 - K_2))`,
//!   `a_3^2 = (L^2 - 2 E K_1) / (K_3 (K_3 - K_1))`,
//! - `λ^2 = (K_3 - K_2)(L^2 - 2 E K_1) / (K_1 K_2 K_3)`,
//! - `m = (K_2 - K_1)(2 E K_3 - L^2) / ((K_3 - K_2)(L^2 - 2 E K_1))`,
//!
//! with `E = Σ J_i Ω_i^2 / 2` and `L^2 = Σ J_i^2 Ω_i^2`. When `L^2 < 2 E K_2` the same formulas
//! hold with the labels 1 and 3 swapped (`K_1 > K_2 > K_3`): every ratio above stays positive.
//! The combinations are evaluated without cancellation as
//! `2 E K_3 - L^2 = Σ J_i (K_3 - J_i) Ω_i^2` and `L^2 - 2 E K_1 = Σ J_i (J_i - K_1) Ω_i^2`.
//!
//! **Signs.** The general solution is `(a_1 cn τ, σ_2 a_2 sn τ, σ_3 a_3 dn τ)` with `σ_i = ±1`.
//! Substituting into Euler's equations gives `σ_2 σ_3 = ε p`, where `ε = +1` for `L^2 > 2 E K_2`,
//! `-1` otherwise, and `p = ±1` is the parity of the relabelling (an odd permutation of the axes
//! flips the sign of Euler's equations). `Ω_3` never vanishes (`dn > 0`), so `σ_3 = sign Ω_3(0)`.
//!
//! **Phase.** `τ_0` makes `Ω(0) = Ω_0`: the amplitude `φ_0 = atan2(Ω_2(0)/(σ_2 a_2), Ω_1(0)/a_1)`
//! and `τ_0 = F(φ_0|m)`, the incomplete elliptic integral ([`super::elliptic::incomplete_f`]),
//! since `sn(F(φ|m)) = sin φ`, `cn(F(φ|m)) = cos φ`.
//!
//! `Ω_1, Ω_2` have period `4K(m)/λ`, `Ω_3` has `2K(m)/λ`: for a spin near the intermediate axis
//! this is the Dzhanibekov flip period. The separatrix `L^2 = 2 E K_2` (`m = 1`, infinite period)
//! and bodies with two equal moments (see [`super::Axisymmetric`]) are not handled here.

use super::elliptic::{complete_k, incomplete_f, jacobi_sn_cn_dn};
use nalgebra::Vector3;

/// The closed-form body angular velocity of a torque-free body with three distinct moments.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Asymmetric {
    /// Principal moments `J`, kg m^2, in the body's own axis order.
    pub moments: Vector3<f64>,
    /// The body axes playing the roles 1, 2, 3 of the formulas.
    axes: [usize; 3],
    /// `(a_1, σ_2 a_2, σ_3 a_3)`, rad/s.
    amplitudes: [f64; 3],
    /// `λ`, 1/s.
    lambda: f64,
    /// Elliptic parameter `m = k^2 ∈ [0, 1)`.
    m: f64,
    /// Phase `τ_0` at `t = 0`.
    tau_0: f64,
}

impl Asymmetric {
    /// The motion with principal moments `moments` and initial body angular velocity
    /// `omega_body_0`. `None` when two moments are equal within `1e-12` relative, when the motion
    /// is on the separatrix (`|L^2 - 2 E K_2| <= 1e-14 L^2`), or when `Ω_0 = 0`.
    pub fn new(moments: Vector3<f64>, omega_body_0: Vector3<f64>) -> Option<Self> {
        let j = moments;
        let mut order = [0, 1, 2];
        order.sort_by(|&a, &b| j[a].total_cmp(&j[b]));
        let [lo, mid, hi] = order;
        if j[mid] - j[lo] <= 1e-12 * j[hi] || j[hi] - j[mid] <= 1e-12 * j[hi] {
            return None;
        }
        let w2 = omega_body_0.component_mul(&omega_body_0);
        // Σ J_i (J_i - x) Ω_i^2 = L^2 - 2 E x, without cancellation for x a moment.
        let l2_minus_2e = |x: f64| (0..3).map(|i| j[i] * (j[i] - x) * w2[i]).sum::<f64>();
        let l2 = (0..3).map(|i| j[i] * j[i] * w2[i]).sum::<f64>();
        if l2 == 0.0 {
            return None;
        }
        let d = l2_minus_2e(j[mid]);
        if d.abs() <= 1e-14 * l2 {
            return None;
        }
        let (axes, epsilon) = if d > 0.0 {
            ([lo, mid, hi], 1.0)
        } else {
            ([hi, mid, lo], -1.0)
        };
        let [k1, k2, k3] = axes.map(|a| j[a]);
        let num_12 = -l2_minus_2e(k3); // 2 E K_3 - L^2
        let num_3 = l2_minus_2e(k1); // L^2 - 2 E K_1
        let a1 = (num_12 / (k1 * (k3 - k1))).max(0.0).sqrt();
        let a2 = (num_12 / (k2 * (k3 - k2))).max(0.0).sqrt();
        let a3 = (num_3 / (k3 * (k3 - k1))).max(0.0).sqrt();
        let lambda = ((k3 - k2) * num_3 / (k1 * k2 * k3)).max(0.0).sqrt();
        let m = ((k2 - k1) * num_12 / ((k3 - k2) * num_3)).clamp(0.0, 1.0);
        if m >= 1.0 {
            return None;
        }
        // Parity of the relabelling (i1, i2, i3): even iff it is a cyclic shift of (0, 1, 2).
        let parity = if axes[1] == (axes[0] + 1) % 3 {
            1.0
        } else {
            -1.0
        };
        let sigma_3 = omega_body_0[axes[2]].signum();
        let sigma_2 = epsilon * parity * sigma_3;
        let tau_0 = if a1 > 0.0 && a2 > 0.0 {
            let phi_0 = (omega_body_0[axes[1]] / (sigma_2 * a2)).atan2(omega_body_0[axes[0]] / a1);
            incomplete_f(phi_0, m)
        } else {
            0.0 // a steady spin about axis 3: Ω = (0, 0, σ_3 a_3)
        };
        Some(Self {
            moments,
            axes,
            amplitudes: [a1, sigma_2 * a2, sigma_3 * a3],
            lambda,
            m,
            tau_0,
        })
    }

    /// Body angular velocity `Ω(t)`, rad/s, in the body's axis order.
    pub fn angvel_body(&self, t_secs: f64) -> Vector3<f64> {
        let (sn, cn, dn) = jacobi_sn_cn_dn(self.lambda * t_secs + self.tau_0, self.m);
        let mut omega = Vector3::zeros();
        omega[self.axes[0]] = self.amplitudes[0] * cn;
        omega[self.axes[1]] = self.amplitudes[1] * sn;
        omega[self.axes[2]] = self.amplitudes[2] * dn;
        omega
    }

    /// Body angular momentum `M(t) = J Ω(t)`, kg m^2/s.
    pub fn angmom_body(&self, t_secs: f64) -> Vector3<f64> {
        self.moments.component_mul(&self.angvel_body(t_secs))
    }

    /// The elliptic parameter `m = k^2`.
    pub fn parameter(&self) -> f64 {
        self.m
    }

    /// The period of `Ω_1` and `Ω_2` (and of the whole vector `Ω`), `4 K(m) / λ`, s.
    pub fn period_secs(&self) -> f64 {
        4.0 * complete_k(self.m) / self.lambda
    }

    /// The body axis (0, 1 or 2) whose `Ω` component never vanishes (`dn`): the axis the
    /// angular momentum circles in the body frame (role 3 of the formulas).
    pub fn circled_axis(&self) -> usize {
        self.axes[2]
    }

    /// Whether the motion circles the largest-moment axis (`L^2 > 2 E J_mid`).
    pub fn about_major_axis(&self) -> bool {
        self.moments[self.axes[2]] > self.moments[self.axes[0]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Moments in every axis order (even and odd relabellings), initial conditions on both sides
    /// of the separatrix and with every sign pattern.
    fn cases() -> Vec<(Vector3<f64>, Vector3<f64>)> {
        let mut v = Vec::new();
        for j in [
            Vector3::new(1.0, 2.0, 3.0),
            Vector3::new(3.0, 1.0, 2.0),
            Vector3::new(2.0, 3.0, 1.0),
            Vector3::new(1.0, 3.0, 2.0),
            Vector3::new(3.0, 2.0, 1.0),
            Vector3::new(2.0, 1.0, 3.5),
        ] {
            for w in [
                Vector3::new(0.3, 0.8, 2.0),
                Vector3::new(-2.0, 0.5, -0.4),
                Vector3::new(0.05, 3.0, 0.05),
                Vector3::new(-0.7, -1.1, 0.9),
            ] {
                v.push((j, w));
            }
        }
        v
    }

    fn euler_rhs(j: &Vector3<f64>, w: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(
            (j.y - j.z) * w.y * w.z / j.x,
            (j.z - j.x) * w.z * w.x / j.y,
            (j.x - j.y) * w.x * w.y / j.z,
        )
    }

    /// `Ω(0) = Ω_0`, `dΩ/dt` (central differences) satisfies Euler's equations, and `E`, `|L|`
    /// are constant along `Ω(t)`.
    #[test]
    fn closed_form_solves_euler_equations() {
        let mut both_sides = [false, false];
        for (j, w0) in cases() {
            let r = Asymmetric::new(j, w0).unwrap();
            both_sides[usize::from(r.about_major_axis())] = true;
            // Measured ≤ 2.4e-15 relative.
            assert!(
                (r.angvel_body(0.0) - w0).norm() < 1e-14 * w0.norm(),
                "{j} {w0}"
            );
            let e0 = 0.5 * w0.dot(&j.component_mul(&w0));
            let l0 = j.component_mul(&w0).norm();
            for t in [0.37, 1.9, 7.3, 55.0] {
                let w = r.angvel_body(t);
                let eps = 1e-5;
                let fd = (r.angvel_body(t + eps) - r.angvel_body(t - eps)) / (2.0 * eps);
                let rhs = euler_rhs(&j, &w);
                // Central differences: O(eps^2 |Ω|^3) + 1e-16 |Ω| / eps; measured ≤ 4.8e-10.
                assert!(
                    (fd - rhs).norm() < 1e-8 * (1.0 + rhs.norm()),
                    "{j} {w0} t={t}"
                );
                let e = 0.5 * w.dot(&j.component_mul(&w));
                // Measured ≤ 4.9e-16 relative.
                assert!((e - e0).abs() < 1e-13 * e0, "{j} {w0} t={t}: E {e} vs {e0}");
                assert!((j.component_mul(&w).norm() - l0).abs() < 1e-13 * l0);
            }
            // Periodicity: Ω(T) = Ω(0). Measured ≤ 2.4e-15 relative.
            let w_t = r.angvel_body(r.period_secs());
            assert!((w_t - w0).norm() < 1e-13 * w0.norm(), "{j} {w0}: {w_t}");
        }
        assert_eq!(
            both_sides,
            [true, true],
            "cases must cover both sides of the separatrix"
        );
    }

    #[test]
    fn degenerate_cases_are_refused() {
        let w = Vector3::new(0.3, 0.8, 2.0);
        assert!(Asymmetric::new(Vector3::new(1.0, 1.0, 2.0), w).is_none());
        assert!(Asymmetric::new(Vector3::new(1.0, 2.0, 3.0), Vector3::zeros()).is_none());
        // A pure spin about the intermediate axis is on the separatrix.
        assert!(
            Asymmetric::new(Vector3::new(1.0, 2.0, 3.0), Vector3::new(0.0, 2.0, 0.0)).is_none()
        );
        // A pure spin about the major or minor axis is a steady solution.
        for axis in [0, 2] {
            let w0 = Vector3::ith(axis, 1.5);
            let r = Asymmetric::new(Vector3::new(1.0, 2.0, 3.0), w0).unwrap();
            assert!((r.angvel_body(3.7) - w0).norm() < 1e-15);
        }
    }
}
