//! Step-size limits: how far each integrator may turn a body per step, `h|Ω|` in radians, with
//! `|Ω|` the largest angular speed on the body's exact orbit ([`spin_rate_max`]).
//!
//! The limits are read off the stability map (`tumble stability`, [`crate::stability`], docs/limits.md; the committed map is `docs/stability/`): for each integrator, the largest `h|Ω|` of
//! the map's grid up to which every cell (every inertia ratio from 1 to 1e-6, the flat disk,
//! both spin axes) runs about 10 turns (at most 20 000 steps) without substepping or failure
//! and keeps the rotational energy within [`ENERGY_ERROR_BOUND`] of its initial value.
//! `tests/integrator/stability.rs` recomputes the map and checks these numbers against it. Past a limit a
//! run still proceeds (the variational family substeps where Newton needs it; the guard stops
//! diverging runs), but `tumble simulate` warns and names the largest safe step.

use super::{Bodies, IntegratorKind};
use nalgebra::Vector3;

/// Energy error (relative) that defines the limit.
pub const ENERGY_ERROR_BOUND: f64 = 0.01;

/// The documented limit of `h|Ω|` (rad per step) for `kind` over every shape of the map (the
/// minimum of [`LIMITS_BY_RATIO`]; the step warning uses the body's own row,
/// [`h_omega_limit_at_ratio`]): the limit derived from the full stability map ([`crate::stability::derived_limit`]). What sets each, at the next grid value:
///
/// | integrator | limit | first cell past it |
/// |---|---|---|
/// | `variational` | 0.03 | 0.1: rod-like `r = 1e-6` needs Newton substeps. Newton's iterations grow as `r` falls (at 0.1: 2, 3, 4 and over the cap of 10 for `r` = 1e-2, 1e-3, 1e-4, 1e-6; the Newton matrix `J - h ∂(T^T M)/∂ξ` inherits `J`'s condition `1/r`); shapes with `r >= 1e-2` stay `ok` up to 0.5 |
/// | `moser-veselov` | 0.7 | 1: the isotropic body substeps (its step solves `sin θ = h|Ω|`: no solution past 1, a singular Jacobian at 1); from 2 on every shape substeps. The energy error stays at the Newton tolerance (≤ 1.4e-10) everywhere |
/// | `variational4`, `variational6` | 0.01 | 0.03: `r = 1e-6` substeps (stages up to 1.7 `h`, same conditioning as `variational`) |
/// | `euler`, `semi-implicit` | 0.001 | 0.003: energy error 4.8 % (`|M|^2` grows by `h^2 |M × Ω|^2` per step; 0.5 % at 0.001 over 20 000 steps). Both schemes update `M` alike, so their energy errors are identical |
/// | `rk4` | 0.5 | 0.7: energy error 1.2 % (`r <= 1e-2`, generic spin; 0.17 % at 0.5); diverges from 3 or 4 (linear stability bound `2√2` on the imaginary axis) |
pub fn h_omega_limit(kind: IntegratorKind) -> f64 {
    match kind {
        IntegratorKind::Variational => 0.03,
        IntegratorKind::MoserVeselov => 0.7,
        IntegratorKind::Variational4 => 0.01,
        IntegratorKind::Variational6 => 0.01,
        IntegratorKind::Euler => 0.001,
        IntegratorKind::SemiImplicit => 0.001,
        IntegratorKind::Rk4 => 0.5,
    }
}

/// Rows of the stability map: inertia ratio `J_min / J_max`, then the limit of each integrator
/// (in [`IntegratorKind::ALL`] order: variational, moser-veselov, variational4, variational6,
/// euler, semi-implicit, rk4) over the map's cells of that ratio (both spin axes; at 0.5 the
/// flat disk and the asymmetric body together). `tests/integrator/stability.rs` checks every entry against
/// a freshly computed map ([`crate::stability::derived_limit_at_ratio`]).
pub const LIMITS_BY_RATIO: [(f64, [f64; 7]); 7] = [
    (1.0, [6.0, 0.7, 6.0, 6.0, 6.0, 6.0, 6.0]),
    (0.5, [1.0, 1.0, 1.0, 1.0, 0.001, 0.001, 0.7]),
    (0.1, [0.5, 1.0, 0.5, 0.7, 0.001, 0.001, 0.7]),
    (1e-2, [0.5, 1.0, 0.2, 0.3, 0.001, 0.001, 0.5]),
    (1e-3, [0.3, 1.0, 0.1, 0.1, 0.001, 0.001, 0.5]),
    (1e-4, [0.1, 1.0, 0.03, 0.03, 0.001, 0.001, 0.5]),
    (1e-6, [0.03, 1.0, 0.01, 0.01, 0.001, 0.001, 0.5]),
];

/// The limit of `h|Ω|` for a body of inertia ratio `J_min / J_max` (`inertia_ratio` in (0, 1]):
/// the smaller of the limits of the two map rows that bracket it (so between rows it is never
/// more permissive than either neighbour; below the last row, 1e-6, that row's). An exactly
/// isotropic body (ratio 1 to 1e-12) takes the isotropic row alone.
pub fn h_omega_limit_at_ratio(kind: IntegratorKind, inertia_ratio: f64) -> f64 {
    let col = IntegratorKind::ALL
        .iter()
        .position(|&k| k == kind)
        .unwrap_or(0);
    let r = inertia_ratio.clamp(0.0, 1.0);
    if r >= 1.0 - 1e-12 {
        return LIMITS_BY_RATIO[0].1[col];
    }
    let below = LIMITS_BY_RATIO.iter().position(|&(ratio, _)| ratio <= r);
    match below {
        Some(0) => LIMITS_BY_RATIO[0].1[col],
        Some(i) => LIMITS_BY_RATIO[i].1[col].min(LIMITS_BY_RATIO[i - 1].1[col]),
        None => LIMITS_BY_RATIO[LIMITS_BY_RATIO.len() - 1].1[col],
    }
}

/// `J_min / J_max` of principal moments.
pub fn inertia_ratio(principal_moments: &Vector3<f64>) -> f64 {
    principal_moments.min() / principal_moments.max()
}

/// The largest angular speed `|Ω|` (rad/s) a torque-free body with principal moments
/// `inertia_body` and body angular momentum `angmom_body` reaches on its exact orbit.
///
/// `x_i = M_i^2 >= 0` satisfies `Σ x_i = |M|^2` (momentum) and `Σ x_i / J_i = 2T` (energy),
/// both conserved; `|Ω|^2 = Σ x_i / J_i^2` is linear in `x`, so its maximum over that segment
/// of the simplex is at an end, where one `x_k = 0` (the orbit passes through both ends:
/// every Euler-equation orbit crosses the planes `M_k = 0` of the axes it does not circle).
pub fn spin_rate_max(inertia_body: &Vector3<f64>, angmom_body: &Vector3<f64>) -> f64 {
    let x = angmom_body.component_mul(angmom_body);
    let inv_j = inertia_body.map(|j| 1.0 / j);
    let l2 = x.sum();
    let two_t = x.dot(&inv_j);
    let mut best = x.dot(&inv_j.component_mul(&inv_j));
    for (i, j) in [(0, 1), (1, 2), (0, 2)] {
        let d = inv_j[i] - inv_j[j];
        if d.abs() <= 1e-12 * inv_j[i].abs().max(inv_j[j].abs()) {
            continue;
        }
        let xi = (two_t - l2 * inv_j[j]) / d;
        let xj = l2 - xi;
        let slack = -1e-12 * l2;
        if xi >= slack && xj >= slack {
            best = best.max(xi.max(0.0) * inv_j[i] * inv_j[i] + xj.max(0.0) * inv_j[j] * inv_j[j]);
        }
    }
    best.sqrt()
}

/// A step too large for some body's spin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepWarning {
    /// The body with the largest `h|Ω|max`.
    pub body: usize,
    /// Bodies over the limit.
    pub bodies_over: usize,
    /// Its largest angular speed on its orbit, rad/s.
    pub spin_rate_max: f64,
    /// `dt · spin_rate_max`, rad.
    pub h_omega: f64,
    /// The integrator's limit for that body's inertia ratio, rad.
    pub limit: f64,
    /// That body's inertia ratio `J_min / J_max`.
    pub inertia_ratio: f64,
    /// The largest step within the limit for every body, s.
    pub dt_safe: f64,
}

/// Checks every body's largest `h|Ω|` against the limit of `kind` for its inertia ratio
/// ([`h_omega_limit_at_ratio`]); reports the body furthest past its limit.
pub fn check_step(bodies: &Bodies, kind: IntegratorKind, dt_secs: f64) -> Option<StepWarning> {
    let over: Vec<StepWarning> = (0..bodies.len())
        .filter_map(|i| {
            let rate = spin_rate_max(&bodies.inertia_body[i], &bodies.angmom_body[i]);
            let ratio = inertia_ratio(&bodies.inertia_body[i]);
            let limit = h_omega_limit_at_ratio(kind, ratio);
            let h_omega = dt_secs.abs() * rate;
            (h_omega > limit).then_some(StepWarning {
                body: i,
                bodies_over: 0,
                spin_rate_max: rate,
                h_omega,
                limit,
                inertia_ratio: ratio,
                dt_safe: limit / rate,
            })
        })
        .collect();
    let worst = over.iter().min_by(|a, b| a.dt_safe.total_cmp(&b.dt_safe))?;
    Some(StepWarning {
        bodies_over: over.len(),
        ..*worst
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Between two rows the smaller limit applies; the isotropic row only for isotropic bodies;
    /// below the last row, the last row.
    #[test]
    fn limit_at_ratio_takes_the_bracketing_rows() {
        let v = IntegratorKind::Variational;
        assert_eq!(h_omega_limit_at_ratio(v, 1.0), 6.0);
        assert_eq!(h_omega_limit_at_ratio(v, 0.99), 1.0); // rows 1 (6.0) and 0.5 (1.0)
        assert_eq!(h_omega_limit_at_ratio(v, 0.5), 1.0);
        assert_eq!(h_omega_limit_at_ratio(v, 0.385), 0.5); // rows 0.5 (1.0) and 0.1 (0.5)
        assert_eq!(h_omega_limit_at_ratio(v, 1e-6), 0.03);
        assert_eq!(h_omega_limit_at_ratio(v, 1e-9), 0.03);
        assert_eq!(
            h_omega_limit_at_ratio(IntegratorKind::MoserVeselov, 0.99),
            0.7
        );
        assert_eq!(h_omega_limit(v), 0.03);
    }

    /// Against a brute-force maximum of `|J^-1 M|` over the exact orbit, traced by a fine
    /// integration of Euler's equations (RK4, 2e5 steps over several periods).
    #[test]
    fn spin_rate_max_matches_the_orbit() {
        let j = Vector3::new(1.0, 2.0, 3.0);
        for m0 in [
            Vector3::new(0.1, 2.0, 0.1), // near the intermediate axis: wide orbit
            Vector3::new(1.0, 0.2, 0.1), // around the minor axis
            Vector3::new(0.1, 0.3, 3.0), // around the major axis
        ] {
            let omega = |m: &Vector3<f64>| m.component_div(&j);
            let f = |m: &Vector3<f64>| m.cross(&omega(m));
            let (mut m, h) = (m0, 1e-4);
            let mut seen: f64 = 0.0;
            for _ in 0..200_000 {
                let k1 = f(&m);
                let k2 = f(&(m + k1 * (h / 2.0)));
                let k3 = f(&(m + k2 * (h / 2.0)));
                let k4 = f(&(m + k3 * h));
                m += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
                seen = seen.max(omega(&m).norm());
            }
            let bound = spin_rate_max(&j, &m0);
            // The traced maximum approaches the bound from below (sampling): measured
            // relative gaps below 1e-8.
            assert!(seen <= bound * (1.0 + 1e-9), "{m0}: {seen} > {bound}");
            assert!(seen >= bound * (1.0 - 1e-6), "{m0}: {seen} << {bound}");
        }
        // Isotropic: |Ω| is constant.
        let iso = Vector3::new(2.0, 2.0, 2.0);
        let m = Vector3::new(1.0, -2.0, 0.5);
        assert!((spin_rate_max(&iso, &m) - m.norm() / 2.0).abs() < 1e-15);
    }
}
