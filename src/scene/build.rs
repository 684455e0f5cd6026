//! A scene's [`World`], built in two steps that datasets and scenes share:
//! [`Scene::load_models`] loads each table's URDF, gives it mass properties and checks it (the
//! slow part, done once however many copies or runs use it), and [`Scene::assemble`] places
//! every copy of every table where a [`Placement`] says (the scene's own draws, or a dataset
//! run's).

use super::placement::{self, Placement};
use super::{BodiesMode, ModelEntry, Scene, URDF_METADATA_PREFIX, articulated, bounds};
use super::{actuator, contact, links, load, rigid};
use crate::model::policy;
use crate::model::{Model, urdf};
use crate::record::RobotDescription;
use crate::world::World;
use anyhow::{Context, bail};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// One `[[model]]` table's model, loaded and checked.
#[derive(Debug, Clone)]
pub struct LoadedTable {
    pub model: Arc<Model>,
    pub urdf_path: PathBuf,
    /// Key of the URDF's text in [`LoadedModels::urdf_texts`].
    pub text_key: String,
    /// The table's `/robot_description` (with copies: the first copy's).
    pub description: RobotDescription,
    /// Its actuators, signals read ([`actuator::resolve_all`]).
    pub(crate) actuators: Vec<actuator::ResolvedActuator>,
    /// Its loads, signals read ([`load::resolve_all`]); every copy gets them.
    pub(crate) loads: Vec<load::LinkLoad>,
    /// Its colliders' shapes and settings (`None`: `collisions = "none"`); every copy gets them.
    pub(crate) colliders: Option<contact::TableColliders>,
}

/// What replaces the first table's loaded model and actuators in [`Scene::assemble_with`]: the
/// same model placed at other joint positions ([`Model::at_joint_positions`], the scene entry's
/// `joints`), and the same actuators with other signals.
pub(crate) struct FirstTable<'a> {
    pub model: &'a Model,
    pub actuators: &'a [actuator::ResolvedActuator],
}

/// Every table's model ([`Scene::load_models`]).
#[derive(Debug, Clone)]
pub struct LoadedModels {
    /// In `[[model]]` order.
    pub tables: Vec<LoadedTable>,
    /// Each URDF's text, once per distinct `urdf` value, for the recordings' metadata.
    pub urdf_texts: BTreeMap<String, String>,
    /// The URDF oddities the models loaded with, each once.
    pub warnings: Vec<urdf::LoadWarning>,
}

impl Scene {
    /// Loads the models and builds what is simulated and recorded: [`Scene::load_models`],
    /// then [`Scene::assemble`] with each table's own placements ([`ModelEntry::placement`]).
    pub fn build(&self) -> anyhow::Result<World> {
        let loaded = self.load_models()?;
        let mut world =
            self.assemble(&loaded, &|table, copy| self.models[table].placement(copy))?;
        self.describe(&loaded, &mut world);
        Ok(world)
    }

    /// Loads every table's model. Each distinct URDF with its loading settings (package paths,
    /// joints, strictness, mass settings, `bodies`, `allow_non_physical_inertia`) is loaded,
    /// given its mass properties and checked once, however many tables use it.
    pub fn load_models(&self) -> anyhow::Result<LoadedModels> {
        // Every mesh read for the models' mass properties counts against one per-scene cap
        // (a file used by many links counts per use).
        let _triangles = crate::model::geometry::mesh_io::TriangleBudget::open();
        let mut urdf_texts: BTreeMap<String, String> = BTreeMap::new();
        // A URDF used by many models warns once.
        let mut seen_warnings: HashSet<String> = HashSet::new();
        let mut warnings = Vec::new();
        let mut loaded: HashMap<String, Arc<Model>> = HashMap::new();
        let mut tables = Vec::with_capacity(self.models.len());
        // Collision meshes, each read and made a hull once (their triangles count against the
        // budget above).
        let mut hulls = contact::HullCache::default();
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
                            warnings.push(warning);
                        }
                    }
                    policy::apply(&mut model, &mass_settings).with_context(context)?;
                    match entry.bodies {
                        BodiesMode::Links => {
                            model.check_simulable(entry.allow_non_physical_inertia)
                        }
                        BodiesMode::Rigid | BodiesMode::Articulated => {
                            rigid::check_rigid_parts(&model, entry.allow_non_physical_inertia)
                        }
                    }
                    .with_context(context)?;
                    let model = Arc::new(model);
                    loaded.insert(load_key, model.clone());
                    model
                }
            };
            // Issue 30's inputs: joints and links checked against the model, signals read once
            // per table however many copies or runs use it.
            let key = format!("{}: model[{i}]", self.source.display());
            let label = entry.name.clone().unwrap_or_else(|| model.name.clone());
            let actuators = actuator::resolve_all(&key, entry, &model, &label, &self.base_dir)?;
            let loads = load::resolve_all(&key, entry, &model, &label, &self.base_dir)?;
            let colliders = contact::table_colliders(&key, entry, &model, &label, &mut hulls)?;
            let text_key = format!("{URDF_METADATA_PREFIX}{}", entry.urdf.display());
            if let std::collections::btree_map::Entry::Vacant(slot) =
                urdf_texts.entry(text_key.clone())
            {
                slot.insert(
                    crate::input::read_text(&urdf_path, crate::input::URDF_MAX_BYTES)
                        .with_context(context)?,
                );
            }
            // One description per table, whatever its copies: with copies, the first copy's
            // (its links named by copy 0's frame ids; docs/scale.md "ROS 2").
            let base = entry.name.clone().unwrap_or_else(|| model.name.clone());
            let described = match entry.copies {
                Some(copies) => Some(placement::copy_name(&base, 0, copies)),
                None => entry.name.clone(),
            };
            let description = robot_description(
                &urdf_texts[&text_key],
                &urdf_path,
                &package_paths,
                described.as_deref(),
                &model,
            );
            tables.push(LoadedTable {
                model,
                urdf_path,
                text_key,
                description,
                actuators,
                loads,
                colliders,
            });
        }
        Ok(LoadedModels {
            tables,
            urdf_texts,
            warnings,
        })
    }

    /// Places copy `copy` of every table `table` at `place(table, copy)`: the bodies' initial
    /// states, the attachments of link frames to bodies, the mechanisms, and the layout of
    /// what is recorded (frames, visuals, bodies, joints). `loaded` is [`Scene::load_models`]
    /// of this scene (or of one with the same tables). The layout's name, metadata and robot
    /// descriptions are [`Scene::describe`]'s (a dataset run, which records through its
    /// choice's layout, does not pay for them).
    pub fn assemble(
        &self,
        loaded: &LoadedModels,
        place: &dyn Fn(usize, u64) -> Placement,
    ) -> anyhow::Result<World> {
        self.assemble_with(loaded, place, None)
    }

    /// [`Scene::assemble`] with the first table's model and actuators replaced (a dataset
    /// run's drawn joint positions and signals, [`FirstTable`]).
    pub(crate) fn assemble_with(
        &self,
        loaded: &LoadedModels,
        place: &dyn Fn(usize, u64) -> Placement,
        first: Option<&FirstTable<'_>>,
    ) -> anyhow::Result<World> {
        let mut world = World {
            warnings: loaded.warnings.clone(),
            ..Default::default()
        };
        let total: u64 = self.models.iter().map(ModelEntry::copy_count).sum();
        let capacity = usize::try_from(total).unwrap_or(usize::MAX).min(1 << 24);
        world.bodies.reserve(capacity);
        world.layout.bodies.reserve(capacity);
        let mut frame_ids: HashSet<String> = HashSet::with_capacity(capacity);
        let mut body_names: HashSet<String> = HashSet::new();
        world.contact.ground = self.ground()?;
        // One collision group per model copy, whatever its table.
        let mut group: u32 = 0;
        for (i, (entry, table)) in self.models.iter().zip(&loaded.tables).enumerate() {
            let (model, actuators): (&Model, _) = match first {
                Some(f) if i == 0 => (f.model, f.actuators),
                _ => (&table.model, &table.actuators[..]),
            };
            let urdf_path = &table.urdf_path;
            let context = || format!("{}: model[{i}]", self.source.display());
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
                let place = place(i, copy);
                let before = world.layout.frames.len();
                let mechanisms_before = world.mechanisms.len();
                let population_before = world.population();
                match entry.bodies {
                    BodiesMode::Links => {
                        links::add_links_model(&mut world, model, prefix.as_deref(), &label, &place)
                    }
                    BodiesMode::Rigid => rigid::add_rigid_model(
                        &mut world,
                        model,
                        prefix.as_deref(),
                        &label,
                        &place,
                        entry.allow_non_physical_inertia,
                        &mut body_names,
                    )
                    .with_context(context)?,
                    BodiesMode::Articulated => articulated::add_articulated_model(
                        &mut world,
                        model,
                        entry,
                        &articulated::CopyPlace {
                            prefix: prefix.as_deref(),
                            label: &label,
                            place: &place,
                        },
                        actuators,
                        &mut body_names,
                        &mut template,
                    )
                    .with_context(context)?,
                }
                let copy_frames = before..world.layout.frames.len();
                load::attach(&mut world, copy_frames.clone(), &table.loads, entry, &label)
                    .with_context(context)?;
                if let Some(colliders) = &table.colliders {
                    let (added, left_out) =
                        contact::attach(&mut world, copy_frames.clone(), colliders, group);
                    if copy == 0 {
                        let key = format!("{}: model[{i}]", self.source.display());
                        contact::check_first_copy(
                            &key, entry, model, &label, colliders, added, &left_out, &mut world,
                        )?;
                    }
                    let copy_mechanisms = mechanisms_before..world.mechanisms.len();
                    contact::exclude_joint_pairs(
                        &mut world,
                        model,
                        entry.bodies,
                        copy_frames,
                        copy_mechanisms,
                    );
                }
                group = group.checked_add(1).with_context(|| {
                    format!(
                        "{}: more than {} model copies: too many collision groups",
                        self.source.display(),
                        u32::MAX
                    )
                })?;
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
                        "{}: model[{i}] ({}) has no link with positive mass: nothing to \
                         simulate ({})",
                        self.source.display(),
                        urdf_path.display(),
                        urdf::MASSLESS_REMEDY
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
        }
        bounds::check_total_energy(self, &world)?;
        contact::finish(&mut world.contact);
        if let Some(note) = composition_damping_note(self.integrator(), &world) {
            world.notes.push(note);
        }
        // Grown one copy at a time, the per-frame vectors hold up to twice what they need
        // (10 000 bodies: 16 384 slots of frames and attachments, about 1 MB spare).
        world.bodies.shrink_to_fit();
        std::sync::Arc::make_mut(&mut world.attachments).shrink_to_fit();
        world.layout.frames.shrink_to_fit();
        world.layout.bodies.shrink_to_fit();
        // What drives the joints, for the recorders (`RecordingLayout::drives`; a run checks it).
        world.describe_drives();
        Ok(world)
    }

    /// The recording layout's name (the scene file's stem), metadata (the scene's settings
    /// and each URDF's text) and one robot description per table.
    pub fn describe(&self, loaded: &LoadedModels, world: &mut World) {
        world.layout.name = self
            .source
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "tumble".into());
        world.layout.metadata = self.metadata();
        world.layout.metadata.extend(loaded.urdf_texts.clone());
        world.layout.robot_descriptions = loaded
            .tables
            .iter()
            .map(|t| t.description.clone())
            .collect();
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

/// A note when `kind` composes steps of negative size (`variational4`, `variational6`) and a
/// mechanism has a damper (URDF damping, a servo's `kd`): there the damper anti-damps, stable
/// only while it is resolved in time (docs/forces.md, Limits).
fn composition_damping_note(kind: crate::sim::IntegratorKind, world: &World) -> Option<String> {
    use crate::sim::IntegratorKind;
    use crate::sim::mechanism::ActuatorKind;
    if !matches!(
        kind,
        IntegratorKind::Variational4 | IntegratorKind::Variational6
    ) {
        return None;
    }
    let damped = world.mechanisms.iter().any(|m| {
        m.drives.iter().any(|d| {
            d.damping > 0.0
                || d.actuator.as_ref().is_some_and(|a| match a.kind {
                    ActuatorKind::Position { kd, .. } | ActuatorKind::Velocity { kd, .. } => {
                        kd > 0.0
                    }
                    ActuatorKind::Motor { .. } => false,
                })
        })
    });
    damped.then(|| {
        format!(
            "{} composes steps of negative size, where joint damping and servo kd anti-damp: \
             stable only while each damper is resolved in time (b h / (2 I) well below 0.5); \
             watch the energy balance line, or use variational (docs/forces.md, Limits)",
            kind.name()
        )
    })
}
