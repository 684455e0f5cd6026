//! The Moser–Veselov discrete rigid body, solved through the Cayley parameter.
//!
//! **Discrete Lagrangian** (Moser & Veselov 1991, "Discrete versions of some classical integrable
//! systems and factorization of matrix polynomials", Comm. Math. Phys. 139, 217–243; written for
//! a body-fixed step as in Lee, Leok & McClamroch 2007, "Lie group variational integrators for the
//! full body problem", CMAME 196, 2907–2924): with the body-frame increment `F_k = R_k^T R_{k+1}`,
//!
//! `L_d(R_k, R_{k+1}) = tr((I - F_k) J_d) / h`, `J_d = tr(J)/2 · I - J` (so `J = tr(J_d) I - J_d`).
//!
//! For `F = exp(hΩ^)`, `tr((I - F) J_d) = h^2 Ω^T J Ω / 2 + O(h^3)`, so `L_d ≈ h · (kinetic energy)`.
//!
//! **Discrete Euler–Lagrange equations** (Lee, Leok & McClamroch 2007, free rigid body;
//! Hairer, Lubich & Wanner, *Geometric Numerical Integration*, 2nd ed., §VII.5, the discrete
//! Moser–Veselov algorithm): with the body angular momentum `Π_k` (= [`Bodies::angmom_body`]),
//!
//! 1. solve `h Π_k^ = F_k J_d - J_d F_k^T` for `F_k ∈ SO(3)`;
//! 2. `R_{k+1} = R_k F_k`;
//! 3. `Π_{k+1} = F_k^T Π_k`.
//!
//! Steps 2 and 3 rotate by the same `F_k`, so the spatial momentum `R_k Π_k` is conserved to
//! round-off (as in every scheme of the variational family).
//!
//! **The solve.** With the Cayley parameter `f` (`F = (I + f^)(I - f^)^-1`, the rotation by
//! `2 atan|f|` about `f`, unit quaternion `(1, f)/sqrt(1 + |f|^2)`), multiplying step 1 by
//! `(I - f^)` on the left and `(I + f^)` on the right turns it into the quadratic vector equation
//! (the Cayley-parameter solve of Lee, Leok & McClamroch 2007; for quaternion and Cayley
//! parametrisations of such implicit rigid-body steps see also Lewis & Simo 1994, "Conserving
//! algorithms for the dynamics of Hamiltonian systems on Lie groups", J. Nonlinear Sci. 4, 253–299)
//!
//! `G(f) = 2 J f - h Π - h Π × f - h (Π·f) f = 0`,
//!
//! solved by Newton with the exact Jacobian `G'(f) = 2J - h Π^ - h f Π^T - h (Π·f) I`,
//! warm-started from the previous step's `f` (cold start `f = h Ω / 2`). No trigonometry at all:
//! the quaternion of `F` is built from `f` with one square root.
//!
//! **The exactly conserved energy.** Write `F`'s unit quaternion as `(w, v)` (`f = v/w`). Then
//! `F J_d - J_d F^T = (2w J v + 2 v × J v)^`, so step 1 reads `h Π_k = 2w J v + 2 v × J v`, and by
//! the same identity for `F^T` (quaternion `(w, -v)`), `h Π_{k+1} = h F^T Π_k = 2w J v - 2 v × J v`.
//! The two differ only in the sign of `v × J v`, and the cross term of the energy vanishes:
//! `(J v)^T J^-1 (v × J v) = v · (v × J v) = 0`. Hence
//!
//! `Π_{k+1}^T J^-1 Π_{k+1} = Π_k^T J^-1 Π_k`:
//!
//! the scheme conserves the **true** kinetic energy `E = Π^T J^-1 Π / 2` exactly (up to round-off
//! and the Newton tolerance), as well as `|Π|`. So `Π_k` stays on the exact body-frame orbit (the
//! intersection of the energy ellipsoid and the momentum sphere) and its only error is a phase
//! (time-reparametrisation) error, O(h^2) (McLachlan & Zanna 2005, "The discrete Moser–Veselov
//! algorithm for the free rigid body, revisited", Found. Comput. Math. 5, 87–123).
//! Global order 2 in orientation.
//!
//! **Step limit.** The image of `F ↦ F J_d - J_d F^T` is bounded, so step 1 has no solution for
//! too large `h |Π|`: for a spin about principal axis `i` it reads `h J_i Ω_i = J_i sin θ` (θ the
//! rotation angle of `F`), so `h |Ω| <= 1` is required, and the step rotates by `asin(h Ω)`
//! instead of `h Ω` (the phase error above). Beyond it Newton fails, which is counted in
//! [`StepStats::newton_failures`]. Bodies violating the triangle inequality of inertia
//! (`J_3 > J_1 + J_2`, an indefinite `J_d`) are not refused; they have their own limit (for
//! `J = (1, 2, 3.5)`, `Π = (0.4, 2.5, -1.2)` Newton found no solution at `h|Ω| = 1.35`).
//!
//! Initial conditions: `Π_0 = J Ω_0` (as stored in [`Bodies`]). Translation: Störmer–Verlet
//! ([`step_translation`] with the configured [`super::Potential`], symmetric by default: exact parabola).

use super::translation::step_translation;
use super::{Integrator, StepStats, VariationalSettings, step_blocks_watched};
use crate::sim::Bodies;
use crate::sim::guard::Watch;
use crate::sim::loads::Loads;
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use std::ops::Range;

/// Result of one Cayley-parameter Newton solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CayleySolve {
    /// The Cayley parameter `f` of `F` (`|f| = tan(θ/2)`).
    pub f: Vector3<f64>,
    /// Newton updates applied.
    pub iterations: u32,
    pub converged: bool,
}

/// The residual `G(f) = 2 J f - h Π - h Π × f - h (Π·f) f`, with `h_pi = h Π`.
#[inline]
pub fn cayley_residual(
    inertia_body: &Vector3<f64>,
    h_pi: &Vector3<f64>,
    f: &Vector3<f64>,
) -> Vector3<f64> {
    inertia_body.component_mul(f) * 2.0 - h_pi - h_pi.cross(f) - f * h_pi.dot(f)
}

/// Solves `2 J f = h Π + h Π × f + h (Π·f) f` for the Cayley parameter `f` by Newton, starting
/// from `f_guess`. Stops when `|G(f)|_∞ <= newton_tol · h |Π|_∞` (relative residual, the same
/// criterion as the `variational` Newton solve).
pub fn solve_cayley(
    inertia_body: &Vector3<f64>,
    angmom_body: &Vector3<f64>,
    dt_secs: f64,
    f_guess: &Vector3<f64>,
    settings: &VariationalSettings,
) -> CayleySolve {
    let h_pi = angmom_body * dt_secs;
    let tol = settings.newton_tol * h_pi.amax();
    let mut f = *f_guess;
    let mut iterations = 0;
    loop {
        let residual = cayley_residual(inertia_body, &h_pi, &f);
        let res_max = residual.amax();
        let converged = res_max <= tol;
        if converged {
            return CayleySolve {
                f,
                iterations,
                converged: true,
            };
        }
        if iterations >= settings.newton_max_iters || !res_max.is_finite() {
            return CayleySolve {
                f,
                iterations,
                converged,
            };
        }
        let jacobian = Matrix3::from_diagonal(&(inertia_body * 2.0))
            - skew(&h_pi)
            - f * h_pi.transpose()
            - Matrix3::from_diagonal_element(h_pi.dot(&f));
        match solve3(&jacobian, &residual) {
            Some(delta) => f -= delta,
            None => {
                return CayleySolve {
                    f,
                    iterations,
                    converged,
                };
            }
        }
        iterations += 1;
    }
}

/// The unit quaternion of the Cayley rotation `(I + f^)(I - f^)^-1`: `(1, f) / sqrt(1 + |f|^2)`.
#[inline]
pub fn cayley_quaternion(f: &Vector3<f64>) -> UnitQuaternion<f64> {
    let w = 1.0 / (1.0 + f.norm_squared()).sqrt();
    UnitQuaternion::new_unchecked(Quaternion::new(w, w * f.x, w * f.y, w * f.z))
}

/// `x^`, the skew matrix with `x^ y = x × y`.
#[inline]
fn skew(x: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -x.z, x.y, x.z, 0.0, -x.x, -x.y, x.x, 0.0)
}

/// Solves the 3x3 system `a x = b` by the adjugate (Cramer); `None` when `a` is singular.
#[inline]
fn solve3(a: &Matrix3<f64>, b: &Vector3<f64>) -> Option<Vector3<f64>> {
    let c0 = a.column(1).cross(&a.column(2));
    let c1 = a.column(2).cross(&a.column(0));
    let c2 = a.column(0).cross(&a.column(1));
    let det = a.column(0).dot(&c0);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    // Rows of a^-1 are c_i / det.
    Some(Vector3::new(c0.dot(b), c1.dot(b), c2.dot(b)) / det)
}

/// The substepping guard (see [`VariationalSettings::substep`]): the step of `h` redone as
/// `n = 2, 4, ... <= max_substeps` Moser–Veselov steps of `h/n` (each from the cold start
/// `f = h Ω / 2n`), until every solve converges. Returns the composed rotation, the last
/// substep's `f`, `n` and the most Newton iterations of a substep; `None` when no split works.
fn substep_cayley(
    inertia_body: &Vector3<f64>,
    angmom_body: &Vector3<f64>,
    dt_secs: f64,
    settings: &VariationalSettings,
) -> Option<(UnitQuaternion<f64>, Vector3<f64>, u32, u32)> {
    let mut n = 2;
    while n <= settings.max_substeps {
        if let Some((rotation, f, iterations)) =
            cayley_substeps(inertia_body, angmom_body, dt_secs, n, settings)
        {
            return Some((rotation, f, n, iterations));
        }
        n *= 2;
    }
    None
}

/// `n` Moser–Veselov steps of `dt_secs / n` from `angmom_body`: the composed rotation, the last
/// `f`, the most Newton iterations; `None` when a solve fails.
fn cayley_substeps(
    inertia_body: &Vector3<f64>,
    angmom_body: &Vector3<f64>,
    dt_secs: f64,
    n: u32,
    settings: &VariationalSettings,
) -> Option<(UnitQuaternion<f64>, Vector3<f64>, u32)> {
    let h = dt_secs / f64::from(n);
    let mut pi = *angmom_body;
    let mut rotation = UnitQuaternion::identity();
    let mut f = Vector3::zeros();
    let mut iterations = 0;
    for _ in 0..n {
        let guess = pi.component_div(inertia_body) * (0.5 * h);
        let solve = solve_cayley(inertia_body, &pi, h, &guess, settings);
        iterations = iterations.max(solve.iterations);
        if !solve.converged {
            return None;
        }
        let step = cayley_quaternion(&solve.f);
        rotation *= step;
        pi = step.inverse_transform_vector(&pi);
        f = solve.f;
    }
    rotation.renormalize();
    Some((rotation, f, iterations))
}

/// The Moser–Veselov integrator over a batch.
#[derive(Debug, Clone)]
pub struct MoserVeselov {
    /// Newton tolerance and iteration cap, and the translation's potential quadrature
    /// (the Jacobian setting does not apply: the Cayley Jacobian is always exact).
    pub settings: VariationalSettings,
    dt_secs: f64,
    /// Per body: the last solved Cayley parameter (warm start of the next solve).
    f: Vec<Vector3<f64>>,
    /// The work of the applied loads ([`Loads::forced_step`]).
    ledger: crate::sim::loads::KickLedger,
}

impl MoserVeselov {
    pub fn new(dt_secs: f64, settings: VariationalSettings) -> Self {
        Self {
            settings,
            dt_secs,
            f: Vec::new(),
            ledger: Default::default(),
        }
    }

    /// One step of the bodies `range` of the batch (after [`Integrator::init`] of the batch).
    fn step_range(&mut self, bodies: &mut Bodies, range: Range<usize>, loads: &Loads) -> StepStats {
        let mut ledger = std::mem::take(&mut self.ledger);
        let stats = loads.forced_step(bodies, &range, self.dt_secs, &mut ledger, |b| {
            self.step_range_unforced(b, range.clone(), loads)
        });
        self.ledger = ledger;
        stats
    }

    /// [`MoserVeselov::step_range`] without the applied loads' kicks.
    fn step_range_unforced(
        &mut self,
        bodies: &mut Bodies,
        range: Range<usize>,
        loads: &Loads,
    ) -> StepStats {
        let mut stats = StepStats::default();
        for i in range.clone() {
            let pi = bodies.angmom_body[i];
            let j = bodies.inertia_body[i];
            let solve = solve_cayley(&j, &pi, self.dt_secs, &self.f[i], &self.settings);
            let (rotation, f_next) = if solve.converged || !self.settings.substep {
                stats.add_solve(i, solve.iterations, solve.converged);
                (cayley_quaternion(&solve.f), solve.f)
            } else {
                stats.newton_iters_max = stats.newton_iters_max.max(solve.iterations);
                stats.substepped += 1;
                match substep_cayley(&j, &pi, self.dt_secs, &self.settings) {
                    Some((rotation, f, n, iterations)) => {
                        stats.newton_iters_max = stats.newton_iters_max.max(iterations);
                        stats.substep_factor_max = stats.substep_factor_max.max(n);
                        (rotation, f * f64::from(n))
                    }
                    None => {
                        stats.substep_factor_max =
                            stats.substep_factor_max.max(self.settings.max_substeps);
                        stats.add_solve(i, solve.iterations, false);
                        (cayley_quaternion(&solve.f), solve.f)
                    }
                }
            };
            let q = &mut bodies.world_from_body[i];
            *q *= rotation;
            q.renormalize();
            bodies.angmom_body[i] = rotation.inverse_transform_vector(&pi);
            self.f[i] = f_next;
        }
        step_translation(
            &mut bodies.com_world[range.clone()],
            &mut bodies.linvel_world[range],
            self.dt_secs,
            loads,
            self.settings.potential,
        );
        stats
    }
}

impl Integrator for MoserVeselov {
    /// The potential's quadrature ([`crate::sim::integrators::translation::Potential::alpha`]).
    fn gravity_drift(&self) -> f64 {
        self.settings.potential.alpha()
    }

    fn name(&self) -> &'static str {
        "moser-veselov"
    }

    fn dt(&self) -> f64 {
        self.dt_secs
    }

    fn init(&mut self, bodies: &Bodies) {
        // Cold start f = hΩ/2 (the first-order solution); the first step refines it.
        self.f = (0..bodies.len())
            .map(|i| bodies.angvel_body(i) * (0.5 * self.dt_secs))
            .collect();
    }

    fn step(&mut self, bodies: &mut Bodies, loads: &Loads) -> StepStats {
        if self.f.len() != bodies.len() {
            self.init(bodies);
        }
        self.step_range(bodies, 0..bodies.len(), loads)
    }

    fn step_watched(
        &mut self,
        bodies: &mut Bodies,
        loads: &Loads,
        watch: &Watch,
    ) -> (StepStats, bool) {
        if self.f.len() != bodies.len() {
            self.init(bodies);
        }
        step_blocks_watched(bodies, watch, |bodies, range| {
            self.step_range(bodies, range, loads)
        })
    }

    fn energy_flow(&self) -> crate::sim::integrators::EnergyFlow {
        crate::sim::integrators::EnergyFlow {
            input_work: self.ledger.work,
            dissipated: 0.0,
            ..Default::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn moments_and_momentum() -> (Vector3<f64>, Vector3<f64>) {
        (Vector3::new(1.0, 2.0, 2.5), Vector3::new(0.4, 2.5, -1.2))
    }

    /// Beyond the step limit (module docs) there is no solution, and the failure is reported:
    /// a spin `Ω` about a principal axis needs `h Ω <= 1`.
    #[test]
    fn no_solution_beyond_the_step_limit_is_reported() {
        let j = Vector3::new(1.0, 2.0, 2.5);
        let settings = VariationalSettings::default();
        for (h, solvable) in [(0.9, true), (1.1, false)] {
            let pi = Vector3::new(0.0, 2.0, 0.0); // Ω = 1 rad/s about axis 2
            let solve = solve_cayley(&j, &pi, h, &(pi.component_div(&j) * (0.5 * h)), &settings);
            assert_eq!(solve.converged, solvable, "h = {h}: {solve:?}");
            if solvable {
                // The rotation angle is asin(hΩ), not hΩ: 2 atan|f| = asin(0.9) = 1.1198 rad.
                let angle = 2.0 * solve.f.norm().atan();
                assert!((angle - 0.9f64.asin()).abs() < 1e-12, "{angle}");
            }
        }
    }

    /// The Cayley form solves the matrix equation `h Π^ = F J_d - J_d F^T` it was derived from.
    #[test]
    fn cayley_solution_satisfies_the_matrix_equation() {
        let (j, pi) = moments_and_momentum();
        let h = 0.3;
        let settings = VariationalSettings {
            newton_tol: 1e-14,
            newton_max_iters: 50,
            ..Default::default()
        };
        let guess = pi.component_div(&j) * (0.5 * h);
        let solve = solve_cayley(&j, &pi, h, &guess, &settings);
        assert!(solve.converged);
        let f_mat = cayley_quaternion(&solve.f)
            .to_rotation_matrix()
            .into_inner();
        let j_d = Matrix3::from_diagonal_element(j.sum() / 2.0) - Matrix3::from_diagonal(&j);
        let lhs = skew(&(pi * h));
        let rhs = f_mat * j_d - j_d * f_mat.transpose();
        // Round-off: measured 1.1e-16.
        assert!((lhs - rhs).amax() < 1e-14, "{}", lhs - rhs);
        // Quadratic convergence from the first-order guess at h|Ω| ≈ 0.4: measured 3 updates.
        assert!(solve.iterations <= 5, "{}", solve.iterations);
    }

    /// One step conserves `Π^T J^-1 Π` and `|Π|` (the identity in the module docs), even at a
    /// large step `h|Ω| ≈ 0.8`.
    #[test]
    fn one_step_conserves_kinetic_energy_and_momentum_norm() {
        let (j, pi) = moments_and_momentum();
        let h = 0.6;
        let settings = VariationalSettings {
            newton_tol: 1e-14,
            newton_max_iters: 50,
            ..Default::default()
        };
        let solve = solve_cayley(&j, &pi, h, &(pi.component_div(&j) * 0.5), &settings);
        assert!(solve.converged);
        let pi1 = cayley_quaternion(&solve.f).inverse_transform_vector(&pi);
        let e = |p: &Vector3<f64>| 0.5 * p.dot(&p.component_div(&j));
        // Round-off: measured 1.2e-16 and 1.6e-16 relative.
        assert!((e(&pi1) - e(&pi)).abs() < 1e-14 * e(&pi));
        assert!((pi1.norm() - pi.norm()).abs() < 1e-14 * pi.norm());
        // The step really moved Π (not a trivial identity): measured |ΔΠ| = 0.65.
        assert!((pi1 - pi).norm() > 0.3);
    }
}
