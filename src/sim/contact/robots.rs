//! Robots in contact: mechanisms whose bodies have colliders.
//!
//! A free body's response to a contact impulse is its own (`Δv = P/m`, `Δω = I⁻¹ (r × P)`);
//! a robot's body answers through its joints: an impulse on a foot moves the whole robot,
//! `Δ(twists) = M_c⁻¹ P` with `M_c⁻¹ P = S (P + G(q)ᵀ μ)` the projection of
//! [`crate::sim::mechanism::constrained`] (the joints' impulses that keep the velocity
//! constraints). The contact phase needs three things of a robot, all here:
//!
//! - **Its response** at `q_k` (start) and `q_{k+1}` (end): the columns of `M_c⁻¹` for the
//!   bodies that touch, six projections each ([`Robot::columns`]).
//! - **Its motion over the step without the solve's correction**: predicted by stepping the
//!   mechanism once on its own state with the last step's contact impulses already applied
//!   ([`Robot::predict`], [`crate::sim::mechanism::step::predict`]), servos, joint rows,
//!   gravity and applied loads included, so that the solve only corrects that prediction
//!   through `M_c⁻¹`. A resting robot's impulses barely change from step to step, so its
//!   feet's gaps close to the solver's tolerance although `M_c⁻¹` leaves out the servos'
//!   stiffness (the correction is what it scales, and it tends to zero); without the
//!   prediction, a servo pressing a foot into the ground would sink it by about
//!   `h² τ / (m_foot r)` each step.
//! - **Its velocities at the end of the step** for the end projection: the carried momenta
//!   are the discrete Legendre transform's, which meet the velocity constraints only to
//!   O(h); the projected ones do ([`Robot::twists`]).
//!
//! The impulses reach the robot as raw momentum kicks on the bodies that touch; the step that
//! follows applies the joints' impulses (its Newton solve), so the motion is `M_c⁻¹ P` to
//! first order and exactly what the prediction stepped for the warm-start part.

use crate::sim::Bodies;
use crate::sim::integrators::VariationalSettings;
use crate::sim::loads::Loads;
use crate::sim::mechanism::Mechanism;
use crate::sim::mechanism::constrained::{Impulse6, Projector, add_impulses};
use crate::sim::mechanism::step::{self, MechanismState, Warm};
use nalgebra::{DMatrix, Matrix3, UnitQuaternion, Vector3};
use std::sync::Arc;

/// One mechanism with colliders, as the contact phase moves it.
pub struct Robot {
    /// The mechanism with its partition's body indices.
    model: Arc<Mechanism>,
    /// Its partition, and its first body in the batch.
    pub part: usize,
    pub first: usize,
    projector: Projector,
    /// The prediction's own state (warm starts, coordinate branches): the run's stays the
    /// stepper's.
    trial: MechanismState,
    warm: Warm,
    /// The coordinates' branches for the mimic rows' gradients.
    positions: Vec<f64>,
    momenta: Vec<Impulse6>,
    correction: Vec<Impulse6>,
    /// Per body: the contact impulse on it, `[linear (world); angular (body frame)]`.
    pub kicks: Vec<Impulse6>,
    /// Per body: the predicted centre of mass and rotation at the end of the step.
    pub predicted: Vec<(Vector3<f64>, UnitQuaternion<f64>)>,
}

impl Robot {
    /// `model` re-based to partition `part`, whose first body is `first` in the batch.
    pub fn new(model: Arc<Mechanism>, part: usize, first: usize) -> Self {
        let n = model.body_count;
        Self {
            projector: Projector::new(&model),
            trial: MechanismState::new(&model),
            warm: Warm::new(&model),
            positions: model.coordinates.iter().map(|c| c.initial).collect(),
            momenta: vec![Impulse6::zeros(); n],
            correction: vec![Impulse6::zeros(); n],
            kicks: vec![Impulse6::zeros(); n],
            predicted: vec![(Vector3::zeros(), UnitQuaternion::identity()); n],
            part,
            first,
            model,
        }
    }

    /// Its bodies in the batch.
    pub fn bodies(&self) -> std::ops::Range<usize> {
        self.first..self.first + self.model.body_count
    }

    pub fn body_count(&self) -> usize {
        self.model.body_count
    }

    /// Loads the poses from the partition's `bodies` and factors the projection there.
    pub fn load(&mut self, bodies: &Bodies) {
        self.projector.load(&self.model, bodies);
        self.projector.mimics(&self.model, &self.positions);
        self.projector.factor(&self.model);
    }

    /// The projection of `momenta` (in [`Robot::momenta`]-form), into `self.correction`.
    fn project(&mut self) {
        self.projector
            .project(&self.model, &self.momenta, &mut self.correction);
    }

    /// Body `i`'s world twist for the projected momentum `P̂_i`.
    fn world_twist(&self, i: usize, projected: &Impulse6) -> (Vector3<f64>, Vector3<f64>) {
        let v = self.projector.velocity(i, projected);
        let rot: &Matrix3<f64> = &self.projector.poses()[i].rot;
        (
            Vector3::new(v[0], v[1], v[2]),
            rot * Vector3::new(v[3], v[4], v[5]),
        )
    }

    /// The columns of `M_c⁻¹` for body `local` at the loaded poses (after [`Robot::load`]):
    /// the world twists `[v; ω]` of every body (6 rows each) per unit world wrench
    /// `[F; τ]` on it (6 columns).
    pub fn columns(&mut self, local: usize) -> DMatrix<f64> {
        let n = self.model.body_count;
        let mut out = DMatrix::zeros(6 * n, 6);
        let rot = self.projector.poses()[local].rot;
        for k in 0..6 {
            for m in self.momenta.iter_mut() {
                *m = Impulse6::zeros();
            }
            let mut e = Vector3::zeros();
            e[k % 3] = 1.0;
            if k < 3 {
                self.momenta[local].fixed_rows_mut::<3>(0).copy_from(&e);
            } else {
                let body = rot.transpose() * e;
                self.momenta[local].fixed_rows_mut::<3>(3).copy_from(&body);
            }
            self.project();
            for i in 0..n {
                let p = self.momenta[i] + self.correction[i];
                let (v, w) = self.world_twist(i, &p);
                for r in 0..3 {
                    out[(6 * i + r, k)] = v[r];
                    out[(6 * i + 3 + r, k)] = w[r];
                }
            }
        }
        out
    }

    /// The carried momenta of the partition's `bodies`, `[m v; M]` per body.
    fn read_momenta(&mut self, bodies: &Bodies) {
        let first = self.model.first_body;
        for (i, m) in self.momenta.iter_mut().enumerate() {
            let gi = first + i;
            let p = bodies.linvel_world[gi] * bodies.mass[gi];
            let l = bodies.angmom_body[gi];
            *m = Impulse6::new(p.x, p.y, p.z, l.x, l.y, l.z);
        }
    }

    /// The projected world twists of every body (after [`Robot::load`]), into `out`.
    pub fn twists(&mut self, bodies: &Bodies, out: &mut [(Vector3<f64>, Vector3<f64>)]) {
        self.read_momenta(bodies);
        self.project();
        for (i, o) in out.iter_mut().enumerate() {
            let p = self.momenta[i] + self.correction[i];
            *o = self.world_twist(i, &p);
        }
    }

    /// The kinetic energy of the projected momenta, plus [`Robot::kicks`] when `kicked`, J.
    fn kinetic_energy(&mut self, bodies: &Bodies, kicked: bool) -> f64 {
        self.read_momenta(bodies);
        if kicked {
            for (m, k) in self.momenta.iter_mut().zip(&self.kicks) {
                *m += k;
            }
        }
        self.project();
        (0..self.model.body_count)
            .map(|i| {
                let p = self.momenta[i] + self.correction[i];
                0.5 * p.dot(&self.projector.velocity(i, &p))
            })
            .sum()
    }

    /// Steps the mechanism once from the partition's `bodies` with [`Robot::kicks`] applied
    /// (then undone) into [`Robot::predicted`]; `loads` are the partition's at the step's start.
    pub fn predict(
        &mut self,
        bodies: &mut Bodies,
        h: f64,
        loads: &Loads,
        settings: &VariationalSettings,
    ) {
        step::predict(
            &self.model,
            &mut self.trial,
            &mut self.warm,
            bodies,
            h,
            loads,
            settings,
            &self.kicks,
            &mut self.predicted,
        );
    }

    /// Adds [`Robot::kicks`] to the momenta of the partition's `bodies` (after
    /// [`Robot::load`] at their poses); returns the kinetic energy they changed (of the
    /// projected momenta: what the joints let move), J.
    pub fn apply_kicks(&mut self, bodies: &mut Bodies) -> f64 {
        if self.kicks.iter().all(|k| *k == Impulse6::zeros()) {
            return 0.0;
        }
        let before = self.kinetic_energy(bodies, false);
        let after = self.kinetic_energy(bodies, true);
        add_impulses(bodies, self.model.first_body, &self.kicks);
        after - before
    }
}
