//! The exponential-map Lie-group variational integrator (the seed's scheme).
//!
//! Discrete Lagrangian per body (Kobilarov, Crane & Desbrun 2009, "Lie group integrators for
//! animation and control of vehicles", with the retraction τ = exp): with `R1 = R0 exp(ξ)`,
//! `L_d = ξ^T J ξ / (2h) - h V_d(c0, c1) + (translation, see [`super::translation`])`.
//! Varying `R_k → R_k exp(η_k)` changes `ξ_{k-1}` by `T(-ξ_{k-1})^-1 η_k` and `ξ_k` by
//! `-T(ξ_k)^-1 η_k` (right and left Jacobians of exp, [`crate::sim::so3`]); the discrete
//! Euler-Lagrange equations
//! `D2 L_d(q_{k-1}, q_k) + D1 L_d(q_k, q_{k+1}) = 0` become, with the body angular momentum
//! `M_k = T(ξ_k)^{-T} J ξ_k / h` (the discrete Legendre transform `-D1 L_d`):
//!
//! 1. solve `f(ξ) = J ξ - h T(ξ)^T M_k = 0` for `ξ` (Newton, warm-started from the previous `ξ`
//!    extrapolated with Euler's equations, see `predict`);
//! 2. `R_{k+1} = R_k exp(ξ)` (quaternion product, renormalised);
//! 3. `M_{k+1} = exp(ξ)^T M_k`.
//!
//! Step 3 and step 2 rotate by the same `exp(ξ)`, so the spatial angular momentum
//! `π = R_k M_k` is conserved to round-off whatever the Newton tolerance. Energy is not conserved
//! but bounded (no drift), error O(h^2); orientation converges with order 2.
//! Initial conditions: `M_0 = J Ω_0` (continuous Legendre transform), then `ξ_0` solves step 1;
//! taking `ξ_0 = h Ω_0` instead would make the momentum wrong by O(h).
//!
//! The Newton Jacobian is `∂f/∂ξ = J - h ∂(T(ξ)^T M)/∂ξ` in closed form
//! ([`so3::t_transpose_times_jacobian`](crate::sim::so3::t_transpose_times_jacobian)); the
//! seed's approximation `J T(ξ)^-1` (the seed's spatial `R^T M_I R T(hw)^-1` written in the
//! body frame) is kept as [`Jacobian::Approximate`]: cheaper per iteration, but only linearly
//! convergent.
//!
//! The cost of a step and what bounds it (benchmark history): `docs/variational_performance.md`.
//!
//! The files: `lanes.rs` (the SIMD lane types), `newton.rs` (the Newton core: residual,
//! Jacobians, solve, predictor, rotation), `substep.rs` (substepping of unconverged bodies),
//! `one_body.rs` (the one-body API the articulated step uses), `integrator.rs` ([`Variational`],
//! the [`Integrator`](super::Integrator) impl and the batched step); the settings are here.

mod integrator;
mod lanes;
mod newton;
mod one_body;
mod substep;
#[cfg(test)]
mod tests;
#[cfg(target_arch = "x86_64")]
mod vector;

pub use integrator::Variational;
pub use one_body::{NewtonSolve, RotationEval, solve_xi, solve3};

use super::translation::Potential;

/// The Newton Jacobian used by [`Variational`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Jacobian {
    /// `J - h ∂(T(ξ)^T M)/∂ξ`: quadratic convergence. The default.
    #[default]
    Analytic,
    /// The seed's `J T(ξ)^-1`: linear convergence, cheaper per iteration.
    Approximate,
}

impl Jacobian {
    pub fn name(self) -> &'static str {
        match self {
            Jacobian::Analytic => "analytic",
            Jacobian::Approximate => "approximate",
        }
    }
}

/// Settings of the variational integrator.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VariationalSettings {
    /// Newton stops when `|f(ξ)|_∞ <= newton_tol · h |M|_∞` (relative residual; tested as
    /// `|f(ξ)/h|_∞ <= newton_tol · |M|_∞`, component by component, so a NaN never passes).
    pub newton_tol: f64,
    /// Iteration cap. A solve that reaches it has not converged: the body's step is split
    /// into substeps (when `substep` is on), else counted in
    /// [`StepStats::newton_failures`](super::StepStats::newton_failures).
    pub newton_max_iters: u32,
    pub jacobian: Jacobian,
    pub potential: Potential,
    /// Automatic substepping: a body whose Newton solve does not converge within
    /// `newton_max_iters` redoes its step as 2, 4, 8, ... substeps of `h/n` (each a full
    /// variational step, so momentum stays exact) until every substep converges or `n` would
    /// exceed `max_substeps`. Counted in [`StepStats::substepped`](super::StepStats::substepped).
    /// Default on.
    pub substep: bool,
    /// Largest substep split factor tried (default 1024).
    pub max_substeps: u32,
}

impl Default for VariationalSettings {
    fn default() -> Self {
        Self {
            newton_tol: 1e-12,
            newton_max_iters: 10,
            jacobian: Jacobian::Analytic,
            potential: Potential::Symmetric,
            substep: true,
            max_substeps: 1024,
        }
    }
}
