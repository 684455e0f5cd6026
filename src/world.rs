//! What a scene builds and a simulation steps: the bodies' initial states, the mechanisms over
//! them, how recorded link frames follow the bodies, and what the recorders need to know
//! ([`RecordingLayout`]).
//!
//! `scene` builds a [`World`] (`crate::scene::Scene::build`); `simulation` steps it; nothing
//! here knows TOML or integrator choice.

use crate::model::urdf;
use crate::record::{ActuatorLaw, DriveLayout, GroundLayout, RecordingLayout};
use crate::sim::BodyInit;
use crate::sim::integrators::{IntegratorKind, VariationalSettings};
use crate::sim::mechanism::Mechanism;
use nalgebra::Isometry3;

/// What a scene builds: the bodies' initial states and how link frames follow them.
#[derive(Debug, Clone, Default)]
pub struct World {
    pub layout: RecordingLayout,
    pub bodies: Vec<BodyInit>,
    /// Per recorded frame (same order as `layout.frames`): the body it moves with and the
    /// constant pose of the link in that body's principal frame. Shared with the run's frame
    /// builder ([`crate::simulation::FrameBuilder`]) instead of copied: 64 bytes per frame.
    pub attachments: std::sync::Arc<Vec<Attachment>>,
    /// Articulated models (`bodies = "articulated"`), each over a contiguous range of
    /// `bodies`, in scene order (the same order as `layout.mechanisms`).
    pub mechanisms: Vec<std::sync::Arc<Mechanism>>,
    /// Frames of compound joints' massless interior links: placed from the mechanism's report,
    /// not from a body (their [`Attachment`] is a placeholder).
    pub interior_frames: Vec<InteriorFrame>,
    /// Applied loads on bodies (a scene's `[[model.load]]`), batch indices of `bodies`.
    pub body_loads: Vec<crate::sim::loads::BodyLoad>,
    /// The ground and the colliders (a scene's `[ground]` and the models' `collisions`), batch
    /// indices of `bodies`; inactive ([`crate::sim::contact::ContactModel::is_active`]) when
    /// nothing can touch.
    pub contact: crate::sim::contact::ContactModel,
    /// What the build decided that the user should know (e.g. joints locked because no mass
    /// hangs from them), one line each; the command prints them.
    pub notes: Vec<String>,
    /// The URDF oddities the models loaded with (docs/urdf.md), each once however many models
    /// share the file; the command prints them.
    pub warnings: Vec<urdf::LoadWarning>,
}

/// A massless link frame inside a compound joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InteriorFrame {
    /// Index into `layout.frames`.
    pub frame: usize,
    /// Index into `World::mechanisms`.
    pub mechanism: usize,
    /// Index into the mechanism report's interior link poses
    /// ([`crate::sim::mechanism::project::Report::interior_world_from_link`]).
    pub interior: usize,
    /// Pose of the frame's link in that interior link's frame (identity for the link itself).
    pub interior_from_link: Isometry3<f64>,
}

/// A link frame riding on a body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Attachment {
    /// Index into `World::bodies`, or [`Attachment::WORLD`] for a frame at rest (the welded
    /// root of a fixed-base articulated model): then `body_from_link` is `world_from_link`.
    pub body: usize,
    pub body_from_link: Isometry3<f64>,
}

impl Attachment {
    /// The `body` of a frame at rest in the world.
    pub const WORLD: usize = usize::MAX;
}

impl World {
    /// Every recorded frame's pose before the first step, in layout order (a frame inside a
    /// compound joint at its attachment's pose).
    pub fn initial_world_from_link(&self) -> Vec<Isometry3<f64>> {
        self.attachments
            .iter()
            .map(|a| match self.bodies.get(a.body) {
                Some(body) if a.body != Attachment::WORLD => {
                    body.world_from_body * a.body_from_link
                }
                _ => a.body_from_link,
            })
            .collect()
    }

    /// What the world holds, for the memory estimate ([`crate::budget::Population`]).
    pub fn population(&self) -> crate::budget::Population {
        crate::budget::Population {
            bodies: self.bodies.len() as f64,
            frames: self.layout.frames.len() as f64,
            mechanism_bodies: self
                .mechanisms
                .iter()
                .map(|m| m.bodies().len())
                .sum::<usize>() as f64,
            mechanisms: self.mechanisms.len() as f64,
        }
    }

    /// The integrator that steps this whole world ([`crate::sim::integrator_for`]).
    /// What acts on this world's bodies in uniform gravity `g` (m/s²): gravity and the
    /// applied loads ([`World::body_loads`]).
    pub fn loads(&self, gravity: nalgebra::Vector3<f64>) -> crate::sim::Loads {
        crate::sim::Loads::uniform_gravity(gravity).with_body_loads(self.body_loads.clone())
    }

    pub fn integrator(
        &self,
        kind: IntegratorKind,
        dt_secs: f64,
        settings: &VariationalSettings,
    ) -> anyhow::Result<Box<dyn crate::sim::Integrator>> {
        crate::sim::integrator_for(kind, dt_secs, settings, &self.mechanisms, self.bodies.len())
    }

    /// Fills `layout.drives` from the mechanisms' drives ([`Self::drive_layouts`]): what the
    /// recorders need to know of them before the first frame; and the layout's contact fields
    /// ([`Self::describe_contact`]). Called once every model is placed and the contact model
    /// is filled (the end of `crate::scene::Scene::assemble`); a run refuses a world whose
    /// layout disagrees with its mechanisms or its contact model
    /// ([`Self::check_drive_layout`], [`Self::check_contact_layout`]).
    pub fn describe_drives(&mut self) {
        self.layout.drives = self.drive_layouts();
        self.layout.limited = self.limited_joints();
        self.describe_contact();
    }

    /// Fills `layout.ground` and `layout.contacts` from [`Self::contact`]
    /// ([`Self::contact_layout`]).
    pub fn describe_contact(&mut self) {
        (self.layout.ground, self.layout.contacts) = self.contact_layout();
    }

    /// The contact model as the recording layout says it: the ground to draw, and whether the
    /// run can have contacts ([`crate::sim::contact::ContactModel::is_active`]).
    pub fn contact_layout(&self) -> (Option<GroundLayout>, bool) {
        let ground = self.contact.ground.as_ref().map(|g| GroundLayout {
            normal: g.normal.into_inner(),
            point: g.point,
        });
        (ground, self.contact.is_active())
    }

    /// Fails when the layout's contact fields are not what [`Self::contact`] makes of them
    /// (the contact model changed after [`Self::describe_contact`]): the recordings would leave
    /// out the ground or the contacts, or list a topic nothing fills.
    pub fn check_contact_layout(&self) -> anyhow::Result<()> {
        let (ground, contacts) = self.contact_layout();
        if self.layout.ground != ground || self.layout.contacts != contacts {
            anyhow::bail!(
                "internal error: the recording layout says ground {}, contacts {}; the contact \
                 model says ground {}, contacts {} (World::describe_contact was not called after \
                 the contact model was filled)",
                self.layout.ground.is_some(),
                self.layout.contacts,
                ground.is_some(),
                contacts
            );
        }
        Ok(())
    }

    /// The mechanisms' drives as the recording layout lists them: the drive on coordinate `c`
    /// of mechanism `k` is on layout joint `layout.mechanisms[k].joints.start + c` (a
    /// mechanism's coordinates are its recorded joints, in order).
    pub fn drive_layouts(&self) -> Vec<DriveLayout> {
        use crate::sim::mechanism::ActuatorKind;
        let mut out = Vec::new();
        for (mechanism, layout) in self.mechanisms.iter().zip(&self.layout.mechanisms) {
            for d in &mechanism.drives {
                out.push(DriveLayout {
                    joint: layout.joints.start + d.coordinate,
                    actuator: d.actuator.as_ref().map(|a| match a.kind {
                        ActuatorKind::Motor { .. } => ActuatorLaw::Motor,
                        ActuatorKind::Position { .. } => ActuatorLaw::Position,
                        ActuatorKind::Velocity { .. } => ActuatorLaw::Velocity,
                    }),
                    effort_limit: d.actuator.as_ref().and_then(|a| a.effort_limit),
                    damping: d.damping,
                });
            }
        }
        out
    }

    /// The layout joints whose limit is enforced ([`RecordingLayout::limited`]): coordinate `c`
    /// of mechanism `k` is layout joint `layout.mechanisms[k].joints.start + c`.
    pub fn limited_joints(&self) -> Vec<usize> {
        let mut out = Vec::new();
        for (mechanism, layout) in self.mechanisms.iter().zip(&self.layout.mechanisms) {
            for s in mechanism.stops.iter().filter(|s| s.limits.is_some()) {
                out.push(layout.joints.start + s.coordinate);
            }
        }
        out
    }

    /// Fails when `layout.drives` is not what the mechanisms' drives make of it (the world was
    /// built without [`Self::describe_drives`]): the recordings would leave out what drives
    /// the joints.
    pub fn check_drive_layout(&self) -> anyhow::Result<()> {
        let expected = self.drive_layouts();
        let drives: usize = self.mechanisms.iter().map(|m| m.drives.len()).sum();
        if self.layout.limited != self.limited_joints() {
            anyhow::bail!(
                "internal error: the recording layout lists {} limited joints, the mechanisms \
                 have {} (World::describe_drives was not called after the models were placed)",
                self.layout.limited.len(),
                self.limited_joints().len()
            );
        }
        if self.layout.drives != expected || expected.len() != drives {
            anyhow::bail!(
                "internal error: the recording layout lists {} joint drives, the mechanisms have \
                 {} (World::describe_drives was not called after the models were placed)",
                self.layout.drives.len(),
                drives
            );
        }
        Ok(())
    }
}
