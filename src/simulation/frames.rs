//! The frame builder: the batch state turned into recorded frames, straight into the buffers
//! the sinks share.

use super::time_ns;
use crate::budget::readable;
use crate::record::{
    BodyState, ContactState, Frame, FramePool, JointState, MechanismState, OwnedFrame,
};
use crate::sim::Bodies;
use crate::sim::Loads;
use crate::sim::contact::{ContactPoint, GROUND};
use crate::sim::mechanism::Mechanism;
use crate::sim::mechanism::project::Reporter;
use crate::sim::partition::Partitions;
use crate::world::{Attachment, InteriorFrame, World};
use nalgebra::{Isometry3, Vector3};
use rayon::prelude::*;
use std::sync::Arc;

/// A joint position for a warning: six decimals, or [`readable`] when that would be more
/// than a few dozen digits.
fn position_text(p: f64) -> String {
    if p.abs() < 1e15 {
        format!("{p:.6}")
    } else {
        readable(p)
    }
}

/// Reusable buffers turning the batch state into recorded frames.
///
/// Free bodies report their carried state. Bodies of an articulated model report the momenta
/// projected onto the velocity constraints ([`crate::sim::mechanism::project`]), and each such
/// model its joint coordinates and totals; compound joints' massless links are placed from the
/// report. A driven joint reports its effort (actuator plus damping), target and saturation
/// from its drive's continuous-time law ([`crate::sim::mechanism::JointDrive::effort`]) at the
/// recorded time (`time_ns / 1e9`), with the recorded position and velocity. A joint found
/// outside its URDF range by more than round-off (1e-9 × (1 + the larger |bound|)) at a
/// recorded step is warned about once (on standard error), naming the joint and the time;
/// never when quiet ([`FrameBuilder::set_quiet`]: the sweeps of `trade` and `stability`).
pub struct FrameBuilder {
    attachments: Arc<Vec<Attachment>>,
    interior: Vec<InteriorFrame>,
    mechanisms: Vec<(Arc<Mechanism>, Reporter)>,
    /// Per mechanism, once a partitioned batch was seen: its partition and itself re-based to
    /// it ([`crate::sim::partition::rebase`]).
    located: Vec<(usize, Mechanism)>,
    /// Per mechanism: its bodies and joints in the layout.
    mechanism_ranges: Vec<(std::ops::Range<usize>, std::ops::Range<usize>)>,
    joint_names: Vec<String>,
    warned_range: Vec<bool>,
    /// No joint-range warning (the sweeps of `trade` and `stability`).
    quiet: bool,
    /// The largest constraint residual over the mechanisms' frames built: m, rad.
    residual_max: [f64; 2],
    /// The frames built: each is written once, straight into a buffer the sinks then share
    /// ([`FrameBuilder::shared`], [`crate::record::owned_frame`]).
    pool: FramePool,
}

/// The state of body `j` of `bodies`, as recorded.
fn body_state(bodies: &Bodies, j: usize, loads: &Loads) -> BodyState {
    BodyState {
        linvel_world: bodies.linvel_world[j],
        angvel_world: bodies.angvel_world(j),
        angmom_world: bodies.angmom_world(j),
        kinetic_energy: bodies.kinetic_energy(j),
        potential_energy: bodies.potential_energy(j, loads),
    }
}

/// The contacts of a step as recorded, appended to `out`: body indices as the layout's (the
/// batch's), the ground as `None`, and the mean force over the step `impulse / dt_secs`.
pub fn contact_states(points: &[ContactPoint], dt_secs: f64, out: &mut Vec<ContactState>) {
    out.extend(points.iter().map(|c| ContactState {
        body_a: c.body_a as usize,
        body_b: (c.body_b != GROUND).then_some(c.body_b as usize),
        point_world: c.point_world,
        normal_world: c.normal_world,
        force_world: c.impulse_world / dt_secs,
        impulse_world: c.impulse_world,
        gap_m: c.gap_m,
    }));
}

/// Items per parallel task when a frame is built from partitions.
const FRAME_TASK_ITEMS: usize = 2048;

/// A body state of zeros (the slots of a new frame buffer, all overwritten).
const NO_STATE: BodyState = BodyState {
    linvel_world: Vector3::new(0.0, 0.0, 0.0),
    angvel_world: Vector3::new(0.0, 0.0, 0.0),
    angmom_world: Vector3::new(0.0, 0.0, 0.0),
    kinetic_energy: 0.0,
    potential_energy: 0.0,
};

impl FrameBuilder {
    pub fn new(world: &World) -> Self {
        let mechanisms: Vec<_> = world
            .mechanisms
            .iter()
            .map(|m| (Arc::clone(m), Reporter::new(m)))
            .collect();
        let mechanism_ranges = world
            .layout
            .mechanisms
            .iter()
            .map(|m| (m.bodies.clone(), m.joints.clone()))
            .collect();
        Self {
            attachments: Arc::clone(&world.attachments),
            interior: world.interior_frames.clone(),
            mechanisms,
            located: Vec::new(),
            mechanism_ranges,
            joint_names: world.layout.joints.iter().map(|j| j.name.clone()).collect(),
            warned_range: vec![false; world.layout.joints.len()],
            quiet: false,
            residual_max: [0.0; 2],
            pool: FramePool::default(),
        }
    }

    /// A free frame buffer for step `step`, sized for `bodies` bodies (every slot is then
    /// written).
    fn start(pool: &mut FramePool, sizes: [usize; 4], step: u64, time_ns: i64) -> &mut OwnedFrame {
        let out = pool.next_free();
        out.step = step;
        out.time_ns = time_ns;
        out.world_from_link.resize(sizes[0], Isometry3::identity());
        out.bodies.resize(sizes[1], NO_STATE);
        out.joints.resize(sizes[2], JointState::default());
        out.mechanisms.resize(sizes[3], MechanismState::default());
        out.contacts.clear();
        out
    }

    /// Silences the joint-range warnings (sweeps that run many variants of one scene).
    pub fn set_quiet(&mut self, quiet: bool) {
        self.quiet = quiet;
    }

    /// The largest constraint residual over the mechanism frames built so far: anchor gap, m,
    /// and axis misalignment, rad ([`crate::sim::mechanism::Totals`]).
    pub fn residual_max(&self) -> [f64; 2] {
        self.residual_max
    }

    fn sizes(&self, bodies: usize) -> [usize; 4] {
        [
            self.attachments.len(),
            bodies,
            self.joint_names.len(),
            self.mechanisms.len(),
        ]
    }

    /// The last frame built.
    fn last(&self) -> Frame<'_> {
        self.pool.current().expect("a frame was built").as_frame()
    }

    /// The last frame built, as the buffer the sinks share ([`Sink::write_shared`]).
    pub fn shared(&mut self) -> &Arc<OwnedFrame> {
        self.pool.shared()
    }

    /// Fills a frame buffer from `bodies` and returns the frame of step `step` (no contacts:
    /// a bare batch has no contact phase).
    pub fn frame(&mut self, bodies: &Bodies, loads: &Loads, step: u64, dt_secs: f64) -> Frame<'_> {
        let time_ns = time_ns(step, dt_secs);
        let time_secs = time_ns as f64 / 1e9;
        let sizes = self.sizes(bodies.len());
        let mut pool = std::mem::take(&mut self.pool);
        let out = Self::start(&mut pool, sizes, step, time_ns);
        for (pose, a) in out.world_from_link.iter_mut().zip(self.attachments.iter()) {
            *pose = if a.body == Attachment::WORLD {
                a.body_from_link
            } else {
                bodies.world_from_body(a.body) * a.body_from_link
            };
        }
        for (i, state) in out.bodies.iter_mut().enumerate() {
            *state = body_state(bodies, i, loads);
        }
        for k in 0..self.mechanisms.len() {
            let (model, reporter) = &mut self.mechanisms[k];
            reporter.report(model, bodies, loads, time_secs);
            let model = Arc::clone(model);
            self.write_mechanism(out, k, &model, bodies, 0, loads, time_secs);
        }
        self.place_interior_frames(out);
        self.pool = pool;
        self.last()
    }

    /// Copies mechanism `k`'s last report into the frame `out`: its bodies' projected states
    /// (`model` is the mechanism as `bodies` index it, `offset` the batch index of `bodies`'
    /// first body), joints and totals; warns once per joint found outside its URDF range.
    #[allow(clippy::too_many_arguments)]
    fn write_mechanism(
        &mut self,
        out: &mut OwnedFrame,
        k: usize,
        model: &Mechanism,
        bodies: &Bodies,
        offset: usize,
        loads: &Loads,
        time_secs: f64,
    ) {
        let report = &self.mechanisms[k].1.report;
        for (i, gi) in model.bodies().enumerate() {
            let q = bodies.world_from_body[gi];
            let m = report.angmom_body[i];
            let omega = m.component_mul(&bodies.inv_inertia_body[gi]);
            let v = report.linvel_world[i];
            let mass = bodies.mass[gi];
            out.bodies[offset + gi] = BodyState {
                linvel_world: v,
                angvel_world: q * omega,
                angmom_world: q * m,
                kinetic_energy: 0.5 * mass * v.norm_squared() + 0.5 * m.dot(&omega),
                potential_energy: bodies.potential_energy(gi, loads),
            };
        }
        let joints = self.mechanism_ranges[k].1.clone();
        // The drives are sorted by coordinate: one pass beside the joints.
        let mut drives = model.drives.iter().peekable();
        let mut stops = model.stops.iter().peekable();
        for (c, j) in joints.enumerate() {
            let (position, velocity) = (report.position[c], report.velocity[c]);
            let drive = drives.next_if(|d| d.coordinate == c);
            out.joints[j] = match drive {
                None => JointState {
                    position,
                    velocity,
                    ..JointState::default()
                },
                Some(d) => {
                    let effort = d.effort(time_secs, position, velocity);
                    JointState {
                        position,
                        velocity,
                        effort: effort.total(),
                        target: d.target(time_secs),
                        saturated: effort.saturated,
                        ..JointState::default()
                    }
                }
            };
            let stop = stops.next_if(|s| s.coordinate == c);
            if let Some([lo, hi]) = model.coordinates[c].limits {
                let p = report.position[c];
                let enforced = stop.and_then(|s| s.limits).is_some();
                // With the limit on, the joint stays in its range to the solver's tolerance:
                // only a joint placed beyond a bound (which the limit keeps from going
                // further) is outside it by more.
                let slack = if enforced {
                    1e-9 * (1.0 + lo.abs().max(hi.abs()))
                } else {
                    0.0
                };
                if enforced {
                    out.joints[j].at_limit = p >= hi - slack || p <= lo + slack;
                }
                // A warning only beyond round-off of the bounds (a joint at -0.0 or -1e-17
                // in [0, x] is at its bound, limit on or off), and none in quiet sweeps.
                let tolerance = 1e-9 * (1.0 + lo.abs().max(hi.abs()));
                if !self.quiet
                    && !self.warned_range[j]
                    && !(lo - tolerance..=hi + tolerance).contains(&p)
                {
                    self.warned_range[j] = true;
                    let why = if enforced {
                        "it was placed there: its limit keeps it from going further"
                    } else {
                        "its limit is off (joint_limits = false, or a mimic follower)"
                    };
                    eprintln!(
                        "warning: joint {:?} left its URDF range [{}, {}] at t = {} s \
                         (position {}); {why} (docs/mechanisms.md)",
                        self.joint_names[j],
                        readable(lo),
                        readable(hi),
                        readable(time_secs),
                        position_text(p)
                    );
                }
            }
        }
        let t = &report.totals;
        self.residual_max[0] = self.residual_max[0].max(t.residual_m);
        self.residual_max[1] = self.residual_max[1].max(t.residual_rad);
        out.mechanisms[k] = MechanismState {
            linear_momentum: t.linear_momentum,
            angular_momentum: t.angular_momentum,
            com: t.com,
            kinetic_energy: t.kinetic_energy,
            potential_energy: t.potential_energy,
            residual_m: t.residual_m,
            residual_rad: t.residual_rad,
        };
    }

    /// Places the compound joints' massless links of `out` from the last reports.
    fn place_interior_frames(&self, out: &mut OwnedFrame) {
        for f in &self.interior {
            let report = &self.mechanisms[f.mechanism].1.report;
            out.world_from_link[f.frame] =
                report.interior_world_from_link[f.interior] * f.interior_from_link;
        }
    }

    /// [`Self::frame`] from a partitioned batch, built on its threads (same values), with the
    /// contacts of the batch's last step ([`Partitions::contacts`], [`contact_states`]).
    pub fn frame_of_parts(
        &mut self,
        batch: &Partitions<'_>,
        loads: &Loads,
        step: u64,
        dt_secs: f64,
    ) -> Frame<'_> {
        let time_ns = time_ns(step, dt_secs);
        let sizes = self.sizes(batch.len());
        let mut pool = std::mem::take(&mut self.pool);
        let out = Self::start(&mut pool, sizes, step, time_ns);
        contact_states(batch.contacts(), dt_secs, &mut out.contacts);
        let attachments = &self.attachments;
        let view = batch.view();
        let parts = &view;
        let (poses, states) = (&mut out.world_from_link, &mut out.bodies);
        let place = |(poses, attachments): (&mut [Isometry3<f64>], &[Attachment])| {
            for (pose, a) in poses.iter_mut().zip(attachments) {
                *pose = if a.body == Attachment::WORLD {
                    a.body_from_link
                } else {
                    parts.world_from_body(a.body) * a.body_from_link
                };
            }
        };
        let fill = |(c, states): (usize, &mut [BodyState])| {
            for (k, state) in states.iter_mut().enumerate() {
                let (bodies, j) = parts.body(c * FRAME_TASK_ITEMS + k);
                *state = body_state(bodies, j, loads);
            }
        };
        // On the stepping pool's threads, or here on one thread (`View::is_threaded`).
        if view.is_threaded() {
            view.install(|| {
                poses
                    .par_chunks_mut(FRAME_TASK_ITEMS)
                    .zip(attachments.par_chunks(FRAME_TASK_ITEMS))
                    .for_each(place);
                states
                    .par_chunks_mut(FRAME_TASK_ITEMS)
                    .enumerate()
                    .for_each(fill);
            });
        } else {
            poses
                .chunks_mut(FRAME_TASK_ITEMS)
                .zip(attachments.chunks(FRAME_TASK_ITEMS))
                .for_each(place);
            states
                .chunks_mut(FRAME_TASK_ITEMS)
                .enumerate()
                .for_each(fill);
        }
        if !self.mechanisms.is_empty() {
            let time_secs = time_ns as f64 / 1e9;
            self.report_mechanisms(batch, loads, time_secs);
            let located = std::mem::take(&mut self.located);
            for (m, (k, local)) in located.iter().enumerate() {
                let part = &batch.parts[*k];
                self.write_mechanism(out, m, local, &part.bodies, part.first, loads, time_secs);
            }
            self.located = located;
            self.place_interior_frames(out);
        }
        self.pool = pool;
        self.last()
    }

    /// Runs every mechanism's reporter on the batch (projections, coordinates, rates, totals),
    /// one task per mechanism on the stepping pool.
    fn report_mechanisms(&mut self, batch: &Partitions<'_>, loads: &Loads, time_secs: f64) {
        if self.located.len() != self.mechanisms.len() {
            self.located = self
                .mechanisms
                .iter()
                .map(|(m, _)| {
                    let k = batch.part_of(m.first_body);
                    let start = batch.parts[k].first;
                    let range = start..start + batch.parts[k].bodies.len();
                    let local = crate::sim::partition::rebase(std::slice::from_ref(m), &range);
                    (k, Mechanism::clone(&local[0]))
                })
                .collect();
        }
        for (model, reporter) in &mut self.mechanisms {
            let (carried, use_carried) = reporter.carried_mut();
            *use_carried = batch.joint_coordinates(model.first_body, carried);
        }
        let view = batch.view();
        let located = &self.located;
        let report = |((_, reporter), (k, local)): (
            &mut (Arc<Mechanism>, Reporter),
            &(usize, Mechanism),
        )| {
            reporter.report(local, view.part(*k), loads, time_secs);
        };
        if view.is_threaded() {
            view.install(|| {
                self.mechanisms
                    .par_iter_mut()
                    .zip(located.par_iter())
                    .for_each(report);
            });
        } else {
            self.mechanisms.iter_mut().zip(located).for_each(report);
        }
    }

    /// The joints' positions and rates at `step`, as [`FrameBuilder::frame_of_parts`] reports
    /// them (the mechanisms' reports alone: no link pose, body state or total), in the order
    /// of the layout's joints.
    pub fn joints_of_parts(
        &mut self,
        batch: &Partitions<'_>,
        loads: &Loads,
        step: u64,
        dt_secs: f64,
        position: &mut [f64],
        velocity: &mut [f64],
    ) {
        if self.mechanisms.is_empty() {
            return;
        }
        self.report_mechanisms(batch, loads, time_ns(step, dt_secs) as f64 / 1e9);
        for (k, (_, reporter)) in self.mechanisms.iter().enumerate() {
            let joints = self.mechanism_ranges[k].1.clone();
            let report = &reporter.report;
            position[joints.clone()].copy_from_slice(&report.position[..joints.len()]);
            velocity[joints.clone()].copy_from_slice(&report.velocity[..joints.len()]);
        }
    }

    /// Total mechanical energy of the last frame built (reported states), J.
    pub fn total_energy(&self) -> f64 {
        self.last()
            .bodies
            .iter()
            .map(|s| s.kinetic_energy + s.potential_energy)
            .sum()
    }

    /// The scale of each quantity of [`Self::conserved_angmom`], in its order: the sum of
    /// `body_scale` over its bodies (one free body's own; a floating mechanism's summed).
    pub fn conserved_scales(
        &self,
        touches: &dyn Fn(usize) -> bool,
        body_scale: &dyn Fn(usize) -> f64,
    ) -> Vec<f64> {
        let last = self.last();
        let mut out = Vec::new();
        let mut in_mechanism: Vec<bool> = (0..last.bodies.len()).map(touches).collect();
        for (model, _) in &self.mechanisms {
            let collides = model.bodies().any(touches);
            for i in model.bodies() {
                in_mechanism[i] = true;
            }
            if model.base == crate::sim::mechanism::Base::Floating && !collides {
                out.push(model.bodies().map(body_scale).sum());
            }
        }
        out.extend(
            in_mechanism
                .iter()
                .enumerate()
                .filter(|(_, m)| !**m)
                .map(|(i, _)| body_scale(i)),
        );
        out
    }

    /// Angular momenta whose conservation the run summary checks, from the last frame built:
    /// every free body's (about its centre of mass) and every floating articulated model's
    /// total (about the model's centre of mass); fixed-base models are held by the world and
    /// left out, and so are the bodies `touches` (those with colliders: contact exchanges
    /// their momenta with the ground) and the models holding one.
    pub fn conserved_angmom(&self, out: &mut Vec<Vector3<f64>>, touches: &dyn Fn(usize) -> bool) {
        out.clear();
        let last = self.last();
        let mut in_mechanism: Vec<bool> = (0..last.bodies.len()).map(touches).collect();
        for (k, (model, _)) in self.mechanisms.iter().enumerate() {
            let collides = model.bodies().any(touches);
            for i in model.bodies() {
                in_mechanism[i] = true;
            }
            if model.base == crate::sim::mechanism::Base::Floating && !collides {
                out.push(last.mechanisms[k].angular_momentum);
            }
        }
        out.extend(
            last.bodies
                .iter()
                .zip(&in_mechanism)
                .filter(|(_, m)| !**m)
                .map(|(s, _)| s.angmom_world),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A contact with the ground records `body_b = None`, one between bodies its index; the
    /// force is the impulse over the step (a thousand times it at dt = 1 ms); the rest is
    /// copied; `out` is appended to.
    #[test]
    fn contact_states_name_the_ground_and_divide_the_impulse_by_the_step() {
        let points = [
            ContactPoint {
                body_a: 3,
                body_b: GROUND,
                point_world: Vector3::new(0.5, -0.25, 0.0),
                normal_world: Vector3::z(),
                impulse_world: Vector3::new(1e-4, -2e-4, 5.886e-2),
                gap_m: -3e-7,
            },
            ContactPoint {
                body_a: 1,
                body_b: 2,
                point_world: Vector3::new(1.0, 2.0, 3.0),
                normal_world: -Vector3::x(),
                impulse_world: Vector3::new(-0.002, 0.0, 0.0),
                gap_m: 1e-9,
            },
        ];
        let mut out = vec![ContactState {
            body_a: 0,
            body_b: None,
            point_world: Vector3::zeros(),
            normal_world: Vector3::z(),
            force_world: Vector3::zeros(),
            impulse_world: Vector3::zeros(),
            gap_m: 0.0,
        }];
        contact_states(&points, 1e-3, &mut out);
        assert_eq!(out.len(), 3);
        let (ground, pair) = (&out[1], &out[2]);
        assert_eq!((ground.body_a, ground.body_b), (3, None));
        assert_eq!((pair.body_a, pair.body_b), (1, Some(2)));
        for (state, point) in [ground, pair].into_iter().zip(&points) {
            let expected = point.impulse_world * 1e3;
            assert!((state.force_world - expected).norm() <= 1e-15 * expected.norm());
            assert_eq!(state.impulse_world, point.impulse_world);
            assert_eq!(state.point_world, point.point_world);
            assert_eq!(state.normal_world, point.normal_world);
            assert_eq!(state.gap_m, point.gap_m);
        }
    }
}
