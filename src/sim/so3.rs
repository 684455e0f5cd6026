//! The exponential map on SO(3) and its differential, with Taylor series near zero.
//!
//! For `x ∈ R^3`, `θ = |x|` and `x^` the skew matrix (`x^ y = x × y`):
//!
//! - `exp(x) = I + A x^ + B x^2` (Rodrigues), `A = sin θ / θ`, `B = (1 - cos θ) / θ^2 = 2 sin^2(θ/2) / θ^2`.
//! - `T(x) = I + B x^ + C x^2`, `C = (θ - sin θ) / θ^3`: the differential of `exp`
//!   (`d/dt exp(x(t)) = (T(x) ẋ)^ exp(x)`, the *left* Jacobian). `T(x)^T = T(-x)` is the right Jacobian.
//! - `T(x)^-1 = I - x^/2 + D x^2`, `D = (1 - (θ/2) cot(θ/2)) / θ^2`.
//! - For the analytic Newton Jacobian: `B'(θ)/θ = (A - 2B)/θ^2`, `C'(θ)/θ = (B - 3C)/θ^2`
//!   (the same closed forms as GTSAM's `SO3.cpp`).
//!
//! The direct formulas lose digits for small θ (relative error ~1e-4 at θ = 1e-6, from cancellation in
//! `θ - sin θ` and `1 - cos θ`), so below [`SERIES_THETA`] the truncated Taylor series are used:
//! `C = 1/6 - θ^2/120 + θ^4/5040`, `D = 1/12 + θ^2/720 + θ^4/30240`,
//! `B'/θ = -1/12 + θ^2/180 - θ^4/6720`, `C'/θ = -1/60 + θ^2/1260 - θ^4/60480`, and `A`, `B` from the
//! half-angle pair `cos(θ/2) = 1 - θ²/8 + θ⁴/384 - θ⁶/46080`, `sin(θ/2)/θ = 1/2 - θ²/48 + θ⁴/3840 - θ⁶/645120`
//! (`A = 2 sin(θ/2)/θ cos(θ/2)`, `B = 2 (sin(θ/2)/θ)^2`, exact identities), which the quaternion
//! `exp(x)` uses too. At θ = 0.02 the first omitted terms are below 2e-15 relative, i.e. at f64
//! round-off, while the direct formula for C has lost about `eps/θ^2 ≈ 5.6e-13` relative there.
//! Above the switch one `sin_cos(θ/2)` gives every coefficient.
//! `T` is singular at `θ = 2πn`; per-step rotations that large are aliased anyway.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// Below this angle (rad) the coefficient functions use their Taylor series.
pub const SERIES_THETA: f64 = 0.02;

/// `θ^2` below which the series are used: `SERIES_THETA^2`.
pub const SERIES_THETA_SQ: f64 = SERIES_THETA * SERIES_THETA;

/// The arithmetic the series branch needs: `f64`, or several `f64` lanes processed together (the
/// batched variational step evaluates two bodies at once with the same instructions, so both
/// paths round identically).
pub trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// Every lane set to `v`.
    fn splat(v: f64) -> Self;
    /// Lane-wise `|self|`.
    fn abs(self) -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn splat(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
}

/// The skew-symmetric matrix `x^` with `x^ y = x × y`.
#[inline]
pub fn hat(x: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -x.z, x.y, x.z, 0.0, -x.x, -x.y, x.x, 0.0)
}

/// The coefficient functions of `exp`, `T` and the derivatives of `T` at one angle.
///
/// `A` and `B` are built from the half-angle pair, `A = 2 sin(θ/2) cos(θ/2) / θ` and
/// `B = 2 (sin(θ/2)/θ)^2`, so the rotation applied to the momentum (`A`, `B`) and to the
/// quaternion (`cos(θ/2)`, `sin(θ/2)/θ`) come from the same two numbers, and one `sin_cos` call
/// serves all of them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coefficients<R = f64> {
    /// `sin θ / θ`
    pub a: R,
    /// `(1 - cos θ) / θ^2`
    pub b: R,
    /// `(θ - sin θ) / θ^3`
    pub c: R,
    /// `B'(θ) / θ = (A - 2B) / θ^2`
    pub db_over_theta: R,
    /// `C'(θ) / θ = (B - 3C) / θ^2`
    pub dc_over_theta: R,
    /// `cos(θ/2)`, the scalar part of the quaternion `exp(x)`.
    pub half_cos: R,
    /// `sin(θ/2) / θ`, the factor of `x` in the vector part of the quaternion `exp(x)`.
    pub half_sin_over_theta: R,
}

/// `(cos(θ/2), sin(θ/2)/θ)` by series in `θ^2`, for `θ < SERIES_THETA`:
/// `cos(θ/2) = 1 - θ²/8 + θ⁴/384 - θ⁶/46080`, `sin(θ/2)/θ = 1/2 - θ²/48 + θ⁴/3840 - θ⁶/645120`.
/// The first omitted terms (`θ⁸/10321920`, `θ⁸/185794560`) are below 3e-21 at θ = 0.02.
#[inline(always)]
fn half_angle_series<R: Real>(t2: R) -> (R, R) {
    let k = R::splat;
    let cos = k(1.0) + t2 * (k(-1.0 / 8.0) + t2 * (k(1.0 / 384.0) + t2 * k(-1.0 / 46080.0)));
    let sinc = k(0.5) + t2 * (k(-1.0 / 48.0) + t2 * (k(1.0 / 3840.0) + t2 * k(-1.0 / 645120.0)));
    (cos, sinc)
}

impl<R: Real> Coefficients<R> {
    /// All coefficients by their Taylor series in `θ^2` (Horner); valid for
    /// `theta_sq < SERIES_THETA_SQ` only. The first omitted terms of `C`, `B'/θ`, `C'/θ` are
    /// `θ⁶/362880`, `θ⁶/453600` (relative ~2e-15 of the leading term at θ = 0.02, where these
    /// coefficients are only ever multiplied by `|x|^2 ≤ 4e-4`).
    #[inline(always)]
    pub fn series(theta_sq: R) -> Self {
        let k = R::splat;
        let t2 = theta_sq;
        let (half_cos, half_sin_over_theta) = half_angle_series(t2);
        let two_hs = k(2.0) * half_sin_over_theta;
        Self {
            a: two_hs * half_cos,
            b: two_hs * half_sin_over_theta,
            c: k(1.0 / 6.0) + t2 * (k(-1.0 / 120.0) + t2 * k(1.0 / 5040.0)),
            db_over_theta: k(-1.0 / 12.0) + t2 * (k(1.0 / 180.0) + t2 * k(-1.0 / 6720.0)),
            dc_over_theta: k(-1.0 / 60.0) + t2 * (k(1.0 / 1260.0) + t2 * k(-1.0 / 60480.0)),
            half_cos,
            half_sin_over_theta,
        }
    }
}

impl Coefficients<f64> {
    /// Evaluates all coefficients at `θ^2 = |x|^2` (series below [`SERIES_THETA`], otherwise one
    /// `sqrt`, one `sin_cos(θ/2)` and one division).
    #[inline]
    pub fn new(theta_sq: f64) -> Self {
        if theta_sq < SERIES_THETA_SQ {
            Self::series(theta_sq)
        } else {
            let theta = theta_sq.sqrt();
            let (half_sin, half_cos) = (0.5 * theta).sin_cos();
            let inv_theta = 1.0 / theta;
            let inv_theta_sq = inv_theta * inv_theta;
            let half_sin_over_theta = half_sin * inv_theta;
            let two_hs = 2.0 * half_sin_over_theta;
            // sin θ = 2 sin(θ/2) cos(θ/2); 1 - cos θ = 2 sin^2(θ/2): no cancellation.
            let a = two_hs * half_cos;
            let b = two_hs * half_sin_over_theta;
            let c = (1.0 - a) * inv_theta_sq;
            Self {
                a,
                b,
                c,
                db_over_theta: (a - 2.0 * b) * inv_theta_sq,
                dc_over_theta: (b - 3.0 * c) * inv_theta_sq,
                half_cos,
                half_sin_over_theta,
            }
        }
    }
}

/// `D(θ) = (1 - (θ/2) cot(θ/2)) / θ^2`, the x^2 coefficient of `T(x)^-1`.
pub fn d_coefficient(theta_sq: f64) -> f64 {
    if theta_sq < SERIES_THETA * SERIES_THETA {
        1.0 / 12.0 + theta_sq / 720.0 + theta_sq * theta_sq / 30240.0
    } else {
        let half = 0.5 * theta_sq.sqrt();
        (1.0 - half * half.cos() / half.sin()) / theta_sq
    }
}

/// `exp(x)` as a rotation matrix (Rodrigues).
pub fn exp_matrix(x: &Vector3<f64>) -> Matrix3<f64> {
    let k = Coefficients::new(x.norm_squared());
    let xh = hat(x);
    Matrix3::identity() + xh * k.a + xh * xh * k.b
}

/// `exp(x)` as a unit quaternion `(cos(θ/2), sin(θ/2) x/θ)`; by series near zero.
#[inline]
pub fn exp_quaternion(x: &Vector3<f64>) -> UnitQuaternion<f64> {
    let t2 = x.norm_squared();
    let (w, s) = if t2 < SERIES_THETA_SQ {
        half_angle_series(t2)
    } else {
        let theta = t2.sqrt();
        let (sh, ch) = (0.5 * theta).sin_cos();
        (ch, sh / theta)
    };
    UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(w, s * x.x, s * x.y, s * x.z))
}

/// `T(x) = I + B x^ + C x^2`, the differential of `exp` (left Jacobian).
pub fn t_matrix(x: &Vector3<f64>) -> Matrix3<f64> {
    let k = Coefficients::new(x.norm_squared());
    let xh = hat(x);
    Matrix3::identity() + xh * k.b + xh * xh * k.c
}

/// `T(x)^-1 = I - x^/2 + D x^2`.
pub fn t_inverse_matrix(x: &Vector3<f64>) -> Matrix3<f64> {
    let xh = hat(x);
    Matrix3::identity() - xh * 0.5 + xh * xh * d_coefficient(x.norm_squared())
}

/// `T(x)^T m = m - B (x × m) + C x × (x × m)`, without forming a matrix.
#[inline]
pub fn t_transpose_times(x: &Vector3<f64>, k: &Coefficients, m: &Vector3<f64>) -> Vector3<f64> {
    let xm = x.cross(m);
    m - xm * k.b + x.cross(&xm) * k.c
}

/// The Jacobian `∂/∂x [T(x)^T m]` for a fixed vector `m`.
///
/// With `T(x)^T m = m - B(θ) x×m + C(θ) x×(x×m)` and `∂θ/∂x = x^T/θ`:
/// `∂(x×m)/∂x = -m^`, `∂(x×(x×m))/∂x = (x·m) I + x m^T - 2 m x^T`, so
/// `∂/∂x = -(x×m)(B'/θ) x^T + B m^ + (x×(x×m))(C'/θ) x^T + C ((x·m) I + x m^T - 2 m x^T)`.
#[inline]
pub fn t_transpose_times_jacobian(
    x: &Vector3<f64>,
    k: &Coefficients,
    m: &Vector3<f64>,
) -> Matrix3<f64> {
    let xm = x.cross(m);
    let xxm = x.cross(&xm);
    let xdm = x.dot(m);
    (xxm * k.dc_over_theta - xm * k.db_over_theta) * x.transpose()
        + hat(m) * k.b
        + (Matrix3::identity() * xdm + x * m.transpose() - m * x.transpose() * 2.0) * k.c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Direct (non-series) coefficients evaluated in higher working precision is not available in
    /// std; instead compare the series and the closed forms on both sides of the switch, where
    /// both are accurate to ~1e-13.
    #[test]
    fn coefficients_continuous_across_series_switch() {
        let below = Coefficients::new((SERIES_THETA * (1.0 - 1e-9)).powi(2));
        let above = Coefficients::new((SERIES_THETA * (1.0 + 1e-9)).powi(2));
        // Measured: differences ~1e-12 (the closed form of C/dC lose ~eps/θ^2 ≈ 5.6e-13 there).
        assert!((below.a - above.a).abs() < 1e-11);
        assert!((below.b - above.b).abs() < 1e-11);
        assert!((below.c - above.c).abs() < 1e-11);
        assert!((below.db_over_theta - above.db_over_theta).abs() < 1e-9);
        assert!((below.dc_over_theta - above.dc_over_theta).abs() < 1e-8);
        let d_below = d_coefficient((SERIES_THETA * (1.0 - 1e-9)).powi(2));
        let d_above = d_coefficient((SERIES_THETA * (1.0 + 1e-9)).powi(2));
        assert!((d_below - d_above).abs() < 1e-10);
    }

    #[test]
    fn series_exact_at_tiny_angle() {
        // At θ = 1e-6 the series are exact to round-off: B = 1/2 - θ²/24 = 0.5 - 4.2e-14.
        let k = Coefficients::new(1e-12);
        assert!((k.b - (0.5 - 1e-12 / 24.0)).abs() < 1e-16);
        assert!((k.c - (1.0 / 6.0 - 1e-12 / 120.0)).abs() < 1e-16);
    }

    #[test]
    fn exp_quaternion_matches_rodrigues() {
        for x in [
            Vector3::new(1e-9, -2e-9, 3e-9),
            Vector3::new(0.01, 0.005, -0.012),
            Vector3::new(0.3, -1.2, 0.7),
            Vector3::new(2.0, 1.0, -2.5),
        ] {
            let from_q = exp_quaternion(&x).to_rotation_matrix().into_inner();
            // Measured max entry difference ~2e-16.
            assert!((from_q - exp_matrix(&x)).amax() < 1e-14, "x = {x}");
            assert!((exp_quaternion(&x).norm() - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn t_inverse_is_inverse() {
        for x in [
            Vector3::new(1e-7, 2e-7, -1e-7),
            Vector3::new(0.01, 0.0, 0.015),
            Vector3::new(0.5, -0.4, 0.9),
            Vector3::new(-2.0, 1.5, 1.0),
        ] {
            let prod = t_matrix(&x) * t_inverse_matrix(&x);
            // Measured ~4e-16.
            assert!((prod - Matrix3::identity()).amax() < 1e-13, "x = {x}");
        }
    }

    /// `T(x)` is the differential of exp: `exp(x + εδ) exp(x)^T ≈ exp(ε T(x) δ)` to O(ε^2).
    #[test]
    fn t_is_the_differential_of_exp() {
        let eps = 1e-6;
        for x in [
            Vector3::new(1e-4, -3e-4, 2e-4),
            Vector3::new(0.01, 0.012, -0.004), // series branch
            Vector3::new(0.6, -0.2, 1.1),
            Vector3::new(-2.0, 0.5, 1.5),
        ] {
            for i in 0..3 {
                let mut d = Vector3::zeros();
                d[i] = 1.0;
                let plus = exp_matrix(&(x + d * eps));
                let minus = exp_matrix(&(x - d * eps));
                let central = (plus - minus) / (2.0 * eps) * exp_matrix(&x).transpose();
                // central is skew: (T(x) e_i)^
                let omega = Vector3::new(central[(2, 1)], central[(0, 2)], central[(1, 0)]);
                let expected = t_matrix(&x) * d;
                // Central differences: error O(ε^2) ~ 1e-12 plus round-off eps/ε ~ 1e-10. Measured ~3e-11.
                assert!((omega - expected).amax() < 1e-9, "x = {x}, i = {i}");
            }
        }
    }

    /// The analytic Jacobian of `T(x)^T m` against central finite differences, on both branches.
    #[test]
    fn t_transpose_jacobian_matches_finite_differences() {
        let m = Vector3::new(0.7, -1.3, 2.1);
        let eps = 1e-6;
        for x in [
            Vector3::new(1e-5, 2e-5, -1e-5),
            Vector3::new(0.011, -0.009, 0.013), // series branch, |x| ≈ 0.019
            Vector3::new(0.012, -0.011, 0.014), // closed-form branch, |x| ≈ 0.021
            Vector3::new(0.4, 0.9, -0.3),
            Vector3::new(-1.8, 2.0, 0.7),
        ] {
            let k = Coefficients::new(x.norm_squared());
            let jac = t_transpose_times_jacobian(&x, &k, &m);
            for i in 0..3 {
                let mut d = Vector3::zeros();
                d[i] = eps;
                let kp = Coefficients::new((x + d).norm_squared());
                let km = Coefficients::new((x - d).norm_squared());
                let fd = (t_transpose_times(&(x + d), &kp, &m)
                    - t_transpose_times(&(x - d), &km, &m))
                    / (2.0 * eps);
                // O(ε^2) truncation + eps/ε round-off ≈ 1e-10. Measured ≤ 2e-10.
                assert!(
                    (jac.column(i) - fd).amax() < 1e-8,
                    "x = {x}, column {i}: {} vs {fd}",
                    jac.column(i)
                );
            }
        }
    }

    #[test]
    fn t_transpose_is_t_of_minus_x() {
        let x = Vector3::new(0.3, -0.8, 0.5);
        let m = Vector3::new(1.0, 2.0, 3.0);
        let k = Coefficients::new(x.norm_squared());
        let lhs = t_transpose_times(&x, &k, &m);
        assert!((lhs - t_matrix(&x).transpose() * m).amax() < 1e-15);
        assert!((lhs - t_matrix(&-x) * m).amax() < 1e-15);
    }
}
