//! The constrained discrete Euler-Lagrange step of one mechanism (see [`super`] for the
//! equations), solved by Newton on the per-body `ξ_i` and the multipliers `λ` together.
//!
//! Unknowns `ξ_i` (3 per body), `λ_j` (one per row), `μ_m` (one per mimic row). Residuals: the
//! free-body residual `f_i = (J_i/h) ξ_i − T(ξ_i)ᵀ M_i⁺(λ)` (scaled by `1/h`, as in
//! [`crate::sim::integrators::variational`]) and the rows `g(q_{k+1}(ξ, λ))`. Linearised, with
//! `A_i = ∂f_i/∂ξ_i`, `δξ_i = A_i⁻¹ (−f_i + T_iᵀ δM_i⁺)` and the end pose moving by
//! `[δc_i'; η_i'] = S_i δP_i + [0; e_i]`, `S_i = [(h/m_i) I, 0; 0, T_iᵀ A_i⁻¹ T_iᵀ]`,
//! `e_i = −T_iᵀ A_i⁻¹ f_i`, `δP = G(q_k)ᵀ δλ`, so Newton's system for `δλ` is
//!
//! ```text
//! G(q_{k+1}) S G(q_k)ᵀ δλ = −g − G(q_{k+1}) [0; e]
//! ```
//!
//! solved by [`super::tree`] in time linear in the joints; then `δξ` from the line above.
//! Quadratic convergence: 2-3 iterations per step from the warm start.
//!
//! Stopping rule (a NaN never passes): every `|f_i|_∞ <= tol · max(|M_i⁺|_∞, |M_i|_∞,
//! |τ_i|_∞, |J_i ξ_i/h|_∞)` (the free step's own relative rule, and the largest torque impulse
//! `τ_i` added to `M_i`: impulses that cancel leave round-off of their own size), every gap row `<= tol · L + 8 ε |c|_∞` (m; `L` the
//! mechanism's [`super::Mechanism::length_scale`], the second term the round-off of positions
//! far from the origin), every dot and mimic row `<= tol` (rad; m for a prismatic mimic, times
//! `L`). Then the solved root is checked against the spurious one with a reversed axis
//! ([`super::rows::JointRows::sign_ok`]).
//!
//! Guards (as for free bodies): a warm-started solve that does not converge within
//! `newton_max_iters`, whose residual grows tenfold after the second iteration, meets a
//! singular pivot, a non-finite value or the spurious root, is retried cold (`λ = 0`,
//! `ξ = h J⁻¹ M`); if that fails too, the step is split into `n = 2, 4, …, max_substeps`
//! constrained steps of `h/n` (with `substep`); a step that fails even then is a Newton
//! failure (the run's guard stops the run).
//!
//! Files: `warm.rs` (the warm start), `workspace.rs` (the buffers, named after their equations),
//! `assembly.rs` (the residuals and Jacobians at an iterate), `newton.rs` (the Newton loop, one
//! update, the commit); here, the step with its guards: warm, cold, substeps.

mod assembly;
#[cfg(test)]
mod drive_tests;
mod drives;
mod newton;
#[cfg(test)]
mod stop_tests;
mod stops;
#[cfg(test)]
pub(crate) mod tests;
mod warm;
mod workspace;

pub use drives::DriveWork;
pub(crate) use drives::time_only;
pub use stops::StopRows;
pub use warm::Warm;
pub use workspace::Workspace;

use super::Mechanism;
use crate::sim::Bodies;
use crate::sim::integrators::{StepStats, VariationalSettings};
use crate::sim::loads::Loads;

/// Why an attempt failed (for the statistics and tests).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failure {
    NotConverged,
    Diverging,
    Singular,
    NonFinite,
    SpuriousRoot,
}

/// One mechanism's mutable state: warm starts per step size and the workspace.
#[derive(Debug, Clone)]
pub struct MechanismState {
    pub ws: Workspace,
}

impl MechanismState {
    pub fn new(model: &Mechanism) -> Self {
        Self {
            ws: Workspace::new(model),
        }
    }

    /// The coordinates carried step to step, in the model's coordinate order (rad or m).
    pub fn coordinates(&self) -> &[f64] {
        &self.ws.coord_ref
    }
}

/// Result of one attempt.
type Attempt = Result<u32, (Failure, u32)>;

/// Advances one mechanism by `h`: warm-started Newton, then cold, then substeps (see the module
/// doc). Statistics are per mechanism-step: `newton_iters_max` its iterations; a failure, a
/// substepped step count once, with the mechanism's first body as `failed_body`.
pub fn step(
    model: &Mechanism,
    state: &mut MechanismState,
    warm: &mut Warm,
    bodies: &mut Bodies,
    h: f64,
    loads: &Loads,
    settings: &VariationalSettings,
) -> StepStats {
    let ws = &mut state.ws;
    let t0 = loads.time_secs();
    let range = model.bodies();
    let kicked = loads.loads_any(&range);
    if kicked {
        ws.load_work.begin();
        loads.kick(bodies, &range, t0, 0.5 * h, &mut ws.load_work);
    }
    ws.time0_secs = t0;
    let stats = step_unforced(model, ws, warm, bodies, h, loads, settings);
    if kicked {
        ws.load_work.end();
        loads.kick(bodies, &range, t0 + h, 0.5 * h, &mut ws.load_work);
    }
    stats
}

/// The poses one [`step`] of `model` reaches from the batch's state with the impulses `kicks`
/// (per local body, `[linear (world); angular (body frame)]`) added to its momenta first,
/// written to `out` per body (centre of mass, rotation); the batch is left as it was. With
/// its own `state` and `warm`, the run's are untouched. The contact phase's prediction of a
/// robot's motion over a step ([`crate::sim::contact`]).
#[allow(clippy::too_many_arguments)]
pub fn predict(
    model: &Mechanism,
    state: &mut MechanismState,
    warm: &mut Warm,
    bodies: &mut Bodies,
    h: f64,
    loads: &Loads,
    settings: &VariationalSettings,
    kicks: &[nalgebra::SVector<f64, 6>],
    out: &mut [(nalgebra::Vector3<f64>, nalgebra::UnitQuaternion<f64>)],
) -> StepStats {
    state.ws.save(model, bodies);
    let first = model.first_body;
    super::constrained::add_impulses(bodies, first, kicks);
    let stats = step(model, state, warm, bodies, h, loads, settings);
    for (i, o) in out.iter_mut().enumerate() {
        let gi = first + i;
        *o = (bodies.com_world[gi], bodies.world_from_body[gi]);
    }
    // The coordinates' references and the stops' modes follow the predicted step (a continuous
    // joint stays on its branch, a joint at its limit stays there); the bodies go back.
    state.ws.keep_references();
    state.ws.restore(model, bodies);
    stats
}

/// [`step`] between the applied loads' kicks (the joint drives are in the solve). A split step
/// keeps the kicks of the whole step around its substeps (Strang splitting: still second order,
/// momentum still exact).
fn step_unforced(
    model: &Mechanism,
    ws: &mut Workspace,
    warm: &mut Warm,
    bodies: &mut Bodies,
    h: f64,
    loads: &Loads,
    settings: &VariationalSettings,
) -> StepStats {
    let mut stats = StepStats::default();
    let warm_start = warm.valid.then_some(&*warm);
    let first = ws.attempt(model, bodies, h, loads, settings, warm_start);
    let outcome = match first {
        Ok(it) => Ok(it),
        Err((_, it)) if warm.valid => {
            stats.newton_iters_max = it;
            ws.attempt(model, bodies, h, loads, settings, None)
        }
        Err(e) => Err(e),
    };
    match outcome {
        Ok(it) => {
            stats.newton_iters_max = stats.newton_iters_max.max(it);
            ws.commit(model, bodies, h, loads, warm);
            stats
        }
        Err((_, it)) => {
            stats.newton_iters_max = stats.newton_iters_max.max(it);
            if !settings.substep {
                // As for free bodies without substepping: the unconverged iterate is used.
                ws.commit(model, bodies, h, loads, warm);
                warm.valid = false;
                stats.add_solve(model.first_body, it, false);
                return stats;
            }
            split(model, ws, warm, bodies, h, loads, settings, &mut stats);
            ws.time0_secs = loads.time_secs();
            stats
        }
    }
}

/// The substep guard: `n = 2, 4, …` constrained steps of `h/n`, the first split at which every
/// substep converges kept.
#[allow(clippy::too_many_arguments)]
#[cold]
fn split(
    model: &Mechanism,
    ws: &mut Workspace,
    warm: &mut Warm,
    bodies: &mut Bodies,
    h: f64,
    loads: &Loads,
    settings: &VariationalSettings,
    stats: &mut StepStats,
) {
    ws.save(model, bodies);
    stats.substepped += 1;
    let mut n = 2u32;
    while n <= settings.max_substeps {
        let hs = h / f64::from(n);
        let mut sub_warm = Warm::new(model);
        let mut ok = true;
        for s in 0..n {
            ws.time0_secs = loads.time_secs() + f64::from(s) * hs;
            let start = sub_warm.valid.then_some(&sub_warm);
            let mut result = ws.attempt(model, bodies, hs, loads, settings, start);
            if result.is_err() && sub_warm.valid {
                result = ws.attempt(model, bodies, hs, loads, settings, None);
            }
            match result {
                Ok(it) => {
                    stats.newton_iters_max = stats.newton_iters_max.max(it);
                    ws.commit(model, bodies, hs, loads, &mut sub_warm);
                }
                Err(_) => {
                    ok = false;
                    break;
                }
            }
        }
        if ok {
            stats.substep_factor_max = stats.substep_factor_max.max(n);
            // The next full step's warm start: the last substep's, scaled to the full step.
            sub_warm.scale(f64::from(n));
            *warm = sub_warm;
            return;
        }
        ws.restore(model, bodies);
        n *= 2;
    }
    stats.substep_factor_max = stats.substep_factor_max.max(settings.max_substeps);
    warm.valid = false;
    stats.add_solve(model.first_body, settings.newton_max_iters, false);
}
