//! The drive rows of a mechanism's step: each driven coordinate `θ` (an actuator, joint
//! damping, or both; [`crate::sim::mechanism::drive`]) adds one row to its joint's block.
//!
//! Discrete Lagrange-d'Alembert forcing (Marsden & West 2001, §3.2) with the step's symmetric
//! effort `τ̄(θ_k, θ_{k+1}, t_k, t_{k+1})` ([`JointDrive::step_effort`]): the impulse
//! `ν = (h/2) τ̄` acts along `∇θ(q_k)` at the start of the step (with the joints' impulses
//! `G(q_k)ᵀ λ`) and along `∇θ(q_{k+1})` at its end, i.e.
//!
//! ```text
//! f_d⁻ = (h/2) τ̄ ∇θ(q_k),   f_d⁺ = (h/2) τ̄ ∇θ(q_{k+1})
//! ```
//!
//! Both are gradients of a coordinate that no rigid motion of the whole mechanism changes, so
//! they pair to zero with every rigid motion: the total linear and angular momentum of a
//! free-floating mechanism stay exact under its own motors, whatever `τ̄` and the Newton
//! tolerance (forced discrete Noether). `ν` is an unknown of Newton's system, beside `λ`, with
//! the residual `r = ν − (h/2) τ̄(θ_{k+1})`; linearised with `c = −(h/2) ∂τ̄/∂θ_{k+1} ≥ 0`
//! and `δθ_{k+1} = ∇θ(q_{k+1}) δq_{k+1}`:
//!
//! ```text
//! c ∇θ(q_{k+1}) S G(q_k)ᵀ δx + δν = −r − c ∇θ(q_{k+1}) [0; e]
//! ```
//!
//! which is a row of the tree system `(G_R S G_Lᵀ + D₀) δx = −g − G_R [0; e]` with left row
//! `∇θ(q_k)`, right row `c ∇θ(q_{k+1})`, residual `r` and `D₀ = 1`, the diagonal the tree solve
//! puts on a joint's unused rows ([`crate::sim::mechanism::tree::TreeSolver::free_row_diag`]),
//! the whole row divided by `max(c, 1)` to keep it of the size of the joint's own rows. So
//! stiffness and damping are implicit (a servo stays stable at any `h² kp / I`) at no cost in
//! structure; a pure motor has `c = 0` and its row just reads `ν = (h/2) τ̄`.

use super::super::coords::{CompoundChain, decompose, unwrap_near};
use super::super::drive::StepEffort;
use super::super::drive::{ActuatorKind, JointDrive};
use super::super::rows::{BodyPose, Row6};
use super::super::{CoordinateKind, Mechanism};
use super::assembly::{parent_pose, relative};
use super::{Failure, Workspace};
use crate::sim::Bodies;
use nalgebra::{Matrix3, Vector3};

/// Per drive of the mechanism (same order as `MechanismModel::drives`): its row, and its
/// values at the current iterate.
#[derive(Debug, Clone, Default)]
pub struct DriveRows {
    /// The joint and the row of its block the drive occupies (after the joint's own rows).
    pub(super) slot: Vec<(usize, usize)>,
    /// `θ_k` (unwrapped near the coordinate's reference).
    pub(super) theta_k: Vec<f64>,
    /// `θ_{k+1}` at the current iterate.
    pub(super) theta_next: Vec<f64>,
    /// `∇θ(q_{k+1})` (parent, child), unscaled: the end impulses' directions.
    pub(super) grad_next: Vec<(Row6, Row6)>,
    /// The step's effort at the current iterate.
    pub(super) effort: Vec<StepEffort>,
    /// Per drive: whether its row does not depend on the iterate ([`time_only`]): its effort
    /// is taken once per attempt and `θ_{k+1}`, `∇θ(q_{k+1})` once, at the commit.
    pub(super) time_only: Vec<bool>,
}

/// Whether a drive's step effort depends on time alone: a motor (`τ = u(t)`, clamped) without
/// damping, on a hinge or a slider. Its row then reads `ν = (h/2) τ̄(t_k, t_{k+1})` with `c = 0`
/// (a zero right row) whatever the iterate, so Newton's iterations need neither `θ_{k+1}` nor
/// `∇θ(q_{k+1})` (an `atan2` and a gradient per drive and iteration): they are read once, at
/// the solved end pose, for the end impulses and the work. A compound stage is left out (its
/// gradient can fail, which must fail the attempt, not the commit).
pub(crate) fn time_only(model: &Mechanism, drive: &JointDrive) -> bool {
    let motor = matches!(
        drive.actuator.as_ref().map(|a| &a.kind),
        Some(ActuatorKind::Motor { .. })
    );
    let kind = &model.coordinates[drive.coordinate].kind;
    motor && drive.damping == 0.0 && !matches!(kind, CoordinateKind::Compound { .. })
}

impl DriveRows {
    pub(super) fn new(model: &Mechanism) -> Self {
        let mut used: Vec<usize> = model.joints.iter().map(|j| j.rows.count()).collect();
        let slot = model
            .drives
            .iter()
            .map(|d| {
                let j = model.coordinates[d.coordinate].joint;
                used[j] += 1;
                (j, used[j] - 1)
            })
            .collect();
        let n = model.drives.len();
        Self {
            slot,
            theta_k: vec![0.0; n],
            theta_next: vec![0.0; n],
            grad_next: vec![(Row6::zeros(), Row6::zeros()); n],
            effort: vec![StepEffort::default(); n],
            time_only: model.drives.iter().map(|d| time_only(model, d)).collect(),
        }
    }
}

/// Energy flows of a mechanism's drives, summed over the steps taken.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DriveWork {
    /// `Σ τ̄_a (θ_{k+1} − θ_k)`: the work of the actuators, J.
    pub actuators: f64,
    /// `Σ b (θ_{k+1} − θ_k)² / h`: the energy the joint damping removed (≥ 0), J.
    pub damping: f64,
    /// The energy the joint limits removed (≥ 0 up to round-off), J ([`super::stops`]).
    pub limits: f64,
    /// The energy joint friction removed (≥ 0 up to round-off), J.
    pub friction: f64,
}

impl DriveWork {
    /// Everything the drives, limits and friction removed: damping, limits, friction.
    pub fn dissipated(&self) -> f64 {
        self.damping + self.limits + self.friction
    }
}

impl Workspace {
    /// The drive rows at the start of the step: `θ_k` and `∇θ(q_k)` into `G(q_k)`, and the
    /// effort of the time-only drives ([`time_only`]).
    pub(super) fn drive_rows_start(&mut self, model: &Mechanism, h: f64) -> Result<(), Failure> {
        for (k, d) in model.drives.iter().enumerate() {
            let (j, row) = self.drives.slot[k];
            let (theta, ga, gb) = self.coordinate_gradient(model, &self.pose_k, d.coordinate)?;
            self.drives.theta_k[k] = theta;
            if self.drives.time_only[k] {
                // No damping: `θ_{k+1}` enters only `0 · θ̇`; taken at `θ_k`.
                self.drives.effort[k] = d.step_effort(self.time0_secs, h, theta, theta);
            }
            let (jp, jc) = &mut self.jac_k[j];
            jp.set_row(row, &ga);
            jc.set_row(row, &gb);
        }
        Ok(())
    }

    /// The drive rows at the end of the step, after the joints' rows were evaluated at
    /// `q_{k+1}`: the residual `r = ν − (h/2) τ̄`, the right row `c ∇θ(q_{k+1})`; returns the
    /// largest residual relative to `tol` times the impulse's size.
    pub(super) fn drive_rows_end(
        &mut self,
        model: &Mechanism,
        h: f64,
        tol: f64,
    ) -> Result<f64, Failure> {
        let mut ratio: f64 = 0.0;
        let t0 = self.time0_secs;
        for (k, d) in model.drives.iter().enumerate() {
            let (j, row) = self.drives.slot[k];
            if self.drives.time_only[k] {
                // `c = 0`: the right row stays the zeros the joint's evaluation wrote, the
                // diagonal 1; only the residual and its test.
                let effort = &self.drives.effort[k];
                let nu = self.lambda[j][row];
                let r = nu - 0.5 * h * effort.effort.total();
                self.constraint_residual[j][row] = r;
                self.solver.free_row_diag[j][row] = 1.0;
                let scale = self.drive_scale(model, j, nu, h, effort);
                ratio = ratio.max(relative(r.abs(), tol * scale));
                continue;
            }
            let (theta, ga, gb) = self.coordinate_gradient(model, &self.pose_next, d.coordinate)?;
            let effort = d.step_effort(t0, h, self.drives.theta_k[k], theta);
            let nu = self.lambda[j][row];
            let target = 0.5 * h * effort.effort.total();
            let r = nu - target;
            let c = -0.5 * h * effort.slope;
            // The row divided by max(c, 1), so that a stiff servo's row is of the size of the
            // joint's own rows (partial pivoting is not scale-invariant): for c ≥ 1, right row
            // ∇θ, diagonal 1/c, residual r/c; for c < 1, right row c ∇θ, diagonal 1, residual r.
            let scale_row = 1.0 / c.max(1.0);
            let (jp, jc) = &mut self.jac_next[j];
            jp.set_row(row, &(ga * (c * scale_row)));
            jc.set_row(row, &(gb * (c * scale_row)));
            self.constraint_residual[j][row] = r * scale_row;
            self.solver.free_row_diag[j][row] = scale_row;
            self.drives.theta_next[k] = theta;
            self.drives.grad_next[k] = (ga, gb);
            self.drives.effort[k] = effort;
            // Relative to the impulse, to its terms (see `StepEffort::magnitude`) and to the
            // largest torque impulse on the joint's child (the joint's own impulses, solved
            // together with ν, set the round-off floor of ν: a weak damper on a loaded arm
            // has ν far below it).
            // And the round-off of θ itself (about 8 ε of the positions it is read from)
            // through the slope: a damper's rate is a difference of nearly equal positions.
            let child = model.joints[j].child;
            let theta_roundoff =
                8.0 * f64::EPSILON * (self.pose_next[child].com.amax() + model.length_scale);
            let scale = self.drive_scale(model, j, nu, h, &effort);
            let floor = 0.5 * h.abs() * effort.slope.abs() * theta_roundoff;
            ratio = ratio.max(relative(r.abs(), tol * scale + floor));
        }
        Ok(ratio)
    }

    /// The size a drive row's residual is measured against: the impulse `ν`, its terms
    /// ([`StepEffort::magnitude`]) and the largest torque impulse on joint `joint`'s child.
    fn drive_scale(
        &self,
        model: &Mechanism,
        joint: usize,
        nu: f64,
        h: f64,
        effort: &StepEffort,
    ) -> f64 {
        nu.abs()
            .max(0.5 * h.abs() * effort.magnitude)
            .max(self.impulse_scale[model.joints[joint].child])
    }

    /// `θ` and `∇θ` (parent, child) of coordinate `coordinate` at `poses`, unwrapped near the
    /// coordinate's reference.
    pub(super) fn coordinate_gradient(
        &self,
        model: &Mechanism,
        poses: &[BodyPose],
        coordinate: usize,
    ) -> Result<(f64, Row6, Row6), Failure> {
        let c = &model.coordinates[coordinate];
        let a = parent_pose(model, poses, c.joint);
        let b = &poses[model.joints[c.joint].child];
        if let CoordinateKind::Compound { stage } = c.kind {
            let chain = model.joints[c.joint]
                .compound
                .as_ref()
                .ok_or(Failure::Singular)?;
            return compound_gradient(model, c.joint, chain, stage, a, b, &self.coord_ref);
        }
        c.kind
            .gradient(a, b, self.coord_ref[coordinate])
            .ok_or(Failure::Singular)
    }

    /// Every coordinate's value at the committed poses `q_{k+1}`, on the branch nearest its
    /// value at `q_k` (a joint turns far less than π in one step): the joint angles carried
    /// step to step, which the recorders, the controllers and the limits all read
    /// ([`crate::sim::Integrator::joint_coordinates`]), never recovered from sparse samples.
    pub(super) fn track_coordinates(&mut self, model: &Mechanism) {
        for (k, c) in model.coordinates.iter().enumerate() {
            let value = if let CoordinateKind::Compound { .. } = c.kind {
                self.coordinate_gradient(model, &self.pose_next, k)
                    .ok()
                    .map(|(theta, _, _)| theta)
            } else {
                let a = parent_pose(model, &self.pose_next, c.joint);
                c.kind.value(
                    a,
                    &self.pose_next[model.joints[c.joint].child],
                    self.coord_ref[k],
                )
            };
            if let Some(v) = value.filter(|v| v.is_finite()) {
                self.coord_ref[k] = unwrap_near(v, self.coord_ref[k]);
            }
        }
    }

    /// The end impulses `ν ∇θ(q_{k+1})` of a solved step on the committed state, the drives'
    /// work, and the coordinates' new references.
    pub(super) fn drive_commit(&mut self, model: &Mechanism, bodies: &mut Bodies) {
        let first = model.first_body;
        for (k, d) in model.drives.iter().enumerate() {
            let (j, row) = self.drives.slot[k];
            if self.drives.time_only[k] {
                // Hinge and slider gradients do not fail.
                if let Ok((theta, ga, gb)) =
                    self.coordinate_gradient(model, &self.pose_next, d.coordinate)
                {
                    self.drives.theta_next[k] = theta;
                    self.drives.grad_next[k] = (ga, gb);
                }
            }
            let nu = self.lambda[j][row];
            let (ga, gb) = &self.drives.grad_next[k];
            let joint = &model.joints[j];
            let mut apply = |i: usize, g: &Row6| {
                let gi = first + i;
                let lin = nalgebra::Vector3::new(g[0], g[1], g[2]) * nu;
                let ang = nalgebra::Vector3::new(g[3], g[4], g[5]) * nu;
                bodies.linvel_world[gi] += lin / bodies.mass[gi];
                bodies.angmom_body[gi] += ang;
            };
            apply(joint.child, gb);
            if let Some(p) = joint.parent {
                apply(p, ga);
            }
            let dtheta = self.drives.theta_next[k] - self.drives.theta_k[k];
            let e = &self.drives.effort[k].effort;
            self.drive_work.actuators += e.actuator * dtheta;
            self.drive_work.damping -= e.damping * dtheta;
            self.coord_ref[d.coordinate] = self.drives.theta_next[k];
        }
    }
}

/// The angle of stage `stage` of compound joint `joint` and its gradient (rotations only: the
/// stages turn about axes through the joint's anchor). The chain's angles `θ` solve
/// `Q(θ) = P⁻¹ R_aᵀ R_b C` ([`decompose`], from the stages' references `refs`); a variation
/// `R_a exp(η_a)`, `R_b exp(η_b)` turns `Q` by `ω = P⁻¹ W η_b − P⁻¹ η_a` (`P⁻¹ W = Q C⁻¹`;
/// left-trivialised, in
/// the first joint's frame), and `ω = A δθ` with `A` the stage axes at `θ`
/// ([`CompoundChain::product`]), so `δθ = A⁺ ω` (`A⁻¹` for three stages, the least-squares
/// inverse `(AᵀA)⁻¹ Aᵀ` for two, whose `ω` lies in the span of `A`).
fn compound_gradient(
    model: &Mechanism,
    joint: usize,
    chain: &CompoundChain,
    stage: usize,
    a: &BodyPose,
    b: &BodyPose,
    refs: &[f64],
) -> Result<(f64, Row6, Row6), Failure> {
    let n = chain.axes.len();
    let mut theta = [0.0; 3];
    for (ci, c) in model.coordinates.iter().enumerate() {
        if let CoordinateKind::Compound { stage: s } = c.kind
            && c.joint == joint
        {
            theta[s] = refs[ci];
        }
    }
    let w = a.rot.transpose() * b.rot;
    let err = decompose(chain, &chain.target(&w), &mut theta[..n]);
    if !err.is_finite() {
        return Err(Failure::NonFinite);
    }
    let (_, axes) = chain.product(&theta[..n]);
    let mut ata = Matrix3::<f64>::identity();
    for i in 0..n {
        for j in 0..n {
            ata[(i, j)] = axes[i].dot(&axes[j]);
        }
    }
    let inv = ata.try_inverse().ok_or(Failure::Singular)?;
    // Row `stage` of A⁺ = (AᵀA)⁻¹ Aᵀ.
    let row: Vector3<f64> = (0..n).map(|j| axes[j] * inv[(stage, j)]).sum();
    // `Q C⁻¹ = P⁻¹ W` taken from the poses, not from `Q(θ)`: the two differ by the joint's
    // rows' residual (the chain's angles are a least-squares fit while Newton converges), and
    // only `P⁻¹ W` makes the pair of torques cancel exactly under a rigid motion of both bodies
    // (`η_a = R_aᵀ δ`, `η_b = R_bᵀ δ` give `ω = 0`): momentum exact at any Newton tolerance.
    let to_parent = chain.parent_from_first.inverse().to_rotation_matrix();
    let to_child = to_parent.matrix() * w;
    let gb = to_child.transpose() * row;
    let ga = -(to_parent.matrix().transpose() * row);
    Ok((
        theta[stage],
        Row6::new(0.0, 0.0, 0.0, ga.x, ga.y, ga.z),
        Row6::new(0.0, 0.0, 0.0, gb.x, gb.y, gb.z),
    ))
}
