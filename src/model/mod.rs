//! What a body is: URDF models, their links' mass properties and their visual and collision
//! geometry.

pub mod articulation;
pub mod confine;
pub mod description;
pub mod geometry;
pub mod kinematics;
pub mod mass_properties;
pub mod package;
pub mod policy;
pub mod urdf;

pub use mass_properties::MassProperties;

use nalgebra::{Isometry3, Vector3};
use std::path::PathBuf;

/// A URDF model after loading: every link placed at the zero joint configuration.
#[derive(Debug, Clone)]
pub struct Model {
    /// The `<robot name=...>`.
    pub name: String,
    /// The URDF file it came from.
    pub path: PathBuf,
    /// Links in a stable order (the order of the URDF file). `links[root]` is the root link.
    pub links: Vec<Link>,
    /// Index of the root link (the one that is no joint's child). Model frame = root link frame.
    pub root: usize,
    /// The URDF joints, links referred to by index into `links`, in file order.
    pub joints: Vec<kinematics::Joint>,
    /// The oddities the loader accepted, one per oddity, in file order (by the line their
    /// element starts on; see
    /// [`urdf::Strictness`]); empty for a file URDF defines fully.
    pub warnings: Vec<urdf::LoadWarning>,
    /// Every `<mesh>` (visual and collision), in file order: the file it resolved to, its real
    /// path and whether it is read ([`confine`]: meshes outside the allowed folders are
    /// refused; [`Model::check_meshes`]).
    pub meshes: Vec<confine::MeshUse>,
}

/// Where a link's mass properties came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum InertiaSource {
    /// The URDF's `<inertial>` element, valid as written.
    Urdf,
    /// No `<inertial>` element at all: the link is massless (a frame), not a body.
    Missing,
    /// Computed from the link's geometry because `inertia = "geometry"` asked for it, whatever
    /// the URDF says ([`policy::apply`]). `inertial: None` here means the link has no geometry
    /// at all and is a massless frame.
    Geometry,
    /// `inertia = "auto"`: the URDF's `<inertial>` was missing or invalid and was replaced by
    /// values computed from the link's geometry ([`policy::apply`]; why in `Link::notes`).
    Repaired,
}

/// One URDF link.
#[derive(Debug, Clone)]
pub struct Link {
    pub name: String,
    /// Pose of the link frame in the model (root link) frame at the zero joint configuration.
    pub model_from_link: Isometry3<f64>,
    /// Mass properties in the link frame (centre of mass in link coordinates, inertia about the
    /// centre of mass in link axes: the URDF inertial `rpy` already applied). `None` when the link
    /// has no `<inertial>` element.
    pub inertial: Option<MassProperties>,
    pub source: InertiaSource,
    /// Validation findings (rule broken, in words) about the values in use and the visuals.
    /// Empty when the link is fine. Findings about URDF values a policy replaced move to `notes`.
    pub problems: Vec<String>,
    /// Shared (an [`std::sync::Arc`]) by every copy of the model placed in a scene.
    pub visuals: std::sync::Arc<[Visual]>,
    /// The `<collision>` elements: mass properties (inertia policies) and, with a scene's
    /// `collisions = "urdf"`, colliders (`crate::scene::contact`).
    pub collisions: Vec<Collision>,
    /// The URDF's `<inertial>` as written (`None` when absent), kept whatever the inertia
    /// policy puts in `inertial`, so that the two can be compared.
    pub urdf_inertial: Option<MassProperties>,
    /// Which geometry `inertial` was computed from, when it was ([`InertiaSource::Geometry`],
    /// [`InertiaSource::Repaired`]).
    pub geometry_used: Option<geometry::GeometryUsed>,
    /// What the inertia policy did to this link and why, in words (e.g. "no `<inertial>`:
    /// computed from 1 collision shape at 1000 kg/m^3"). Empty when the URDF's values are used
    /// as they are.
    pub notes: Vec<String>,
}

impl Link {
    /// A link becomes a free body when it has positive mass.
    pub fn has_mass(&self) -> bool {
        self.inertial.as_ref().is_some_and(|mp| mp.mass > 0.0)
    }
}

/// One `<visual>` element of a link.
#[derive(Debug, Clone)]
pub struct Visual {
    /// The `name` attribute of `<visual>`, if any.
    pub name: Option<String>,
    pub link_from_visual: Isometry3<f64>,
    pub geometry: Geometry,
    /// RGBA in 0..1 from the `<material>` (inline or by reference to a robot-level material).
    pub rgba: Option<[f32; 4]>,
}

/// One `<collision>` element of a link.
#[derive(Debug, Clone)]
pub struct Collision {
    /// The `name` attribute of `<collision>`, if any.
    pub name: Option<String>,
    pub link_from_collision: Isometry3<f64>,
    pub geometry: Geometry,
}

/// URDF geometry, SI units. Cylinders and capsules have their axis along z, centred at the origin.
#[derive(Debug, Clone)]
pub enum Geometry {
    /// Full side lengths.
    Box {
        size: Vector3<f64>,
    },
    Cylinder {
        radius: f64,
        length: f64,
    },
    Sphere {
        radius: f64,
    },
    /// URDF 1.1 capsule: `length` is the straight part only; two hemispheres are added.
    Capsule {
        radius: f64,
        length: f64,
    },
    /// A mesh file. `path` is the resolved file (`None` when `package://`/relative resolution
    /// found no file, or when the file is outside the folders meshes are read from:
    /// [`confine`]; `uri` keeps what the URDF said). A file that exists but is not a regular
    /// file of at most [`crate::input::MESH_MAX_BYTES`] is kept here with a problem on the
    /// link; every reader refuses it through [`crate::input`], saying why.
    Mesh {
        uri: String,
        path: Option<PathBuf>,
        scale: Vector3<f64>,
    },
}
