//! The Newton loop of one attempt at the step ([`Workspace::attempt`]: start, iterate, stopping
//! rule and guards), one Newton update of `(ξ, λ, μ)` through the tree solve, and the commit of
//! a solved step.

use super::super::Mechanism;
use super::super::rows::{BodyPose, MAX_ROWS, RowValues};
use super::super::tree::{Compliance, ExtraRow, Jacobians};
use super::assembly::{mimic_row, parent_pose};
use super::{Attempt, Failure, Warm, Workspace};
use crate::sim::Bodies;
use crate::sim::integrators::VariationalSettings;
use crate::sim::loads::Loads;
use nalgebra::Vector3;

/// The most mode switches of the stop rows in one solve (limits reached or released, friction
/// sticking or sliding: one or two per stop in practice); past it the last converged modes are
/// kept.
const MAX_SWITCHES: u32 = 8;

/// `π²`: a step's rotation `ξ` must stay below `π` in norm.
const PI_SQUARED: f64 = std::f64::consts::PI * std::f64::consts::PI;

impl Workspace {
    /// One Newton solve of the step `h` from the bodies' state (left untouched); on success the
    /// end state is in the workspace, for [`Workspace::commit`].
    #[allow(clippy::too_many_arguments)]
    pub(super) fn attempt(
        &mut self,
        model: &Mechanism,
        bodies: &Bodies,
        h: f64,
        loads: &Loads,
        settings: &VariationalSettings,
        warm: Option<&Warm>,
    ) -> Attempt {
        let first = model.first_body;
        let n = model.body_count;
        let alpha = settings.potential.alpha();
        let tol = settings.newton_tol;
        for i in 0..n {
            let gi = first + i;
            self.pose_k[i] = BodyPose {
                rot: bodies.world_from_body[gi].to_rotation_matrix().into_inner(),
                com: bodies.com_world[gi],
            };
        }
        for (j, joint) in model.joints.iter().enumerate() {
            let a = *parent_pose(model, &self.pose_k, j);
            let (jp, jc) = &mut self.jac_k[j];
            joint.rows.evaluate(&a, &self.pose_k[joint.child], jp, jc);
        }
        let mut scratch = std::mem::take(&mut self.coord_next);
        for m in 0..model.mimics.len() {
            let mut row = ExtraRow::default();
            if mimic_row(
                model,
                &self.pose_k,
                m,
                &self.coord_ref,
                &mut row,
                &mut scratch,
            )
            .is_none()
            {
                self.coord_next = scratch;
                return Err((Failure::Singular, 0));
            }
            self.mimic_jac_k[m] = row;
        }
        self.coord_next = scratch;
        if let Err(f) = self.drive_rows_start(model, h) {
            return Err((f, 0));
        }
        if let Err(f) = self.stop_rows_start(model, bodies) {
            return Err((f, 0));
        }
        // Start: warm λ, μ, ξ, or cold (λ = 0, ξ from the momenta).
        match warm {
            Some(w) if w.history => {
                for (l, (a, b)) in self
                    .lambda
                    .iter_mut()
                    .zip(w.lambda.iter().zip(&w.lambda_prev))
                {
                    *l = a * 2.0 - b;
                }
                for (m, (a, b)) in self.mu.iter_mut().zip(w.mu.iter().zip(&w.mu_prev)) {
                    *m = 2.0 * a - b;
                }
            }
            Some(w) => {
                self.lambda.copy_from_slice(&w.lambda);
                self.mu.copy_from_slice(&w.mu);
            }
            None => {
                self.lambda.iter_mut().for_each(|l| *l = RowValues::zeros());
                self.mu.iter_mut().for_each(|m| *m = 0.0);
            }
        }
        self.impulses(model, bodies);
        if !model.drives.is_empty() {
            // With drives, the momenta between steps carry the drives' end impulses, which
            // the next step's joint impulses redistribute: `ξ` from the momenta alone can be
            // far off (a stiff servo's torque impulse lands on one body's small inertia) and
            // lead Newton to an aliased root beyond π. Start instead from the previous step's
            // `ξ` (extrapolated) or, cold, from rest; Newton's first update solves the
            // coupled linear system.
            for i in 0..n {
                self.xi[i] = warm.map_or(Vector3::zeros(), |w| {
                    if w.history {
                        w.xi[i] * 2.0 - w.xi_prev[i]
                    } else {
                        w.xi[i]
                    }
                });
            }
        } else {
            for i in 0..n {
                let gi = first + i;
                let inv_j = bodies.inv_inertia_body[gi];
                let m = self.angmom_plus[i];
                // ξ ≈ h J⁻¹ (M⁺ − ξ × M⁺ / 2) (from J ξ = h T(ξ)ᵀ M⁺ to second order), with the
                // previous ξ (warm) or the first-order guess (cold) on the right.
                let first_guess = m.component_mul(&inv_j) * h;
                let xi_ref = warm.map_or(first_guess, |w| {
                    if w.history {
                        w.xi[i] * 2.0 - w.xi_prev[i]
                    } else {
                        w.xi[i]
                    }
                });
                self.xi[i] = (m - xi_ref.cross(&m) * 0.5).component_mul(&inv_j) * h;
            }
        }
        let mut previous = f64::INFINITY;
        let mut iterations = 0;
        let mut switches = 0;
        loop {
            if iterations > 0 {
                self.impulses(model, bodies);
            }
            let ratio = self.residuals(model, bodies, h, loads, alpha, tol)?;
            if ratio <= 1.0 && switches < MAX_SWITCHES && self.stops_switch(model, h, tol) {
                // A limit reached or released, friction sliding or sticking: solve the step
                // again in the new modes, from this iterate.
                switches += 1;
                previous = f64::INFINITY;
                continue;
            }
            if ratio <= 1.0 {
                // Converged: reject a root that turns a body by π or more in one step (the
                // exponential map is one-to-one only below π: such a root aliases a rotation
                // the step does not resolve, e.g. after a stiff servo's first Newton update
                // overshoots), then the spurious root with a reversed axis.
                if self.xi.iter().any(|x| x.norm_squared() >= PI_SQUARED) {
                    return Err((Failure::SpuriousRoot, iterations));
                }
                for (j, joint) in model.joints.iter().enumerate() {
                    let a = parent_pose(model, &self.pose_next, j);
                    if !joint.rows.sign_ok(a, &self.pose_next[joint.child]) {
                        return Err((Failure::SpuriousRoot, iterations));
                    }
                }
                return Ok(iterations);
            }
            if !ratio.is_finite() {
                return Err((Failure::NonFinite, iterations));
            }
            if iterations >= 2 && ratio > 10.0 * previous {
                return Err((Failure::Diverging, iterations));
            }
            if iterations >= settings.newton_max_iters * (1 + switches) {
                return Err((Failure::NotConverged, iterations));
            }
            previous = ratio;
            self.newton_update(model, bodies, h)
                .map_err(|f| (f, iterations))?;
            iterations += 1;
        }
    }

    /// One Newton update of `(ξ, λ, μ)` from the residuals just evaluated.
    pub(super) fn newton_update(
        &mut self,
        model: &Mechanism,
        bodies: &Bodies,
        h: f64,
    ) -> Result<(), Failure> {
        let first = model.first_body;
        for i in 0..model.body_count {
            let a = self.free_evals[i].jacobian();
            let a_inv = a.try_inverse().ok_or(Failure::Singular)?;
            let tt = self.free_evals[i].t_transpose();
            self.free_jacobian_inv[i] = a_inv;
            self.t_transpose[i] = tt;
            self.eta_fixed_lambda[i] = -(tt * (a_inv * self.free_residual[i]));
            self.compliance[i] = Compliance {
                trans: h / bodies.mass[first + i],
                rot: tt * a_inv * tt,
            };
        }
        for (j, joint) in model.joints.iter().enumerate() {
            let (gp, gc) = &self.jac_next[j];
            let mut r = -self.constraint_residual[j]
                - gc.fixed_view::<MAX_ROWS, 3>(0, 3) * self.eta_fixed_lambda[joint.child];
            if let Some(p) = joint.parent {
                r -= gp.fixed_view::<MAX_ROWS, 3>(0, 3) * self.eta_fixed_lambda[p];
            }
            self.delta_lambda[j] = r;
        }
        for m in 0..model.mimics.len() {
            let mut r = -self.mimic_residual[m];
            for (i, row) in self.mimic_jac_next[m].bodies.iter().flatten() {
                r -= (row.fixed_view::<1, 3>(0, 3) * self.eta_fixed_lambda[*i])[0];
            }
            self.delta_mu[m] = r;
        }
        let jac = Jacobians {
            left: &self.jac_k,
            right: &self.jac_next,
            extra_left: &self.mimic_jac_k,
            extra_right: &self.mimic_jac_next,
        };
        if !self.solver.factor(&jac, &self.compliance) {
            return Err(Failure::Singular);
        }
        self.solver
            .solve(&jac, &mut self.delta_lambda, &mut self.delta_mu);
        // δM⁺ = Gηᵀ δλ (+ mimic rows), then δξ.
        for d in self.delta_angmom_plus.iter_mut() {
            *d = Vector3::zeros();
        }
        for (j, joint) in model.joints.iter().enumerate() {
            let (gp, gc) = &self.jac_k[j];
            let dl = &self.delta_lambda[j];
            self.delta_angmom_plus[joint.child] +=
                gc.fixed_view::<MAX_ROWS, 3>(0, 3).transpose() * dl;
            if let Some(p) = joint.parent {
                self.delta_angmom_plus[p] += gp.fixed_view::<MAX_ROWS, 3>(0, 3).transpose() * dl;
            }
            self.lambda[j] += dl;
        }
        for m in 0..model.mimics.len() {
            for (i, row) in self.mimic_jac_k[m].bodies.iter().flatten() {
                self.delta_angmom_plus[*i] +=
                    row.fixed_view::<1, 3>(0, 3).transpose() * self.delta_mu[m];
            }
            self.mu[m] += self.delta_mu[m];
        }
        for i in 0..model.body_count {
            self.xi[i] += self.free_jacobian_inv[i]
                * (self.t_transpose[i] * self.delta_angmom_plus[i] - self.free_residual[i]);
        }
        Ok(())
    }

    /// Writes the solved end state into the batch and the warm start.
    pub(super) fn commit(
        &mut self,
        model: &Mechanism,
        bodies: &mut Bodies,
        h: f64,
        loads: &Loads,
        warm: &mut Warm,
    ) {
        let first = model.first_body;
        self.stop_commit(model, h);
        for i in 0..model.body_count {
            let gi = first + i;
            let (q, m) = self.free_evals[i].advance(&bodies.world_from_body[gi]);
            bodies.world_from_body[gi] = q;
            bodies.angmom_body[gi] = m;
            bodies.com_world[gi] = self.pose_next[i].com;
            bodies.linvel_world[gi] = self.linvel_plus[i] + loads.gravity() * h;
        }
        self.drive_commit(model, bodies);
        warm.push(&self.lambda, &self.mu, &self.xi);
        for m in &model.mimics {
            for c in [m.follower, m.leader] {
                self.coord_ref[c] = self.coord_next[c];
            }
        }
        self.track_coordinates(model);
    }
}
