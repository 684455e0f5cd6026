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
//! joint_damping = true          # articulated: the URDF's <dynamics damping> on every moving joint (default true)
//! joint_limits = true           # articulated: the URDF's <limit lower upper> stop revolute and prismatic joints (default true)
//! joint_friction = true         # articulated: the URDF's <dynamics friction> on every moving joint (default true)
//! collisions = "none"           # "none" | "urdf" (<collision>) | "visual" (<visual>): what collides (crate::scene::contact)
//! self_collision = false        # the links of one copy collide with each other (default false)
//! friction = 0.8                # Coulomb coefficient of the model's colliders (default 0.8)
//! restitution = 0.0             # restitution of the model's colliders, in [0, 1] (default 0)
//!
//! [[model.actuator]]            # articulated: one per driven joint (crate::scene::actuator)
//! joint = "elbow"
//! kind = "position"             # "motor" (effort) | "position" (target, kp, kd) | "velocity" (target, kd)
//! target = 0.5                  # a signal: number, sine, CSV table, MCAP log (crate::scene::signal)
//! kp = 80.0
//! effort_limit = 3.0            # default: the URDF's <limit effort>; 0: none
//!
//! [[model.load]]                # any body mode: a force and torque on a link (crate::scene::load)
//! link = "tool0"
//! force = [0.0, 0.0, 5.0]       # N at the link frame's origin; each component a signal
//! torque = [0.0, 0.0, 0.1]      # N m
//! frame = "world"               # | "link"
//! # position, rpy, linvel, angvel: a value or a distribution ({ uniform = [lo, hi] }, log_uniform, normal, choice);
//! # orientation = "uniform" | [x, y, z, w] instead of rpy ([`crate::scene::placement`])
//!
//! [ground]                      # a half-space (absent: no ground; crate::scene::contact)
//! height = 0.0                  # m along -gravity (or normal = [x, y, z], point = [x, y, z])
//! friction = 0.8                # (default 0.8)
//! restitution = 0.0             # (default 0)
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
use crate::model::policy::{MassSettings, ModelMassSettings};

use crate::sim::integrators::{IntegratorKind, Jacobian, Potential, VariationalSettings};

mod actuator;
mod articulated;
mod build;
mod contact;
pub use contact::refuse_contact;
mod drives;
mod entry;
mod joint_states;
mod links;
mod load;
pub mod placement;
mod rigid;
pub mod signal;
pub mod signal_log;

pub(crate) use build::FirstTable;
pub use build::{LoadedModels, LoadedTable};
pub use contact::{DEFAULT_FRICTION, DEFAULT_RESTITUTION, GroundEntry};
pub use entry::{BaseMode, BodiesMode, Collisions, ModelEntry, SimSettings};
pub mod bounds;
pub mod triangles;
use anyhow::{Context, bail};
use nalgebra::Vector3;
use serde::Deserialize;
use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

/// Prefix of the recording metadata keys holding URDF texts: `urdf/<the model's urdf value as
/// the scene wrote it>` = the file's text, one entry per distinct file however many models use it.
pub const URDF_METADATA_PREFIX: &str = "urdf/";

#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    sim: SimSettings,
    #[serde(default, rename = "model")]
    models: Vec<ModelEntry>,
    #[serde(default)]
    mass: MassSettings,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    ground: Option<GroundEntry>,
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
    /// The `[ground]` table (`None`: no ground; [`Scene::ground`] resolves it).
    pub ground: Option<GroundEntry>,
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
            ground: file.ground,
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
            ground: None,
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
        // --- contact (issue 31): `[ground]` (the models' keys below) ---
        self.ground()?;
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
            contact::check_model_keys(&key, m)?;
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
        // --- driven robots (issue 30): `[[model.actuator]]`, `[[model.load]]` ---
        for (i, m) in self.models.iter().enumerate() {
            let key = format!("{file}: model[{i}]");
            actuator::read_all(&key, m)?;
            load::read_all(&key, m)?;
        }
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
                } else if m.joint_damping.is_some() {
                    Some("joint_damping")
                } else if m.joint_limits.is_some() {
                    Some("joint_limits")
                } else if m.joint_friction.is_some() {
                    Some("joint_friction")
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

    /// What a run ([`crate::sim::RunSettings`]) needs from `[sim]`.
    pub fn run_settings(&self) -> crate::sim::RunSettings {
        crate::sim::RunSettings {
            steps: self.steps(),
            log_every: self.sim.log_every,
            gravity: self.gravity(),
            divergence_energy_ratio: self.sim.divergence_energy_ratio,
            stop_on_newton_failure: self.sim.substep.then_some(self.sim.max_substeps),
            stop_on_interrupt: false,
            quiet: false,
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
                ground: self.ground.clone(),
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
}

fn finite3(key: &str, v: &[f64; 3]) -> anyhow::Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        bail!("{key} must hold three finite numbers (got {v:?})")
    }
}
