//! The a priori orientation error model of the variational family, and the substep factor it
//! picks for a tolerance.
//!
//! # The model
//!
//! For a symmetric scheme of order `p` on a torque-free body, backward error analysis says the
//! numerical orbit is the exact orbit of a modified Hamiltonian `H + h^p K_p + …` (Hairer,
//! Lubich & Wanner, *Geometric Numerical Integration*, §IX.3 and §X.1; the variational family
//! keeps `|M|` and `π` exactly, so only `K_p` on the momentum sphere matters): the body-frame
//! momentum loop is deformed by `O(h^p)` (a bounded orientation error) and its two frequencies
//! (the loop's and the precession about `π`) are shifted by `O(h^p)`, so the phase error grows
//! linearly in time. With `ν` the body's fastest time scale on its exact orbit ([`time_scale`]:
//! its largest `|Ω|` plus the body-frame turning rate of `Ω`) the error over a run of `T` seconds
//! at step `h` is
//!
//! `e(h, T) = C (h ν)^p (ν T + B)` (leading term in `h`; `B` rad the bounded part),
//!
//! and everything but `C` is known from the body. `C` depends on the body's shape **and** its
//! state: measured over a fitting set (inertia ratios 1e-3 to 0.9, 30 shapes and spins per
//! ratio) a table `C(r)` spans four decades at a fixed ratio (a rod spinning about a transverse
//! axis is 100x worse than the median rod; spins near a principal axis are nearly exact), so it
//! would be 100-1000x pessimistic for most bodies. Instead `C` is measured per body, before the
//! run, by a **pilot**: the body alone, from its own initial state, at the pilot step
//! `h_1 = pilot_h_omega / max(ν, |M| / J_min)` (the second term: the stiffness of the step's
//! equation, a rod's spin about its axis is set by its smallest moment) and at `h_1 / 2`, over a
//! pilot time `T_1` (one loop of its momentum when it can be computed, clamped to `[20, 400] / ν`,
//! never longer than the run; at most [`PILOT_STEPS_MAX`] steps), with the error of the `h_1` run
//! estimated by Richardson extrapolation, `e_1(t) = |θ_{h1}(t) - θ_{h1/2}(t)| 2^p / (2^p - 1)`,
//! at 16 sample times. The linear growth carries it to the run's length:
//! `E = max_s e_1(t_s) (ν T + B) / (ν t_s + B)` over the samples of the pilot's second half
//! (every sample when the pilot is the whole run), and
//!
//! `e(h, T) = E (h / h_1)^p`.
//!
//! The pilot costs `1.5 T_1 / h_1` single-body steps (about 600 for a typical body, 30 000 at
//! most), independent of `dt` and `T`. An isotropic body (moments equal to 1e-12) is integrated
//! exactly by every scheme of the family (`ξ = h Ω` solves the step): `e = 0`, no pilot; so is a
//! body at rest.
//!
//! Validity: the `h^p` law holds in the asymptotic range; up to `h ν` = [`H_OMEGA_VALID`] it
//! overestimates (the error grows more slowly than `h^p` there, and saturates at O(1) rad), and
//! no factor is chosen with `h ν / k` above it. Validation on states no pilot saw
//! (`tests/integrator/accuracy.rs`, docs/accuracy.md, `docs/accuracy/validation.png`): achieved over
//! predicted error 0.63-1.34 wherever the prediction is below 0.1 rad, for the three orders.
//! Bodies breaking the triangle inequality (`J_i > J_j + J_k`, not physical) get pessimistic
//! predictions.

use crate::sim::integrators::VariationalSettings;
use crate::sim::limits::spin_rate_max;
use crate::sim::loads::Loads;
use crate::sim::reference::Asymmetric;
use crate::sim::{Bodies, BodyInit, IntegratorKind};
use nalgebra::{Isometry3, Vector3};

/// Largest per-substep `h ν` (rad, [`time_scale`]) a factor is chosen at.
pub const H_OMEGA_VALID: f64 = 0.5;

/// The bounded part of the error, rad of `W t` (see the module doc).
pub const BOUNDED_TERM: f64 = 2.0;

/// The factor is chosen so that `SAFETY` times the predicted error meets the tolerance: the
/// validation's largest achieved / predicted ratio is 1.34 (docs/accuracy.md).
pub const SAFETY: f64 = 2.0;

/// Largest substep factor chosen.
pub const MAX_FACTOR: u32 = 1 << 24;

/// Most steps of a pilot (the step grows past `h_1` when the pilot time needs more).
pub const PILOT_STEPS_MAX: u64 = 20_000;

/// Sample times of the pilot.
pub const PILOT_SAMPLES: u32 = 16;

/// Pilot time bounds, in units of `1 / W`.
pub const PILOT_TIME_MIN: f64 = 20.0;
pub const PILOT_TIME_MAX: f64 = 400.0;

/// `h_1 W` of the pilot: in the asymptotic range, and far enough above round-off for the order
/// (at 0.2 the sixth-order error of a nearly round body is still 1e-12 rad, above the 1e-14
/// round-off of the pilot).
pub fn pilot_h_omega(kind: IntegratorKind) -> f64 {
    match kind.order() {
        0..=2 => 0.05,
        3..=4 => 0.1,
        _ => 0.2,
    }
}

/// Whether `--accuracy` supports `kind` (the exponential-map variational family, whose pilot
/// extrapolation in `h` and time the validation covers).
pub fn supports(kind: IntegratorKind) -> bool {
    matches!(
        kind,
        IntegratorKind::Variational | IntegratorKind::Variational4 | IntegratorKind::Variational6
    )
}

/// The model. `scale` multiplies every prediction (1 for the model as validated; tests feed the
/// a posteriori check a too-optimistic model with a small scale).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorModel {
    pub scale: f64,
}

impl Default for ErrorModel {
    fn default() -> Self {
        Self { scale: 1.0 }
    }
}

/// A body's pilot: its error over the run at the pilot step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// `W`, rad/s.
    pub spin_rate_max: f64,
    /// `ν` ([`time_scale`]), rad/s.
    pub time_scale: f64,
    /// `h_1`, s (0 when the body needs no pilot).
    pub h_pilot_secs: f64,
    /// `E`: the predicted largest error over the run at step `h_1`, rad.
    pub error_at_pilot_rad: f64,
    /// Order `p`.
    pub order: u32,
}

impl Calibration {
    /// The predicted largest error over the run at step `h_secs`, rad.
    pub fn predicted_error(&self, h_secs: f64) -> f64 {
        if self.error_at_pilot_rad == 0.0 {
            return 0.0;
        }
        self.error_at_pilot_rad * (h_secs.abs() / self.h_pilot_secs).powi(self.order as i32)
    }
}

/// A body's chosen substep factor and the error the model predicts with it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Factor {
    pub k: u32,
    /// rad over the run.
    pub predicted_rad: f64,
}

/// The period (s) of the body-frame momentum loop, when it is finite and computable.
fn loop_period(inertia_body: &Vector3<f64>, angmom_body: &Vector3<f64>) -> Option<f64> {
    let omega = angmom_body.component_div(inertia_body);
    if let Some(a) = Asymmetric::new(*inertia_body, omega) {
        return Some(a.period_secs());
    }
    // Axisymmetric: the odd axis `c`, `Ω_⊥` turns at `Ω_c (1 - J_c / J_p)`.
    let j = inertia_body;
    let c = (0..3).find(|&c| {
        let (a, b) = (j[(c + 1) % 3], j[(c + 2) % 3]);
        (a - b).abs() <= 1e-12 * j.max()
    })?;
    let jp = j[(c + 1) % 3];
    let rate = (omega[c] * (1.0 - j[c] / jp)).abs();
    (rate > 0.0).then(|| 2.0 * std::f64::consts::PI / rate)
}

/// The body's fastest time scale on its exact orbit, rad/s: `ν = W + max |Ω'| / W` with
/// `Ω' = J^-1 (M × Ω)` (Euler's equations). `W` alone misses the body-frame turning of `Ω`: a
/// prolate body `(r, r, 1)` with `|Ω| = 1` turns its transverse `Ω` at `Ω_3 (1/r - 1)` in the
/// body frame, and the scheme's error follows that rate. Two moments equal: `|Ω'|` is constant,
/// `|Ω_c (1 - J_c/J_p)| |Ω_⊥|`; three distinct: the maximum over 64 points of the elliptic
/// `Ω(t)` over one period; near the separatrix (no closed form) the bound `W |M| / J_min`.
pub fn time_scale(inertia_body: &Vector3<f64>, angmom_body: &Vector3<f64>) -> f64 {
    let w = spin_rate_max(inertia_body, angmom_body);
    if w == 0.0 {
        return 0.0;
    }
    let rate = |omega: &Vector3<f64>| {
        let m = inertia_body.component_mul(omega);
        m.cross(omega).component_div(inertia_body).norm()
    };
    let omega0 = angmom_body.component_div(inertia_body);
    let dot_max = if isotropic(inertia_body) {
        0.0
    } else if let Some(a) = Asymmetric::new(*inertia_body, omega0) {
        let period = a.period_secs();
        (0..64)
            .map(|i| rate(&a.angvel_body(period * f64::from(i) / 64.0)))
            .fold(rate(&omega0), f64::max)
    } else if (0..3).any(|c| {
        let (a, b) = (inertia_body[(c + 1) % 3], inertia_body[(c + 2) % 3]);
        (a - b).abs() <= 1e-12 * inertia_body.max()
    }) {
        rate(&omega0)
    } else {
        w * angmom_body.norm() / inertia_body.min()
    };
    w + dot_max / w
}

/// Whether the moments are equal within 1e-12 relative (an isotropic body).
fn isotropic(inertia_body: &Vector3<f64>) -> bool {
    inertia_body.max() - inertia_body.min() <= 1e-12 * inertia_body.max()
}

impl ErrorModel {
    /// Runs the body's pilot for a run of `duration_secs` (module doc).
    pub fn calibrate(
        &self,
        kind: IntegratorKind,
        settings: &VariationalSettings,
        inertia_body: &Vector3<f64>,
        angmom_body: &Vector3<f64>,
        duration_secs: f64,
    ) -> Calibration {
        let w = spin_rate_max(inertia_body, angmom_body);
        let order = kind.order();
        let exact = Calibration {
            spin_rate_max: w,
            time_scale: 0.0,
            h_pilot_secs: 0.0,
            error_at_pilot_rad: 0.0,
            order,
        };
        if w == 0.0 || !w.is_finite() || isotropic(inertia_body) || duration_secs <= 0.0 {
            return exact;
        }
        let nu = time_scale(inertia_body, angmom_body);
        // The pilot step also resolves the stiffness `|M| / J_min` of the step's equation
        // (module doc): a rod's spin about its axis is set by its smallest moment.
        let stiff = nu.max(angmom_body.norm() / inertia_body.min());
        let h1 = pilot_h_omega(kind) / stiff;
        let loop_secs = loop_period(inertia_body, angmom_body).unwrap_or(PILOT_TIME_MAX / nu);
        let pilot_secs = loop_secs
            .clamp(PILOT_TIME_MIN / nu, PILOT_TIME_MAX / nu)
            .min(duration_secs);
        let steps =
            ((pilot_secs / h1).ceil() as u64).clamp(u64::from(PILOT_SAMPLES), PILOT_STEPS_MAX);
        let h1 = pilot_secs / steps as f64;
        let init = BodyInit {
            mass: 1.0,
            principal_moments: *inertia_body,
            world_from_body: Isometry3::identity(),
            linvel_world: Vector3::zeros(),
            angvel_world: angmom_body.component_div(inertia_body),
        };
        let mut coarse = Bodies::new(std::slice::from_ref(&init));
        let mut fine = coarse.clone();
        let mut step_coarse = kind.build(h1, settings);
        let mut step_fine = kind.build(h1 / 2.0, settings);
        step_coarse.init(&coarse);
        step_fine.init(&fine);
        let g = Loads::none();
        let richardson = f64::from(1u32 << order) / (f64::from(1u32 << order) - 1.0);
        let whole_run = pilot_secs >= duration_secs;
        let mut estimate: f64 = 0.0;
        for s in 1..=steps {
            step_coarse.step(&mut coarse, &g);
            step_fine.step(&mut fine, &g);
            step_fine.step(&mut fine, &g);
            let sample =
                s * u64::from(PILOT_SAMPLES) / steps != (s - 1) * u64::from(PILOT_SAMPLES) / steps;
            if !sample || (!whole_run && 2 * s < steps) {
                continue;
            }
            let e = coarse.world_from_body[0].angle_to(&fine.world_from_body[0]) * richardson;
            let t = s as f64 * h1;
            let grow = if whole_run {
                1.0
            } else {
                (nu * duration_secs + BOUNDED_TERM) / (nu * t + BOUNDED_TERM)
            };
            estimate = estimate.max(e * grow);
        }
        Calibration {
            spin_rate_max: w,
            time_scale: nu,
            h_pilot_secs: h1,
            error_at_pilot_rad: self.scale * estimate,
            order,
        }
    }

    /// The smallest factor `k` whose predicted error with steps of `dt_secs / k` over
    /// `duration_secs` is at most `tol_rad`, and never with `h W / k` above [`H_OMEGA_VALID`]
    /// (capped at [`MAX_FACTOR`]).
    pub fn factor(
        &self,
        kind: IntegratorKind,
        settings: &VariationalSettings,
        inertia_body: &Vector3<f64>,
        angmom_body: &Vector3<f64>,
        dt_secs: f64,
        duration_secs: f64,
        tol_rad: f64,
    ) -> Factor {
        let cal = self.calibrate(kind, settings, inertia_body, angmom_body, duration_secs);
        factor_from(&cal, dt_secs, tol_rad)
    }
}

/// The factor of [`ErrorModel::factor`] from a body's calibration.
pub fn factor_from(cal: &Calibration, dt_secs: f64, tol_rad: f64) -> Factor {
    let e1 = cal.predicted_error(dt_secs);
    if e1 == 0.0 {
        return Factor {
            k: 1,
            predicted_rad: 0.0,
        };
    }
    let p = f64::from(cal.order);
    let from_validity = (dt_secs.abs() * cal.time_scale / H_OMEGA_VALID)
        .ceil()
        .max(1.0);
    let tol_rad = tol_rad / SAFETY;
    let from_model = (e1 / tol_rad).powf(1.0 / p).ceil().max(1.0);
    let cap = f64::from(MAX_FACTOR);
    let mut k = from_model.max(from_validity).min(cap) as u32;
    let pred = |k: u32| e1 / f64::from(k).powf(p);
    // `powf` and `ceil` may land one off: settle on the smallest k that meets the tolerance.
    while f64::from(k) > from_validity && pred(k - 1) <= tol_rad {
        k -= 1;
    }
    while k < MAX_FACTOR && pred(k) > tol_rad {
        k += 1;
    }
    Factor {
        k,
        predicted_rad: pred(k),
    }
}
