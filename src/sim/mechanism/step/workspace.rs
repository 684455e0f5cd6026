//! [`Workspace`]: the buffers of one mechanism's step, named after the equations they hold, and
//! the body state saved before a split step.

use super::super::Mechanism;
use super::super::rows::{BodyPose, RowJacobian, RowValues};
use super::super::tree::{Compliance, ExtraRow, TreeSolver};
use crate::sim::Bodies;
use crate::sim::integrators::variational::RotationEval;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// Buffers of one mechanism's step, sized once. Indices: `i` a body of the mechanism (local), `j`
/// a joint, `m` a mimic row; `k` is the start of the step, `k + 1` (`next`) its end. The
/// equations are those of the module doc and of [`super`].
#[derive(Debug, Clone)]
pub struct Workspace {
    /// `q_k`: each body's pose (`R_i`, `c_i`) at the start of the step.
    pub(super) pose_k: Vec<BodyPose>,
    /// `q_{k+1}(ξ, λ)`: each body's pose at the end, `R_i exp(ξ_i)` and
    /// `c_i + h v_i⁺ + α h² g`, at the current iterate.
    pub(super) pose_next: Vec<BodyPose>,
    /// `R_i exp(ξ_i)` as a quaternion, at the current iterate (the commit takes the renormalised
    /// one from [`RotationEval::advance`]).
    pub(super) rot_next: Vec<UnitQuaternion<f64>>,
    /// `G(q_k)`: each joint's row Jacobian at the start poses, (parent block, child block); the
    /// impulses are `G(q_k)ᵀ λ`.
    pub(super) jac_k: Vec<(RowJacobian, RowJacobian)>,
    /// `G(q_{k+1})`: each joint's row Jacobian at the end poses, (parent block, child block).
    pub(super) jac_next: Vec<(RowJacobian, RowJacobian)>,
    /// The mimic rows' gradients at `q_k` (the mimic impulses are their transpose times `μ`).
    pub(super) mimic_jac_k: Vec<ExtraRow>,
    /// The mimic rows' gradients at `q_{k+1}`.
    pub(super) mimic_jac_next: Vec<ExtraRow>,
    /// `g(q_{k+1})`: each joint's constraint rows at the end poses (zero when solved).
    pub(super) constraint_residual: Vec<RowValues>,
    /// Each mimic row's value at the end poses, `θ_follower − k θ_leader − offset`.
    pub(super) mimic_residual: Vec<f64>,
    /// `M_i⁺ = M_i + G_ηᵀ λ` (+ mimic rows): body angular momentum after the start impulses.
    pub(super) angmom_plus: Vec<Vector3<f64>>,
    /// Per body: the largest torque impulse added to `M` (its round-off sets the floor of the
    /// free-step residual's tolerance).
    pub(super) impulse_scale: Vec<f64>,
    /// Per body, `Σ |G_η,r| |λ_r|` over every row acting on it (per component): the size of
    /// the terms summed into its torque impulse, whose round-off floors its free residual.
    pub(super) torque_terms: Vec<Vector3<f64>>,
    /// `v_i⁺ = v_i + G_cᵀ λ / m_i` (+ mimic rows): velocity after the start impulses.
    pub(super) linvel_plus: Vec<Vector3<f64>>,
    /// The unknowns `ξ_i`: each body's rotation over the step, `R_i' = R_i exp(ξ_i)`.
    pub(super) xi: Vec<Vector3<f64>>,
    /// The unknowns `λ_j`: each joint's multipliers (impulses).
    pub(super) lambda: Vec<RowValues>,
    /// The unknowns `μ_m`: each mimic row's multiplier.
    pub(super) mu: Vec<f64>,
    /// The free-body step of each body evaluated at `ξ_i` with `M_i⁺`: the residual, the
    /// Jacobian `A_i`, `T(ξ_i)ᵀ` and the end rotation.
    pub(super) free_evals: Vec<RotationEval>,
    /// `f_i = (J_i/h) ξ_i − T(ξ_i)ᵀ M_i⁺`: the free-body residual (scaled by `1/h`).
    pub(super) free_residual: Vec<Vector3<f64>>,
    /// `A_i⁻¹ = (∂f_i/∂ξ_i)⁻¹`.
    pub(super) free_jacobian_inv: Vec<Matrix3<f64>>,
    /// `T_iᵀ = T(ξ_i)ᵀ`: maps `δξ_i` to the end orientation's variation `η_i'`.
    pub(super) t_transpose: Vec<Matrix3<f64>>,
    /// `e_i = −T_iᵀ A_i⁻¹ f_i`: the end orientation's variation from the free-body Newton
    /// step alone (at fixed `λ`).
    pub(super) eta_fixed_lambda: Vec<Vector3<f64>>,
    /// `S_i = [(h/m_i) I, 0; 0, T_iᵀ A_i⁻¹ T_iᵀ]`: how the end pose moves with the impulse,
    /// `[δc_i'; η_i'] = S_i δP_i + [0; e_i]`.
    pub(super) compliance: Vec<Compliance>,
    /// Newton's right-hand side `−g − G(q_{k+1}) [0; e]` per joint, overwritten by the solve of
    /// `G(q_{k+1}) S G(q_k)ᵀ δλ = −g − G(q_{k+1}) [0; e]` with the increment `δλ`.
    pub(super) delta_lambda: Vec<RowValues>,
    /// The same for the mimic rows: their right-hand side, then the increment `δμ`.
    pub(super) delta_mu: Vec<f64>,
    /// `δM_i⁺ = G_ηᵀ δλ` (+ mimic rows); then `δξ_i = A_i⁻¹ (T_iᵀ δM_i⁺ − f_i)`.
    pub(super) delta_angmom_plus: Vec<Vector3<f64>>,
    /// The linear-time solve of Newton's system for `δλ`, `δμ` ([`super::tree`]).
    pub(super) solver: TreeSolver,
    /// Unwrapped coordinate values at the current configuration (mimic references).
    pub coord_ref: Vec<f64>,
    /// Coordinate values at the end poses (scratch for the start's mimic rows).
    pub(super) coord_next: Vec<f64>,
    /// The drive rows ([`super::drives`]).
    pub(super) drives: super::drives::DriveRows,
    /// The stop rows: limits and friction ([`super::stops`]).
    pub stops: super::stops::StopRows,
    /// The time at the start of the step (or substep) being solved, s.
    pub(super) time0_secs: f64,
    /// The drives' work and dissipation so far.
    pub drive_work: super::drives::DriveWork,
    /// The work of applied loads on the mechanism's bodies so far.
    pub load_work: crate::sim::loads::KickLedger,
    /// Body state saved before a split step.
    backup: Backup,
    backup_coords: Vec<f64>,
    backup_modes: Vec<super::super::StopMode>,
    backup_rates: Vec<f64>,
}

#[derive(Debug, Clone, Default)]
struct Backup {
    q: Vec<UnitQuaternion<f64>>,
    m: Vec<Vector3<f64>>,
    c: Vec<Vector3<f64>>,
    v: Vec<Vector3<f64>>,
}

impl Workspace {
    pub fn new(model: &Mechanism) -> Self {
        let (n, nj, nm) = (model.body_count, model.joints.len(), model.mimics.len());
        let zero_eval = RotationEval::new(
            &Vector3::new(1.0, 1.0, 1.0),
            &Vector3::zeros(),
            1.0,
            &Vector3::zeros(),
        );
        let zj = (RowJacobian::zeros(), RowJacobian::zeros());
        Self {
            pose_k: vec![BodyPose::identity(); n],
            pose_next: vec![BodyPose::identity(); n],
            rot_next: vec![UnitQuaternion::identity(); n],
            jac_k: vec![zj; nj],
            jac_next: vec![zj; nj],
            mimic_jac_k: vec![ExtraRow::default(); nm],
            mimic_jac_next: vec![ExtraRow::default(); nm],
            constraint_residual: vec![RowValues::zeros(); nj],
            mimic_residual: vec![0.0; nm],
            angmom_plus: vec![Vector3::zeros(); n],
            impulse_scale: vec![0.0; n],
            torque_terms: vec![Vector3::zeros(); n],
            linvel_plus: vec![Vector3::zeros(); n],
            xi: vec![Vector3::zeros(); n],
            lambda: vec![RowValues::zeros(); nj],
            mu: vec![0.0; nm],
            free_evals: vec![zero_eval; n],
            free_residual: vec![Vector3::zeros(); n],
            free_jacobian_inv: vec![Matrix3::identity(); n],
            t_transpose: vec![Matrix3::identity(); n],
            eta_fixed_lambda: vec![Vector3::zeros(); n],
            compliance: vec![
                Compliance {
                    trans: 0.0,
                    rot: Matrix3::zeros()
                };
                n
            ],
            delta_lambda: vec![RowValues::zeros(); nj],
            delta_mu: vec![0.0; nm],
            delta_angmom_plus: vec![Vector3::zeros(); n],
            solver: TreeSolver::new(model.topology(), nm),
            coord_ref: model.coordinates.iter().map(|c| c.initial).collect(),
            coord_next: model.coordinates.iter().map(|c| c.initial).collect(),
            drives: super::drives::DriveRows::new(model),
            stops: super::stops::StopRows::new(model),
            time0_secs: 0.0,
            drive_work: super::drives::DriveWork::default(),
            load_work: crate::sim::loads::KickLedger::default(),
            backup: Backup {
                q: vec![UnitQuaternion::identity(); n],
                m: vec![Vector3::zeros(); n],
                c: vec![Vector3::zeros(); n],
                v: vec![Vector3::zeros(); n],
            },
            backup_coords: vec![0.0; model.coordinates.len()],
            backup_modes: vec![Default::default(); model.stops.len()],
            backup_rates: vec![0.0; model.stops.len()],
        }
    }

    pub(super) fn save(&mut self, model: &Mechanism, bodies: &Bodies) {
        let r = model.bodies();
        self.backup
            .q
            .copy_from_slice(&bodies.world_from_body[r.clone()]);
        self.backup
            .m
            .copy_from_slice(&bodies.angmom_body[r.clone()]);
        self.backup.c.copy_from_slice(&bodies.com_world[r.clone()]);
        self.backup.v.copy_from_slice(&bodies.linvel_world[r]);
        self.backup_coords.copy_from_slice(&self.coord_ref);
        self.backup_modes.copy_from_slice(&self.stops.mode);
        self.backup_rates.copy_from_slice(&self.stops.rate_prev);
    }

    /// Makes the saved state's coordinate references and stop modes the current ones, so that
    /// [`Workspace::restore`] puts the bodies back but keeps them (a prediction step:
    /// [`super::predict`]).
    pub(super) fn keep_references(&mut self) {
        self.backup_coords.copy_from_slice(&self.coord_ref);
        self.backup_modes.copy_from_slice(&self.stops.mode);
        self.backup_rates.copy_from_slice(&self.stops.rate_prev);
    }

    pub(super) fn restore(&mut self, model: &Mechanism, bodies: &mut Bodies) {
        let r = model.bodies();
        bodies.world_from_body[r.clone()].copy_from_slice(&self.backup.q);
        bodies.angmom_body[r.clone()].copy_from_slice(&self.backup.m);
        bodies.com_world[r.clone()].copy_from_slice(&self.backup.c);
        bodies.linvel_world[r].copy_from_slice(&self.backup.v);
        self.coord_ref.copy_from_slice(&self.backup_coords);
        self.stops.mode.copy_from_slice(&self.backup_modes);
        self.stops.rate_prev.copy_from_slice(&self.backup_rates);
    }
}
