//! The [`RecordingLayout`] as JSON, stored in every MCAP file (metadata record `tumble`, key
//! [`LAYOUT_KEY`]) so that a recording can be replayed (`tumble convert`) with the same entity
//! layout as a fresh run, without the URDF files at hand.
//!
//! Format (version [`LAYOUT_VERSION`]): `{"version": 1, "name": ..., "frames": [{"frame_id",
//! "model", "link", "visuals": [{"name", "link_from_visual", "geometry", "rgba"}]}], "bodies":
//! [{"name", "frame", "mass", "link_from_principal", "principal_moments"}], "topic_groups":
//! [{"prefix", "frames": [start, end], "bodies": [start, end], "joints": [start, end],
//! "mechanisms": [start, end]}], "joints": [{"name", "model", "kind", "limits"}],
//! "mechanisms": [{"name", "bodies": [start, end], "joints": [start, end], "floating"}]}`
//! (`joints` and `mechanisms` and the groups' `joints`/`mechanisms` ranges are absent from
//! files written before articulated models existed; they read as empty). Poses are `{"translation": [x,
//! y, z], "rotation_xyzw": [x, y, z, w]}` (metres; unit quaternion, Hamilton convention); geometry
//! is `{"box": {"size": [..]}}`, `{"cylinder": {"radius", "length"}}`, `{"sphere": {"radius"}}`,
//! `{"capsule": {"radius", "length"}}` or `{"mesh": {"uri", "path", "scale"}}` (the mesh path as
//! resolved when recording; a replay elsewhere skips meshes it cannot find, with a warning).
//! The recording's metadata map is not part of this JSON (it is the rest of the record).

use super::{BodyLayout, FrameLayout, JointLayout, MechanismLayout, RecordingLayout, TopicGroup};
use crate::model::{Geometry, Visual};
use anyhow::{Context, bail};
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Metadata key holding the layout JSON in MCAP files.
pub const LAYOUT_KEY: &str = "layout_json";
/// Current format version.
pub const LAYOUT_VERSION: u32 = 1;

#[derive(Serialize, Deserialize)]
struct LayoutJson {
    version: u32,
    name: String,
    frames: Vec<FrameJson>,
    bodies: Vec<BodyJson>,
    topic_groups: Vec<GroupJson>,
    #[serde(default)]
    joints: Vec<JointJson>,
    #[serde(default)]
    mechanisms: Vec<MechanismJson>,
}

#[derive(Serialize, Deserialize)]
struct JointJson {
    name: String,
    model: String,
    kind: String,
    limits: Option<[f64; 2]>,
}

#[derive(Serialize, Deserialize)]
struct MechanismJson {
    name: String,
    bodies: [usize; 2],
    joints: [usize; 2],
    floating: bool,
}

#[derive(Serialize, Deserialize)]
struct FrameJson {
    frame_id: String,
    model: String,
    link: String,
    visuals: Vec<VisualJson>,
}

#[derive(Serialize, Deserialize)]
struct VisualJson {
    name: Option<String>,
    link_from_visual: PoseJson,
    geometry: GeometryJson,
    rgba: Option<[f32; 4]>,
}

#[derive(Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
enum GeometryJson {
    Box {
        size: [f64; 3],
    },
    Cylinder {
        radius: f64,
        length: f64,
    },
    Sphere {
        radius: f64,
    },
    Capsule {
        radius: f64,
        length: f64,
    },
    Mesh {
        uri: String,
        path: Option<PathBuf>,
        scale: [f64; 3],
    },
}

#[derive(Serialize, Deserialize)]
struct BodyJson {
    name: String,
    frame: usize,
    mass: f64,
    link_from_principal: PoseJson,
    principal_moments: [f64; 3],
}

#[derive(Serialize, Deserialize)]
struct GroupJson {
    prefix: String,
    frames: [usize; 2],
    bodies: [usize; 2],
    #[serde(default)]
    joints: [usize; 2],
    #[serde(default)]
    mechanisms: [usize; 2],
}

#[derive(Serialize, Deserialize)]
struct PoseJson {
    translation: [f64; 3],
    rotation_xyzw: [f64; 4],
}

impl From<&Isometry3<f64>> for PoseJson {
    fn from(iso: &Isometry3<f64>) -> Self {
        let q = iso.rotation.quaternion().coords;
        Self {
            translation: iso.translation.vector.into(),
            rotation_xyzw: [q.x, q.y, q.z, q.w],
        }
    }
}

impl PoseJson {
    /// The pose; the quaternion is used as stored when it is unit to 1e-12 (so a round trip is
    /// exact), renormalised otherwise. Non-finite or zero quaternions are errors.
    fn isometry(&self) -> anyhow::Result<Isometry3<f64>> {
        let [x, y, z, w] = self.rotation_xyzw;
        let q = Quaternion::new(w, x, y, z);
        let norm = q.norm();
        if !(norm.is_finite() && norm > 0.0) || self.translation.iter().any(|v| !v.is_finite()) {
            bail!(
                "pose {:?} / {:?} is not finite",
                self.translation,
                self.rotation_xyzw
            );
        }
        let rotation = if (norm - 1.0).abs() < 1e-12 {
            UnitQuaternion::new_unchecked(q)
        } else {
            UnitQuaternion::from_quaternion(q)
        };
        Ok(Isometry3::from_parts(
            Translation3::from(Vector3::from(self.translation)),
            rotation,
        ))
    }
}

fn geometry_json(g: &Geometry) -> GeometryJson {
    match g {
        Geometry::Box { size } => GeometryJson::Box {
            size: (*size).into(),
        },
        Geometry::Cylinder { radius, length } => GeometryJson::Cylinder {
            radius: *radius,
            length: *length,
        },
        Geometry::Sphere { radius } => GeometryJson::Sphere { radius: *radius },
        Geometry::Capsule { radius, length } => GeometryJson::Capsule {
            radius: *radius,
            length: *length,
        },
        Geometry::Mesh { uri, path, scale } => GeometryJson::Mesh {
            uri: uri.clone(),
            path: path.clone(),
            scale: (*scale).into(),
        },
    }
}

fn geometry(g: GeometryJson) -> Geometry {
    match g {
        GeometryJson::Box { size } => Geometry::Box { size: size.into() },
        GeometryJson::Cylinder { radius, length } => Geometry::Cylinder { radius, length },
        GeometryJson::Sphere { radius } => Geometry::Sphere { radius },
        GeometryJson::Capsule { radius, length } => Geometry::Capsule { radius, length },
        GeometryJson::Mesh { uri, path, scale } => Geometry::Mesh {
            uri,
            path,
            scale: scale.into(),
        },
    }
}

/// The layout (without its metadata map) as JSON.
pub fn to_json(layout: &RecordingLayout) -> String {
    let json = LayoutJson {
        version: LAYOUT_VERSION,
        name: layout.name.clone(),
        frames: layout
            .frames
            .iter()
            .map(|f| FrameJson {
                frame_id: f.frame_id.clone(),
                model: f.model.clone(),
                link: f.link.clone(),
                visuals: f
                    .visuals
                    .iter()
                    .map(|v| VisualJson {
                        name: v.name.clone(),
                        link_from_visual: (&v.link_from_visual).into(),
                        geometry: geometry_json(&v.geometry),
                        rgba: v.rgba,
                    })
                    .collect(),
            })
            .collect(),
        bodies: layout
            .bodies
            .iter()
            .map(|b| BodyJson {
                name: b.name.clone(),
                frame: b.frame,
                mass: b.mass,
                link_from_principal: (&b.link_from_principal).into(),
                principal_moments: b.principal_moments.into(),
            })
            .collect(),
        topic_groups: layout
            .topic_groups
            .iter()
            .map(|g| GroupJson {
                prefix: g.prefix.clone(),
                frames: [g.frames.start, g.frames.end],
                bodies: [g.bodies.start, g.bodies.end],
                joints: [g.joints.start, g.joints.end],
                mechanisms: [g.mechanisms.start, g.mechanisms.end],
            })
            .collect(),
        joints: layout
            .joints
            .iter()
            .map(|j| JointJson {
                name: j.name.clone(),
                model: j.model.clone(),
                kind: j.kind.clone(),
                limits: j.limits,
            })
            .collect(),
        mechanisms: layout
            .mechanisms
            .iter()
            .map(|m| MechanismJson {
                name: m.name.clone(),
                bodies: [m.bodies.start, m.bodies.end],
                joints: [m.joints.start, m.joints.end],
                floating: m.floating,
            })
            .collect(),
    };
    // Plain data (strings, finite or non-finite numbers become null): cannot fail.
    serde_json::to_string(&json).unwrap_or_default()
}

/// Parses [`to_json`]'s output back; the metadata map is left empty. Indices are checked, so a
/// damaged or foreign JSON is an error, never a panic later.
pub fn from_json(text: &str) -> anyhow::Result<RecordingLayout> {
    let json: LayoutJson = serde_json::from_str(text).context("the layout JSON is malformed")?;
    if json.version != LAYOUT_VERSION {
        bail!(
            "layout JSON version {} (this tumble reads version {LAYOUT_VERSION})",
            json.version
        );
    }
    let mut frames = Vec::with_capacity(json.frames.len());
    for f in json.frames {
        let mut visuals = Vec::with_capacity(f.visuals.len());
        for v in f.visuals {
            visuals.push(Visual {
                name: v.name,
                link_from_visual: v
                    .link_from_visual
                    .isometry()
                    .with_context(|| format!("frame {:?}: visual origin", f.frame_id))?,
                geometry: geometry(v.geometry),
                rgba: v.rgba,
            });
        }
        frames.push(FrameLayout {
            frame_id: f.frame_id,
            model: f.model,
            link: f.link,
            visuals,
        });
    }
    let mut bodies = Vec::with_capacity(json.bodies.len());
    for b in json.bodies {
        if b.frame >= frames.len() {
            bail!(
                "body {:?} moves frame {} of {}",
                b.name,
                b.frame,
                frames.len()
            );
        }
        bodies.push(BodyLayout {
            link_from_principal: b
                .link_from_principal
                .isometry()
                .with_context(|| format!("body {:?}: principal frame", b.name))?,
            name: b.name,
            frame: b.frame,
            mass: b.mass,
            principal_moments: b.principal_moments.into(),
        });
    }
    let range_ok = |r: [usize; 2], len: usize| r[0] <= r[1] && r[1] <= len;
    let joints: Vec<JointLayout> = json
        .joints
        .into_iter()
        .map(|j| JointLayout {
            name: j.name,
            model: j.model,
            kind: j.kind,
            limits: j.limits,
        })
        .collect();
    let mut mechanisms = Vec::with_capacity(json.mechanisms.len());
    for m in json.mechanisms {
        if !range_ok(m.bodies, bodies.len()) || !range_ok(m.joints, joints.len()) {
            bail!("mechanism {:?} has ranges outside the layout", m.name);
        }
        mechanisms.push(MechanismLayout {
            name: m.name,
            bodies: m.bodies[0]..m.bodies[1],
            joints: m.joints[0]..m.joints[1],
            floating: m.floating,
        });
    }
    let mut topic_groups = Vec::with_capacity(json.topic_groups.len());
    for g in json.topic_groups {
        let ok = range_ok(g.frames, frames.len())
            && range_ok(g.bodies, bodies.len())
            && range_ok(g.joints, joints.len())
            && range_ok(g.mechanisms, mechanisms.len());
        if !ok {
            bail!("topic group {:?} has ranges outside the layout", g.prefix);
        }
        topic_groups.push(TopicGroup {
            prefix: g.prefix,
            frames: g.frames[0]..g.frames[1],
            bodies: g.bodies[0]..g.bodies[1],
            joints: g.joints[0]..g.joints[1],
            mechanisms: g.mechanisms[0]..g.mechanisms[1],
        });
    }
    Ok(RecordingLayout {
        name: json.name,
        frames,
        bodies,
        metadata: Default::default(),
        topic_groups,
        joints,
        mechanisms,
        robot_descriptions: Vec::new(),
    })
}
