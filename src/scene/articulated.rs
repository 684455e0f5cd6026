//! `bodies = "articulated"`: a URDF model as a mechanism (bodies, joint rows, coordinates)
//! plus its recording layout.
//!
//! The model side (which links merge, compound joints, refusals) is
//! [`crate::model::articulation`]; this module places the groups in the world and writes the
//! joint rows in the bodies' principal frames:
//!
//! - every group with mass is one body, its frame the composite's principal frame
//!   `F_g = (c_g, Q_g)` in the model frame (the same composite as `bodies = "rigid"`, so a
//!   model whose joints are all fixed or locked is exactly the rigid body, and is simulated as
//!   one: no mechanism);
//! - a joint's parent-side frame is `F_a⁻¹ · model_from_parent_link · parent_from_joint`, its
//!   child-side frame `F_b⁻¹ · model_from_child_link` (the two coincide at joint position 0:
//!   `world_from_child_frame = world_from_parent_frame · motion(q)`), so the anchors are their
//!   origins and the axis `u` is carried by both rotations; the coordinates read back the URDF
//!   joint positions exactly;
//! - with `base = "fixed"` the root group is welded at `position`/`rpy`: joints on it see a
//!   "world body" at rest at the pose `world_from_model · F_0`, and its links are recorded at
//!   rest;
//! - initial velocities: `linvel`/`angvel` are the twist of the root link frame (floating
//!   base), `joint_velocities` the joint rates; body twists by forward velocity kinematics
//!   ([`crate::sim::mechanism::init`]).
//!
//! Every link frame is recorded (massless ones too), frame ids as in the other modes. A body is
//! named after its group's root link frame id.

use super::actuator::ResolvedActuator;
use super::{BaseMode, ModelEntry};
use crate::model::articulation::{self, Articulation};
use crate::model::kinematics::JointKind;
use crate::model::{MassProperties, Model};
use crate::record::{BodyLayout, FrameLayout, JointLayout, MechanismLayout};
use crate::sim::BodyInit;
use crate::sim::mechanism::init::{RootTwist, body_twists};
use crate::sim::mechanism::rows::normals;
use crate::sim::mechanism::{
    Base, BodyPose, CompoundChain, Coordinate, CoordinateKind, JointRows, Mechanism,
    MechanismJoint, MechanismModel, Mimic, RowKind,
};
use crate::world::{Attachment, InteriorFrame, World};
use anyhow::{Context, bail};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use std::collections::{BTreeSet, HashMap, HashSet};

/// One copy of a `[[model]]` table: its frame-id prefix, its label (the copy's name, the
/// table's `name` or the URDF's) and its drawn placement (`position`/`rpy`/`linvel`/`angvel`,
/// docs/scale.md).
pub(super) struct CopyPlace<'a> {
    pub prefix: Option<&'a str>,
    pub label: &'a str,
    pub place: &'a crate::scene::placement::Placement,
}
use std::sync::Arc;

/// What the copies of one `[[model]]` table share, made by its first copy: the checks, the
/// merged groups and the [`MechanismModel`] are done once per table, so each further copy only
/// places bodies and frames (and shares the model through one [`Arc`]).
pub(super) enum Template {
    /// No joint kept and a floating base: every copy is the rigid body it is.
    Rigid,
    Mechanism(Box<Shared>),
}

/// The shared part of an articulated table.
pub(super) struct Shared {
    art: Articulation,
    /// Group frames `F_g` (model_from_group) and principal moments.
    frames: Vec<(Vector3<f64>, Isometry3<f64>)>,
    model: Arc<MechanismModel>,
}

/// Adds `model` as a mechanism (or, with no joint kept and a floating base, as the rigid body
/// it is). Errors name the model, and the key and joint or link at fault. `template` is the
/// table's: `None` for its first copy, which fills it; later copies reuse it.
pub(super) fn add_articulated_model(
    world: &mut World,
    model: &Model,
    entry: &ModelEntry,
    copy: &CopyPlace<'_>,
    actuators: &[ResolvedActuator],
    body_names: &mut HashSet<String>,
    template: &mut Option<Template>,
) -> anyhow::Result<()> {
    if template.is_none() {
        *template = Some(prepare(world, model, entry, copy.label, actuators)?);
    }
    match template.as_ref().expect("filled above") {
        Template::Rigid => super::rigid::add_rigid_model(
            world,
            model,
            copy.prefix,
            copy.label,
            copy.place,
            entry.allow_non_physical_inertia,
            body_names,
        ),
        Template::Mechanism(shared) => place(world, model, entry, copy, shared),
    }
}

/// The table's checks, merged groups and mechanism model with its drives (see [`Template`]).
fn prepare(
    world: &mut World,
    model: &Model,
    entry: &ModelEntry,
    label: &str,
    actuators: &[ResolvedActuator],
) -> anyhow::Result<Template> {
    let label = label.to_string();
    let joint_index: HashMap<&str, usize> = model
        .joints
        .iter()
        .enumerate()
        .map(|(i, j)| (j.name.as_str(), i))
        .collect();
    let known = |key: &str, name: &str| -> anyhow::Result<usize> {
        joint_index.get(name).copied().with_context(|| {
            format!(
                "{key}: model `{label}` ({}) has no joint named `{name}`{}",
                model.path.display(),
                crate::message::did_you_mean(name, model.joints.iter().map(|j| j.name.as_str()))
            )
        })
    };
    for name in &entry.locked_joints {
        known("locked_joints", name)?;
    }
    for name in entry.joint_velocities.keys() {
        known(&format!("joint_velocities.{name}"), name)?;
    }
    for name in entry.joints.keys() {
        let j = known(&format!("joints.{name}"), name)?;
        if let Some(m) = &model.joints[j].mimic {
            bail!(
                "joints.{name}: joint `{name}` of model `{label}` mimics `{}`: its position \
                 follows that joint's (set `{}` instead)",
                m.joint,
                m.joint
            );
        }
    }
    let base = entry.base.unwrap_or_default();
    let fixed = base == BaseMode::Fixed;
    let locked: BTreeSet<String> = entry.locked_joints.iter().cloned().collect();
    let art = articulation::articulate(model, &locked, fixed).with_context(|| {
        format!(
            "bodies = \"articulated\": model `{label}` ({})",
            model.path.display()
        )
    })?;
    // Velocities of merged joints make no sense.
    let kept: BTreeSet<usize> = art.joints.iter().flat_map(|j| j.chain.clone()).collect();
    for name in entry.joint_velocities.keys() {
        let j = joint_index[name.as_str()];
        if !kept.contains(&j) {
            let why = match model.joints[j].kind {
                JointKind::Fixed => "a fixed joint".to_string(),
                _ if locked.contains(name) => "locked (locked_joints)".to_string(),
                _ if model.joints[j].mimic.is_some() => "a mimic joint of a merged leader".into(),
                _ => "locked (no mass hangs from it)".to_string(),
            };
            bail!(
                "joint_velocities.{name}: joint `{name}` of model `{label}` is {why}: it does not move"
            );
        }
        if let Some(m) = &model.joints[j].mimic {
            bail!(
                "joint_velocities.{name}: joint `{name}` of model `{label}` mimics `{}`: its \
                 velocity follows that joint's (set `{}` instead)",
                m.joint,
                m.joint
            );
        }
    }
    for name in &art.locked_massless {
        world.notes.push(format!(
            "model `{label}`: joint `{name}` carries no mass (nothing with mass hangs from it): \
             locked at its position"
        ));
    }
    check_groups(&art, model, &label, entry.allow_non_physical_inertia)?;
    let merged = super::drives::Merged {
        locked: &locked,
        massless: &art.locked_massless,
    };
    if art.joints.is_empty() {
        if fixed {
            // Issue 32: a one-link object (pybullet_data's cubes, spheres, mugs) welded to the
            // world has no dynamics; the refusal names the key that does run it: the same model
            // floating is one rigid body falling under gravity.
            bail!(
                "bodies = \"articulated\", base = \"fixed\": model `{label}` ({}) has no moving \
                 joint left (after merging fixed and locked joints): nothing would move (to run \
                 it anyway, base = \"floating\" (`--base floating`) lets it fall as one rigid \
                 body{})",
                model.path.display(),
                if locked.is_empty() {
                    ""
                } else {
                    ", or unlock a joint of locked_joints"
                }
            );
        }
        // One group: exactly the rigid body. An actuated joint was merged: say why.
        super::drives::drives(model, entry, &label, &[], actuators, &merged)?;
        return Ok(Template::Rigid);
    }
    let (frames, mut shared) = shared_model(model, entry, &art, fixed)?;
    shared.drives = super::drives::drives(
        model,
        entry,
        &label,
        &shared.coordinates,
        actuators,
        &merged,
    )?;
    shared.stops = super::drives::stops(model, entry, &label, &shared, &mut world.notes)?;
    shared
        .validate()
        .map_err(|e| anyhow::anyhow!("internal error driving model `{}`: {e}", model.name))?;
    Ok(Template::Mechanism(Box::new(Shared {
        art,
        frames,
        model: Arc::new(shared),
    })))
}

/// Every group that is a body must be a valid rigid body (the rigid-mode rules).
fn check_groups(
    art: &Articulation,
    model: &Model,
    label: &str,
    allow_non_physical: bool,
) -> anyhow::Result<()> {
    for group in &art.groups {
        let Some(mp) = &group.composite else { continue };
        let rules = mp.validate_with(allow_non_physical);
        if !rules.is_empty() {
            let links: Vec<&str> = group
                .links
                .iter()
                .map(|&l| model.links[l].name.as_str())
                .collect();
            // What lets a user run the file anyway: the integrator turns every body, so it
            // needs positive principal moments; the links' geometry can give them.
            let overrides: Vec<String> = links
                .iter()
                .map(|l| format!("{l} = {{ inertia = \"geometry\" }}"))
                .collect();
            bail!(
                "bodies = \"articulated\": model `{label}` ({}): the body made of link(s) {} is \
                 not a valid rigid body: {} (to run it anyway, take these links' mass properties \
                 from their geometry: `links = {{ {} }}` on the model, or `inertia = \"geometry\"` \
                 for the whole model (`--inertia geometry`); `allow_non_physical_inertia = true` \
                 accepts moments that break the triangle inequality, not zero ones)",
                model.path.display(),
                links.join(", "),
                rules.join("; "),
                overrides.join(", ")
            );
        }
    }
    Ok(())
}

/// The URDF position of joint `j` at the entry's configuration (as forward kinematics used it).
fn joint_position(model: &Model, entry: &ModelEntry, j: usize) -> f64 {
    let joint = &model.joints[j];
    match &joint.mimic {
        Some(m) => m.multiplier * entry.joints.get(&m.joint).copied().unwrap_or(0.0) + m.offset,
        None => entry.joints.get(&joint.name).copied().unwrap_or(0.0),
    }
}

fn principal_frame(mp: &MassProperties) -> (Vector3<f64>, Isometry3<f64>) {
    let (moments, rot) = mp.principal();
    (
        moments,
        Isometry3::from_parts(Translation3::from(mp.com), rot),
    )
}

fn body_pose(iso: &Isometry3<f64>) -> BodyPose {
    BodyPose {
        rot: iso.rotation.to_rotation_matrix().into_inner(),
        com: iso.translation.vector,
    }
}

/// The group frames and the placement-free mechanism model of an articulation.
#[allow(clippy::type_complexity)]
fn shared_model(
    model: &Model,
    entry: &ModelEntry,
    art: &Articulation,
    fixed: bool,
) -> anyhow::Result<(Vec<(Vector3<f64>, Isometry3<f64>)>, MechanismModel)> {
    // Group frames F_g (model_from_group) and moments.
    let frames: Vec<(Vector3<f64>, Isometry3<f64>)> = art
        .groups
        .iter()
        .map(|g| match &g.composite {
            Some(mp) => principal_frame(mp),
            None => (Vector3::zeros(), Isometry3::identity()),
        })
        .collect();
    let local = |g: usize| if fixed { g.checked_sub(1) } else { Some(g) };
    let body_count = if fixed {
        art.groups.len() - 1
    } else {
        art.groups.len()
    };
    // Joints, coordinates, mimics.
    let mut joints = Vec::new();
    let mut coordinates: Vec<Coordinate> = Vec::new();
    let mut coord_of_joint: HashMap<usize, usize> = HashMap::new();
    let mut length_scale: f64 = 1e-3;
    for (k, gj) in art.joints.iter().enumerate() {
        let first = &model.joints[gj.chain[0]];
        let last = &model.joints[*gj.chain.last().unwrap()];
        let parent_frame = frames[gj.parent].1;
        let child_frame = frames[gj.child].1;
        let model_from_joint = model.links[first.parent].model_from_link * first.parent_from_joint;
        let fa = parent_frame.inverse() * model_from_joint;
        let fb = child_frame.inverse() * model.links[last.child].model_from_link;
        let anchor_parent = fa.translation.vector;
        let anchor_child = fb.translation.vector;
        length_scale = length_scale
            .max(anchor_parent.norm())
            .max(anchor_child.norm());
        // Kept joints have a direction (`articulation::articulate` refuses any other).
        let axis = |j: &crate::model::kinematics::Joint| {
            crate::model::kinematics::axis_direction(&j.axis)
                .map_or_else(Vector3::zeros, |u| u.into_inner())
        };
        let mut compound = None;
        let mut stage_origins = Vec::new();
        let kind = if gj.chain.len() == 1 {
            let u = axis(first);
            let ua = fa.rotation * u;
            let [n1, n2] = normals(&ua);
            let coord_kind;
            let row_kind = match first.kind {
                JointKind::Prismatic => {
                    // The rotation is locked at W0 = Fa Fbᵀ (the frames stay parallel).
                    let w0 = (fa.rotation * fb.rotation.inverse()).to_rotation_matrix();
                    let s = |t: Vector3<f64>| w0.transpose() * t;
                    coord_kind = CoordinateKind::Slider {
                        axis_parent: ua,
                        anchor_parent,
                        anchor_child,
                    };
                    RowKind::Slider {
                        axis_parent: ua,
                        normals_parent: [n1, n2],
                        lock: [(n1, s(n2)), (n2, s(ua)), (ua, s(n1))],
                    }
                }
                _ => {
                    let w = normals(&u)[0];
                    coord_kind = CoordinateKind::Hinge {
                        axis_parent: ua,
                        ref_parent: fa.rotation * w,
                        ref_child: fb.rotation * w,
                    };
                    RowKind::Hinge {
                        axis_parent: ua,
                        axis_child: fb.rotation * u,
                        normals_parent: [n1, n2],
                    }
                }
            };
            coord_of_joint.insert(gj.chain[0], coordinates.len());
            coordinates.push(Coordinate {
                name: first.name.clone(),
                joint: k,
                kind: coord_kind,
                limits: first.limits,
                initial: joint_position(model, entry, gj.chain[0]),
                is_linear: first.kind == JointKind::Prismatic,
            });
            row_kind
        } else {
            let axes: Vec<Vector3<f64>> =
                gj.chain.iter().map(|&j| axis(&model.joints[j])).collect();
            let mut origins = vec![UnitQuaternion::identity()];
            stage_origins.push(Isometry3::identity());
            for &j in &gj.chain[1..] {
                origins.push(model.joints[j].parent_from_joint.rotation);
                stage_origins.push(model.joints[j].parent_from_joint);
            }
            for (stage, &j) in gj.chain.iter().enumerate() {
                coordinates.push(Coordinate {
                    name: model.joints[j].name.clone(),
                    joint: k,
                    kind: CoordinateKind::Compound { stage },
                    limits: model.joints[j].limits,
                    initial: joint_position(model, entry, j),
                    is_linear: false,
                });
            }
            let chain = CompoundChain {
                axes: axes.clone(),
                origins: origins.clone(),
                parent_from_first: fa.rotation,
                child_from_last: fb.rotation,
            };
            let kind = if gj.chain.len() == 2 {
                RowKind::Universal {
                    axis_parent: fa.rotation * axes[0],
                    axis_child: fb.rotation * axes[1],
                    cos0: axes[0].dot(&(origins[1] * axes[1])),
                }
            } else {
                RowKind::Ball
            };
            compound = Some(chain);
            kind
        };
        joints.push(MechanismJoint {
            name: first.name.clone(),
            parent: local(gj.parent),
            child: local(gj.child).expect("a joint's child is a body"),
            rows: JointRows {
                anchor_parent,
                anchor_child,
                kind,
            },
            compound,
            parent_from_first: fa,
            stage_origins,
        });
    }
    let mimics: Vec<Mimic> = art
        .joints
        .iter()
        .filter(|gj| gj.chain.len() == 1)
        .filter_map(|gj| {
            let j = gj.chain[0];
            let m = model.joints[j].mimic.as_ref()?;
            let leader = model.joints.iter().position(|l| l.name == m.joint)?;
            Some(Mimic {
                follower: coord_of_joint[&j],
                leader: *coord_of_joint.get(&leader)?,
                multiplier: m.multiplier,
                offset: m.offset,
            })
        })
        .collect();
    let shared = MechanismModel {
        body_count,
        joints,
        coordinates,
        mimics,
        drives: Vec::new(),
        stops: Vec::new(),
        base: if fixed { Base::Fixed } else { Base::Floating },
        length_scale,
    };
    shared
        .validate()
        .map_err(|e| anyhow::anyhow!("internal error building model `{}`: {e}", model.name))?;
    Ok((frames, shared))
}

/// Places one copy of a prepared table: its bodies (forward velocity kinematics from the
/// copy's root twist and the joint rates), its link frames and its layout.
fn place(
    world: &mut World,
    model: &Model,
    entry: &ModelEntry,
    copy: &CopyPlace<'_>,
    shared: &Shared,
) -> anyhow::Result<()> {
    let (art, frames) = (&shared.art, &shared.frames);
    let fixed = shared.model.base == Base::Fixed;
    let local = |g: usize| if fixed { g.checked_sub(1) } else { Some(g) };
    let label = copy.label;
    let frame_id = |link: &str| match copy.prefix {
        Some(prefix) => format!("{prefix}/{link}"),
        None => link.to_string(),
    };
    let world_from_model = copy.place.world_from_model;
    let first_body = world.bodies.len();
    let body_count = shared.model.body_count;
    let mechanism = Mechanism {
        name: label.to_string(),
        first_body,
        world_pose: if fixed {
            body_pose(&(world_from_model * frames[0].1))
        } else {
            BodyPose::identity()
        },
        shared: Arc::clone(&shared.model),
    };
    // Initial velocities: joint rates (mimic followers at their rule), then the body twists.
    let mut rates: Vec<f64> = mechanism
        .coordinates
        .iter()
        .map(|c| entry.joint_velocities.get(&c.name).copied().unwrap_or(0.0))
        .collect();
    for m in &mechanism.mimics {
        rates[m.follower] = m.multiplier * rates[m.leader];
    }
    let world_from_body: Vec<Isometry3<f64>> = art
        .groups
        .iter()
        .enumerate()
        .filter(|(g, _)| local(*g).is_some())
        .map(|(g, _)| world_from_model * frames[g].1)
        .collect();
    let root = (!fixed).then_some(RootTwist {
        origin: world_from_model.translation.vector,
        linvel: copy.place.linvel_world,
        angvel: copy.place.angvel_world,
    });
    let twists = body_twists(&mechanism, &world_from_body, root, &rates);
    for (g, group) in art.groups.iter().enumerate() {
        let Some(i) = local(g) else { continue };
        let mp = group.composite.as_ref().expect("bodies have mass");
        world.bodies.push(BodyInit {
            mass: mp.mass,
            principal_moments: frames[g].0,
            world_from_body: world_from_body[i],
            linvel_world: twists[i].0,
            angvel_world: twists[i].1,
        });
    }
    // Frames: every link, in file order.
    let mechanism_index = world.mechanisms.len();
    let mut place: HashMap<usize, Place> = HashMap::new();
    for (g, group) in art.groups.iter().enumerate() {
        for &l in &group.links {
            place.insert(l, Place::Group(g));
        }
    }
    let mut interior = 0;
    for gj in &art.joints {
        for group in &gj.interior {
            for &l in &group.links {
                place.insert(l, Place::Interior(interior, group.links[0]));
            }
            interior += 1;
        }
    }
    let mut frame_of_link = vec![0; model.links.len()];
    for (l, link) in model.links.iter().enumerate() {
        let frame = world.layout.frames.len();
        frame_of_link[l] = frame;
        let attachment = match place.get(&l) {
            Some(Place::Group(g)) => match local(*g) {
                Some(i) => Attachment {
                    body: first_body + i,
                    body_from_link: frames[*g].1.inverse() * link.model_from_link,
                },
                None => Attachment {
                    body: Attachment::WORLD,
                    body_from_link: world_from_model * link.model_from_link,
                },
            },
            Some(Place::Interior(k, root_link)) => {
                world.interior_frames.push(InteriorFrame {
                    frame,
                    mechanism: mechanism_index,
                    interior: *k,
                    interior_from_link: model.links[*root_link].model_from_link.inverse()
                        * link.model_from_link,
                });
                Attachment {
                    body: Attachment::WORLD,
                    body_from_link: world_from_model * link.model_from_link,
                }
            }
            None => bail!("internal error: link `{}` in no group", link.name),
        };
        std::sync::Arc::make_mut(&mut world.attachments).push(attachment);
        world.layout.frames.push(FrameLayout {
            frame_id: frame_id(&link.name),
            model: label.to_string(),
            link: link.name.clone(),
            visuals: link.visuals.clone(),
        });
    }
    for (g, group) in art.groups.iter().enumerate() {
        if local(g).is_none() {
            continue;
        }
        let root_link = group.links[0];
        let mp = group.composite.as_ref().expect("bodies have mass");
        world.layout.bodies.push(BodyLayout {
            name: frame_id(&model.links[root_link].name),
            frame: frame_of_link[root_link],
            mass: mp.mass,
            link_from_principal: model.links[root_link].model_from_link.inverse() * frames[g].1,
            principal_moments: frames[g].0,
        });
    }
    let joints_start = world.layout.joints.len();
    for c in &mechanism.coordinates {
        let j = &model.joints[model
            .joints
            .iter()
            .position(|j| j.name == c.name)
            .expect("a coordinate is a URDF joint")];
        world.layout.joints.push(JointLayout {
            name: match copy.prefix {
                Some(prefix) => format!("{prefix}/{}", c.name),
                None => c.name.clone(),
            },
            model: label.to_string(),
            kind: j.kind.as_str().to_string(),
            limits: c.limits,
        });
    }
    world.layout.mechanisms.push(MechanismLayout {
        name: label.to_string(),
        bodies: first_body..first_body + body_count,
        joints: joints_start..world.layout.joints.len(),
        floating: !fixed,
    });
    world.mechanisms.push(Arc::new(mechanism));
    Ok(())
}

enum Place {
    Group(usize),
    /// Interior link index (joint order, stage order) and that interior group's root link.
    Interior(usize, usize),
}
