//! What run `i` is: its drawn parameters ([`draw`]), its scene ([`run_scene`]) and its world
//! ([`ModelCache::world`], the scene's own build path).

use super::joint_vary::{ChoiceJoints, JointDraws};
use super::spec::DatasetSpec;
use crate::scene::FirstTable;
use crate::scene::LoadedModels;
use crate::scene::Scene;
use crate::scene::placement::{Dist, Placement, Rng, draw_vec3, run_seed};
use crate::sim::IntegratorKind;
use crate::world::World;
use anyhow::Context;
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use std::sync::Arc;

/// Everything drawn for one run (the template's value where a key is not varied).
#[derive(Debug, Clone, PartialEq)]
pub struct RunParams {
    pub run: u64,
    /// [`run_seed`]`(master seed, run)`.
    pub seed: u64,
    /// Index into [`DatasetSpec::model_choices`].
    pub model: usize,
    pub dt_secs: f64,
    pub duration_secs: f64,
    pub integrator: IntegratorKind,
    pub gravity_world: [f64; 3],
    /// World position of the root link frame, m.
    pub root_position_world: [f64; 3],
    /// `world_from_root` as a unit quaternion `[x, y, z, w]` (Hamilton).
    pub root_orientation_xyzw: [f64; 4],
    /// Initial velocity of every body's centre of mass, world, m/s.
    pub linvel_world: [f64; 3],
    /// Initial angular velocity of every body, world, rad/s.
    pub angvel_world: [f64; 3],
    /// The joint draws (`vary.joints`, `joint_velocities`, `actuators`): empty from [`draw`],
    /// filled by [`ModelCache::draw`], which knows the chosen model's joints.
    pub joints: JointDraws,
}

impl RunParams {
    /// `round(duration / dt)`, as [`Scene::steps`].
    pub fn steps(&self) -> u64 {
        (self.duration_secs / self.dt_secs).round() as u64
    }

    pub fn world_from_root(&self) -> Isometry3<f64> {
        let [x, y, z, w] = self.root_orientation_xyzw;
        Isometry3::from_parts(
            Translation3::from(Vector3::from(self.root_position_world)),
            UnitQuaternion::new_normalize(Quaternion::new(w, x, y, z)),
        )
    }
}

/// Draws run `run` of `spec`: each varied key from its own stream of the run's seed.
pub fn draw(spec: &DatasetSpec, run: u64) -> RunParams {
    let seed = run_seed(spec.seed, run);
    let t = &spec.template;
    let entry = &t.models[0];
    let scalar = |key: &str, d: &Option<Dist>, default: f64| match d {
        Some(d) => d.sample(&mut Rng::for_key(seed, key))[0],
        None => default,
    };
    let vec3 = |key: &str, d: &Option<Dist>, default: [f64; 3]| draw_vec3(seed, key, d, default);
    let v = &spec.vary;
    let model = match &v.model {
        Some(choices) => Rng::for_key(seed, "model").below(choices.len() as u64) as usize,
        None => 0,
    };
    let integrator = match &v.integrator {
        Some(names) => {
            let i = Rng::for_key(seed, "integrator").below(names.len() as u64) as usize;
            IntegratorKind::from_name(&names[i])
        }
        None => None,
    }
    .unwrap_or_else(|| t.integrator());
    let rotation = v.orientation.rotation(seed, entry.rpy);
    let q = rotation.quaternion().coords;
    RunParams {
        run,
        seed,
        model,
        dt_secs: scalar("dt", &v.dt, t.sim.dt),
        duration_secs: scalar("duration", &v.duration, t.sim.duration),
        integrator,
        gravity_world: vec3("gravity", &v.gravity, t.sim.gravity),
        root_position_world: vec3("position", &v.position, entry.position),
        root_orientation_xyzw: [q.x, q.y, q.z, q.w],
        linvel_world: vec3("linvel", &v.linvel, entry.linvel),
        angvel_world: vec3("angvel", &v.angvel, entry.angvel),
        joints: JointDraws::default(),
    }
}

/// The scene of one run: the template with the drawn values (`rpy` is the drawn rotation's
/// roll, pitch, yaw; it is informational, the run uses the quaternion). Used for the integrator,
/// the run settings and the recordings' metadata.
pub fn run_scene(spec: &DatasetSpec, params: &RunParams) -> Scene {
    let mut scene = spec.template.clone();
    scene.sim.dt = params.dt_secs;
    scene.sim.duration = params.duration_secs;
    scene.sim.gravity = params.gravity_world;
    scene.sim.integrator = params.integrator.name().to_string();
    let entry = &mut scene.models[0];
    entry.urdf = spec.model_choices()[params.model].clone().into();
    entry.position = params.root_position_world;
    let (r, p, y) = params.world_from_root().rotation.euler_angles();
    entry.rpy = [r, p, y];
    entry.linvel = params.linvel_world;
    entry.angvel = params.angvel_world;
    let drawn = &params.joints;
    entry
        .joints
        .extend(drawn.positions.iter().map(|(k, v)| (k.clone(), *v)));
    entry
        .joint_velocities
        .extend(drawn.velocities.iter().map(|(k, v)| (k.clone(), *v)));
    scene
}

/// Each model choice loaded once (URDF parsing and mass properties are the slow part of a
/// short run) with the template's scene build ([`Scene::load_models`]); shared by every thread.
/// Every run is then placed by that same build path ([`Scene::assemble`]) at its drawn
/// [`Placement`], so a dataset's bodies, attachments and mechanisms are exactly what a scene
/// with those values builds, articulated models included.
#[derive(Debug, Clone)]
pub struct ModelCache {
    /// Per model choice, in [`DatasetSpec::model_choices`] order: its loaded model.
    pub loaded: Vec<LoadedModels>,
    /// Per model choice: the template with that choice placed at the origin, at rest (its
    /// recording layout and body count serve every run of the choice).
    pub worlds: Vec<Arc<World>>,
    /// Per model choice: its moving and actuated joints ([`super::joint_vary`]).
    pub joints: Vec<ChoiceJoints>,
}

impl ModelCache {
    /// Loads every model choice; an error names the spec and the choice. An articulated
    /// choice is checked against every integrator the spec can draw (the articulated stepper
    /// steps the variational family only).
    pub fn load(spec: &DatasetSpec) -> anyhow::Result<Self> {
        let mut loaded = Vec::new();
        let mut worlds = Vec::new();
        let mut joints = Vec::new();
        for (i, urdf) in spec.model_choices().iter().enumerate() {
            let context = || format!("{}: model choice {i} ({urdf})", spec.path.display());
            let mut scene = spec.template.clone();
            let entry = &mut scene.models[0];
            entry.urdf = urdf.into();
            entry.position = [0.0; 3];
            entry.rpy = [0.0; 3];
            entry.linvel = [0.0; 3];
            entry.angvel = [0.0; 3];
            let models = scene.load_models().with_context(context)?;
            let mut world = scene
                .assemble(&models, &|table, copy| scene.models[table].placement(copy))
                .with_context(context)?;
            scene.describe(&models, &mut world);
            if !world.mechanisms.is_empty() {
                let integrators: Vec<IntegratorKind> = match &spec.vary.integrator {
                    Some(names) => names
                        .iter()
                        .filter_map(|n| IntegratorKind::from_name(n))
                        .collect(),
                    None => vec![spec.template.integrator()],
                };
                for kind in integrators {
                    crate::sim::integrator_for(
                        kind,
                        spec.template.sim.dt,
                        &spec.template.variational_settings(),
                        &world.mechanisms,
                        world.bodies.len(),
                    )
                    .with_context(context)?;
                }
            }
            let choice = choice_joints(&spec.template, &models, &world);
            spec.vary
                .joints
                .check(&format!("{}: vary", spec.path.display()), &choice)
                .with_context(context)?;
            joints.push(choice);
            loaded.push(models);
            worlds.push(Arc::new(world));
        }
        Ok(Self {
            loaded,
            worlds,
            joints,
        })
    }

    /// Run `run` of `spec`: [`draw`], and the joint draws for the chosen model.
    pub fn draw(&self, spec: &DatasetSpec, run: u64) -> RunParams {
        let mut params = draw(spec, run);
        if !spec.vary.joints.is_empty() {
            params.joints = spec
                .vary
                .joints
                .draw(params.seed, &self.joints[params.model]);
        }
        params
    }

    /// The world of run `params`: [`run_scene`] (the template with the drawn values) placed
    /// at the drawn root pose and velocities through the scene's own build path (without
    /// [`Scene::describe`]: a run records through its choice's layout, [`ModelCache::worlds`]).
    pub fn world(&self, spec: &DatasetSpec, params: &RunParams) -> anyhow::Result<World> {
        let scene = run_scene(spec, params);
        let place = Placement {
            world_from_model: params.world_from_root(),
            linvel_world: Vector3::from(params.linvel_world),
            angvel_world: Vector3::from(params.angvel_world),
        };
        let loaded = &self.loaded[params.model];
        let context = || format!("{}: run {}", spec.path.display(), params.run);
        let drawn = &params.joints;
        if drawn.positions.is_empty() && drawn.signals.is_empty() {
            return scene.assemble(loaded, &|_, _| place).with_context(context);
        }
        let table = &loaded.tables[0];
        // The model placed at the run's joint positions (the template's and the drawn ones).
        let positions: std::collections::HashMap<String, f64> = scene.models[0]
            .joints
            .iter()
            .map(|(k, v)| (k.clone(), *v))
            .collect();
        let model = table
            .model
            .at_joint_positions(&positions)
            .map_err(|e| anyhow::anyhow!("{e}"))
            .with_context(context)?;
        // The drawn signals replace the template's on their joints.
        let mut actuators = table.actuators.clone();
        for a in &mut actuators {
            if let Some(signal) = drawn.signals.get(&a.joint) {
                a.actuator.set_signal(signal.clone());
            }
        }
        let first = FirstTable {
            model: &model,
            actuators: &actuators,
        };
        scene
            .assemble_with(loaded, &|_, _| place, Some(&first))
            .with_context(context)
    }
}

/// The joints of a model choice as the joint draws see them: its moving joints (the recorded
/// ones, URDF names) with the range a drawn position is clamped into (revolute and prismatic
/// joints with a URDF range, limits on), and the joints of the template's actuators.
fn choice_joints(template: &Scene, models: &LoadedModels, world: &World) -> ChoiceJoints {
    let entry = &template.models[0];
    let prefix = entry.name.as_ref().map(|n| format!("{n}/"));
    let limits_on = entry.joint_limits != Some(false);
    let moving = world
        .layout
        .joints
        .iter()
        .map(|j| {
            let name = match &prefix {
                Some(p) => j.name.strip_prefix(p.as_str()).unwrap_or(&j.name),
                None => &j.name,
            };
            let range = j
                .limits
                .filter(|[lo, hi]| limits_on && j.kind != "continuous" && lo < hi);
            (name.to_string(), range)
        })
        .collect();
    ChoiceJoints {
        moving,
        actuated: models.tables[0]
            .actuators
            .iter()
            .map(|a| (a.joint.clone(), a.actuator.constant_signal()))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulation::Simulation;

    /// A dataset of a floating articulated chain (`bodies = "articulated"`, no gravity) with
    /// drawn poses and velocities.
    fn chain_spec(vary_extra: &str) -> DatasetSpec {
        let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
        let text = format!(
            "[dataset]\nruns = 4\nseed = 3\n\n[scene.sim]\nduration = 0.2\ndt = 0.001\n\
             gravity = [0.0, 0.0, 0.0]\n\n[[scene.model]]\nurdf = \"{}\"\n\
             bodies = \"articulated\"\njoints = {{ j1 = 0.4, j2 = -0.3 }}\n\
             joint_velocities = {{ j1 = 2.0, j2 = -3.0 }}\n\n[vary]\n\
             position = {{ uniform = [[-1, -1, 0], [1, 1, 2]] }}\norientation = \"uniform\"\n\
             linvel = {{ uniform = [[-1, -1, -1], [1, 1, 1]] }}\n\
             angvel = {{ normal = {{ mean = [0, 0, 0], std = [2, 2, 2] }} }}\n{vary_extra}",
            models.join("chain3_free.urdf").display()
        );
        DatasetSpec::parse(&text, &models.join("spec.toml")).unwrap()
    }

    /// Articulated models go through the scene's placement: each run is a mechanism placed
    /// at its drawn pose and velocities, and the variational step keeps the floating chain's
    /// total angular momentum (about its centre of mass) to round-off, the exact discrete
    /// conservation law. Before issue 29 the cache refused articulated models.
    #[test]
    fn articulated_runs_are_placed_by_the_scene_and_conserve_momentum() {
        let spec = chain_spec("");
        let cache = ModelCache::load(&spec).unwrap();
        for run in 0..spec.runs {
            let params = draw(&spec, run);
            let world = cache.world(&spec, &params).unwrap();
            assert_eq!(world.mechanisms.len(), 1);
            assert_eq!(world.bodies.len(), 3);
            // The drawn root pose places the chain: its first body is exactly where the
            // cache's origin-placed body lands under `world_from_root` (the scene composes
            // `world_from_model · model_from_body` for every body mode).
            let at_origin = cache.worlds[0].bodies[0].world_from_body;
            assert_eq!(
                world.bodies[0].world_from_body,
                params.world_from_root() * at_origin,
                "run {run}"
            );
            let scene = run_scene(&spec, &params);
            let mut sim = Simulation::of_world(
                &world,
                params.integrator,
                params.dt_secs,
                &scene.variational_settings(),
                1,
                &scene.run_settings(),
            )
            .unwrap();
            sim.run().unwrap();
            let summary = sim.summary();
            assert_eq!(summary.stopped, None);
            assert_eq!(summary.steps, 200);
            // Exact discrete conservation: measured 5.8e-16 to 2.8e-15 over the four runs.
            assert!(
                summary.angmom_rel_change_max < 1e-12,
                "run {run}: {}",
                summary.angmom_rel_change_max
            );
        }
    }

    /// An integrator the articulated stepper cannot use is refused when the cache loads,
    /// naming the model choice, before any run.
    #[test]
    fn an_articulated_choice_with_an_explicit_integrator_is_refused_up_front() {
        let spec = chain_spec("integrator = { choice = [\"variational\", \"rk4\"] }\n");
        let e = format!("{:#}", ModelCache::load(&spec).unwrap_err());
        assert!(e.contains("model choice 0") && e.contains("rk4"), "{e}");
    }
}
