//! The [`RecordingLayout`] as JSON, stored in every MCAP file (metadata record `tumble`, key
//! [`LAYOUT_KEY`]) so that a recording can be replayed (`tumble convert`) with the same entity
//! layout as a fresh run, without the URDF files at hand.
//!
//! Format (version [`LAYOUT_VERSION`]): `{"version": 2, "name": ..., "visual_sets": [[{"name",
//! "link_from_visual", "geometry", "rgba"}, ...], ...], "frames": [{"frame_id", "model", "link",
//! "visuals": k}], "bodies":
//! [{"name", "frame", "mass", "link_from_principal", "principal_moments"}], "topic_groups":
//! [{"prefix", "frames": [start, end], "bodies": [start, end], "joints": [start, end],
//! "mechanisms": [start, end]}], "joints": [{"name", "model", "kind", "limits"}],
//! "mechanisms": [{"name", "bodies": [start, end], "joints": [start, end], "floating"}],
//! "drives": [{"joint", "actuator", "effort_limit", "damping"}]}`
//! (`joints` and `mechanisms` and the groups' `joints`/`mechanisms` ranges are absent from
//! files written before articulated models existed; they read as empty). `drives`
//! ([`DriveLayout`]: `joint` an index into `joints`, increasing; `actuator` `"motor"`,
//! `"position"`, `"velocity"` or null for damping alone; `effort_limit` N m or N, or null;
//! `damping` N m s/rad or N s/m) is written only when a joint is driven, so a recording without
//! drives has the JSON it had before drives existed. Likewise `"ground": {"normal": [x, y, z],
//! "point": [x, y, z]}` ([`super::GroundLayout`]) only with a ground, and `"contacts": true`
//! only in runs that can have contacts ([`RecordingLayout::contacts`]), and `"limited": [j, ...]`
//! (indices into `joints`, increasing) only when a joint's limit is enforced
//! ([`RecordingLayout::limited`]). Poses are `{"translation": [x,
//! y, z], "rotation_xyzw": [x, y, z, w]}` (metres; unit quaternion, Hamilton convention); geometry
//! is `{"box": {"size": [..]}}`, `{"cylinder": {"radius", "length"}}`, `{"sphere": {"radius"}}`,
//! `{"capsule": {"radius", "length"}}` or `{"mesh": {"uri", "path", "scale"}}` (the mesh path as
//! resolved when recording; a replay elsewhere skips meshes it cannot find, with a warning).
//! The recording's metadata map is not part of this JSON (it is the rest of the record).
//!
//! A frame's `visuals` is the index of its list in `visual_sets`: the copies of a model share
//! their links' lists (one [`std::sync::Arc`] per URDF link), so each list is written once
//! (version 1 wrote every frame's list inline, `"visuals": [...]`, which version 2 still reads).
//! On the 10 000-body swarm that took the JSON from 5.5 MB to 3.0 MB; the writer serialises
//! straight from the layout into a buffer of the exact size (a counting pass first), so the
//! JSON is held once, not in a growing buffer beside a copy of the layout.

use super::{
    ActuatorLaw, BodyLayout, DriveLayout, FrameLayout, JointLayout, MechanismLayout,
    RecordingLayout, TopicGroup,
};
use crate::model::{Geometry, Visual};
use anyhow::{Context, bail};
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::Arc;

/// Metadata key holding the layout JSON in MCAP files.
pub const LAYOUT_KEY: &str = "layout_json";
/// Current format version (1 is read too).
pub const LAYOUT_VERSION: u32 = 2;

#[derive(Deserialize)]
struct LayoutJson {
    version: u32,
    name: String,
    #[serde(default)]
    visual_sets: Vec<Vec<VisualJson>>,
    frames: Vec<FrameJson>,
    bodies: Vec<BodyJson>,
    topic_groups: Vec<GroupJson>,
    #[serde(default)]
    joints: Vec<JointJson>,
    #[serde(default)]
    mechanisms: Vec<MechanismJson>,
    #[serde(default)]
    drives: Vec<DriveJson>,
    #[serde(default)]
    ground: Option<GroundJson>,
    #[serde(default)]
    contacts: bool,
    #[serde(default)]
    limited: Vec<usize>,
}

/// The ground (read and written: plain data).
#[derive(Serialize, Deserialize)]
struct GroundJson {
    normal: [f64; 3],
    point: [f64; 3],
}

/// A joint's drive (read and written: plain data).
#[derive(Serialize, Deserialize)]
struct DriveJson {
    joint: usize,
    /// `motor`, `position`, `velocity`, or null for damping alone.
    actuator: Option<String>,
    effort_limit: Option<f64>,
    damping: f64,
}

#[derive(Deserialize)]
struct JointJson {
    name: String,
    model: String,
    kind: String,
    limits: Option<[f64; 2]>,
}

#[derive(Deserialize)]
struct MechanismJson {
    name: String,
    bodies: [usize; 2],
    joints: [usize; 2],
    floating: bool,
}

#[derive(Deserialize)]
struct FrameJson {
    frame_id: String,
    model: String,
    link: String,
    visuals: FrameVisuals,
}

/// A frame's visuals: an index into `visual_sets` (version 2) or the list itself (version 1).
#[derive(Deserialize)]
#[serde(untagged)]
enum FrameVisuals {
    Set(usize),
    Inline(Vec<VisualJson>),
}

/// What [`to_json`] writes, borrowed from the layout (field for field the reader's structs).
#[derive(Serialize)]
struct LayoutOut<'a> {
    version: u32,
    name: &'a str,
    visual_sets: Vec<Vec<VisualJson>>,
    frames: Vec<FrameOut<'a>>,
    bodies: Vec<BodyOut<'a>>,
    topic_groups: Vec<GroupJson>,
    joints: Vec<JointOut<'a>>,
    mechanisms: Vec<MechanismOut<'a>>,
    /// Absent without drives: a recording of undriven models keeps the JSON it had.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    drives: Vec<DriveJson>,
    /// Absent without a ground, and without contacts: a run without contact keeps its JSON.
    #[serde(skip_serializing_if = "Option::is_none")]
    ground: Option<GroundJson>,
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    contacts: bool,
    /// Absent without enforced joint limits: a recording without them keeps its JSON.
    #[serde(skip_serializing_if = "<[usize]>::is_empty")]
    limited: &'a [usize],
}

#[derive(Serialize)]
struct FrameOut<'a> {
    frame_id: &'a str,
    model: &'a str,
    link: &'a str,
    visuals: usize,
}

#[derive(Serialize)]
struct BodyOut<'a> {
    name: &'a str,
    frame: usize,
    mass: f64,
    link_from_principal: PoseJson,
    principal_moments: [f64; 3],
}

#[derive(Serialize)]
struct JointOut<'a> {
    name: &'a str,
    model: &'a str,
    kind: &'a str,
    limits: Option<[f64; 2]>,
}

#[derive(Serialize)]
struct MechanismOut<'a> {
    name: &'a str,
    bodies: [usize; 2],
    joints: [usize; 2],
    floating: bool,
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

#[derive(Deserialize)]
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

/// Counts the bytes written to it.
struct Counter(usize);

impl std::io::Write for Counter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0 += buf.len();
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

fn visual_json(v: &Visual) -> VisualJson {
    VisualJson {
        name: v.name.clone(),
        link_from_visual: (&v.link_from_visual).into(),
        geometry: geometry_json(&v.geometry),
        rgba: v.rgba,
    }
}

/// The layout (without its metadata map) as JSON.
pub fn to_json(layout: &RecordingLayout) -> String {
    // One visual set per distinct list (by identity: the copies of a link share theirs).
    let mut set_of: std::collections::HashMap<*const Visual, usize> = Default::default();
    let mut visual_sets: Vec<Vec<VisualJson>> = Vec::new();
    let frames = layout
        .frames
        .iter()
        .map(|f| {
            let key = f.visuals.as_ptr();
            let visuals = *set_of.entry(key).or_insert_with(|| {
                visual_sets.push(f.visuals.iter().map(visual_json).collect());
                visual_sets.len() - 1
            });
            FrameOut {
                frame_id: &f.frame_id,
                model: &f.model,
                link: &f.link,
                visuals,
            }
        })
        .collect();
    let json = LayoutOut {
        version: LAYOUT_VERSION,
        name: &layout.name,
        visual_sets,
        frames,
        bodies: layout
            .bodies
            .iter()
            .map(|b| BodyOut {
                name: &b.name,
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
            .map(|j| JointOut {
                name: &j.name,
                model: &j.model,
                kind: &j.kind,
                limits: j.limits,
            })
            .collect(),
        mechanisms: layout
            .mechanisms
            .iter()
            .map(|m| MechanismOut {
                name: &m.name,
                bodies: [m.bodies.start, m.bodies.end],
                joints: [m.joints.start, m.joints.end],
                floating: m.floating,
            })
            .collect(),
        drives: layout
            .drives
            .iter()
            .map(|d| DriveJson {
                joint: d.joint,
                actuator: d.actuator.map(|a| a.name().to_string()),
                effort_limit: d.effort_limit,
                damping: d.damping,
            })
            .collect(),
        ground: layout.ground.map(|g| GroundJson {
            normal: g.normal.into(),
            point: g.point.into(),
        }),
        contacts: layout.contacts,
        limited: &layout.limited,
    };
    // Plain data (strings, finite or non-finite numbers become null): cannot fail. Sized by a
    // counting pass, so the text is built in place once (no doubling buffer).
    let mut counter = Counter(0);
    if serde_json::to_writer(&mut counter, &json).is_err() {
        return String::new();
    }
    let mut bytes = Vec::with_capacity(counter.0);
    if serde_json::to_writer(&mut bytes, &json).is_err() {
        return String::new();
    }
    String::from_utf8(bytes).unwrap_or_default()
}

/// Parses [`to_json`]'s output back; the metadata map is left empty. Indices are checked, so a
/// damaged or foreign JSON is an error, never a panic later.
pub fn from_json(text: &str) -> anyhow::Result<RecordingLayout> {
    let json: LayoutJson = serde_json::from_str(text).context("the layout JSON is malformed")?;
    if !(1..=LAYOUT_VERSION).contains(&json.version) {
        bail!(
            "layout JSON version {} (this tumble reads versions 1 to {LAYOUT_VERSION})",
            json.version
        );
    }
    let visuals_of = |list: Vec<VisualJson>, what: &str| -> anyhow::Result<Arc<[Visual]>> {
        list.into_iter()
            .map(|v| {
                Ok(Visual {
                    name: v.name,
                    link_from_visual: v
                        .link_from_visual
                        .isometry()
                        .with_context(|| format!("{what}: visual origin"))?,
                    geometry: geometry(v.geometry),
                    rgba: v.rgba,
                })
            })
            .collect()
    };
    let sets: Vec<Arc<[Visual]>> = json
        .visual_sets
        .into_iter()
        .enumerate()
        .map(|(k, list)| visuals_of(list, &format!("visual set {k}")))
        .collect::<anyhow::Result<_>>()?;
    let mut frames = Vec::with_capacity(json.frames.len());
    for f in json.frames {
        let visuals = match f.visuals {
            FrameVisuals::Set(k) => match sets.get(k) {
                Some(set) => Arc::clone(set),
                None => bail!(
                    "frame {:?} uses visual set {k} of {}",
                    f.frame_id,
                    sets.len()
                ),
            },
            FrameVisuals::Inline(list) => visuals_of(list, &format!("frame {:?}", f.frame_id))?,
        };
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
    let mut drives: Vec<DriveLayout> = Vec::with_capacity(json.drives.len());
    for d in json.drives {
        if d.joint >= joints.len() || drives.last().is_some_and(|p| p.joint >= d.joint) {
            bail!(
                "drive on joint {} of {} (drives must name joints in increasing order)",
                d.joint,
                joints.len()
            );
        }
        let actuator = match d.actuator.as_deref() {
            None => None,
            Some(name) => Some(ActuatorLaw::from_name(name).with_context(|| {
                format!(
                    "drive on joint {}: unknown actuator {name:?} (motor, position, velocity)",
                    d.joint
                )
            })?),
        };
        drives.push(DriveLayout {
            joint: d.joint,
            actuator,
            effort_limit: d.effort_limit,
            damping: d.damping,
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
    if json
        .limited
        .iter()
        .enumerate()
        .any(|(k, &j)| j >= joints.len() || (k > 0 && json.limited[k - 1] >= j))
    {
        bail!(
            "limited joints {:?} of {} (they must name joints in increasing order)",
            json.limited,
            joints.len()
        );
    }
    let ground = match json.ground {
        Some(g) => {
            let normal = Vector3::from(g.normal);
            let point = Vector3::from(g.point);
            let norm = normal.norm();
            if !(norm.is_finite() && norm > 0.0 && point.iter().all(|v| v.is_finite())) {
                bail!(
                    "ground normal {:?} / point {:?} is not finite and nonzero",
                    g.normal,
                    g.point
                );
            }
            Some(super::GroundLayout { normal, point })
        }
        None => None,
    };
    Ok(RecordingLayout {
        name: json.name,
        frames,
        bodies,
        metadata: Default::default(),
        topic_groups,
        joints,
        mechanisms,
        robot_descriptions: Vec::new(),
        drives,
        ground,
        contacts: json.contacts,
        limited: json.limited,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Geometry;
    use crate::record::{MechanismLayout, TopicGroup};
    use nalgebra::Translation3;

    fn visual(geometry: Geometry, x: f64) -> Visual {
        Visual {
            name: Some(format!("v{x}")),
            link_from_visual: Isometry3::from_parts(
                Translation3::new(x, 0.1, -0.2),
                UnitQuaternion::from_euler_angles(0.3, x, 0.1),
            ),
            geometry,
            rgba: Some([0.1, 0.2, 0.3, 1.0]),
        }
    }

    fn frame(id: &str, visuals: &Arc<[Visual]>) -> FrameLayout {
        FrameLayout {
            frame_id: id.into(),
            model: id.split('/').next().unwrap().into(),
            link: "base".into(),
            visuals: Arc::clone(visuals),
        }
    }

    /// Three frames, two of them copies sharing one list: the JSON holds two visual sets, reads
    /// back to the same layout (Debug text equal: floats print exactly), and the copies share
    /// one list again after reading.
    #[test]
    fn shared_visuals_are_written_once_and_read_back_shared() {
        let boxes: Arc<[Visual]> = vec![
            visual(
                Geometry::Box {
                    size: [0.1, 0.2, 0.3].into(),
                },
                0.5,
            ),
            visual(Geometry::Sphere { radius: 0.05 }, 0.25),
        ]
        .into();
        let disc: Arc<[Visual]> = vec![visual(
            Geometry::Cylinder {
                radius: 0.3,
                length: 0.01,
            },
            1.0 / 3.0,
        )]
        .into();
        let layout = RecordingLayout {
            name: "swarm".into(),
            frames: vec![
                frame("b_0/base", &boxes),
                frame("d_0/base", &disc),
                frame("b_1/base", &boxes),
            ],
            bodies: vec![BodyLayout {
                name: "b_0".into(),
                frame: 0,
                mass: 1.5,
                link_from_principal: Isometry3::translation(0.01, 0.0, 0.0),
                principal_moments: Vector3::new(0.1, 0.2, 0.3),
            }],
            topic_groups: vec![TopicGroup {
                prefix: String::new(),
                frames: 0..3,
                bodies: 0..1,
                joints: 0..0,
                mechanisms: 0..1,
            }],
            mechanisms: vec![MechanismLayout {
                name: "b_0".into(),
                bodies: 0..1,
                joints: 0..0,
                floating: true,
            }],
            ..Default::default()
        };
        let text = to_json(&layout);
        // Built in a buffer of the exact size (the counting pass).
        assert_eq!(text.capacity(), text.len());
        let raw: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(raw["version"], 2);
        assert_eq!(raw["visual_sets"].as_array().unwrap().len(), 2);
        assert_eq!(
            raw["frames"]
                .as_array()
                .unwrap()
                .iter()
                .map(|f| f["visuals"].as_u64().unwrap())
                .collect::<Vec<_>>(),
            [0, 1, 0]
        );
        let back = from_json(&text).unwrap();
        assert_eq!(format!("{:?}", back.frames), format!("{:?}", layout.frames));
        assert_eq!(format!("{:?}", back.bodies), format!("{:?}", layout.bodies));
        assert_eq!(back.topic_groups, layout.topic_groups);
        assert_eq!(back.mechanisms, layout.mechanisms);
        assert!(Arc::ptr_eq(
            &back.frames[0].visuals,
            &back.frames[2].visuals
        ));
        assert!(!Arc::ptr_eq(
            &back.frames[0].visuals,
            &back.frames[1].visuals
        ));
    }

    /// The drives round-trip; a layout without drives has no `drives` key (its JSON is the one
    /// written before drives existed); drives out of order, on a joint the layout lacks, or of
    /// an unknown law are refused.
    #[test]
    fn drives_round_trip_and_are_absent_without_drives() {
        let joint = |name: &str| JointLayout {
            name: name.into(),
            model: "m".into(),
            kind: "revolute".into(),
            limits: None,
        };
        let mut layout = RecordingLayout {
            name: "driven".into(),
            joints: vec![joint("a"), joint("b"), joint("c")],
            ..Default::default()
        };
        assert!(!to_json(&layout).contains("drives"));
        layout.drives = vec![
            DriveLayout {
                joint: 0,
                actuator: Some(ActuatorLaw::Position),
                effort_limit: Some(2.5),
                damping: 0.1,
            },
            DriveLayout {
                joint: 2,
                actuator: None,
                effort_limit: None,
                damping: 0.3,
            },
        ];
        let text = to_json(&layout);
        assert!(
            text.contains(
                r#""drives":[{"joint":0,"actuator":"position","effort_limit":2.5,"damping":0.1},"#
            ),
            "{text}"
        );
        let back = from_json(&text).unwrap();
        assert_eq!(back.drives, layout.drives);
        assert_eq!(back.drive_of(2).map(|d| d.kind_name()), Some("damping"));
        assert!(back.drive_of(1).is_none());
        for (bad, message) in [
            (
                r#"{"joint":2,"actuator":null,"effort_limit":null,"damping":0.3},{"joint":0,"actuator":null,"effort_limit":null,"damping":0.3}"#,
                "drive on joint 0 of 3",
            ),
            (
                r#"{"joint":3,"actuator":null,"effort_limit":null,"damping":0.3}"#,
                "drive on joint 3 of 3",
            ),
            (
                r#"{"joint":1,"actuator":"spring","effort_limit":null,"damping":0.3}"#,
                "unknown actuator \"spring\"",
            ),
        ] {
            let start = text.find(r#""drives":["#).unwrap() + r#""drives":["#.len();
            let end = text.rfind(']').unwrap();
            let damaged = format!("{}{bad}{}", &text[..start], &text[end..]);
            let err = format!("{:#}", from_json(&damaged).unwrap_err());
            assert!(err.contains(message), "{err}");
        }
    }

    /// The ground and the contacts flag round-trip; a layout without them has neither key (its
    /// JSON is the one written before contact existed); a zero ground normal is refused.
    #[test]
    fn ground_and_contacts_round_trip_and_are_absent_without_contact() {
        let mut layout = RecordingLayout {
            name: "c".into(),
            ..Default::default()
        };
        let plain = to_json(&layout);
        assert!(
            !plain.contains("ground") && !plain.contains("contacts"),
            "{plain}"
        );
        layout.ground = Some(crate::record::GroundLayout {
            normal: Vector3::new(0.0, 0.6, 0.8),
            point: Vector3::new(0.0, 0.0, -1.0 / 3.0),
        });
        layout.contacts = true;
        let text = to_json(&layout);
        assert!(text.contains(r#""contacts":true"#), "{text}");
        let back = from_json(&text).unwrap();
        assert_eq!((back.ground, back.contacts), (layout.ground, true));
        let zero = text.replace("[0.0,0.6,0.8]", "[0.0,0.0,0.0]");
        assert_ne!(zero, text);
        let err = format!("{:#}", from_json(&zero).unwrap_err());
        assert!(err.contains("ground normal"), "{err}");
    }

    /// Files written before version 2 (every frame's list inline) still read.
    #[test]
    fn version_one_inline_visuals_still_read() {
        let text = r#"{"version": 1, "name": "old", "frames": [{"frame_id": "a/base",
            "model": "a", "link": "base", "visuals": [{"name": null, "link_from_visual":
            {"translation": [0.0, 0.0, 0.5], "rotation_xyzw": [0.0, 0.0, 0.0, 1.0]},
            "geometry": {"sphere": {"radius": 0.25}}, "rgba": null}]}], "bodies": [],
            "topic_groups": []}"#;
        let layout = from_json(text).unwrap();
        assert_eq!(layout.frames.len(), 1);
        assert_eq!(layout.frames[0].visuals.len(), 1);
        assert!(matches!(
            layout.frames[0].visuals[0].geometry,
            Geometry::Sphere { radius } if radius == 0.25
        ));
        assert_eq!(
            layout.frames[0].visuals[0].link_from_visual.translation.z,
            0.5
        );
    }

    /// A set index past the sets and an unknown version are errors naming what is wrong.
    #[test]
    fn bad_set_indices_and_versions_are_refused() {
        let text = r#"{"version": 2, "name": "x", "visual_sets": [[]], "frames": [{"frame_id":
            "a/base", "model": "a", "link": "base", "visuals": 1}], "bodies": [],
            "topic_groups": []}"#;
        let err = format!("{:#}", from_json(text).unwrap_err());
        assert!(err.contains("\"a/base\" uses visual set 1 of 1"), "{err}");
        let text = r#"{"version": 3, "name": "x", "frames": [], "bodies": [], "topic_groups": []}"#;
        let err = format!("{:#}", from_json(text).unwrap_err());
        assert!(err.contains("version 3"), "{err}");
    }

    /// Ranges of models and topic groups outside the layout (or reversed) are refused, each
    /// range on its own: one frame, one body, no joint, one model in the layout below.
    #[test]
    fn ranges_outside_the_layout_are_refused() {
        let layout = |mechanism: &str, group: &str| {
            format!(
                r#"{{"version": 2, "name": "x", "visual_sets": [[]], "frames": [{{"frame_id":
                "a/base", "model": "a", "link": "base", "visuals": 0}}], "bodies": [{{"name": "a",
                "frame": 0, "mass": 1.0, "link_from_principal": {{"translation": [0.0, 0.0, 0.0],
                "rotation_xyzw": [0.0, 0.0, 0.0, 1.0]}}, "principal_moments": [1.0, 1.0, 1.0]}}],
                "mechanisms": [{{"name": "a", {mechanism}, "floating": true}}],
                "topic_groups": [{{"prefix": "", {group}}}]}}"#
            )
        };
        let good_m = r#""bodies": [0, 1], "joints": [0, 0]"#;
        let good_g =
            r#""frames": [0, 1], "bodies": [0, 1], "joints": [0, 0], "mechanisms": [0, 1]"#;
        assert!(from_json(&layout(good_m, good_g)).is_ok());
        for m in [
            r#""bodies": [1, 0], "joints": [0, 0]"#,
            r#""bodies": [0, 2], "joints": [0, 0]"#,
            r#""bodies": [0, 1], "joints": [0, 1]"#,
        ] {
            let err = format!("{:#}", from_json(&layout(m, good_g)).unwrap_err());
            assert!(
                err.contains("mechanism \"a\" has ranges outside"),
                "{m}: {err}"
            );
        }
        for g in [
            r#""frames": [0, 2], "bodies": [0, 1], "joints": [0, 0], "mechanisms": [0, 1]"#,
            r#""frames": [0, 1], "bodies": [1, 0], "joints": [0, 0], "mechanisms": [0, 1]"#,
            r#""frames": [0, 1], "bodies": [0, 1], "joints": [0, 1], "mechanisms": [0, 1]"#,
            r#""frames": [0, 1], "bodies": [0, 1], "joints": [0, 0], "mechanisms": [0, 2]"#,
        ] {
            let err = format!("{:#}", from_json(&layout(good_m, g)).unwrap_err());
            assert!(
                err.contains("topic group \"\" has ranges outside"),
                "{g}: {err}"
            );
        }
    }
}
