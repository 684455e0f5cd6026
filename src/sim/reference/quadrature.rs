//! Adaptive Gauss–Legendre quadrature of smooth functions, for the precession angle of the
//! torque-free body ([`super::torque_free`]).
//!
//! The `n`-point Gauss–Legendre rule on `[-1, 1]` integrates polynomials of degree `2n - 1`
//! exactly; its nodes are the roots of the Legendre polynomial `P_n`, found by Newton's method
//! from `cos(π (i - 1/4) / (n + 1/2))` with `P_n` and `P_n'` from the three-term recurrence
//! `(k + 1) P_{k+1} = (2k + 1) x P_k - k P_{k-1}`, `P_n' = n (x P_n - P_{n-1}) / (x^2 - 1)`, and
//! weights `2 / ((1 - x^2) P_n'(x)^2)` (Abramowitz & Stegun 25.4.29; Davis & Rabinowitz,
//! *Methods of Numerical Integration*, §2.7). [`integrate`] compares the rule on an interval
//! with the rule on its two halves and splits until they agree.

use std::sync::OnceLock;

/// Points of the rule.
const NODES: usize = 12;

/// `(node, weight)` pairs of the [`NODES`]-point rule on `[-1, 1]`.
fn rule() -> &'static [(f64, f64); NODES] {
    static RULE: OnceLock<[(f64, f64); NODES]> = OnceLock::new();
    RULE.get_or_init(|| {
        let n = NODES as f64;
        std::array::from_fn(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 1..NODES {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k + 1.0) * x * p1 - k * p0) / (k + 1.0));
                }
                dp = n * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() <= 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
    })
}

/// The rule on `[a, b]`: the estimate and `Σ |w f|` (the scale of its round-off).
fn gauss(f: &impl Fn(f64) -> f64, a: f64, b: f64) -> (f64, f64) {
    let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
    let (mut sum, mut abs) = (0.0, 0.0);
    for &(x, w) in rule() {
        let v = w * f(mid + half * x);
        sum += v;
        abs += v.abs();
    }
    (half * sum, half.abs() * abs)
}

/// Relative noise floor of the integrands (elliptic functions near the separatrix lose a few
/// digits): 256 ulp.
const NOISE: f64 = 256.0 * f64::EPSILON;

/// Levels of splitting at most (2^20 panels).
const MAX_DEPTH: u32 = 20;

/// `∫_a^b f` to the absolute tolerance `tol`: the rule on `[a, b]` is accepted when it agrees
/// with the sum over the two halves within `tol`, or within [`NOISE`] of the integrand's
/// scale (below that, round-off in the integrand keeps the halves from agreeing better), and the halves' sum is returned;
/// else each half is integrated to `tol / 2`. At most [`MAX_DEPTH`] levels of splitting.
pub fn integrate(f: &impl Fn(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
    fn recurse(f: &impl Fn(f64) -> f64, a: f64, b: f64, whole: f64, tol: f64, depth: u32) -> f64 {
        let m = 0.5 * (a + b);
        let ((left, left_abs), (right, right_abs)) = (gauss(f, a, m), gauss(f, m, b));
        let floor = NOISE * (left_abs + right_abs);
        if (left + right - whole).abs() <= tol.max(floor) || depth >= MAX_DEPTH {
            left + right
        } else {
            recurse(f, a, m, left, 0.5 * tol, depth + 1)
                + recurse(f, m, b, right, 0.5 * tol, depth + 1)
        }
    }
    if a == b {
        return 0.0;
    }
    recurse(f, a, b, gauss(f, a, b).0, tol, 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact for polynomials of degree 2n - 1 = 23 on one panel; weights sum to 2; smooth
    /// non-polynomial integrands to the tolerance.
    #[test]
    fn integrates_polynomials_exactly_and_smooth_functions_to_tolerance() {
        let w: f64 = rule().iter().map(|r| r.1).sum();
        // Measured 4.4e-16.
        assert!((w - 2.0).abs() < 1e-14, "{w}");
        let p = |x: f64| x.powi(23) + 3.0 * x.powi(22) - x + 0.5;
        // ∫_0^1 = 1/24 + 3/23 - 1/2 + 1/2.
        let exact = 1.0 / 24.0 + 3.0 / 23.0;
        assert!((gauss(&p, 0.0, 1.0).0 - exact).abs() < 1e-15);
        // ∫_0^10 exp(sin t) dt, a periodic smooth function; reference by 1e6-panel Simpson's rule
        // would cost too much here, so compare ∫_0^{2π} against 2π I_0(1) = 7.954926521012845.
        let f = |t: f64| t.sin().exp();
        let got = integrate(&f, 0.0, 2.0 * std::f64::consts::PI, 1e-14);
        assert!((got - 7.954_926_521_012_845).abs() < 1e-13, "{got}");
        // A sharp peak: ∫ 1/(1e-4 + x^2) over [-1, 1] = 2 atan(100)/1e-2.
        let g = |x: f64| 1.0 / (1e-4 + x * x);
        let exact = 2.0 * 100f64.atan() / 1e-2;
        let got = integrate(&g, -1.0, 1.0, 1e-10);
        assert!((got - exact).abs() < 1e-9 * exact, "{got} vs {exact}");
    }
}
