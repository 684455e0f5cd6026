//! Where results go. One [`Sink`] trait; implementations for MCAP ([`mcap`]), Rerun ([`rerun`]),
//! ROS 2 MCAP ([`ros2`]) and Parquet tables ([`parquet`]), one folder per format.
//!
//! A recorder receives a [`RecordingLayout`] once (what frames exist, what they look like, the
//! metadata) and then one [`Frame`] per recorded step. It knows nothing of integrators.
//!
//! Shared by the formats: [`format`] the formats, their files and the one place their sinks
//! are opened ([`open`], [`open_file`]); [`names`] the topics and frame ids; [`pipelined`] a
//! sink on its own thread; [`owned_frame`] the frames such sinks share; [`writeback`] files
//! handed to the disk's writeback as they grow; [`layout_json`] the layout stored in the MCAP
//! files; [`scene_update`] the visual geometry (MCAP `/scene`, and the meshes Rerun embeds);
//! [`contacts`] what the formats share of the contacts (the ground's pose, the arrows' scale).
//! [`finish_all`] ends a run's sinks and publishes all their files or none.

pub mod contacts;
pub mod format;
pub mod foxglove_layout;
pub mod layout_json;
pub mod mcap;
pub mod names;
pub mod owned_frame;
pub mod parquet;
pub mod pipelined;
pub mod rerun;
pub mod ros2;
pub mod scene_update;
pub mod writeback;

use crate::model::Visual;
use nalgebra::{Isometry3, Vector3};
use std::collections::BTreeMap;

pub use format::{Format, FormatSet, OutputFile, SinkOptions, open, open_file};
pub use owned_frame::{FramePool, OwnedFrame};

/// Everything a recorder needs to know before the first frame.
#[derive(Debug, Clone, Default)]
pub struct RecordingLayout {
    /// Application/recording name (e.g. the scene's file stem). ASCII letters, digits, `_ -`.
    pub name: String,
    /// One entry per recorded link frame, in the order of [`Frame::world_from_link`].
    pub frames: Vec<FrameLayout>,
    /// One entry per simulated body, in the order of [`Frame::bodies`].
    pub bodies: Vec<BodyLayout>,
    /// Scene text, integrator settings, tool version, ... (written as MCAP metadata and as
    /// Rerun recording properties / a text document).
    pub metadata: BTreeMap<String, String>,
    /// MCAP topic groups: each group gets its own `<prefix>/tf` and `<prefix>/bodies` topics
    /// holding only its frames and bodies (e.g. one group per integrator in `tumble trade`).
    /// Empty: one group with the empty prefix, i.e. the topics `/tf` and `/bodies`.
    pub topic_groups: Vec<TopicGroup>,
    /// One entry per recorded joint coordinate of the articulated models, in the order of
    /// [`Frame::joints`] (empty without articulated models).
    pub joints: Vec<JointLayout>,
    /// One entry per articulated model, in the order of [`Frame::mechanisms`].
    pub mechanisms: Vec<MechanismLayout>,
    /// One per model of the scene, in scene order: its URDF prepared for publishing next to the
    /// frames ([`crate::model::description`]). Read by the ROS 2 sink (`/robot_description`).
    pub robot_descriptions: Vec<RobotDescription>,
    /// What drives the joints (actuators, damping): at most one entry per joint, sorted by
    /// [`DriveLayout::joint`]; empty when no joint is driven. It decides which fields, series
    /// and columns the recordings carry beside [`JointState::effort`] and
    /// [`JointState::target`] (filled by `crate::world::World::describe_drives`).
    pub drives: Vec<DriveLayout>,
    /// The ground the bodies stand on (a half-space), drawn in the viewers; `None` without one.
    pub ground: Option<GroundLayout>,
    /// Whether the run can have contacts (a ground or bodies that collide): it decides whether
    /// the recordings have a contacts topic, series and table at all, so a run without contact
    /// writes the files it wrote before contact existed. The contacts themselves arrive in
    /// [`Frame::contacts`]. Filled, with [`Self::ground`], by
    /// `crate::world::World::describe_contact`.
    pub contacts: bool,
    /// The joints whose URDF limit is enforced (joint limits, issue 31): indices into
    /// [`Self::joints`], increasing; empty when none is. It decides which joints carry
    /// [`JointState::at_limit`] in the recordings (a Rerun series, an MCAP field), so a
    /// recording without limits keeps those bytes. Filled by
    /// `crate::world::World::describe_drives`.
    pub limited: Vec<usize>,
}

/// The ground of a scene as the recordings draw it: the plane through [`Self::point`] with
/// the outward unit normal [`Self::normal`] (the bodies are on the side it points to).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundLayout {
    /// Unit outward normal (for a level ground: up, `−g / |g|`).
    pub normal: Vector3<f64>,
    /// A point of the ground's surface, m.
    pub point: Vector3<f64>,
}

/// One contact at a recorded step: the contact points the step that ended at the recorded
/// time applied impulses at (world frame, SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactState {
    /// The body the impulse acts on (index into [`RecordingLayout::bodies`]).
    pub body_a: usize,
    /// The other body (index into [`RecordingLayout::bodies`]; it receives the opposite
    /// impulse), or `None` for the ground.
    pub body_b: Option<usize>,
    /// The contact point (on `b`'s surface), m.
    pub point_world: Vector3<f64>,
    /// Unit normal from `b` toward `a`.
    pub normal_world: Vector3<f64>,
    /// The mean force on `a` over the step, `impulse_world / dt`, N.
    pub force_world: Vector3<f64>,
    /// The impulse on `a` over the step, N s.
    pub impulse_world: Vector3<f64>,
    /// Signed gap at the start of the step, m (negative: penetration).
    pub gap_m: f64,
}

/// What drives a recorded joint (issue 30): its actuator's law, the actuator's effort limit and
/// the joint's damping. The values recorded per step are in [`JointState`].
#[derive(Debug, Clone, PartialEq)]
pub struct DriveLayout {
    /// Index into [`RecordingLayout::joints`].
    pub joint: usize,
    /// The actuator's law; `None`: damping alone.
    pub actuator: Option<ActuatorLaw>,
    /// `|τ_a| ≤ effort_limit` (N m, or N for a prismatic joint) when the actuator's effort is
    /// limited: the joints whose [`JointState::saturated`] can be true.
    pub effort_limit: Option<f64>,
    /// Viscous damping `b` (N m s/rad or N s/m), 0 without.
    pub damping: f64,
}

/// An actuator's law, as recordings name it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ActuatorLaw {
    /// `τ = u(t)`: no target.
    Motor,
    /// A position servo `τ = kp (r(t) − θ) − kd θ̇`: its target `r` is a position (rad or m).
    Position,
    /// A velocity servo `τ = kd (w(t) − θ̇)`: its target `w` is a velocity (rad/s or m/s).
    Velocity,
}

impl ActuatorLaw {
    /// `motor`, `position`, `velocity` (the layout JSON's and the Parquet `drive` column's).
    pub fn name(self) -> &'static str {
        match self {
            ActuatorLaw::Motor => "motor",
            ActuatorLaw::Position => "position",
            ActuatorLaw::Velocity => "velocity",
        }
    }

    /// The law named `name` ([`Self::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        [Self::Motor, Self::Position, Self::Velocity]
            .into_iter()
            .find(|law| law.name() == name)
    }
}

impl DriveLayout {
    /// What the drive is called in recordings: its actuator's law ([`ActuatorLaw::name`]), or
    /// `damping` for damping alone.
    pub fn kind_name(&self) -> &'static str {
        self.actuator.map_or("damping", ActuatorLaw::name)
    }
}

/// A recorded joint of an articulated model.
#[derive(Debug, Clone, PartialEq)]
pub struct JointLayout {
    /// Name used in recordings: the URDF joint name, prefixed `name/` when the scene gave the
    /// model a `name` (like frame ids).
    pub name: String,
    /// The model (as [`FrameLayout::model`]).
    pub model: String,
    /// The URDF joint type: `revolute`, `continuous` or `prismatic` (positions in rad, rad, m).
    pub kind: String,
    /// The URDF `<limit>` range, if any.
    pub limits: Option<[f64; 2]>,
}

/// A recorded articulated model: which bodies and joints are its own.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MechanismLayout {
    /// The model's name (as [`FrameLayout::model`]).
    pub name: String,
    /// Indices into [`RecordingLayout::bodies`].
    pub bodies: std::ops::Range<usize>,
    /// Indices into [`RecordingLayout::joints`].
    pub joints: std::ops::Range<usize>,
    /// Whether the base floats (the totals' momenta are then conserved without gravity).
    pub floating: bool,
}

/// A model's URDF with its link names turned into the layout's frame ids and its meshes into
/// absolute `file://` URIs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RobotDescription {
    /// The model's label, as in [`FrameLayout::model`].
    pub model: String,
    /// The URDF file it was read from.
    pub urdf_path: std::path::PathBuf,
    /// The rewritten URDF text, or why the file could not be rewritten (the ROS 2 sink reports
    /// it; the other sinks do not need the text).
    pub urdf: Result<String, String>,
}

/// A contiguous run of frames and bodies published under one topic prefix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicGroup {
    /// Topic prefix starting with `/` (e.g. `/rk4`), or empty.
    pub prefix: String,
    /// Indices into [`RecordingLayout::frames`].
    pub frames: std::ops::Range<usize>,
    /// Indices into [`RecordingLayout::bodies`].
    pub bodies: std::ops::Range<usize>,
    /// Indices into [`RecordingLayout::joints`].
    pub joints: std::ops::Range<usize>,
    /// Indices into [`RecordingLayout::mechanisms`].
    pub mechanisms: std::ops::Range<usize>,
}

impl RecordingLayout {
    /// Whether any recorded link frame has mesh geometry among its visuals: the inertia
    /// ellipsoids are then left out by default (they would hide the meshes; `--ellipsoids`
    /// brings them back).
    pub fn has_meshes(&self) -> bool {
        self.frames.iter().any(|f| {
            f.visuals
                .iter()
                .any(|v| matches!(v.geometry, crate::model::Geometry::Mesh { .. }))
        })
    }

    /// Whether the inertia ellipsoids are recorded when the user chose neither way: yes, unless
    /// a model has meshes ([`Self::has_meshes`]). A model without visual geometry keeps them
    /// (they are all a viewer would show of it).
    pub fn default_ellipsoids(&self) -> bool {
        !self.has_meshes()
    }

    /// The robot the viewers open on, as the index of the frame they follow: the first
    /// articulated model's (the frame of its first body, the base, when the base floats; else
    /// its first link frame, the fixed base), or without an articulated model the first link
    /// frame of the first model with meshes. `None` for a recording of neither (free bodies of
    /// primitive shapes): the viewers then frame the whole run.
    pub fn robot_root(&self) -> Option<usize> {
        if let Some(m) = self.mechanisms.first() {
            if m.floating
                && let Some(body) = self.bodies.get(m.bodies.start)
                && body.frame < self.frames.len()
            {
                return Some(body.frame);
            }
            if let Some(i) = self.frames.iter().position(|f| f.model == m.name) {
                return Some(i);
            }
        }
        let meshed = self.frames.iter().find(|f| {
            f.visuals
                .iter()
                .any(|v| matches!(v.geometry, crate::model::Geometry::Mesh { .. }))
        })?;
        self.frames.iter().position(|f| f.model == meshed.model)
    }

    /// Whether the robot of [`Self::robot_root`] is welded to the world (a fixed-base articulated
    /// model): it cannot leave its workspace, so the viewers frame all of it over the run and
    /// need not follow it.
    pub fn robot_is_fixed(&self) -> bool {
        self.mechanisms.first().is_some_and(|m| !m.floating)
    }

    /// The drive of joint `joint`, if it is driven.
    pub fn drive_of(&self, joint: usize) -> Option<&DriveLayout> {
        self.drives
            .binary_search_by_key(&joint, |d| d.joint)
            .ok()
            .map(|i| &self.drives[i])
    }

    /// The topic groups, or the single default group covering everything.
    pub fn groups(&self) -> Vec<TopicGroup> {
        if self.topic_groups.is_empty() {
            vec![TopicGroup {
                prefix: String::new(),
                frames: 0..self.frames.len(),
                bodies: 0..self.bodies.len(),
                joints: 0..self.joints.len(),
                mechanisms: 0..self.mechanisms.len(),
            }]
        } else {
            self.topic_groups.clone()
        }
    }
}

/// A recorded link frame.
#[derive(Debug, Clone)]
pub struct FrameLayout {
    /// Frame id used in both recordings: the link name, prefixed `name/` when the scene gave the
    /// model a `name`. The parent of every frame is `"world"`.
    pub frame_id: String,
    /// The model (robot) this link belongs to: the scene's `name` for the model if given,
    /// else the URDF `<robot name>`. Used as the root of the Rerun entity tree.
    pub model: String,
    /// The URDF link name (without prefix).
    pub link: String,
    /// Visual geometry in the link frame (shared with the model's link: copies of a model do
    /// not copy it).
    pub visuals: std::sync::Arc<[Visual]>,
}

impl FrameLayout {
    /// How far the frame's visual geometry reaches from its origin, m: the largest distance of
    /// a visual origin plus the shape's bounding radius (a mesh counts 0.1 m per unit of
    /// scale). What the viewers' framing grows a frame's position by.
    pub fn reach(&self) -> f64 {
        use crate::model::Geometry;
        self.visuals
            .iter()
            .map(|v| {
                let shape = match &v.geometry {
                    Geometry::Box { size } => size.norm() / 2.0,
                    Geometry::Sphere { radius } => *radius,
                    Geometry::Cylinder { radius, length } => radius.hypot(length / 2.0),
                    Geometry::Capsule { radius, length } => radius + length / 2.0,
                    Geometry::Mesh { scale, .. } => 0.1 * scale.amax(),
                };
                v.link_from_visual.translation.vector.norm() + shape
            })
            .fold(0.0, f64::max)
    }
}

/// A simulated body (a link with mass, or a whole model locked rigid).
#[derive(Debug, Clone)]
pub struct BodyLayout {
    /// Name used for per-body series and velocity messages: the frame id of its link, or for a
    /// whole model locked rigid (`bodies = "rigid"`) the model's name (the scene's `name`, else
    /// the URDF `<robot name>`).
    pub name: String,
    /// Index into [`RecordingLayout::frames`] of the frame the body moves (a rigid model's: its
    /// root link frame).
    pub frame: usize,
    pub mass: f64,
    /// Pose of the body's principal frame (origin at the centre of mass, axes along the
    /// principal axes) in the link frame.
    pub link_from_principal: Isometry3<f64>,
    /// Principal moments of inertia about the centre of mass, kg m^2.
    pub principal_moments: Vector3<f64>,
}

impl BodyLayout {
    /// Semi-axes of the uniform-density solid ellipsoid with the same mass and principal moments:
    /// `I1 = m (b^2 + c^2) / 5` etc., so `a^2 = 5 (I2 + I3 - I1) / (2 m)`.
    /// Moments that break the triangle inequality give a zero axis (clamped, never NaN).
    pub fn inertia_ellipsoid_radii(&self) -> Vector3<f64> {
        let i = self.principal_moments;
        let k = 5.0 / (2.0 * self.mass);
        Vector3::new(
            (k * (i.y + i.z - i.x)).max(0.0).sqrt(),
            (k * (i.x + i.z - i.y)).max(0.0).sqrt(),
            (k * (i.x + i.y - i.z)).max(0.0).sqrt(),
        )
    }
}

/// The state of one body at a recorded step, world frame, SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyState {
    /// Velocity of the centre of mass, m/s.
    pub linvel_world: Vector3<f64>,
    /// Angular velocity, rad/s.
    pub angvel_world: Vector3<f64>,
    /// Angular momentum about the body's own centre of mass, kg m^2/s (conserved without torque).
    pub angmom_world: Vector3<f64>,
    /// Translational plus rotational kinetic energy, J.
    pub kinetic_energy: f64,
    /// Gravitational potential energy `-m g . c` (zero at the world origin), J.
    pub potential_energy: f64,
}

/// One joint at a recorded step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct JointState {
    /// rad (continuous joints unwrapped) or m.
    pub position: f64,
    /// rad/s or m/s, from the projected velocities.
    pub velocity: f64,
    /// The effort applied to the joint, actuator plus damping, N m (or N for a prismatic
    /// joint); 0 for a joint nothing drives. The continuous-time effort at the sample: the
    /// drive's law evaluated at the recorded time with the recorded `position` and `velocity`
    /// (the step itself applies each step's symmetric average, `crate::sim::mechanism::drive`).
    pub effort: f64,
    /// The commanded target at the recorded time: a position servo's position (rad or m), a
    /// velocity servo's velocity (rad/s or m/s); `None` for a motor, damping alone or an
    /// undriven joint ([`DriveLayout::actuator`] says which).
    pub target: Option<f64>,
    /// Whether the actuator's effort limit clamped the effort at the sample.
    pub saturated: bool,
    /// Whether the joint is at a bound of its URDF range with its limit on (within 1e-9 of
    /// the bound, relative to `1 + |bound|`): the limit is what holds it there (joint limits,
    /// `crate::sim::mechanism::stop`). `false` for a joint without an enforced limit.
    pub at_limit: bool,
}

/// One articulated model's totals at a recorded step, world frame, SI units (from the momenta
/// projected onto the velocity constraints).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MechanismState {
    /// Total linear momentum, kg m/s.
    pub linear_momentum: Vector3<f64>,
    /// Total angular momentum about the model's centre of mass, kg m^2/s.
    pub angular_momentum: Vector3<f64>,
    /// The model's centre of mass, m.
    pub com: Vector3<f64>,
    /// J
    pub kinetic_energy: f64,
    /// J, zero at the world origin.
    pub potential_energy: f64,
    /// Largest anchor gap of any joint, m.
    pub residual_m: f64,
    /// Largest axis misalignment of any joint, rad.
    pub residual_rad: f64,
}

/// One recorded step.
#[derive(Debug, Clone, Copy)]
pub struct Frame<'a> {
    /// Integrator step index (0 = initial state).
    pub step: u64,
    /// Simulation time, integer nanoseconds (= `step * dt_ns`).
    pub time_ns: i64,
    /// Pose of each link frame in the world, in the order of [`RecordingLayout::frames`].
    pub world_from_link: &'a [Isometry3<f64>],
    /// Per-body state, in the order of [`RecordingLayout::bodies`].
    pub bodies: &'a [BodyState],
    /// Per-joint state, in the order of [`RecordingLayout::joints`] (empty without articulated
    /// models).
    pub joints: &'a [JointState],
    /// Per articulated model, in the order of [`RecordingLayout::mechanisms`].
    pub mechanisms: &'a [MechanismState],
    /// The contacts of the step that ended at this one (empty at step 0, without contact, and
    /// when nothing touches).
    pub contacts: &'a [ContactState],
}

/// Ends a recording run. After `result` is `Ok`, completes every sink under its `<path>.part`
/// name first and renames them onto their final names only when all of them completed, so a run
/// publishes all its files or none (a full disk while finishing the second file does not leave
/// the first one behind as if the run had succeeded). After an error, or when completing one
/// fails, no sink is published and the `.part` files of `outputs` are removed: nothing
/// half-written ever appears under a final name.
pub fn finish_all<T>(
    sinks: Vec<Box<dyn Sink>>,
    result: anyhow::Result<T>,
    outputs: &[&std::path::Path],
) -> anyhow::Result<T> {
    // Only this run's own `.part` files are removed ([`crate::fsutil::discard`]): a `.part`
    // another run holds is never touched.
    let discard = || crate::fsutil::discard(outputs);
    let value = match result {
        Ok(value) => value,
        Err(e) => {
            drop(sinks);
            discard();
            return Err(e);
        }
    };
    // Every sink with a file starts completing at once (on its own thread when pipelined:
    // the summaries, flushes and syncs of the files overlap), then each is waited for.
    let mut sinks = sinks;
    for sink in sinks.iter_mut().filter(|s| s.path().is_some()) {
        sink.start_complete();
    }
    let mut completed = Vec::new();
    for sink in sinks {
        let outcome = match sink.path() {
            Some(path) => sink.complete().map(|()| completed.push(path)),
            None => sink.finish(),
        };
        if let Err(e) = outcome {
            discard();
            return Err(e);
        }
    }
    let completed: Vec<&std::path::Path> = completed.iter().map(|p| p.as_path()).collect();
    crate::fsutil::publish(&completed)?;
    Ok(value)
}

/// A recording being written.
pub trait Sink {
    /// Record one step. Frames arrive in increasing time.
    fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()>;
    /// Record one step held in a shared buffer ([`owned_frame`]). By default it is written as
    /// any frame; a sink on its own thread ([`pipelined::Pipelined`]) queues the buffer itself,
    /// without a copy.
    fn write_shared(&mut self, frame: &std::sync::Arc<OwnedFrame>) -> anyhow::Result<()> {
        self.write(&frame.as_frame())
    }
    /// Flush everything and close the file so that readers see a complete recording under its
    /// final name.
    fn finish(self: Box<Self>) -> anyhow::Result<()>;
    /// The file's final name, for sinks that write one under `<path>.part` (then
    /// [`finish_all`] uses [`Sink::complete`] and renames itself).
    fn path(&self) -> Option<std::path::PathBuf> {
        None
    }
    /// Like [`Sink::finish`], but leaves the complete file under `<path>.part`.
    fn complete(self: Box<Self>) -> anyhow::Result<()> {
        self.finish()
    }
    /// Starts [`Sink::complete`] without waiting for it, so that several sinks complete at the
    /// same time ([`finish_all`]); the caller then calls `complete`, which waits. Sinks that
    /// complete on the caller's thread do nothing here (the default).
    fn start_complete(&mut self) {}
    /// Records what the run did, after its last frame and before the end (the MCAP files
    /// write it as the metadata record [`names::SUMMARY_METADATA_NAME`]); other sinks keep
    /// nothing of it (the default).
    fn write_summary(&mut self, entries: &[(String, String)]) -> anyhow::Result<()> {
        let _ = entries;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// After a failed run nothing appears under the final name, and no `.part` is left behind;
    /// after a good one the final file exists and the `.part` is gone.
    #[test]
    fn finish_all_discards_after_an_error_and_renames_after_success() {
        let dir = tempfile::tempdir().unwrap();
        let layout = RecordingLayout {
            name: "t".into(),
            ..Default::default()
        };
        for ok in [false, true] {
            let path = dir.path().join(format!("run_{ok}.mcap"));
            let sink = mcap::McapSink::create(&path, &layout).unwrap();
            assert!(crate::fsutil::part_path(&path).exists());
            let result = if ok {
                Ok(())
            } else {
                Err(anyhow::anyhow!("boom"))
            };
            let out = finish_all(vec![Box::new(sink)], result, &[&path]);
            assert_eq!(out.is_ok(), ok);
            assert_eq!(path.exists(), ok, "{}", path.display());
            assert!(!crate::fsutil::part_path(&path).exists());
        }
    }
}
