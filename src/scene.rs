//! TOML scene files: what is simulated, and only that.
//!
//! ```toml
//! [sim]
//! dt = 0.001                    # s, > 0                                   (default 0.001)
//! duration = 5.0                # s, >= 0                                  (default 5.0)
//! gravity = [0.0, 0.0, -9.81]   # m/s^2, world frame; [0,0,0] = off       (default [0, 0, -9.81])
//! integrator = "variational"    # variational | moser-veselov | variational4 | variational6 | euler | semi-implicit | rk4
//! log_every = 10                # record every Nth step, >= 1              (default 10)
//! newton_tol = 1e-12            # relative Newton residual                 (default 1e-12)
//! newton_max_iters = 10         # Newton iteration cap                     (default 10)
//! jacobian = "analytic"         # "analytic" | "approximate" (the seed's)  (default "analytic")
//! potential = "symmetric"       # "symmetric" | "end-point" (the seed's)   (default "symmetric")
//! substep = true                # split a body's step when Newton fails    (default true)
//! max_substeps = 1024           # largest split factor, a power of two     (default 1024)
//! divergence_energy_ratio = 100 # stop when a body's rotational energy exceeds this × its initial (default 100)
//! accuracy = 1e-6               # rad of orientation error over the run, per body: substeps chosen per body (default: off; docs/accuracy.md)
//!
//! [[model]]                     # one or more
//! urdf = "box.urdf"             # relative to the scene file
//! name = "box1"                 # optional: frame ids become "box1/<link>"
//! position = [0.0, 0.0, 1.0]    # world position of the root link frame, m    (default 0)
//! rpy = [0.0, 0.0, 0.0]         # world orientation of the root link frame, rad, R = Rz Ry Rx (default 0)
//! linvel = [0.0, 0.0, 0.0]      # initial velocity of every body's centre of mass, world, m/s (default 0)
//! angvel = [0.0, 5.0, 0.1]      # initial angular velocity of every body, world, rad/s (default 0)
//! package_paths = ["../share"]  # optional extra package:// search folders, relative to the scene
//! allow_mesh_paths = ["../cad"] # optional extra folders mesh files may be read from, relative to the scene (crate::model::confine)
//! allow_non_physical_inertia = false  # accept inertia breaking the triangle inequality (default false)
//! bodies = "links"              # "links": one free body per link | "rigid": the whole model as one body
//! joints = { elbow = 0.5 }      # joint positions (rad or m) the model is placed (and locked) at (default 0)
//! inertia = "urdf"              # mass properties from "urdf" | "geometry" | "auto" (default: [mass])
//! density = 1000.0              # kg/m^3 for geometry-derived mass properties (default: [mass])
//! geometry = "collision"        # "collision" (visual as fallback) | "visual" (default: [mass])
//! links = { base = { inertia = "geometry", density = 2700.0 } }   # per-link overrides
//! strict = false                # refuse the URDF oddities urdfdom loads (docs/urdf.md) instead of loading them with a warning (default false; --strict sets it on every model)
//! copies = 10000                # the table stands for N models named <name>_<index> (default: one, named `name`; docs/scale.md)
//! seed = 7                      # copy i draws its distributions from streams seeded by (seed, i) (default 0)
//! # position, rpy, linvel, angvel: a value or a distribution ({ uniform = [lo, hi] }, log_uniform, normal, choice);
//! # orientation = "uniform" | [x, y, z, w] instead of rpy ([`crate::placement`])
//!
//! [mass]                        # scene-wide defaults of the mass settings (flags --inertia, --density, --geometry override them)
//! inertia = "urdf"              # (default "urdf")
//! density = 1000.0              # (default 1000)
//! geometry = "collision"        # (default "collision")
//! ```
//!
//! Every link with positive mass becomes one free rigid body at its forward-kinematics pose
//! (zero joint configuration). Links without mass are not simulated and not recorded.
//! Unknown keys and bad values are errors naming the key.

use crate::budget::readable;
use crate::model::policy::{self, GeometrySource, InertiaPolicy, MassSettings, ModelMassSettings};
use crate::model::{MassProperties, Model, urdf};
use crate::placement;
use crate::record::{BodyLayout, FrameLayout, RecordingLayout, RobotDescription};
use crate::sim::BodyInit;
use crate::sim::integrators::{IntegratorKind, Jacobian, Potential, VariationalSettings};
use crate::sim::mechanism::{Articulated, Mechanism};

mod articulated;
pub mod bounds;
pub mod triangles;
use anyhow::{Context, bail};
use nalgebra::{Isometry3, Translation3, Vector3};
use serde::Deserialize;
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Prefix of the recording metadata keys holding URDF texts: `urdf/<the model's urdf value as
/// the scene wrote it>` = the file's text, one entry per distinct file however many models use it.
pub const URDF_METADATA_PREFIX: &str = "urdf/";

/// `[x, y, z]`: exactly three numbers. (Through `toml`, serde's own `[f64; 3]` reads the first
/// three elements of a longer array and silently drops the rest.)
fn vec3<'de, D: serde::Deserializer<'de>>(deserializer: D) -> Result<[f64; 3], D::Error> {
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
    /// `copies = N`: the table stands for N models named `<name>_<index>` ([`crate::placement`]).
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

#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    sim: SimSettings,
    #[serde(default, rename = "model")]
    models: Vec<ModelEntry>,
    #[serde(default)]
    mass: MassSettings,
}

/// Reads the scene text: the distributions of each `[[model]]` first
/// ([`placement::Draws::take`]), then serde the rest. A scene without distributions goes to
/// serde as text, so its errors point at the line.
fn parse_scene_file(text: &str, path: &Path) -> anyhow::Result<SceneFile> {
    let file = path.display().to_string();
    let syntax = |e: toml::de::Error| anyhow::anyhow!("{file}: {}", e.to_string().trim_end());
    let mut table: toml::Table = toml::from_str(text).map_err(syntax)?;
    let mut draws = Vec::new();
    if let Some(toml::Value::Array(models)) = table.get_mut("model") {
        for (i, model) in models.iter_mut().enumerate() {
            if let toml::Value::Table(t) = model {
                draws.push(placement::Draws::take(&file, i, t)?);
            }
        }
    }
    let mut scene: SceneFile = if draws.iter().all(placement::Draws::is_empty) {
        toml::from_str(text).map_err(syntax)?
    } else {
        toml::Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| anyhow::anyhow!("{file}: {}", e.to_string().trim_end()))?
    };
    for (entry, d) in scene.models.iter_mut().zip(draws) {
        entry.draws = d;
    }
    Ok(scene)
}

/// A parsed scene. Relative paths in it are relative to `base_dir`.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Where the scene came from (a `.toml` file, or the URDF of a one-model scene).
    pub source: PathBuf,
    pub base_dir: PathBuf,
    /// The scene text as given (empty for a URDF given directly).
    pub text: String,
    pub sim: SimSettings,
    pub models: Vec<ModelEntry>,
    /// The `[mass]` table (scene-wide mass settings), after command-line overrides.
    pub mass: MassSettings,
}

/// Command-line overrides of `[sim]` values (`None` = keep the scene's).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SimOverrides {
    pub dt: Option<f64>,
    pub duration: Option<f64>,
    pub gravity: Option<[f64; 3]>,
    pub integrator: Option<String>,
    pub log_every: Option<u64>,
    pub newton_tol: Option<f64>,
    pub newton_max_iters: Option<u32>,
    pub jacobian: Option<Jacobian>,
    pub potential: Option<Potential>,
    /// `Some(false)` switches substepping off.
    pub substep: Option<bool>,
    pub max_substeps: Option<u32>,
    pub divergence_energy_ratio: Option<f64>,
    /// `--accuracy TOL`.
    pub accuracy: Option<f64>,
    /// `--inertia`, `--density`, `--geometry`: override the `[mass]` table.
    pub mass: MassSettings,
}

impl Scene {
    /// Reads a scene file.
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let text = crate::input::read_text(path, crate::input::SCENE_MAX_BYTES)
            .with_context(|| format!("cannot read scene {}", path.display()))?;
        Self::parse(&text, path)
    }

    /// Parses scene text; `path` names the file in errors and anchors relative paths.
    pub fn parse(text: &str, path: &Path) -> anyhow::Result<Self> {
        let file = parse_scene_file(text, path)?;
        let scene = Self {
            source: path.to_path_buf(),
            base_dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
            text: text.to_string(),
            sim: file.sim,
            models: file.models,
            mass: file.mass,
        };
        scene.validate()?;
        Ok(scene)
    }

    /// A one-model scene around a URDF given directly: default `[sim]`, the model at the origin.
    pub fn from_urdf(urdf: &Path) -> Self {
        Self {
            source: urdf.to_path_buf(),
            base_dir: PathBuf::new(),
            text: String::new(),
            sim: SimSettings::default(),
            models: vec![ModelEntry::at(urdf.to_path_buf(), [0.0; 3])],
            mass: MassSettings::default(),
        }
    }

    /// Applies command-line overrides, then validates again.
    pub fn apply(&mut self, o: &SimOverrides) -> anyhow::Result<()> {
        let s = &mut self.sim;
        if let Some(v) = o.dt {
            s.dt = v;
        }
        if let Some(v) = o.duration {
            s.duration = v;
        }
        if let Some(v) = o.gravity {
            s.gravity = v;
        }
        if let Some(v) = &o.integrator {
            s.integrator = v.clone();
        }
        if let Some(v) = o.log_every {
            s.log_every = v;
        }
        if let Some(v) = o.newton_tol {
            s.newton_tol = v;
        }
        if let Some(v) = o.newton_max_iters {
            s.newton_max_iters = v;
        }
        if let Some(v) = o.jacobian {
            s.jacobian = v;
        }
        if let Some(v) = o.potential {
            s.potential = v;
        }
        if let Some(v) = o.substep {
            s.substep = v;
        }
        if let Some(v) = o.max_substeps {
            s.max_substeps = v;
        }
        if let Some(v) = o.divergence_energy_ratio {
            s.divergence_energy_ratio = v;
        }
        if let Some(v) = o.accuracy {
            s.accuracy = Some(v);
        }
        self.mass = self.mass.refined(&o.mass);
        self.validate()
    }

    /// `--strict`: every model refuses the URDF oddities urdfdom loads ([`ModelEntry::strict`]).
    pub fn set_strict(&mut self) {
        for model in &mut self.models {
            model.strict = true;
        }
    }

    /// `--allow-mesh-path DIR...`: adds `dirs` to every model's `allow_mesh_paths`, made
    /// absolute against the working directory (not the scene's folder).
    pub fn allow_mesh_paths(&mut self, dirs: &[PathBuf]) -> anyhow::Result<()> {
        let dirs: Vec<PathBuf> = dirs
            .iter()
            .map(|d| {
                std::path::absolute(d).with_context(|| format!("--allow-mesh-path {}", d.display()))
            })
            .collect::<anyhow::Result<_>>()?;
        for model in &mut self.models {
            model.allow_mesh_paths.extend(dirs.iter().cloned());
        }
        Ok(())
    }

    /// Where mesh files of `entry` may be read from besides the URDF's own folders and the
    /// package paths ([`crate::model::confine`]): the scene's folder (none for a URDF given
    /// directly) and `allow_mesh_paths`, relative to it.
    pub fn mesh_access(&self, entry: &ModelEntry) -> crate::model::confine::MeshAccess {
        let from_urdf = self
            .source
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("urdf"));
        crate::model::confine::MeshAccess {
            allowed: entry
                .allow_mesh_paths
                .iter()
                .map(|p| self.base_dir.join(p))
                .collect(),
            scene_folder: (!from_urdf).then(|| self.base_dir.clone()),
        }
    }

    /// Checks every value; errors name the file and the key.
    pub fn validate(&self) -> anyhow::Result<()> {
        let file = self.source.display();
        let s = &self.sim;
        let positive = |key: &str, v: f64| -> anyhow::Result<()> {
            if !(v.is_finite() && v > 0.0) {
                bail!(
                    "{file}: sim.{key} must be a positive finite number (got {})",
                    readable(v)
                );
            }
            Ok(())
        };
        positive("dt", s.dt)?;
        positive("newton_tol", s.newton_tol)?;
        if !(s.duration.is_finite() && s.duration >= 0.0) {
            bail!(
                "{file}: sim.duration must be a finite number >= 0 (got {})",
                readable(s.duration)
            );
        }
        if s.log_every == 0 {
            bail!("{file}: sim.log_every must be at least 1");
        }
        bounds::check_frame_times(
            &file.to_string(),
            s.dt,
            s.duration,
            s.log_every,
            self.steps(),
        )?;
        if s.newton_max_iters == 0 {
            bail!("{file}: sim.newton_max_iters must be at least 1");
        }
        if !(2..=1 << 20).contains(&s.max_substeps) {
            bail!(
                "{file}: sim.max_substeps must be between 2 and 1048576 (got {})",
                s.max_substeps
            );
        }
        if !(s.divergence_energy_ratio.is_finite() && s.divergence_energy_ratio > 1.0) {
            bail!(
                "{file}: sim.divergence_energy_ratio must be a finite number > 1 (got {})",
                readable(s.divergence_energy_ratio)
            );
        }
        if let Some(tol) = s.accuracy
            && !(tol.is_finite() && (1e-12..=1.0).contains(&tol))
        {
            bail!(
                "{file}: sim.accuracy must be a tolerance in radians between 1e-12 and 1 (got {})",
                readable(tol)
            );
        }
        finite3(&format!("{file}: sim.gravity"), &s.gravity)?;
        if IntegratorKind::from_name(&s.integrator).is_none() {
            let names: Vec<_> = IntegratorKind::ALL.iter().map(|k| k.name()).collect();
            bail!(
                "{file}: sim.integrator: unknown integrator {:?} (expected one of: {})",
                s.integrator,
                names.join(", ")
            );
        }
        if self.models.is_empty() {
            bail!("{file}: no [[model]] entry: the scene simulates nothing");
        }
        if let Some(i) = self
            .models
            .iter()
            .position(|m| m.bodies == BodiesMode::Articulated)
        {
            let kind = self.integrator();
            if !crate::sim::mechanism::stepper::SUPPORTED.contains(&kind) {
                let names: Vec<_> = crate::sim::mechanism::stepper::SUPPORTED
                    .iter()
                    .map(|k| format!("`{}`", k.name()))
                    .collect();
                bail!(
                    "{file}: sim.integrator = {:?} cannot step model[{i}], which has bodies = \
                     \"articulated\" (joints kept as constraints have a constrained form in \
                     {} only; or give the model bodies = \"links\" or \"rigid\")",
                    s.integrator,
                    names.join(", ")
                );
            }
        }
        // Densities, kg/m^3: finite and > 0 wherever given (unknown link names in `links` are
        // checked against the URDF by `policy::apply`).
        let density = |key: &str, v: Option<f64>| -> anyhow::Result<()> {
            match v {
                Some(v) if !(v.is_finite() && v > 0.0) => {
                    bail!(
                        "{key} must be a positive finite number of kg/m^3 (got {})",
                        readable(v)
                    )
                }
                _ => Ok(()),
            }
        };
        density(&format!("{file}: mass.density"), self.mass.density)?;
        let mut names = HashSet::new();
        for (i, m) in self.models.iter().enumerate() {
            let key = format!("{file}: model[{i}]");
            density(&format!("{key}.density"), m.density)?;
            for (link, settings) in &m.links {
                density(&format!("{key}.links.{link}.density"), settings.density)?;
            }
            finite3(&format!("{key}.position"), &m.position)?;
            finite3(&format!("{key}.rpy"), &m.rpy)?;
            finite3(&format!("{key}.linvel"), &m.linvel)?;
            finite3(&format!("{key}.angvel"), &m.angvel)?;
            if let Some(copies) = m.copies
                && !(1..=placement::MAX_COPIES).contains(&copies)
            {
                bail!(
                    "{key}.copies must be between 1 and {} (got {copies})",
                    placement::MAX_COPIES
                );
            }
            if let Some(name) = &m.name {
                if name.is_empty() || name.contains('/') || name.trim() != name {
                    bail!(
                        "{key}.name must be non-empty, without '/' or surrounding spaces (got {name:?})"
                    );
                }
                if !names.insert(name.clone()) {
                    bail!("{key}.name: {name:?} is used by another model");
                }
            }
        }
        // --- whole-model bodies (issue 5): `bodies` and `joints` ---
        self.validate_joints()?;
        Ok(())
    }

    /// The `joints` of every `[[model]]`: each position a finite number. (Joint names are checked
    /// against the URDF when the model is loaded: an unknown name is an error naming the scene
    /// file, the model and the joint. `bodies` needs no check beyond its two spellings.)
    fn validate_joints(&self) -> anyhow::Result<()> {
        let file = self.source.display();
        for (i, m) in self.models.iter().enumerate() {
            for (joint, value) in &m.joints {
                if !value.is_finite() {
                    bail!(
                        "{file}: model[{i}].joints.{joint} must be a finite number \
                         (rad or m; got {value})"
                    );
                }
            }
            for (joint, value) in &m.joint_velocities {
                if !value.is_finite() {
                    bail!(
                        "{file}: model[{i}].joint_velocities.{joint} must be a finite number \
                         (rad/s or m/s; got {value})"
                    );
                }
            }
            if m.bodies != BodiesMode::Articulated {
                let mode = match m.bodies {
                    BodiesMode::Links => "links",
                    _ => "rigid",
                };
                let key = if m.base.is_some() {
                    Some("base")
                } else if !m.joint_velocities.is_empty() {
                    Some("joint_velocities")
                } else if !m.locked_joints.is_empty() {
                    Some("locked_joints")
                } else {
                    None
                };
                if let Some(key) = key {
                    bail!(
                        "{file}: model[{i}].{key} applies to bodies = \"articulated\" only \
                         (this model has bodies = \"{mode}\")"
                    );
                }
            }
            if m.base == Some(BaseMode::Fixed) && (m.linvel != [0.0; 3] || m.angvel != [0.0; 3]) {
                bail!(
                    "{file}: model[{i}]: base = \"fixed\" welds the root link to the world, so \
                     linvel and angvel (the root link's twist) must be zero (got {:?}, {:?})",
                    m.linvel,
                    m.angvel
                );
            }
        }
        Ok(())
    }

    /// Number of integrator steps: `round(duration / dt)`.
    pub fn steps(&self) -> u64 {
        (self.sim.duration / self.sim.dt).round() as u64
    }

    pub fn integrator(&self) -> IntegratorKind {
        IntegratorKind::from_name(&self.sim.integrator).unwrap_or(IntegratorKind::Variational)
    }

    pub fn variational_settings(&self) -> VariationalSettings {
        VariationalSettings {
            newton_tol: self.sim.newton_tol,
            newton_max_iters: self.sim.newton_max_iters,
            jacobian: self.sim.jacobian,
            potential: self.sim.potential,
            substep: self.sim.substep,
            max_substeps: self.sim.max_substeps,
        }
    }

    /// What [`crate::run::run`] needs from `[sim]`.
    pub fn run_settings(&self) -> crate::run::RunSettings {
        crate::run::RunSettings {
            steps: self.steps(),
            log_every: self.sim.log_every,
            gravity: self.gravity(),
            divergence_energy_ratio: self.sim.divergence_energy_ratio,
            stop_on_newton_failure: self.sim.substep.then_some(self.sim.max_substeps),
            stop_on_interrupt: false,
        }
    }

    pub fn gravity(&self) -> Vector3<f64> {
        Vector3::from(self.sim.gravity)
    }

    /// The scene's settings and provenance, as written into recordings' metadata.
    pub fn metadata(&self) -> BTreeMap<String, String> {
        let s = &self.sim;
        let mut m = BTreeMap::new();
        m.insert("tool".into(), "tumble".into());
        m.insert("tool_version".into(), crate::VERSION.into());
        m.insert("scene_file".into(), self.source.display().to_string());
        m.insert("scene".into(), self.text.clone());
        m.insert("integrator".into(), s.integrator.clone());
        m.insert("dt".into(), format!("{:?}", s.dt));
        m.insert("duration".into(), format!("{:?}", s.duration));
        m.insert("steps".into(), self.steps().to_string());
        m.insert("gravity".into(), format!("{:?}", s.gravity));
        m.insert("log_every".into(), s.log_every.to_string());
        m.insert("newton_tol".into(), format!("{:?}", s.newton_tol));
        m.insert("newton_max_iters".into(), s.newton_max_iters.to_string());
        m.insert("jacobian".into(), s.jacobian.name().into());
        m.insert("potential".into(), s.potential.name().into());
        m.insert("substep".into(), s.substep.to_string());
        m.insert("max_substeps".into(), s.max_substeps.to_string());
        m.insert(
            "divergence_energy_ratio".into(),
            format!("{:?}", s.divergence_energy_ratio),
        );
        m.insert(
            "settings_json".into(),
            serde_json::to_string(&SceneFile {
                sim: s.clone(),
                models: self.models.clone(),
                mass: self.mass.clone(),
            })
            .unwrap_or_default(),
        );
        m
    }

    /// The mass settings of `entry`'s links: `[mass]` (after flags) refined by the model's keys.
    pub fn mass_settings(&self, entry: &ModelEntry) -> ModelMassSettings {
        ModelMassSettings {
            model: self.mass.refined(&MassSettings {
                inertia: entry.inertia,
                density: entry.density,
                geometry: entry.geometry,
            }),
            links: entry.links.clone(),
        }
    }

    /// Loads the models and builds what is simulated and recorded.
    ///
    /// Each distinct URDF with its loading settings (package paths, joints, strictness, mass
    /// settings, `bodies`, `allow_non_physical_inertia`) is loaded, given its mass properties
    /// and checked once, however many tables and copies use it; each copy then only places the
    /// loaded links ([`placement`]).
    pub fn build(&self) -> anyhow::Result<World> {
        // Every mesh read for the models' mass properties counts against one per-scene cap
        // (a file used by many links counts per use).
        let _triangles = crate::model::geometry::mesh_io::TriangleBudget::open();
        let mut world = World::default();
        let total: u64 = self.models.iter().map(ModelEntry::copy_count).sum();
        let capacity = usize::try_from(total).unwrap_or(usize::MAX).min(1 << 24);
        world.bodies.reserve(capacity);
        world.layout.bodies.reserve(capacity);
        let mut frame_ids: HashSet<String> = HashSet::with_capacity(capacity);
        let mut body_names: HashSet<String> = HashSet::new();
        // Each URDF's text, once per distinct `urdf` value, for the recordings' metadata.
        let mut urdf_texts: BTreeMap<String, String> = BTreeMap::new();
        // A URDF used by many models warns once.
        let mut seen_warnings: HashSet<String> = HashSet::new();
        let mut loaded: HashMap<String, Arc<Model>> = HashMap::new();
        for (i, entry) in self.models.iter().enumerate() {
            let urdf_path = self.base_dir.join(&entry.urdf);
            let package_paths: Vec<PathBuf> = entry
                .package_paths
                .iter()
                .map(|p| self.base_dir.join(p))
                .collect();
            let context = || format!("{}: model[{i}]", self.source.display());
            let mass_settings = self.mass_settings(entry);
            let mesh_access = self.mesh_access(entry);
            let load_key = format!(
                "{:?}",
                (
                    &urdf_path,
                    &package_paths,
                    &mesh_access,
                    &entry.joints,
                    entry.strict,
                    &mass_settings,
                    entry.bodies,
                    entry.allow_non_physical_inertia
                )
            );
            let model = match loaded.get(&load_key) {
                Some(model) => model.clone(),
                None => {
                    let joints: HashMap<String, f64> = entry.joints.clone().into_iter().collect();
                    let mut model = urdf::load(
                        &urdf_path,
                        &urdf::LoadOptions {
                            package_paths: package_paths.clone(),
                            joint_positions: joints,
                            strictness: urdf::Strictness::from_strict(entry.strict),
                            mesh_access: mesh_access.clone(),
                        },
                    )
                    .with_context(context)?;
                    // A mesh outside the folders meshes are read from stops everything.
                    model.check_meshes().with_context(context)?;
                    for warning in model.warnings.drain(..) {
                        if seen_warnings.insert(warning.to_string()) {
                            world.warnings.push(warning);
                        }
                    }
                    policy::apply(&mut model, &mass_settings).with_context(context)?;
                    match entry.bodies {
                        BodiesMode::Links => {
                            model.check_simulable(entry.allow_non_physical_inertia)
                        }
                        BodiesMode::Rigid | BodiesMode::Articulated => check_rigid_parts(&model),
                    }
                    .with_context(context)?;
                    let model = Arc::new(model);
                    loaded.insert(load_key, model.clone());
                    model
                }
            };
            let key = format!("{URDF_METADATA_PREFIX}{}", entry.urdf.display());
            if let std::collections::btree_map::Entry::Vacant(slot) = urdf_texts.entry(key.clone())
            {
                slot.insert(
                    crate::input::read_text(&urdf_path, crate::input::URDF_MAX_BYTES)
                        .with_context(context)?,
                );
            }
            let copies = entry.copy_count();
            let first_body = world.bodies.len();
            let base = entry.name.clone().unwrap_or_else(|| model.name.clone());
            // What the table's articulated copies share (made by the first one).
            let mut template = None;
            for copy in 0..copies {
                // The frame-id prefix: the copy's name, or the table's `name`, or none.
                let prefix = match entry.copies {
                    Some(_) => Some(placement::copy_name(&base, copy, copies)),
                    None => entry.name.clone(),
                };
                let label = prefix.clone().unwrap_or_else(|| model.name.clone());
                let place = entry.placement(copy);
                let before = world.layout.frames.len();
                let population_before = world.population();
                match entry.bodies {
                    BodiesMode::Links => {
                        add_model(&mut world, &model, prefix.as_deref(), &label, &place)
                    }
                    BodiesMode::Rigid => add_rigid_model(
                        &mut world,
                        &model,
                        prefix.as_deref(),
                        &label,
                        &place,
                        entry.allow_non_physical_inertia,
                        &mut body_names,
                    )
                    .with_context(context)?,
                    BodiesMode::Articulated => articulated::add_articulated_model(
                        &mut world,
                        &model,
                        entry,
                        &articulated::CopyPlace {
                            prefix: prefix.as_deref(),
                            label: &label,
                            place: &place,
                        },
                        &mut body_names,
                        &mut template,
                    )
                    .with_context(context)?,
                }
                if copy == 0 && copies > 1 {
                    // The other copies cost what the first did: refuse a world too big for the
                    // machine before building it (issue 28: 100 000 copies of a 7-link chain
                    // took 6.8 GiB before the estimate was even made).
                    let each = world.population().minus(&population_before);
                    world
                        .population()
                        .plus(&each, (copies - 1) as f64)
                        .check_memory(&format!(
                            "{}: model[{i}] ({} copies of {})",
                            self.source.display(),
                            copies,
                            urdf_path.display()
                        ))?;
                }
                if world.layout.frames.len() == before {
                    bail!(
                        "{}: model[{i}] ({}) has no link with positive mass: nothing to simulate",
                        self.source.display(),
                        urdf_path.display()
                    );
                }
                for f in &world.layout.frames[before..] {
                    if !frame_ids.insert(f.frame_id.clone()) {
                        bail!(
                            "{}: model[{i}]: frame id {:?} is used by an earlier model; give the model a `name`",
                            self.source.display(),
                            f.frame_id
                        );
                    }
                }
            }
            // Initial values the integrator cannot step (issue 28 item 8), named by table.
            bounds::check_initial_states(self, &world, i, entry, first_body..world.bodies.len())?;
            // One description per table, whatever its copies: with copies, the first copy's
            // (its links named by copy 0's frame ids; docs/scale.md "ROS 2").
            let described = match entry.copies {
                Some(copies) => Some(placement::copy_name(&base, 0, copies)),
                None => entry.name.clone(),
            };
            world.layout.robot_descriptions.push(robot_description(
                &urdf_texts[&key],
                &urdf_path,
                &package_paths,
                described.as_deref(),
                &model,
            ));
        }
        bounds::check_total_energy(self, &world)?;
        world.layout.name = self
            .source
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "tumble".into());
        world.layout.metadata = self.metadata();
        world.layout.metadata.extend(urdf_texts);
        // Grown one copy at a time, the per-frame vectors hold up to twice what they need
        // (10 000 bodies: 16 384 slots of frames and attachments, about 1 MB spare).
        world.bodies.shrink_to_fit();
        std::sync::Arc::make_mut(&mut world.attachments).shrink_to_fit();
        world.layout.frames.shrink_to_fit();
        world.layout.bodies.shrink_to_fit();
        Ok(world)
    }
}

/// The model's URDF text `xml` (read from `urdf_path`) rewritten for `/robot_description`
/// ([`crate::model::description`]): links named by their frame ids, meshes as file:// URIs.
fn robot_description(
    xml: &str,
    urdf_path: &Path,
    package_paths: &[PathBuf],
    prefix: Option<&str>,
    model: &Model,
) -> RobotDescription {
    let urdf = crate::model::description::for_frame_ids(xml, urdf_path, package_paths, prefix);
    RobotDescription {
        model: prefix.map_or_else(|| model.name.clone(), str::to_string),
        urdf_path: urdf_path.to_path_buf(),
        urdf,
    }
}

fn finite3(key: &str, v: &[f64; 3]) -> anyhow::Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        bail!("{key} must hold three finite numbers (got {v:?})")
    }
}

/// What a scene builds: the bodies' initial states and how link frames follow them.
#[derive(Debug, Clone, Default)]
pub struct World {
    pub layout: RecordingLayout,
    pub bodies: Vec<BodyInit>,
    /// Per recorded frame (same order as `layout.frames`): the body it moves with and the
    /// constant pose of the link in that body's principal frame. Shared with the run's frame
    /// builder ([`crate::run::FrameBuilder`]) instead of copied: 64 bytes per frame.
    pub attachments: std::sync::Arc<Vec<Attachment>>,
    /// Articulated models (`bodies = "articulated"`), each over a contiguous range of
    /// `bodies`, in scene order (the same order as `layout.mechanisms`).
    pub mechanisms: Vec<std::sync::Arc<Mechanism>>,
    /// Frames of compound joints' massless interior links: placed from the mechanism's report,
    /// not from a body (their [`Attachment`] is a placeholder).
    pub interior_frames: Vec<InteriorFrame>,
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

    /// The integrator that steps this world: `kind` itself when no model is articulated,
    /// else the [`Articulated`] stepper (free bodies and mechanisms), which supports the
    /// variational family only (an error naming the model otherwise).
    pub fn integrator(
        &self,
        kind: IntegratorKind,
        dt_secs: f64,
        settings: &VariationalSettings,
    ) -> anyhow::Result<Box<dyn crate::sim::Integrator>> {
        Self::integrator_of(kind, dt_secs, settings, &self.mechanisms, self.bodies.len())
    }

    /// [`Self::integrator`] for a batch of `body_count` bodies holding `mechanisms` (a
    /// partition of the world, its mechanisms re-based to it: [`crate::sim::partition`]).
    pub fn integrator_of(
        kind: IntegratorKind,
        dt_secs: f64,
        settings: &VariationalSettings,
        mechanisms: &[Arc<Mechanism>],
        body_count: usize,
    ) -> anyhow::Result<Box<dyn crate::sim::Integrator>> {
        if mechanisms.is_empty() {
            return Ok(kind.build(dt_secs, settings));
        }
        Ok(Box::new(Articulated::new(
            kind, dt_secs, settings, mechanisms, body_count,
        )?))
    }
}

/// The parts of a `bodies = "rigid"` model: each link with an `<inertial>` and a non-zero mass
/// must have finite values, a positive mass and a positive *semi*-definite inertia (a point mass
/// or a rod is a fine part of a composite: real robots have sensor links with mass and zero
/// inertia); the composite itself is then validated in full by [`add_rigid_model`].
fn check_rigid_parts(model: &Model) -> Result<(), crate::model::urdf::ModelError> {
    for link in &model.links {
        let Some(mp) = &link.inertial else { continue };
        if mp.mass == 0.0 {
            continue;
        }
        let finite = mp.mass.is_finite()
            && mp.com.iter().all(|x| x.is_finite())
            && mp.inertia.iter().all(|x| x.is_finite());
        let rule = if !finite {
            Some("mass, centre of mass or inertia not finite".to_string())
        } else if mp.mass < 0.0 {
            Some(format!("mass is negative: {} kg", mp.mass))
        } else {
            let moments = mp.principal_moments();
            let scale = mp.inertia.amax();
            (moments.min() < -1e-9 * scale).then(|| {
                format!(
                    "inertia is not positive semi-definite: principal moments {}, {}, {} kg m^2",
                    moments.x, moments.y, moments.z
                )
            })
        };
        if let Some(rule) = rule {
            return Err(crate::model::urdf::ModelError::NotSimulable {
                path: model.path.clone(),
                link: link.name.clone(),
                rule,
            });
        }
    }
    Ok(())
}

/// The whole model, locked at the entry's `joints`, as one rigid body (`bodies = "rigid"`).
///
/// The composite, in the model (root link) frame, of the links with positive mass, link `i` with
/// mass `m_i`, centre of mass `com_i` and inertia `I_i` (about `com_i`, link axes), placed by
/// forward kinematics at `model_from_link_i = (R_i, p_i)`:
///
/// ```text
/// m   = Σ m_i
/// c_i = p_i + R_i com_i
/// c   = Σ m_i c_i / m
/// I   = Σ [ R_i I_i R_iᵀ + m_i (|d_i|² E − d_i d_iᵀ) ],   d_i = c_i − c   (about c, model axes)
/// ```
///
/// ([`MassProperties::transformed`] then [`MassProperties::combine`], which sums the offsets
/// from a reference point near the parts.) Its principal frame `model_from_principal = (c, Q)`,
/// `I = Q diag(moments) Qᵀ`, is the body frame:
///
/// ```text
/// world_from_body = world_from_model · model_from_principal
/// body_from_link  = model_from_principal⁻¹ · model_from_link      (every link, massless too)
/// ```
///
/// Recording: every link frame is recorded (frame ids `link`, or `name/link` with a `name`, as
/// in links mode, so recordings of the two modes line up), all riding on the one body. The
/// body is named after the model: the entry's `name`, else the URDF `<robot name>`; its
/// [`BodyLayout`] refers to the root link frame (= the model frame), so `link_from_principal`
/// is `model_from_principal`. The body gets the entry's `linvel` (of the composite centre of
/// mass) and `angvel`.
///
/// Errors (the caller adds the scene file and model index): no link with positive mass; a
/// composite that is not a valid rigid body (e.g. a total mass or inertia overflowing to
/// infinity), naming the model and the broken rules; a link frame whose pose is not finite; a
/// body name already used by an earlier model.
fn add_rigid_model(
    world: &mut World,
    model: &Model,
    prefix: Option<&str>,
    label: &str,
    place: &placement::Placement,
    allow_non_physical_inertia: bool,
    body_names: &mut HashSet<String>,
) -> anyhow::Result<()> {
    let label = label.to_string();
    let composite = rigid_composite(model, &label, allow_non_physical_inertia)?;
    if let Some(link) = model
        .links
        .iter()
        .find(|l| !isometry_is_finite(&l.model_from_link))
    {
        bail!(
            "bodies = \"rigid\": model `{label}` ({}): link `{}` has a non-finite pose",
            model.path.display(),
            link.name
        );
    }
    if !body_names.insert(label.clone()) {
        bail!(
            "bodies = \"rigid\": body name {label:?} (the model's) is used by an earlier model; \
             give the model a different `name`"
        );
    }
    let (moments, model_from_principal_rot) = composite.principal();
    let model_from_principal =
        Isometry3::from_parts(Translation3::from(composite.com), model_from_principal_rot);
    let principal_from_model = model_from_principal.inverse();
    let body = world.bodies.len();
    world.bodies.push(BodyInit {
        mass: composite.mass,
        principal_moments: moments,
        world_from_body: place.world_from_model * model_from_principal,
        linvel_world: place.linvel_world,
        angvel_world: place.angvel_world,
    });
    let first_frame = world.layout.frames.len();
    for link in &model.links {
        std::sync::Arc::make_mut(&mut world.attachments).push(Attachment {
            body,
            body_from_link: principal_from_model * link.model_from_link,
        });
        world.layout.frames.push(FrameLayout {
            frame_id: match prefix {
                Some(prefix) => format!("{prefix}/{}", link.name),
                None => link.name.clone(),
            },
            model: label.clone(),
            link: link.name.clone(),
            visuals: link.visuals.clone(),
        });
    }
    world.layout.bodies.push(BodyLayout {
        name: label,
        frame: first_frame + model.root,
        mass: composite.mass,
        link_from_principal: model_from_principal,
        principal_moments: moments,
    });
    Ok(())
}

/// The composite mass properties of `model`'s links with positive mass, in the model frame (see
/// [`add_rigid_model`] for the formulas), checked to be a valid rigid body
/// ([`MassProperties::validate_with`], the triangle rule skipped with `allow_non_physical`).
/// `label` names the model in errors.
fn rigid_composite(
    model: &Model,
    label: &str,
    allow_non_physical: bool,
) -> anyhow::Result<MassProperties> {
    let parts: Vec<MassProperties> = model
        .links
        .iter()
        .filter_map(|l| {
            let mp = l.inertial.as_ref().filter(|mp| mp.mass > 0.0)?;
            Some(mp.transformed(&l.model_from_link))
        })
        .collect();
    if parts.is_empty() {
        bail!(
            "bodies = \"rigid\": model `{label}` ({}) has no link with positive mass: \
             nothing to simulate",
            model.path.display()
        );
    }
    let invalid = |rules: &str| {
        anyhow::anyhow!(
            "bodies = \"rigid\": the composite of model `{label}` ({}) is not a valid rigid \
             body: {rules}",
            model.path.display()
        )
    };
    let Some(composite) = MassProperties::combine(&parts) else {
        let total: f64 = parts.iter().map(|p| p.mass).sum();
        return Err(invalid(&format!(
            "total mass is not a positive finite number ({total} kg)"
        )));
    };
    let rules = composite.validate_with(allow_non_physical);
    if !rules.is_empty() {
        return Err(invalid(&rules.join("; ")));
    }
    Ok(composite)
}

fn isometry_is_finite(p: &Isometry3<f64>) -> bool {
    p.translation.vector.iter().all(|x| x.is_finite())
        && p.rotation.coords.iter().all(|x| x.is_finite())
}

/// One free body per link with positive mass, the model placed at `place`; frame ids
/// `<prefix>/<link>` (or `<link>`), the model labelled `label`.
fn add_model(
    world: &mut World,
    model: &Model,
    prefix: Option<&str>,
    label: &str,
    place: &placement::Placement,
) {
    let world_from_model = place.world_from_model;
    let model_label = label.to_string();
    for link in &model.links {
        let Some(mp) = link.inertial.as_ref().filter(|mp| mp.mass > 0.0) else {
            continue;
        };
        let (moments, link_from_principal_rot) = mp.principal();
        let link_from_principal =
            Isometry3::from_parts(Translation3::from(mp.com), link_from_principal_rot);
        let world_from_body = world_from_model * link.model_from_link * link_from_principal;
        let frame_id = match prefix {
            Some(prefix) => format!("{prefix}/{}", link.name),
            None => link.name.clone(),
        };
        let body = world.bodies.len();
        let frame = world.layout.frames.len();
        world.bodies.push(BodyInit {
            mass: mp.mass,
            principal_moments: moments,
            world_from_body,
            linvel_world: place.linvel_world,
            angvel_world: place.angvel_world,
        });
        std::sync::Arc::make_mut(&mut world.attachments).push(Attachment {
            body,
            body_from_link: link_from_principal.inverse(),
        });
        world.layout.frames.push(FrameLayout {
            frame_id: frame_id.clone(),
            model: model_label.clone(),
            link: link.name.clone(),
            visuals: link.visuals.clone(),
        });
        world.layout.bodies.push(BodyLayout {
            name: frame_id,
            frame,
            mass: mp.mass,
            link_from_principal,
            principal_moments: moments,
        });
    }
}
