//! The tables of a scene file as serde reads them: `[sim]` ([`SimSettings`]) and each
//! `[[model]]` ([`ModelEntry`]).

use super::placement;
use crate::model::policy::{GeometrySource, InertiaPolicy, MassSettings};
use crate::sim::integrators::{IntegratorKind, Jacobian, Potential, VariationalSettings};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// `[x, y, z]`: exactly three numbers. (Through `toml`, serde's own `[f64; 3]` reads the first
/// three elements of a longer array and silently drops the rest.)
pub(super) fn vec3<'de, D: serde::Deserializer<'de>>(
    deserializer: D,
) -> Result<[f64; 3], D::Error> {
    let v = Vec::<f64>::deserialize(deserializer)?;
    <[f64; 3]>::try_from(v.as_slice())
        .map_err(|_| serde::de::Error::invalid_length(v.len(), &"an array of 3 numbers"))
}

/// The `[sim]` table.
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimSettings {
    pub dt: f64,
    pub duration: f64,
    #[serde(deserialize_with = "vec3")]
    pub gravity: [f64; 3],
    pub integrator: String,
    pub log_every: u64,
    pub newton_tol: f64,
    pub newton_max_iters: u32,
    pub jacobian: Jacobian,
    pub potential: Potential,
    pub substep: bool,
    pub max_substeps: u32,
    pub divergence_energy_ratio: f64,
    /// `simulate --accuracy`: the largest orientation error (rad) over the run allowed for any
    /// free body; each body gets the substeps that meet it ([`crate::sim::accuracy`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accuracy: Option<f64>,
}

impl Default for SimSettings {
    fn default() -> Self {
        let v = VariationalSettings::default();
        Self {
            dt: 0.001,
            duration: 5.0,
            gravity: [0.0, 0.0, -9.81],
            integrator: IntegratorKind::Variational.name().into(),
            log_every: 10,
            newton_tol: v.newton_tol,
            newton_max_iters: v.newton_max_iters,
            jacobian: v.jacobian,
            potential: v.potential,
            substep: v.substep,
            max_substeps: v.max_substeps,
            divergence_energy_ratio: crate::sim::guard::DEFAULT_DIVERGENCE_ENERGY_RATIO,
            accuracy: None,
        }
    }
}

/// One `[[model]]` entry.
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct ModelEntry {
    pub urdf: PathBuf,
    #[serde(default)]
    pub name: Option<String>,
    #[serde(default, deserialize_with = "vec3")]
    pub position: [f64; 3],
    #[serde(default, deserialize_with = "vec3")]
    pub rpy: [f64; 3],
    #[serde(default, deserialize_with = "vec3")]
    pub linvel: [f64; 3],
    #[serde(default, deserialize_with = "vec3")]
    pub angvel: [f64; 3],
    #[serde(default)]
    pub package_paths: Vec<PathBuf>,
    /// Folders mesh files may be read from besides the URDF's folder and package, the package
    /// paths, `ROS_PACKAGE_PATH` and the scene's folder ([`crate::model::confine`]); relative
    /// to the scene's folder. `--allow-mesh-path` adds to it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub allow_mesh_paths: Vec<PathBuf>,
    /// Accept links whose principal moments break the triangle inequality `I1 + I2 >= I3`
    /// (no mass distribution has them, e.g. Hairer, Lubich & Wanner's test body (2, 1, 2/3));
    /// refused by default. Every other inertia rule still applies.
    #[serde(default)]
    pub allow_non_physical_inertia: bool,
    /// What the model becomes: one body per link, or one rigid body.
    #[serde(default)]
    pub bodies: BodiesMode,
    /// Joint positions (rad or m) the model is placed at; joints not named are at 0.
    #[serde(default)]
    pub joints: BTreeMap<String, f64>,
    /// Articulated models: `floating` (default) or `fixed` root link.
    #[serde(default)]
    pub base: Option<BaseMode>,
    /// Articulated models: initial joint rates (rad/s or m/s; default 0).
    #[serde(default)]
    pub joint_velocities: BTreeMap<String, f64>,
    /// Articulated models: joints locked at their `joints` value and merged like fixed joints.
    #[serde(default)]
    pub locked_joints: Vec<String>,
    /// Articulated models: `[[model.actuator]]` tables, one per driven joint, as written (read
    /// and checked by [`super::actuator`], their signals read when the model is loaded).
    #[serde(default, rename = "actuator", skip_serializing_if = "Vec::is_empty")]
    pub actuators: Vec<toml::Table>,
    /// `[[model.load]]` tables, forces and torques on links, as written (read and checked by
    /// [`super::load`]).
    #[serde(default, rename = "load", skip_serializing_if = "Vec::is_empty")]
    pub loads: Vec<toml::Table>,
    /// Articulated models: `false` leaves the URDF's `<dynamics damping>` out (`None`: the
    /// default, damping on).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint_damping: Option<bool>,
    /// Articulated models: `false` turns the URDF's `<limit lower upper>` off (`None`: the
    /// default, limits on: a kept revolute or prismatic joint stops at its range).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint_limits: Option<bool>,
    /// Articulated models: `false` leaves the URDF's `<dynamics friction>` out (`None`: the
    /// default, joint friction on).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint_friction: Option<bool>,
    /// Which geometry collides (issue 31): `"none"` (default), `"urdf"` (the `<collision>`
    /// elements) or `"visual"` (the `<visual>` elements), as written (checked by
    /// [`Scene::validate`](super::Scene::validate), read by [`ModelEntry::collisions`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub collisions: Option<String>,
    /// Whether the links of one copy collide with each other (default `false`; a joint's
    /// parent and child never do).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub self_collision: Option<bool>,
    /// Coulomb coefficient of the model's colliders (default 0.8; a pair takes the smaller).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
    /// Restitution of the model's colliders (default 0; a pair takes the larger).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub restitution: Option<f64>,
    /// Mass settings of this model (refine the scene's `[mass]`).
    #[serde(default)]
    pub inertia: Option<InertiaPolicy>,
    #[serde(default)]
    pub density: Option<f64>,
    #[serde(default)]
    pub geometry: Option<GeometrySource>,
    /// Per-link mass settings (refine the model's).
    #[serde(default)]
    pub links: BTreeMap<String, MassSettings>,
    /// Refuse the URDF oddities urdfdom loads instead of loading them with a warning
    /// ([`urdf::Strictness`], docs/urdf.md). Written into recordings' settings only when set.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub strict: bool,
    /// `copies = N`: the table stands for N models named `<name>_<index>` ([`crate::scene::placement`]).
    /// `None`: one model, named `name`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub copies: Option<u64>,
    /// `seed = S`: copy `i` draws its distributions from streams seeded by `(S, i)` (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// The distributions given for `position`, `rpy` / `orientation`, `linvel`, `angvel` (taken
    /// out of the table before serde reads it, [`placement::Draws::take`]); what is drawn
    /// replaces the plain value of the same key.
    #[serde(
        skip_deserializing,
        skip_serializing_if = "placement::Draws::is_empty",
        serialize_with = "serialize_draws"
    )]
    pub draws: placement::Draws,
}

fn serialize_draws<S: serde::Serializer>(
    draws: &placement::Draws,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    serde::Serialize::serialize(&draws.written, serializer)
}

/// `bodies = "links" | "rigid"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BodiesMode {
    /// One free body per link with positive mass.
    #[default]
    Links,
    /// The whole model, locked at `joints`, as one rigid body; every link frame rides on it.
    Rigid,
    /// Revolute, continuous and prismatic joints kept as constraints, fixed and locked joints
    /// merged ([`articulated`]).
    Articulated,
}

/// `collisions = "none" | "urdf" | "visual"`: which of a model's geometry collides.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Collisions {
    /// No collider: the model passes through the ground and everything else (the default).
    #[default]
    None,
    /// Each link's `<collision>` elements.
    Urdf,
    /// Each link's `<visual>` elements.
    Visual,
}

impl Collisions {
    /// The spellings, in the order messages list them.
    pub const NAMES: [&'static str; 3] = ["none", "urdf", "visual"];

    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "none" => Some(Collisions::None),
            "urdf" => Some(Collisions::Urdf),
            "visual" => Some(Collisions::Visual),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Collisions::None => "none",
            Collisions::Urdf => "urdf",
            Collisions::Visual => "visual",
        }
    }
}

/// `base = "floating" | "fixed"` (articulated models).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BaseMode {
    /// The root link moves freely (`linvel`/`angvel` are its twist).
    #[default]
    Floating,
    /// The root link is welded to the world at `position`/`rpy`.
    Fixed,
}

impl ModelEntry {
    /// A model at `position` with everything else zero.
    pub fn at(urdf: PathBuf, position: [f64; 3]) -> Self {
        Self {
            urdf,
            name: None,
            position,
            rpy: [0.0; 3],
            linvel: [0.0; 3],
            angvel: [0.0; 3],
            package_paths: Vec::new(),
            allow_mesh_paths: Vec::new(),
            allow_non_physical_inertia: false,
            bodies: BodiesMode::Links,
            joints: BTreeMap::new(),
            base: None,
            joint_velocities: BTreeMap::new(),
            locked_joints: Vec::new(),
            actuators: Vec::new(),
            loads: Vec::new(),
            joint_damping: None,
            joint_limits: None,
            joint_friction: None,
            collisions: None,
            self_collision: None,
            friction: None,
            restitution: None,
            inertia: None,
            density: None,
            geometry: None,
            links: BTreeMap::new(),
            strict: false,
            copies: None,
            seed: None,
            draws: placement::Draws::default(),
        }
    }

    /// The `collisions` key ([`Collisions::None`] when absent or, before validation, unknown).
    pub fn collisions(&self) -> Collisions {
        self.collisions
            .as_deref()
            .and_then(Collisions::from_name)
            .unwrap_or_default()
    }

    /// How many models the table stands for.
    pub fn copy_count(&self) -> u64 {
        self.copies.unwrap_or(1)
    }

    /// The plain values of the keys [`placement::Draws`] may replace.
    pub fn fixed(&self) -> placement::Fixed {
        placement::Fixed {
            position: self.position,
            rpy: self.rpy,
            linvel: self.linvel,
            angvel: self.angvel,
        }
    }

    /// Where copy `copy` starts.
    pub fn placement(&self, copy: u64) -> placement::Placement {
        placement::place(&self.fixed(), &self.draws, self.seed.unwrap_or(0), copy)
    }
}
