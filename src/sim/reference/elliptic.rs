//! Jacobi elliptic functions and elliptic integrals of the first kind, for the closed-form free
//! rigid body. Parameter convention `m = k^2` (Abramowitz & Stegun, *Handbook of Mathematical
//! Functions*, ch. 16–17), `0 <= m <= 1`.
//!
//! - `sn, cn, dn` by the arithmetic-geometric mean (A&S 16.4): with `a_0 = 1`, `b_0 = sqrt(1-m)`,
//!   `c_0 = sqrt(m)`, `a_n = (a_{n-1} + b_{n-1})/2`, `b_n = sqrt(a_{n-1} b_{n-1})`,
//!   `c_n = (a_{n-1} - b_{n-1})/2` until `c_N` is negligible; then `φ_N = 2^N a_N u`,
//!   `sin(2φ_{n-1} - φ_n) = (c_n/a_n) sin φ_n`, and `sn u = sin φ_0`, `cn u = cos φ_0`.
//!   `dn` is taken from `dn^2 = (1 - m) + m cn^2` (A&S 16.9.1), a sum of non-negative terms,
//!   rather than A&S 16.4's `cos φ_0 / cos(φ_1 - φ_0)`, which is a 0/0 form at `u = K` for `m`
//!   near 1 (it gave `dn(K) = 0.064` instead of `1e-3` at `m = 1 - 1e-6`).
//!   The argument is first reduced modulo the period `4K`.
//! - `K(m) = π / (2 a_N)` (A&S 17.6.1, the same AGM).
//! - `F(φ|m)` by Carlson's symmetric integral (DLMF 19.25.5, `F(φ|m) = sin φ R_F(cos^2 φ,
//!   1 - m sin^2 φ, 1)` for `|φ| <= π/2`, extended by `F(φ + nπ|m) = F(φ|m) + 2nK(m)`), with
//!   `R_F` by Carlson's duplication theorem (Carlson 1995, "Numerical computation of real or
//!   complex elliptic integrals", Numer. Algorithms 10, 13–26; DLMF 19.36.1).
//!   `F` is the inverse of the amplitude: `sn(F(φ|m)|m) = sin φ`, `cn(F(φ|m)|m) = cos φ`.
//!
//! At `m = 1` (`K = ∞`) `sn = tanh`, `cn = dn = sech` (A&S 16.6).

use std::f64::consts::PI;

/// Upper bound on AGM iterations: convergence is quadratic, 6 suffice for `1 - m >= 1e-300`.
const AGM_MAX_ITERS: usize = 40;

/// The AGM sequences `(a_n, c_n)` for parameter `m < 1`, `n = 0..=N` with `c_N <= ε a_N`.
fn agm_sequence(m: f64) -> Vec<(f64, f64)> {
    let (mut a, mut b, mut c) = (1.0, (1.0 - m).sqrt(), m.sqrt());
    let mut seq = vec![(a, c)];
    while c.abs() > f64::EPSILON * a && seq.len() < AGM_MAX_ITERS {
        let a_next = 0.5 * (a + b);
        c = 0.5 * (a - b);
        b = (a * b).sqrt();
        a = a_next;
        seq.push((a, c));
    }
    seq
}

/// The complete elliptic integral of the first kind `K(m) = ∫_0^{π/2} dθ / sqrt(1 - m sin^2 θ)`
/// by the AGM (A&S 17.6.1); `∞` at `m = 1`.
pub fn complete_k(m: f64) -> f64 {
    assert!((0.0..=1.0).contains(&m), "parameter m = {m} outside [0, 1]");
    if m == 1.0 {
        return f64::INFINITY;
    }
    let (a_n, _) = *agm_sequence(m).last().unwrap();
    PI / (2.0 * a_n)
}

/// The Jacobi elliptic functions `(sn, cn, dn)` of `u` with parameter `m ∈ [0, 1]` (A&S 16.4).
pub fn jacobi_sn_cn_dn(u: f64, m: f64) -> (f64, f64, f64) {
    assert!((0.0..=1.0).contains(&m), "parameter m = {m} outside [0, 1]");
    if m == 1.0 {
        let sech = 1.0 / u.cosh();
        return (u.tanh(), sech, sech);
    }
    let seq = agm_sequence(m);
    let n = seq.len() - 1;
    let (a_n, _) = seq[n];
    // Reduce u modulo the period 4K of sn and cn (dn has period 2K) to keep 2^N a_N u small.
    let four_k = 2.0 * PI / a_n;
    let u = u - four_k * (u / four_k).round();
    // φ_N, then down to φ_0 (for n = 0, m below ε^2, φ_0 = u: the trigonometric limit).
    let mut phi = 2f64.powi(n as i32) * a_n * u;
    for k in (1..=n).rev() {
        let (a, c) = seq[k];
        phi = 0.5 * (phi + ((c / a) * phi.sin()).asin());
    }
    let (s, c) = phi.sin_cos();
    (s, c, ((1.0 - m) + m * c * c).sqrt())
}

/// Carlson's symmetric elliptic integral `R_F(x, y, z) = 1/2 ∫_0^∞ dt / sqrt((t+x)(t+y)(t+z))`
/// for `x, y, z >= 0`, at most one of them zero (Carlson 1995, algorithm for `R_F`).
pub fn carlson_rf(x: f64, y: f64, z: f64) -> f64 {
    let (mut x, mut y, mut z) = (x, y, z);
    loop {
        let mean = (x + y + z) / 3.0;
        let (dx, dy) = (1.0 - x / mean, 1.0 - y / mean);
        let dz = -(dx + dy);
        // Truncation error of the fifth-order series below is ~ max|d|^6 / 4 (Carlson 1995):
        // below 1e-3 that is < 1e-18.
        if dx.abs().max(dy.abs()).max(dz.abs()) < 1e-3 {
            let e2 = dx * dy - dz * dz;
            let e3 = dx * dy * dz;
            return (1.0 - e2 / 10.0 + e3 / 14.0 + e2 * e2 / 24.0 - 3.0 * e2 * e3 / 44.0)
                / mean.sqrt();
        }
        let (sx, sy, sz) = (x.sqrt(), y.sqrt(), z.sqrt());
        let lambda = sx * sy + sy * sz + sz * sx;
        x = 0.25 * (x + lambda);
        y = 0.25 * (y + lambda);
        z = 0.25 * (z + lambda);
    }
}

/// The incomplete elliptic integral of the first kind
/// `F(φ|m) = ∫_0^φ dθ / sqrt(1 - m sin^2 θ)` for any real `φ` and `m ∈ [0, 1)`.
pub fn incomplete_f(phi: f64, m: f64) -> f64 {
    assert!((0.0..1.0).contains(&m), "parameter m = {m} outside [0, 1)");
    let n = (phi / PI).round();
    let phi_r = phi - n * PI; // in [-π/2, π/2]
    let (s, c) = phi_r.sin_cos();
    let reduced = s * carlson_rf(c * c, 1.0 - m * s * s, 1.0);
    if n == 0.0 {
        reduced
    } else {
        // 2K = 2 R_F(0, 1 - m, 1) (DLMF 19.25.1).
        reduced + 2.0 * n * carlson_rf(0.0, 1.0 - m, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    const PARAMETERS: [f64; 6] = [0.0, 1e-20, 0.1, 0.5, 0.9, 0.999_999];

    /// Tabulated values: `K(1/2) = 1.8540746773013719` (A&S table 17.1), `K(0) = π/2`.
    #[test]
    fn complete_k_matches_tables_and_carlson() {
        // Measured 0 and 2.2e-16.
        assert!((complete_k(0.0) - FRAC_PI_2).abs() < 1e-15);
        assert!((complete_k(0.5) - 1.854_074_677_301_371_9).abs() < 1e-15);
        for m in PARAMETERS {
            let agm = complete_k(m);
            let carlson = carlson_rf(0.0, 1.0 - m, 1.0);
            // Two independent algorithms: measured ≤ 2.1e-16 relative.
            assert!(
                (agm - carlson).abs() < 4e-15 * agm,
                "m = {m}: {agm} vs {carlson}"
            );
            // F(φ) near π/2 has slope 1/dn = 1/sqrt(1 - m): the 6.1e-17 by which the f64 π/2
            // misses π/2 moves F by up to 6.1e-14 (m = 1 - 1e-6, measured 5.9e-14).
            let f = incomplete_f(FRAC_PI_2, m);
            let slack = 1e-16 / (1.0 - m).sqrt();
            assert!(
                (agm - f).abs() < 4e-15 * agm + slack,
                "m = {m}: {agm} vs {f}"
            );
        }
    }

    /// Limits: `m = 0` gives sin, cos, 1; `m = 1` tanh, sech, sech; values near `m = 1` approach
    /// the hyperbolic ones.
    #[test]
    fn jacobi_limits() {
        for u in [-3.0, -0.4, 0.0, 0.7, 2.5, 40.0] {
            let (s, c, d) = jacobi_sn_cn_dn(u, 0.0);
            // Measured ≤ 1.1e-15 (the reduction modulo 2π costs a few ulp at u = 40).
            assert!((s - f64::sin(u)).abs() < 1e-14 && (c - f64::cos(u)).abs() < 1e-14);
            assert_eq!(d, 1.0);
            let (s1, c1, d1) = jacobi_sn_cn_dn(u, 1.0);
            assert_eq!((s1, c1, d1), (u.tanh(), 1.0 / u.cosh(), 1.0 / u.cosh()));
            if u.abs() < 5.0 {
                let (s, c, d) = jacobi_sn_cn_dn(u, 1.0 - 1e-12);
                // sn(u|m) - tanh u = O(1 - m): measured ≤ 2.6e-12.
                assert!((s - s1).abs() < 1e-10 && (c - c1).abs() < 1e-10 && (d - d1).abs() < 1e-10);
            }
        }
    }

    /// Identities `sn^2 + cn^2 = 1`, `dn^2 + m sn^2 = 1`, `sn(K) = 1`, and the derivatives
    /// `sn' = cn dn`, `cn' = -sn dn`, `dn' = -m sn cn` (central differences).
    #[test]
    fn jacobi_identities_and_derivatives() {
        for m in PARAMETERS {
            let k = complete_k(m);
            let (s, c, d) = jacobi_sn_cn_dn(k, m);
            // Measured 0, ≤ 6.1e-17, and dn(K) = sqrt(1 - m) to round-off (0), also at m = 1 - 1e-6.
            assert!(
                (s - 1.0).abs() < 1e-14 && c.abs() < 1e-14,
                "m = {m}: {s} {c}"
            );
            assert!(
                (d / (1.0 - m).sqrt() - 1.0).abs() < 1e-13,
                "m = {m}: dn(K) = {d}"
            );
            for u in [-7.3, -1.1, 0.0, 0.25, 1.9, 3.3, 12.0] {
                let (s, c, d) = jacobi_sn_cn_dn(u, m);
                assert!((s * s + c * c - 1.0).abs() < 1e-14, "m = {m}, u = {u}");
                assert!((d * d + m * s * s - 1.0).abs() < 1e-14, "m = {m}, u = {u}");
                let eps = 1e-5;
                let (sp, cp, dp) = jacobi_sn_cn_dn(u + eps, m);
                let (sm, cm, dm) = jacobi_sn_cn_dn(u - eps, m);
                let fd = |p: f64, q: f64| (p - q) / (2.0 * eps);
                // Central difference error ~ eps^2 |f'''| / 6 + 1e-16 / eps: measured ≤ 6.8e-11;
                // the identities above: ≤ 2.2e-16.
                assert!((fd(sp, sm) - c * d).abs() < 1e-9, "m = {m}, u = {u}");
                assert!((fd(cp, cm) + s * d).abs() < 1e-9, "m = {m}, u = {u}");
                assert!((fd(dp, dm) + m * s * c).abs() < 1e-9, "m = {m}, u = {u}");
            }
        }
    }

    /// `F` inverts the amplitude: `sn(F(φ)) = sin φ`, `cn(F(φ)) = cos φ` over several turns.
    #[test]
    fn incomplete_f_inverts_the_amplitude() {
        for m in PARAMETERS {
            for phi in [-7.0, -3.0, -1.5, -0.2, 0.0, 0.9, 1.6, 3.1, 4.0, 10.0] {
                let u = incomplete_f(phi, m);
                let (s, c, _) = jacobi_sn_cn_dn(u, m);
                // Measured ≤ 7.1e-15 (m = 0.999999: K = 8.3, u up to 45).
                assert!((s - phi.sin()).abs() < 1e-13, "m = {m}, φ = {phi}: {s}");
                assert!((c - phi.cos()).abs() < 1e-13, "m = {m}, φ = {phi}: {c}");
            }
            assert_eq!(incomplete_f(0.0, m), 0.0);
            // Odd in φ.
            assert_eq!(incomplete_f(-0.8, m), -incomplete_f(0.8, m));
        }
    }
}
