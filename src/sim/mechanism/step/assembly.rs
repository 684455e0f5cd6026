//! Assembly of the step's residuals and Jacobians at the current iterate `(ξ, λ, μ)`: the start
//! impulses `M⁺`, `v⁺`; the free-body residuals `f_i`, the end poses `q_{k+1}`, the constraint
//! rows `g(q_{k+1})` and their Jacobians; the mimic rows; each residual relative to its
//! tolerance.

use super::super::Mechanism;
use super::super::rows::{BodyPose, MAX_ROWS};
use super::super::tree::ExtraRow;
use super::{Failure, Workspace};
use crate::sim::integrators::variational::RotationEval;
use crate::sim::loads::Loads;
use crate::sim::{Bodies, so3};
use nalgebra::Vector3;

/// The parent pose of joint `j` (a body's, or the world's constant one).
#[inline]
pub(super) fn parent_pose<'a>(
    model: &'a Mechanism,
    poses: &'a [BodyPose],
    j: usize,
) -> &'a BodyPose {
    match model.joints[j].parent {
        Some(p) => &poses[p],
        None => &model.world_pose,
    }
}

/// Value and gradient row entries of mimic `m` at `poses` (references `refs`): returns the
/// value and writes the row (−k on the leader's entries) and the two coordinate values.
pub(super) fn mimic_row(
    model: &Mechanism,
    poses: &[BodyPose],
    m: usize,
    refs: &[f64],
    row: &mut ExtraRow,
    values: &mut [f64],
) -> Option<f64> {
    let mimic = &model.mimics[m];
    let mut value = -mimic.offset;
    let mut slot = 0;
    for (coord, factor) in [(mimic.follower, 1.0), (mimic.leader, -mimic.multiplier)] {
        let c = &model.coordinates[coord];
        let joint = &model.joints[c.joint];
        let a = parent_pose(model, poses, c.joint);
        let b = &poses[joint.child];
        let (theta, ga, gb) = c.kind.gradient(a, b, refs[coord])?;
        values[coord] = theta;
        value += factor * theta;
        if let Some(p) = joint.parent {
            row.bodies[slot] = Some((p, ga * factor));
        } else {
            row.bodies[slot] = None;
        }
        row.bodies[slot + 1] = Some((joint.child, gb * factor));
        slot += 2;
    }
    Some(value)
}

/// The round-off floor of a body's free-body residual, in units of `ε` times the size of the
/// torque terms summed into its `M⁺` (see [`Workspace::impulses`]).
const TORQUE_ROUNDOFF: f64 = 64.0;

impl Workspace {
    /// `M⁺ = M + Gηᵀ λ`, `v⁺ = v + Gcᵀ λ / m` from the current `λ`, `μ`.
    pub(super) fn impulses(&mut self, model: &Mechanism, bodies: &Bodies) {
        let first = model.first_body;
        for i in 0..model.body_count {
            self.angmom_plus[i] = bodies.angmom_body[first + i];
            self.impulse_scale[i] = 0.0;
            self.torque_terms[i] = Vector3::zeros();
            self.linvel_plus[i] = Vector3::zeros();
        }
        for (j, joint) in model.joints.iter().enumerate() {
            let (gp, gc) = &self.jac_k[j];
            let l = &self.lambda[j];
            let ic = gc.transpose() * l;
            let torque = ic.fixed_rows::<3>(3);
            self.linvel_plus[joint.child] += ic.fixed_rows::<3>(0);
            self.angmom_plus[joint.child] += torque;
            self.impulse_scale[joint.child] = self.impulse_scale[joint.child].max(torque.amax());
            // The size of the terms summed into the torque, `Σ_r |G_η,r| |λ_r|` (per
            // component): their round-off floor, which the net torque above loses when the
            // rows cancel (a body at rest in equilibrium).
            let l_abs = l.abs();
            self.torque_terms[joint.child] +=
                gc.fixed_view::<MAX_ROWS, 3>(0, 3).abs().tr_mul(&l_abs);
            if let Some(p) = joint.parent {
                let ip = gp.transpose() * l;
                let torque = ip.fixed_rows::<3>(3);
                self.linvel_plus[p] += ip.fixed_rows::<3>(0);
                self.angmom_plus[p] += torque;
                self.impulse_scale[p] = self.impulse_scale[p].max(torque.amax());
                self.torque_terms[p] += gp.fixed_view::<MAX_ROWS, 3>(0, 3).abs().tr_mul(&l_abs);
            }
        }
        // A stop's impulse may be balanced by its joint's own rows (a joint held at rest by
        // friction or a limit): the sum over the joint's block above is then round-off, but
        // the stop's torque alone sets the round-off floor.
        for &(j, row) in &self.stops.slot {
            let nu = self.lambda[j][row];
            if nu != 0.0 {
                let joint = &model.joints[j];
                let (gp, gc) = &self.jac_k[j];
                let size = |g: &super::super::rows::RowJacobian| {
                    (g.fixed_view::<1, 3>(row, 3) * nu).amax()
                };
                self.impulse_scale[joint.child] = self.impulse_scale[joint.child].max(size(gc));
                if let Some(p) = joint.parent {
                    self.impulse_scale[p] = self.impulse_scale[p].max(size(gp));
                }
            }
        }
        for (m, row) in self.mimic_jac_k.iter().enumerate() {
            for (i, r) in row.bodies.iter().flatten() {
                let imp = r.transpose() * self.mu[m];
                let torque = imp.fixed_rows::<3>(3);
                self.linvel_plus[*i] += imp.fixed_rows::<3>(0);
                self.angmom_plus[*i] += torque;
                self.impulse_scale[*i] = self.impulse_scale[*i].max(torque.amax());
                self.torque_terms[*i] += torque.abs();
            }
        }
        for i in 0..model.body_count {
            let gi = first + i;
            self.linvel_plus[i] = bodies.linvel_world[gi] + self.linvel_plus[i] / bodies.mass[gi];
        }
    }

    /// Evaluates every residual at the current `(ξ, λ, μ)` (end poses, row values and their
    /// Jacobians) and returns the largest residual relative to its tolerance.
    pub(super) fn residuals(
        &mut self,
        model: &Mechanism,
        bodies: &Bodies,
        h: f64,
        loads: &Loads,
        alpha: f64,
        tol: f64,
    ) -> Result<f64, (Failure, u32)> {
        let first = model.first_body;
        let mut ratio: f64 = 0.0;
        let mut com_max: f64 = 0.0;
        let dc_gravity = loads.gravity() * (alpha * h * h);
        for i in 0..model.body_count {
            let gi = first + i;
            let j = &bodies.inertia_body[gi];
            let eval = RotationEval::new(j, &self.angmom_plus[i], h, &self.xi[i]);
            let f = eval.residual();
            // Relative to the momentum, its terms (the torque impulses may cancel), and `J ξ/h`.
            let scale = self.angmom_plus[i]
                .amax()
                .max(bodies.angmom_body[gi].amax())
                .max(self.impulse_scale[i])
                .max((j.component_mul(&self.xi[i]) / h).amax());
            let floor = TORQUE_ROUNDOFF * f64::EPSILON * self.torque_terms[i].amax();
            ratio = ratio.max(relative(f.amax(), tol * scale + floor));
            self.free_residual[i] = f;
            self.free_evals[i] = eval;
            let q = bodies.world_from_body[gi] * so3::exp_quaternion(&self.xi[i]);
            self.rot_next[i] = q;
            let com = bodies.com_world[gi] + self.linvel_plus[i] * h + dc_gravity;
            com_max = com_max.max(com.amax());
            self.pose_next[i] = BodyPose {
                rot: q.to_rotation_matrix().into_inner(),
                com,
            };
        }
        let len_tol = tol * model.length_scale + 8.0 * f64::EPSILON * com_max;
        let dot_tol = tol.max(8.0 * f64::EPSILON);
        for (j, joint) in model.joints.iter().enumerate() {
            let a = *parent_pose(model, &self.pose_next, j);
            let (jp, jc) = &mut self.jac_next[j];
            let g = joint
                .rows
                .evaluate(&a, &self.pose_next[joint.child], jp, jc);
            for r in 0..joint.rows.count() {
                let t = if joint.rows.kind.is_length_row(r) {
                    len_tol
                } else {
                    dot_tol
                };
                ratio = ratio.max(relative(g[r].abs(), t));
            }
            self.constraint_residual[j] = g;
        }
        let mut values = std::mem::take(&mut self.coord_next);
        for m in 0..model.mimics.len() {
            let mut row = ExtraRow::default();
            let Some(v) = mimic_row(
                model,
                &self.pose_next,
                m,
                &self.coord_ref,
                &mut row,
                &mut values,
            ) else {
                self.coord_next = values;
                return Err((Failure::Singular, 0));
            };
            let t = if model.coordinates[model.mimics[m].follower].is_linear {
                len_tol
            } else {
                dot_tol
            };
            ratio = ratio.max(relative(v.abs(), t));
            self.mimic_residual[m] = v;
            self.mimic_jac_next[m] = row;
        }
        self.coord_next = values;
        let drives = self.drive_rows_end(model, h, tol).map_err(|f| (f, 0))?;
        let stops = self
            .stop_rows_end(model, h, tol, len_tol, dot_tol)
            .map_err(|f| (f, 0))?;
        Ok(ratio.max(drives).max(stops))
    }
}

/// `value / tolerance`, with `0/0 = 0` (an exact zero passes a zero tolerance) and NaN → ∞.
#[inline]
pub(super) fn relative(value: f64, tolerance: f64) -> f64 {
    if value <= tolerance {
        if tolerance > 0.0 {
            value / tolerance
        } else {
            0.0
        }
    } else if tolerance > 0.0 {
        value / tolerance
    } else {
        f64::INFINITY
    }
}
