//! What is reported of a mechanism at a recorded step: velocities projected onto the velocity
//! constraints (RATTLE-style), joint positions and rates, and the totals (momentum, energy,
//! constraint residual).
//!
//! The carried momenta `P = [p; M]` after a step are the left momenta of the discrete
//! Legendre transform; they satisfy the velocity constraints `G(q) S P = 0` (`S = M⁻¹ =
//! diag(I/m, J⁻¹)`) only to O(h): the next step's impulses correct them. Reported velocities,
//! joint rates and energies use the momenta projected onto those constraints in the kinetic
//! metric (Andersen's RATTLE; Leimkuhler & Reich, *Simulating Hamiltonian Dynamics*, §7.2):
//!
//! ```text
//! P̂ = P + G(q)ᵀ μ,   G S Gᵀ μ = −G S P      (the tree solve of super::tree)
//! ```
//!
//! Impulses `G(q)ᵀ μ` carry no net force or torque ([`super::rows`]), so the projection keeps
//! the total linear and angular momentum of a free-floating mechanism as they are. The carried
//! state is not changed: projecting is reporting only.

use super::constrained::{Impulse6, Projector};
use super::coords::{compound_rates, decompose, unwrap_near};
use super::{CoordinateKind, Mechanism};
use crate::sim::Bodies;
use crate::sim::loads::Loads;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// A mechanism's totals at one instant (projected momenta).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Totals {
    /// Total linear momentum, kg m/s (world).
    pub linear_momentum: Vector3<f64>,
    /// Total angular momentum about the mechanism's centre of mass, kg m²/s (world).
    pub angular_momentum: Vector3<f64>,
    /// Centre of mass of the mechanism, m (world).
    pub com: Vector3<f64>,
    /// Kinetic energy, J.
    pub kinetic_energy: f64,
    /// Potential energy `−Σ m g·c` (zero at the world origin), J.
    pub potential_energy: f64,
    /// Largest anchor gap (gap rows; prismatic mimic rows), m.
    pub residual_m: f64,
    /// Largest axis misalignment (dot rows; revolute mimic rows), rad.
    pub residual_rad: f64,
}

impl Totals {
    pub fn energy(&self) -> f64 {
        self.kinetic_energy + self.potential_energy
    }
}

/// The reporter's output for one mechanism, in the mechanism's local body order.
#[derive(Debug, Clone)]
pub struct Report {
    /// Projected velocity of each body's centre of mass, world, m/s.
    pub linvel_world: Vec<Vector3<f64>>,
    /// Projected body angular momentum `M̂` of each body, kg m²/s (body frame).
    pub angmom_body: Vec<Vector3<f64>>,
    /// Joint coordinates (rad or m; continuous joints unwrapped) and rates.
    pub position: Vec<f64>,
    pub velocity: Vec<f64>,
    /// World poses of the compound joints' interior (massless) links, in joint order and,
    /// within a joint, stage order.
    pub interior_world_from_link: Vec<Isometry3<f64>>,
    pub totals: Totals,
}

/// Reusable buffers for [`Reporter::report`].
#[derive(Debug, Clone)]
pub struct Reporter {
    projector: Projector,
    momenta: Vec<Impulse6>,
    impulse: Vec<Impulse6>,
    /// Per compound joint (by joint index): the last decomposed angles.
    compound_theta: Vec<Vec<f64>>,
    /// The coordinates the stepper carries ([`Reporter::carried_mut`]), when it does.
    carried: Vec<f64>,
    use_carried: bool,
    last_time: Option<f64>,
    pub report: Report,
}

impl Reporter {
    pub fn new(model: &Mechanism) -> Self {
        let n = model.body_count;
        let nc = model.coordinates.len();
        let mut compound_theta = vec![Vec::new(); model.joints.len()];
        let mut interior = 0;
        for (j, joint) in model.joints.iter().enumerate() {
            if let Some(chain) = &joint.compound {
                compound_theta[j] = vec![0.0; chain.axes.len()];
                interior += chain.axes.len() - 1;
            }
        }
        for c in &model.coordinates {
            if let CoordinateKind::Compound { stage } = c.kind {
                compound_theta[c.joint][stage] = c.initial;
            }
        }
        Self {
            projector: Projector::new(model),
            momenta: vec![Impulse6::zeros(); n],
            impulse: vec![Impulse6::zeros(); n],
            compound_theta,
            carried: vec![0.0; nc],
            use_carried: false,
            last_time: None,
            report: Report {
                linvel_world: vec![Vector3::zeros(); n],
                angmom_body: vec![Vector3::zeros(); n],
                position: model.coordinates.iter().map(|c| c.initial).collect(),
                velocity: vec![0.0; nc],
                interior_world_from_link: vec![Isometry3::identity(); interior],
                totals: Totals::default(),
            },
        }
    }

    /// The buffer for the coordinates the stepper carries, and whether the next
    /// [`Reporter::report`] takes its positions from it: set it (`true`) from
    /// [`crate::sim::Integrator::joint_coordinates`] before every report of a run, so that
    /// the reported angles are the stepper's own, at every recording rate.
    pub fn carried_mut(&mut self) -> (&mut [f64], &mut bool) {
        (&mut self.carried, &mut self.use_carried)
    }

    /// Fills [`Reporter::report`] from the batch at simulation time `time_secs`. Positions are
    /// the carried coordinates when [`Reporter::carried_mut`] set them; otherwise (a bare
    /// batch, no stepper) each angle is unwrapped to the branch nearest `θ_prev + θ̇_prev Δt`
    /// (`Δt` the time since the last report), which follows a joint turning up to about π per
    /// reported interval beyond its previous rate.
    pub fn report(
        &mut self,
        model: &Mechanism,
        bodies: &Bodies,
        loads: &Loads,
        time_secs: f64,
    ) -> &Report {
        let first = model.first_body;
        let n = model.body_count;
        let dt = self.last_time.map_or(0.0, |t| time_secs - t);
        self.last_time = Some(time_secs);
        let (mut residual_m, mut residual_rad) = self.projector.load(model, bodies);
        let poses = self.projector.poses();
        // Coordinates (positions) first: the mimic rows' gradients need their branches.
        let report = &mut self.report;
        for (k, c) in model.coordinates.iter().enumerate() {
            let joint = &model.joints[c.joint];
            let a = self.projector.parent_pose(model, joint.parent);
            let reference = report.position[k] + report.velocity[k] * dt;
            if let Some(v) = c.kind.value(&a, &poses[joint.child], reference) {
                report.position[k] = v;
            }
        }
        for (j, joint) in model.joints.iter().enumerate() {
            let Some(chain) = &joint.compound else {
                continue;
            };
            let a = self.projector.parent_pose(model, joint.parent);
            let w = a.rot.transpose() * poses[joint.child].rot;
            decompose(chain, &chain.target(&w), &mut self.compound_theta[j]);
        }
        for (k, c) in model.coordinates.iter().enumerate() {
            if let CoordinateKind::Compound { stage } = c.kind {
                let reference = report.position[k] + report.velocity[k] * dt;
                report.position[k] = unwrap_near(self.compound_theta[c.joint][stage], reference);
            }
        }
        if self.use_carried {
            report.position.copy_from_slice(&self.carried);
        }
        let (mimic_m, mimic_rad) = self.projector.mimics(model, &report.position);
        residual_m = residual_m.max(mimic_m);
        residual_rad = residual_rad.max(mimic_rad);
        // Projection: G S Gᵀ μ = −G S P.
        for i in 0..n {
            let gi = first + i;
            let p = bodies.linvel_world[gi] * bodies.mass[gi];
            let m = bodies.angmom_body[gi];
            self.momenta[i] = Impulse6::new(p.x, p.y, p.z, m.x, m.y, m.z);
        }
        self.projector.factor(model);
        self.projector
            .project(model, &self.momenta, &mut self.impulse);
        let poses = self.projector.poses();
        let mut totals = Totals::default();
        let mut mass = 0.0;
        for i in 0..n {
            let gi = first + i;
            let mi = bodies.mass[gi];
            let v = bodies.linvel_world[gi] + self.impulse[i].fixed_rows::<3>(0) / mi;
            let m = bodies.angmom_body[gi] + self.impulse[i].fixed_rows::<3>(3);
            report.linvel_world[i] = v;
            report.angmom_body[i] = m;
            let c = bodies.com_world[gi];
            totals.linear_momentum += v * mi;
            totals.com += c * mi;
            mass += mi;
            totals.kinetic_energy += 0.5 * mi * v.norm_squared()
                + 0.5 * m.dot(&m.component_mul(&bodies.inv_inertia_body[gi]));
            totals.potential_energy -= mi * loads.gravity().dot(&c);
        }
        totals.com /= mass;
        for i in 0..n {
            let gi = first + i;
            let c = bodies.com_world[gi] - totals.com;
            totals.angular_momentum += c.cross(&(report.linvel_world[i] * bodies.mass[gi]))
                + bodies.world_from_body[gi] * report.angmom_body[i];
        }
        totals.residual_m = residual_m;
        totals.residual_rad = residual_rad;
        report.totals = totals;
        // Rates from the projected velocities.
        for (k, c) in model.coordinates.iter().enumerate() {
            let joint = &model.joints[c.joint];
            let (a, va, oa) = match joint.parent {
                Some(p) => (
                    poses[p],
                    report.linvel_world[p],
                    report.angmom_body[p].component_mul(&bodies.inv_inertia_body[first + p]),
                ),
                None => (model.world_pose, Vector3::zeros(), Vector3::zeros()),
            };
            let b = joint.child;
            let ob = report.angmom_body[b].component_mul(&bodies.inv_inertia_body[first + b]);
            if let Some(rate) = c.kind.rate(
                &a,
                &poses[b],
                (&va, &oa),
                (&report.linvel_world[b], &ob),
                report.position[k],
            ) {
                report.velocity[k] = rate;
            }
        }
        let mut rates = [0.0; 3];
        let mut interior = 0;
        for (j, joint) in model.joints.iter().enumerate() {
            let Some(chain) = &joint.compound else {
                continue;
            };
            let (a, oa) = match joint.parent {
                Some(p) => (
                    poses[p],
                    report.angmom_body[p].component_mul(&bodies.inv_inertia_body[first + p]),
                ),
                None => (model.world_pose, Vector3::zeros()),
            };
            let b = joint.child;
            let ob = report.angmom_body[b].component_mul(&bodies.inv_inertia_body[first + b]);
            let w = a.rot.transpose() * poses[b].rot;
            // Relative angular velocity in the first joint's frame.
            let rel = chain.parent_from_first.inverse() * (w * ob - oa);
            compound_rates(chain, &self.compound_theta[j], &rel, &mut rates);
            for (k, c) in model.coordinates.iter().enumerate() {
                if let (true, CoordinateKind::Compound { stage }) = (c.joint == j, &c.kind) {
                    report.velocity[k] = rates[*stage];
                }
            }
            let world_from_a = Isometry3::from_parts(
                Translation3::from(a.com),
                UnitQuaternion::from_matrix(&a.rot),
            );
            let mut pose = world_from_a * joint.parent_from_first;
            for stage in 0..chain.axes.len() - 1 {
                pose = pose
                    * joint.stage_origins[stage]
                    * UnitQuaternion::from_scaled_axis(
                        chain.axes[stage] * self.compound_theta[j][stage],
                    );
                report.interior_world_from_link[interior] = pose;
                interior += 1;
            }
        }
        &self.report
    }
}
