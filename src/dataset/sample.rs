//! What run `i` is: its drawn parameters ([`draw`]), its scene ([`run_scene`]) and its bodies
//! ([`ModelCache::world`]).

use super::spec::DatasetSpec;
use crate::scene::Scene;
use crate::scene::placement::{Dist, Rng, draw_vec3, run_seed};
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
    scene
}

/// Each model choice loaded once (URDF parsing and mass properties are the slow part of a
/// short run), at the identity pose and at rest; shared by every thread.
#[derive(Debug, Clone)]
pub struct ModelCache {
    /// Per model choice, in [`DatasetSpec::model_choices`] order.
    pub worlds: Vec<Arc<World>>,
}

impl ModelCache {
    /// Loads every model choice; an error names the spec and the choice.
    pub fn load(spec: &DatasetSpec) -> anyhow::Result<Self> {
        let worlds = spec
            .model_choices()
            .iter()
            .enumerate()
            .map(|(i, urdf)| {
                let mut scene = spec.template.clone();
                let entry = &mut scene.models[0];
                entry.urdf = urdf.into();
                entry.position = [0.0; 3];
                entry.rpy = [0.0; 3];
                entry.linvel = [0.0; 3];
                entry.angvel = [0.0; 3];
                let world = scene.build().with_context(|| {
                    format!("{}: model choice {i} ({urdf})", spec.path.display())
                })?;
                if !world.mechanisms.is_empty() {
                    anyhow::bail!(
                        "{}: model choice {i} ({urdf}): bodies = \"articulated\" is not \
                             supported in datasets yet (the drawn velocities are per body); use \
                             \"links\" or \"rigid\"",
                        spec.path.display()
                    );
                }
                Ok(Arc::new(world))
            })
            .collect::<anyhow::Result<_>>()?;
        Ok(Self { worlds })
    }

    /// The bodies of run `params`: the cached model moved by `world_from_root`, every body with
    /// the drawn velocities. The layout is left empty (see [`ModelCache::worlds`] for it).
    pub fn world(&self, params: &RunParams) -> World {
        let base = &self.worlds[params.model];
        let world_from_root = params.world_from_root();
        let bodies = base
            .bodies
            .iter()
            .map(|b| {
                let mut b = b.clone();
                b.world_from_body = world_from_root * b.world_from_body;
                b.linvel_world = Vector3::from(params.linvel_world);
                b.angvel_world = Vector3::from(params.angvel_world);
                b
            })
            .collect();
        World {
            layout: Default::default(),
            bodies,
            attachments: base.attachments.clone(),
            warnings: Vec::new(),
            ..Default::default()
        }
    }
}
