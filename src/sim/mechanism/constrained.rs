//! A mechanism's response to impulses through its joints: the projection of momenta onto the
//! velocity constraints `G(q) S P = 0` in the kinetic metric (RATTLE's velocity step;
//! Leimkuhler & Reich, *Simulating Hamiltonian Dynamics*, §7.2):
//!
//! ```text
//! P̂ = P + G(q)ᵀ μ,   G S Gᵀ μ = −G S P      (S = M⁻¹ = diag(I/m, J⁻¹); the tree solve)
//! ```
//!
//! in the step's coordinates (per body: linear momentum in the world, angular momentum in the
//! body's principal frame). `S P̂` is the velocity the joints allow; applied to an impulse `P`
//! alone, `S (P + Gᵀ μ)` is the constrained response `M_c⁻¹ P` the contact solve needs (an
//! impulse on a foot moves the whole robot through its joints). The reporter
//! ([`super::project`]) projects the carried momenta with it; the contact phase
//! ([`crate::sim::contact`]) reads a robot's velocities and its response to contact impulses.
//! Impulses `G(q)ᵀ μ` carry no net force or torque ([`super::rows`]): projecting keeps the
//! total momentum of a free-floating mechanism.

use super::Mechanism;
use super::rows::{BodyPose, RowJacobian, RowValues};
use super::tree::{Compliance, ExtraRow, Jacobians, TreeSolver};
use crate::sim::Bodies;
use nalgebra::{Matrix3, SVector};

/// One body's impulse or momentum `[linear (world); angular (body frame)]`.
pub type Impulse6 = SVector<f64, 6>;

/// Adds `impulses` (one per body of a mechanism whose first body is `first` in `bodies`) to
/// the bodies' momenta: `v += P / m`, `M += L` (body frame).
pub fn add_impulses(bodies: &mut Bodies, first: usize, impulses: &[Impulse6]) {
    for (i, k) in impulses.iter().enumerate() {
        let gi = first + i;
        bodies.linvel_world[gi] += k.fixed_rows::<3>(0) / bodies.mass[gi];
        bodies.angmom_body[gi] += k.fixed_rows::<3>(3);
    }
}

/// Reusable buffers for the projection of one mechanism.
#[derive(Debug, Clone)]
pub struct Projector {
    solver: TreeSolver,
    poses: Vec<BodyPose>,
    g: Vec<(RowJacobian, RowJacobian)>,
    extra: Vec<ExtraRow>,
    s: Vec<Compliance>,
    rhs: Vec<RowValues>,
    rhs_extra: Vec<f64>,
    velocity: Vec<Impulse6>,
    factored: bool,
}

impl Projector {
    pub fn new(model: &Mechanism) -> Self {
        let n = model.body_count;
        let zj = (RowJacobian::zeros(), RowJacobian::zeros());
        Self {
            solver: TreeSolver::new(model.topology(), model.mimics.len()),
            poses: vec![BodyPose::identity(); n],
            g: vec![zj; model.joints.len()],
            extra: vec![ExtraRow::default(); model.mimics.len()],
            s: vec![
                Compliance {
                    trans: 0.0,
                    rot: Matrix3::zeros()
                };
                n
            ],
            rhs: vec![RowValues::zeros(); model.joints.len()],
            rhs_extra: vec![0.0; model.mimics.len()],
            velocity: vec![Impulse6::zeros(); n],
            factored: false,
        }
    }

    /// The mechanism's poses and compliances from the batch, and its joints' rows `G(q)` at
    /// them; returns the largest anchor gap (m) and axis misalignment (rad).
    pub fn load(&mut self, model: &Mechanism, bodies: &Bodies) -> (f64, f64) {
        let first = model.first_body;
        for i in 0..model.body_count {
            let gi = first + i;
            self.poses[i] = BodyPose {
                rot: bodies.world_from_body[gi].to_rotation_matrix().into_inner(),
                com: bodies.com_world[gi],
            };
            self.s[i] = Compliance {
                trans: 1.0 / bodies.mass[gi],
                rot: Matrix3::from_diagonal(&bodies.inv_inertia_body[gi]),
            };
        }
        self.factored = false;
        let mut residual_m: f64 = 0.0;
        let mut residual_rad: f64 = 0.0;
        for (j, joint) in model.joints.iter().enumerate() {
            let a = self.parent_pose(model, joint.parent);
            let (gp, gc) = &mut self.g[j];
            let values = joint.rows.evaluate(&a, &self.poses[joint.child], gp, gc);
            for r in 0..joint.rows.count() {
                if joint.rows.kind.is_length_row(r) {
                    residual_m = residual_m.max(values[r].abs());
                } else {
                    residual_rad = residual_rad.max(values[r].abs());
                }
            }
        }
        (residual_m, residual_rad)
    }

    /// The loaded poses (local body order).
    pub fn poses(&self) -> &[BodyPose] {
        &self.poses
    }

    /// The pose joint rows use for the parent `parent` (`None`: the world).
    pub fn parent_pose(&self, model: &Mechanism, parent: Option<usize>) -> BodyPose {
        match parent {
            Some(p) => self.poses[p],
            None => model.world_pose,
        }
    }

    /// The mimic rows at the loaded poses, each coordinate's gradient taken on the branch
    /// nearest `positions` (per coordinate); returns the largest residual of the mimic rows
    /// (m, rad).
    pub fn mimics(&mut self, model: &Mechanism, positions: &[f64]) -> (f64, f64) {
        let mut residual_m: f64 = 0.0;
        let mut residual_rad: f64 = 0.0;
        for (m, mimic) in model.mimics.iter().enumerate() {
            let mut row = ExtraRow::default();
            let mut value = -mimic.offset;
            let mut slot = 0;
            for (coord, factor) in [(mimic.follower, 1.0), (mimic.leader, -mimic.multiplier)] {
                let c = &model.coordinates[coord];
                let joint = &model.joints[c.joint];
                let a = self.parent_pose(model, joint.parent);
                if let Some((theta, ga, gb)) =
                    c.kind
                        .gradient(&a, &self.poses[joint.child], positions[coord])
                {
                    value += factor * theta;
                    row.bodies[slot] = joint.parent.map(|p| (p, ga * factor));
                    row.bodies[slot + 1] = Some((joint.child, gb * factor));
                }
                slot += 2;
            }
            if model.coordinates[mimic.follower].is_linear {
                residual_m = residual_m.max(value.abs());
            } else {
                residual_rad = residual_rad.max(value.abs());
            }
            self.extra[m] = row;
        }
        self.factored = false;
        (residual_m, residual_rad)
    }

    /// Factors `G S Gᵀ` at the loaded rows (after [`Projector::load`] and
    /// [`Projector::mimics`]); `false` when there is nothing to project or it is singular.
    pub fn factor(&mut self, model: &Mechanism) -> bool {
        let jac = Jacobians {
            left: &self.g,
            right: &self.g,
            extra_left: &self.extra,
            extra_right: &self.extra,
        };
        self.factored = !model.joints.is_empty() && self.solver.factor(&jac, &self.s);
        self.factored
    }

    /// The joints' impulses `G(q)ᵀ μ` with `G S Gᵀ μ = −G S P` that project the momenta `P`
    /// (per body of the mechanism, local order) onto the velocity constraints, into
    /// `correction` (zero when the factorisation failed): `P̂ = P + correction`.
    pub fn project(
        &mut self,
        model: &Mechanism,
        momenta: &[Impulse6],
        correction: &mut [Impulse6],
    ) {
        for c in correction.iter_mut() {
            *c = Impulse6::zeros();
        }
        if !self.factored {
            return;
        }
        for (v, (s, p)) in self
            .velocity
            .iter_mut()
            .zip(self.s.iter().zip(momenta.iter()))
        {
            *v = s.apply(p);
        }
        for (j, joint) in model.joints.iter().enumerate() {
            let (gp, gc) = &self.g[j];
            let mut r = -(gc * self.velocity[joint.child]);
            if let Some(p) = joint.parent {
                r -= gp * self.velocity[p];
            }
            self.rhs[j] = r;
        }
        for (m, row) in self.extra.iter().enumerate() {
            self.rhs_extra[m] = -row
                .bodies
                .iter()
                .flatten()
                .map(|(i, r)| (r * self.velocity[*i])[0])
                .sum::<f64>();
        }
        let jac = Jacobians {
            left: &self.g,
            right: &self.g,
            extra_left: &self.extra,
            extra_right: &self.extra,
        };
        self.solver.solve(&jac, &mut self.rhs, &mut self.rhs_extra);
        for (j, joint) in model.joints.iter().enumerate() {
            let (gp, gc) = &self.g[j];
            correction[joint.child] += gc.transpose() * self.rhs[j];
            if let Some(p) = joint.parent {
                correction[p] += gp.transpose() * self.rhs[j];
            }
        }
        for (m, row) in self.extra.iter().enumerate() {
            for (i, r) in row.bodies.iter().flatten() {
                correction[*i] += r.transpose() * self.rhs_extra[m];
            }
        }
    }

    /// Body `i`'s velocity `S P` for its momentum `P` (linear in the world, angular in its
    /// frame).
    pub fn velocity(&self, i: usize, momentum: &Impulse6) -> Impulse6 {
        self.s[i].apply(momentum)
    }
}
