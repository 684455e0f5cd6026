//! What a body is: URDF models, their links' mass properties and visual geometry.

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
}

/// Where a link's mass properties came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum InertiaSource {
    /// The URDF's `<inertial>` element, valid as written.
    Urdf,
    /// No `<inertial>` element at all: the link is massless (a frame), not a body.
    Missing,
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
    /// Validation findings (rule broken, in words). Empty when the link is fine.
    pub problems: Vec<String>,
    pub visuals: Vec<Visual>,
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
    /// failed; `uri` keeps what the URDF said).
    Mesh {
        uri: String,
        path: Option<PathBuf>,
        scale: Vector3<f64>,
    },
}
