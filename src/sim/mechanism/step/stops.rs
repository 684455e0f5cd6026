//! The stop rows of a mechanism's step: each coordinate with a limit or friction
//! ([`crate::sim::mechanism::stop`], whose doc gives the physics) adds one row to its joint's
//! block, after the drives' rows.
//!
//! Its unknown `ν` acts at the start of the step along `∇θ(q_k)` (the left row, as a joint's
//! own rows), and its equation depends on the row's mode:
//!
//! ```text
//! free, slide:         ν − ν̄ = 0            right row 0,            D₀ = 1
//! stick, upper, lower: θ_{k+1} − θ̄ = 0      right row ∇θ(q_{k+1}),  D₀ = 0
//! ```
//!
//! (`ν̄` is 0 or `−s F h`, `θ̄` is `θ_k` or the bound), a row of the tree system
//! `(G_R S G_Lᵀ + D₀) δx = −g − G_R [0; e]` like a drive's ([`super::drives`]). The modes are
//! switched by [`Workspace::stops_switch`] when Newton has converged (the active set), and kept
//! from one step to the next.

use super::super::rows::Row6;
use super::super::{Mechanism, StopMode};
use super::assembly::relative;
use super::{Failure, Workspace};
use crate::sim::Bodies;

/// Per stop of the mechanism (same order as `MechanismModel::stops`): its row, its mode and
/// its values at the current iterate.
#[derive(Debug, Clone, Default)]
pub struct StopRows {
    /// The joint and the row of its block the stop occupies (after the joint's drive rows).
    pub(super) slot: Vec<(usize, usize)>,
    /// The mode, kept from step to step.
    pub mode: Vec<StopMode>,
    /// `θ_k` (unwrapped near the coordinate's reference).
    pub(super) theta_k: Vec<f64>,
    /// `θ_{k+1}` at the current iterate.
    pub(super) theta_next: Vec<f64>,
    /// The previous step's rate `(θ_k − θ_{k−1})/h` (NaN before the first step).
    pub(super) rate_prev: Vec<f64>,
    /// The position tolerance of each row at the current iterate (rad, or m).
    pub(super) theta_tol: Vec<f64>,
}

impl StopRows {
    pub(super) fn new(model: &Mechanism) -> Self {
        let mut used: Vec<usize> = model.joints.iter().map(|j| j.rows.count()).collect();
        for d in &model.drives {
            used[model.coordinates[d.coordinate].joint] += 1;
        }
        let slot = model
            .stops
            .iter()
            .map(|s| {
                let j = model.coordinates[s.coordinate].joint;
                used[j] += 1;
                (j, used[j] - 1)
            })
            .collect();
        let n = model.stops.len();
        Self {
            slot,
            mode: model.stops.iter().map(|s| s.initial_mode()).collect(),
            theta_k: vec![0.0; n],
            theta_next: vec![0.0; n],
            rate_prev: vec![f64::NAN; n],
            theta_tol: vec![0.0; n],
        }
    }
}

impl Workspace {
    /// The stop rows at the start of the step: `θ_k` and `∇θ(q_k)` into `G(q_k)`. Before the
    /// first step, the rate before it is the initial state's, `θ̇ = ∇θ · [ċ; ω]` from the
    /// bodies' velocities (exact there: the initial state is set from the joint rates), so an
    /// impact at the first step (a joint starting at its bound, moving into it) is charged its
    /// kinetic energy like any other ([`Workspace::stop_commit`]).
    pub(super) fn stop_rows_start(
        &mut self,
        model: &Mechanism,
        bodies: &Bodies,
    ) -> Result<(), Failure> {
        for (k, s) in model.stops.iter().enumerate() {
            let (j, row) = self.stops.slot[k];
            let (theta, ga, gb) = self.coordinate_gradient(model, &self.pose_k, s.coordinate)?;
            self.stops.theta_k[k] = theta;
            if self.stops.rate_prev[k].is_nan() {
                let rate = |i: usize, g: &Row6| {
                    let gi = model.first_body + i;
                    let w = bodies.angmom_body[gi].component_mul(&bodies.inv_inertia_body[gi]);
                    let v = bodies.linvel_world[gi];
                    g[0] * v.x + g[1] * v.y + g[2] * v.z + g[3] * w.x + g[4] * w.y + g[5] * w.z
                };
                let joint = &model.joints[j];
                self.stops.rate_prev[k] =
                    rate(joint.child, &gb) + joint.parent.map_or(0.0, |p| rate(p, &ga));
            }
            let (jp, jc) = &mut self.jac_k[j];
            jp.set_row(row, &ga);
            jc.set_row(row, &gb);
        }
        Ok(())
    }

    /// The stop rows at the end of the step, after the joints' rows were evaluated at
    /// `q_{k+1}`: each row's residual, right row and diagonal by its mode; returns the largest
    /// residual relative to its tolerance (`len_tol` m, `dot_tol` rad for a position, `tol`
    /// times the impulse's size for an impulse).
    pub(super) fn stop_rows_end(
        &mut self,
        model: &Mechanism,
        h: f64,
        tol: f64,
        len_tol: f64,
        dot_tol: f64,
    ) -> Result<f64, Failure> {
        let mut ratio: f64 = 0.0;
        for (k, s) in model.stops.iter().enumerate() {
            let (j, row) = self.stops.slot[k];
            let mode = self.stops.mode[k];
            // An impulse row needs no end gradient, and `θ_{k+1}` only once Newton has
            // converged ([`Self::stops_switch`], [`Self::stop_commit`]): NaN until then.
            let (ga, gb) = if mode.holds_position() {
                let (theta, ga, gb) =
                    self.coordinate_gradient(model, &self.pose_next, s.coordinate)?;
                self.stops.theta_next[k] = theta;
                (ga, gb)
            } else {
                self.stops.theta_next[k] = f64::NAN;
                (Row6::zeros(), Row6::zeros())
            };
            let nu = self.lambda[j][row];
            let theta_k = self.stops.theta_k[k];
            let theta_tol = if model.coordinates[s.coordinate].is_linear {
                len_tol
            } else {
                dot_tol
            };
            let [lo, hi] = s.bounds(theta_k, theta_tol);
            self.stops.theta_tol[k] = theta_tol;
            let hold = s.friction * h.abs();
            let (jp, jc) = &mut self.jac_next[j];
            let (r, diag, t) = if mode.holds_position() {
                let target = match mode {
                    StopMode::Upper => hi,
                    StopMode::Lower => lo,
                    _ => theta_k,
                };
                jp.set_row(row, &ga);
                jc.set_row(row, &gb);
                (self.stops.theta_next[k] - target, 0.0, theta_tol)
            } else {
                let target = match mode {
                    StopMode::Slide(dir) => -f64::from(dir) * s.friction * h,
                    _ => 0.0,
                };
                jp.set_row(row, &ga);
                jc.set_row(row, &gb);
                let child = model.joints[j].child;
                let scale = nu.abs().max(hold).max(self.impulse_scale[child]);
                (nu - target, 1.0, tol * scale)
            };
            self.constraint_residual[j][row] = r;
            self.solver.free_row_diag[j][row] = diag;
            ratio = ratio.max(relative(r.abs(), t));
        }
        Ok(ratio)
    }

    /// `θ_{k+1}` of the stops whose rows did not evaluate it (impulse rows), at the current
    /// end poses.
    fn stops_theta_next(&mut self, model: &Mechanism) -> Result<(), Failure> {
        for (k, s) in model.stops.iter().enumerate() {
            if self.stops.theta_next[k].is_nan() {
                let (theta, _, _) =
                    self.coordinate_gradient(model, &self.pose_next, s.coordinate)?;
                self.stops.theta_next[k] = theta;
            }
        }
        Ok(())
    }

    /// The active set: each stop's next mode from the converged iterate; `true` when any
    /// changed (the step must be solved again).
    pub(super) fn stops_switch(&mut self, model: &Mechanism, h: f64, tol: f64) -> bool {
        if self.stops_theta_next(model).is_err() {
            return false;
        }
        let mut changed = false;
        for (k, s) in model.stops.iter().enumerate() {
            let (j, row) = self.stops.slot[k];
            let nu = self.lambda[j][row];
            let child = model.joints[j].child;
            let nu_tol = tol * nu.abs().max(self.impulse_scale[child]);
            if let Some(next) = s.next_mode(
                self.stops.mode[k],
                self.stops.theta_k[k],
                self.stops.theta_next[k],
                nu,
                h,
                self.stops.theta_tol[k],
                nu_tol,
            ) {
                self.stops.mode[k] = next;
                changed = true;
            }
        }
        changed
    }

    /// A solved step's stop impulses' work (see [`crate::sim::mechanism::stop`]), as
    /// dissipation of the limits or of friction, and the coordinates' new references.
    ///
    /// An impulse `ν` changes the joint's rate from the one before it to the one after it,
    /// and its work is `ν` times their mean. In maximal coordinates the bodies' velocities give
    /// these rates only to O(h) (the start impulses of the joints and the end halves of the
    /// drives land on the bodies before the joints redistribute them), so the rates are read
    /// from the positions instead: `(θ_{k+1} − θ_k)/h` after, the previous step's before. A
    /// joint resting on its limit or sticking is then charged nothing, a sliding one
    /// `F |Δθ|` (to O(h)), and the two steps of an impact (the one that reaches the bound, the
    /// one that stops there) the kinetic energy at impact (to O(h)).
    pub(super) fn stop_commit(&mut self, model: &Mechanism, h: f64) {
        // A NaN θ_{k+1} (not evaluated) would poison the references: keep θ_k then.
        let _ = self.stops_theta_next(model);
        for (k, s) in model.stops.iter().enumerate() {
            let (j, row) = self.stops.slot[k];
            let nu = self.lambda[j][row];
            let theta_next = if self.stops.theta_next[k].is_finite() {
                self.stops.theta_next[k]
            } else {
                self.stops.theta_k[k]
            };
            let rate = (theta_next - self.stops.theta_k[k]) / h;
            let before = self.stops.rate_prev[k];
            self.stops.rate_prev[k] = rate;
            self.coord_ref[s.coordinate] = theta_next;
            if nu == 0.0 {
                continue;
            }
            let before = if before.is_finite() { before } else { rate };
            let removed = -nu * 0.5 * (before + rate);
            if self.stops.mode[k].at_limit() {
                self.drive_work.limits += removed;
            } else {
                self.drive_work.friction += removed;
            }
        }
    }
}
