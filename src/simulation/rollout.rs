//! Many runs of one scene at once (issue 33's `tumble.rollout`, in the shape of MuJoCo's
//! `rollout`): each roll starts from its own initial state, optionally driven by its own input
//! sequence, and the states after every `every`-th step come back as flat row-major arrays
//! `[roll][sample][body][component]`.
//!
//! Two paths, the same physics as `simulate`:
//! - **batched**: a scene of free bodies with nothing coupling them (no mechanism, contact or
//!   applied load) and no inputs: the rolls are cut into one group per thread, each group's
//!   bodies one batch stepped by its own [`Simulation`] on its thread, the threads never
//!   meeting (the bodies are independent, so a body's trajectory does not depend on the batch
//!   it is in);
//! - **per roll**: anything else: one [`Simulation`] per roll (its own world: rolls never
//!   touch), the rolls spread over `threads` threads.
//!
//! A roll's bodies start where [`RollStart::bodies`] puts them (free bodies: centre of mass,
//! principal frame, velocities), or, for an articulated first `[[model]]`, at the joint
//! positions and rates [`RollStart::joint_positions`] and [`RollStart::joint_velocities`] name (forward kinematics of the first table, as
//! a dataset's `vary.joints` does). A diverging roll (the guard, [`crate::sim::guard`]) is an
//! error naming the roll.

use super::inputs::{InputKind, Inputs};
use super::{Inits, Progress, Simulation};
use crate::scene::Scene;
use crate::scene::{FirstTable, LoadedModels};
use crate::sim::BodyInit;
use crate::world::World;
use anyhow::{Context, bail};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use rayon::prelude::*;
use std::collections::HashMap;

/// Where one roll starts.
#[derive(Debug, Clone, Default)]
pub struct RollStart {
    /// Free bodies' initial states (the scene's where `None`).
    pub bodies: BodyStarts,
    /// Joint positions (rad or m) of the first `[[model]]` (articulated), by recorded joint
    /// name; joints not named keep the scene's.
    pub joint_positions: Vec<(String, f64)>,
    /// Joint rates (rad/s or m/s), the same way.
    pub joint_velocities: Vec<(String, f64)>,
}

/// Initial states of every body, each part optional (the scene's where `None`), every given
/// one with one entry per body in the scene's order.
#[derive(Debug, Clone, Default)]
pub struct BodyStarts {
    /// Centres of mass, m, world.
    pub position: Option<Vec<Vector3<f64>>>,
    /// Principal frames in the world (normalised here).
    pub orientation: Option<Vec<Quaternion<f64>>>,
    /// m/s, world.
    pub linear_velocity: Option<Vec<Vector3<f64>>>,
    /// rad/s, world.
    pub angular_velocity: Option<Vec<Vector3<f64>>>,
}

impl BodyStarts {
    fn is_empty(&self) -> bool {
        self.position.is_none()
            && self.orientation.is_none()
            && self.linear_velocity.is_none()
            && self.angular_velocity.is_none()
    }

    /// Checks the counts and values against `bodies` bodies.
    fn check(&self, bodies: usize) -> anyhow::Result<()> {
        let counts = [
            ("position", self.position.as_ref().map(Vec::len)),
            ("orientation", self.orientation.as_ref().map(Vec::len)),
            (
                "linear_velocity",
                self.linear_velocity.as_ref().map(Vec::len),
            ),
            (
                "angular_velocity",
                self.angular_velocity.as_ref().map(Vec::len),
            ),
        ];
        for (name, count) in counts {
            if let Some(n) = count.filter(|&n| n != bodies) {
                bail!("{name}: {n} entries for {bodies} bodies");
            }
        }
        let finite = |v: &Vector3<f64>| v.iter().all(|x| x.is_finite());
        for (name, values) in [
            ("position", &self.position),
            ("linear_velocity", &self.linear_velocity),
            ("angular_velocity", &self.angular_velocity),
        ] {
            if let Some(b) = values.iter().flatten().position(|v| !finite(v)) {
                bail!("{name}: body {b}: not finite");
            }
        }
        if let Some(b) = self.orientation.iter().flatten().position(|q| {
            let n = q.norm();
            !(n.is_finite() && n > 0.0)
        }) {
            bail!("orientation: body {b}: not a rotation (zero or not finite)");
        }
        Ok(())
    }

    /// Puts the given parts onto `inits` (masses and moments stay the scene's).
    fn apply(&self, inits: &mut [BodyInit]) {
        for (i, init) in inits.iter_mut().enumerate() {
            if let Some(p) = &self.position {
                init.world_from_body.translation.vector = p[i];
            }
            if let Some(q) = &self.orientation {
                init.world_from_body.rotation = UnitQuaternion::from_quaternion(q[i]);
            }
            if let Some(v) = &self.linear_velocity {
                init.linvel_world = v[i];
            }
            if let Some(w) = &self.angular_velocity {
                init.angvel_world = w[i];
            }
        }
    }
}

/// One actuated joint's input over every roll and step: `values[r * steps + k]` is held over
/// step `k + 1` of roll `r` ([`Inputs`]).
#[derive(Debug, Clone)]
pub struct RollInput {
    pub joint: String,
    pub kind: InputKind,
    pub values: Vec<f64>,
}

/// What [`rollout`] does.
#[derive(Debug, Clone, Copy)]
pub struct RolloutOptions {
    pub steps: u64,
    /// A sample after every `every`-th step (>= 1).
    pub every: u64,
    pub threads: usize,
}

/// The states of every roll after every `every`-th step (the initial state is not a sample),
/// flat and row-major; world frame, SI units.
#[derive(Debug, Clone, Default)]
pub struct Rollout {
    pub rolls: usize,
    pub samples: usize,
    pub bodies: usize,
    pub joints: usize,
    /// Per sample, s.
    pub time_secs: Vec<f64>,
    /// `[r][s][b][3]`: centre of mass.
    pub position: Vec<f64>,
    /// `[r][s][b][4]`: principal frame, x y z w.
    pub orientation: Vec<f64>,
    pub linear_velocity: Vec<f64>,
    pub angular_velocity: Vec<f64>,
    /// `[r][s][j]`.
    pub joint_position: Vec<f64>,
    pub joint_velocity: Vec<f64>,
    /// Whether the rolls were stepped as one batch (the module doc).
    pub batched: bool,
}

/// What [`rollout_into`] ran: the arrays' shape, the samples' times and the path taken.
#[derive(Debug, Clone, Default)]
pub struct RolloutShape {
    pub rolls: usize,
    pub samples: usize,
    pub bodies: usize,
    pub joints: usize,
    /// Per sample, s.
    pub time_secs: Vec<f64>,
    /// Whether the rolls were stepped as one batch (the module doc).
    pub batched: bool,
}

/// The arrays [`rollout_into`] fills (every element), laid out as [`Rollout`]'s: e.g. numpy
/// arrays the caller made, filled without a copy.
pub struct RolloutBuffers<'a> {
    pub position: &'a mut [f64],
    pub orientation: &'a mut [f64],
    pub linear_velocity: &'a mut [f64],
    pub angular_velocity: &'a mut [f64],
    pub joint_position: &'a mut [f64],
    pub joint_velocity: &'a mut [f64],
}

impl<'a> RolloutBuffers<'a> {
    /// Each roll's part of the arrays (`samples` samples of `bodies` bodies and `joints`
    /// joints per roll).
    fn split(
        self,
        rolls: usize,
        samples: usize,
        bodies: usize,
        joints: usize,
    ) -> Vec<RollBuffers<'a>> {
        fn parts(a: &mut [f64], rolls: usize, len: usize) -> Vec<&mut [f64]> {
            if len == 0 {
                return (0..rolls).map(|_| <&mut [f64]>::default()).collect();
            }
            a.chunks_mut(len).collect()
        }
        let mut p = parts(self.position, rolls, samples * bodies * 3).into_iter();
        let mut o = parts(self.orientation, rolls, samples * bodies * 4).into_iter();
        let mut v = parts(self.linear_velocity, rolls, samples * bodies * 3).into_iter();
        let mut w = parts(self.angular_velocity, rolls, samples * bodies * 3).into_iter();
        let mut jp = parts(self.joint_position, rolls, samples * joints).into_iter();
        let mut jv = parts(self.joint_velocity, rolls, samples * joints).into_iter();
        (0..rolls)
            .map(|_| RollBuffers {
                position: p.next().unwrap_or_default(),
                orientation: o.next().unwrap_or_default(),
                linear_velocity: v.next().unwrap_or_default(),
                angular_velocity: w.next().unwrap_or_default(),
                joint_position: jp.next().unwrap_or_default(),
                joint_velocity: jv.next().unwrap_or_default(),
            })
            .collect()
    }
}

/// Per body: its link frame's index and its principal frame in that link frame (the
/// recordings' body pose: `world_from_link[frame] * link_from_principal`).
pub fn body_frames(world: &World) -> Vec<(usize, nalgebra::Isometry3<f64>)> {
    world
        .layout
        .bodies
        .iter()
        .map(|b| (b.frame, b.link_from_principal))
        .collect()
}

/// Writes the current state of `sim` as the recordings report it (through the frame, as
/// [`Simulation::frame`] builds it: the same numbers as a recording of that step).
fn write_frame(
    sim: &mut Simulation,
    frames: &[(usize, nalgebra::Isometry3<f64>)],
    out: RollBuffers<'_>,
) {
    let frame = sim.frame();
    for (b, (state, (f, link_from_principal))) in frame.bodies.iter().zip(frames).enumerate() {
        let pose = frame.world_from_link[*f] * link_from_principal;
        let q = pose.rotation.quaternion().coords;
        out.position[3 * b..3 * b + 3].copy_from_slice(pose.translation.vector.as_slice());
        out.orientation[4 * b..4 * b + 4].copy_from_slice(&[q.x, q.y, q.z, q.w]);
        out.linear_velocity[3 * b..3 * b + 3].copy_from_slice(state.linvel_world.as_slice());
        out.angular_velocity[3 * b..3 * b + 3].copy_from_slice(state.angvel_world.as_slice());
    }
    for (j, state) in frame.joints.iter().enumerate() {
        out.joint_position[j] = state.position;
        out.joint_velocity[j] = state.velocity;
    }
}

/// Runs `starts.len()` rolls of `scene` (the module doc) into new arrays.
pub fn rollout(
    scene: &Scene,
    starts: &[RollStart],
    inputs: &[RollInput],
    options: &RolloutOptions,
) -> anyhow::Result<Rollout> {
    let (bodies, joints) = shape_of(scene)?;
    let rolls = starts.len();
    let samples = (options.steps / options.every.max(1)) as usize;
    let sized = |width: usize| vec![0.0; rolls * samples * width];
    let mut out = Rollout {
        position: sized(3 * bodies),
        orientation: sized(4 * bodies),
        linear_velocity: sized(3 * bodies),
        angular_velocity: sized(3 * bodies),
        joint_position: sized(joints),
        joint_velocity: sized(joints),
        ..Default::default()
    };
    let shape = rollout_into(
        scene,
        starts,
        inputs,
        options,
        RolloutBuffers {
            position: &mut out.position,
            orientation: &mut out.orientation,
            linear_velocity: &mut out.linear_velocity,
            angular_velocity: &mut out.angular_velocity,
            joint_position: &mut out.joint_position,
            joint_velocity: &mut out.joint_velocity,
        },
    )?;
    out.rolls = shape.rolls;
    out.samples = shape.samples;
    out.bodies = shape.bodies;
    out.joints = shape.joints;
    out.time_secs = shape.time_secs;
    out.batched = shape.batched;
    Ok(out)
}

/// The bodies and recorded joints of `scene`'s world (the per-sample widths of the arrays).
pub fn shape_of(scene: &Scene) -> anyhow::Result<(usize, usize)> {
    let world = scene.build()?;
    Ok((world.bodies.len(), world.layout.joints.len()))
}

/// Runs `starts.len()` rolls of `scene` (the module doc), filling `out` (its arrays sized for
/// the rolls, `steps / every` samples, and [`shape_of`] the scene; an error otherwise).
pub fn rollout_into(
    scene: &Scene,
    starts: &[RollStart],
    inputs: &[RollInput],
    options: &RolloutOptions,
    out: RolloutBuffers<'_>,
) -> anyhow::Result<RolloutShape> {
    let file = scene.source.display().to_string();
    let every = options.every.max(1);
    let loaded = scene.load_models()?;
    let world = scene.assemble(&loaded, &|table, copy| scene.models[table].placement(copy))?;
    let rolls = starts.len();
    let samples = usize::try_from(options.steps / every).context("too many samples")?;
    let (bodies, joints) = (world.bodies.len(), world.layout.joints.len());
    for (name, len, width) in [
        ("position", out.position.len(), 3 * bodies),
        ("orientation", out.orientation.len(), 4 * bodies),
        ("linear_velocity", out.linear_velocity.len(), 3 * bodies),
        ("angular_velocity", out.angular_velocity.len(), 3 * bodies),
        ("joint_position", out.joint_position.len(), joints),
        ("joint_velocity", out.joint_velocity.len(), joints),
    ] {
        if len != rolls * samples * width {
            bail!(
                "internal error: the rollout's {name} array holds {len} values, not {}",
                rolls * samples * width
            );
        }
    }
    for (r, start) in starts.iter().enumerate() {
        if !start.bodies.is_empty() {
            start
                .bodies
                .check(bodies)
                .with_context(|| format!("{file}: roll {r}"))?;
            if !world.mechanisms.is_empty() {
                bail!(
                    "{file}: roll {r}: body states cannot start an articulated model (its bodies \
                     must satisfy its joints); give joint positions and rates"
                );
            }
        }
    }
    for input in inputs {
        let want = rolls as u64 * options.steps;
        if input.values.len() as u64 != want {
            bail!(
                "{file}: the input of {}: {} values for {rolls} rolls of {} steps",
                input.joint,
                input.values.len(),
                options.steps
            );
        }
    }
    let mut shape = RolloutShape {
        rolls,
        samples,
        bodies,
        joints,
        time_secs: (1..=samples as u64)
            .map(|s| super::time_ns(s * every, scene.sim.dt) as f64 / 1e9)
            .collect(),
        batched: false,
    };
    let settings = crate::sim::RunSettings {
        steps: options.steps,
        log_every: every,
        ..scene.run_settings()
    };
    let independent = world.mechanisms.is_empty()
        && world.body_loads.is_empty()
        && !world.contact.is_active()
        && inputs.is_empty();
    if independent && rolls > 0 {
        batched(
            scene,
            &world,
            starts,
            &settings,
            options.threads,
            samples,
            out,
        )?;
        shape.batched = true;
        return Ok(shape);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads.max(1))
        .build()?;
    let buffers = out.split(rolls, samples, bodies, joints);
    let results: Vec<anyhow::Result<()>> = pool.install(|| {
        buffers
            .into_par_iter()
            .enumerate()
            .map(|(r, mut roll)| {
                let roll_world = roll_world(scene, &loaded, &world, &starts[r])
                    .with_context(|| format!("{file}: roll {r}"))?;
                // Each roll's own principal frames: a body with two equal moments has a
                // plane of them, and a model posed otherwise may pick another.
                let frames = body_frames(&roll_world);
                run_roll(scene, roll_world, r, inputs, &settings, &frames, &mut roll)
                    .with_context(|| format!("{file}: roll {r}"))
            })
            .collect()
    });
    for result in results {
        result?;
    }
    Ok(shape)
}

/// One roll's output arrays (or one sample's part of them).
struct RollBuffers<'a> {
    position: &'a mut [f64],
    orientation: &'a mut [f64],
    linear_velocity: &'a mut [f64],
    angular_velocity: &'a mut [f64],
    joint_position: &'a mut [f64],
    joint_velocity: &'a mut [f64],
}

impl RollBuffers<'_> {
    /// Sample `s`'s part of the roll's arrays.
    fn sample(&mut self, s: usize, bodies: usize, joints: usize) -> RollBuffers<'_> {
        RollBuffers {
            position: &mut self.position[s * 3 * bodies..(s + 1) * 3 * bodies],
            orientation: &mut self.orientation[s * 4 * bodies..(s + 1) * 4 * bodies],
            linear_velocity: &mut self.linear_velocity[s * 3 * bodies..(s + 1) * 3 * bodies],
            angular_velocity: &mut self.angular_velocity[s * 3 * bodies..(s + 1) * 3 * bodies],
            joint_position: &mut self.joint_position[s * joints..(s + 1) * joints],
            joint_velocity: &mut self.joint_velocity[s * joints..(s + 1) * joints],
        }
    }
}

/// Roll `start`'s world: the scene's, its bodies replaced, or the first table re-posed at
/// the roll's joint positions and rates.
fn roll_world(
    scene: &Scene,
    loaded: &LoadedModels,
    world: &World,
    start: &RollStart,
) -> anyhow::Result<World> {
    if start.joint_positions.is_empty() && start.joint_velocities.is_empty() {
        let mut w = world.clone();
        start.bodies.apply(&mut w.bodies);
        return Ok(w);
    }
    let Some(entry) = scene.models.first() else {
        bail!("joint states given for a scene without models");
    };
    let prefix = entry.name.as_ref().map(|n| format!("{n}/"));
    let table_joints: Vec<&str> = world
        .layout
        .mechanisms
        .first()
        .filter(|_| entry.bodies == crate::scene::BodiesMode::Articulated)
        .map(|m| {
            world.layout.joints[m.joints.clone()]
                .iter()
                .map(|j| j.name.as_str())
                .collect()
        })
        .unwrap_or_default();
    let urdf_name = |name: &str| -> anyhow::Result<String> {
        if !table_joints.contains(&name) {
            bail!(
                "joint {name:?}: not a moving joint of the first [[model]] (articulated){}",
                crate::message::did_you_mean(name, table_joints.iter().copied())
            );
        }
        Ok(match &prefix {
            Some(p) => name.strip_prefix(p.as_str()).unwrap_or(name).to_string(),
            None => name.to_string(),
        })
    };
    let mut positions: HashMap<String, f64> =
        entry.joints.iter().map(|(k, v)| (k.clone(), *v)).collect();
    for (name, value) in &start.joint_positions {
        positions.insert(urdf_name(name)?, *value);
    }
    let mut roll_scene = scene.clone();
    for (name, value) in &start.joint_velocities {
        roll_scene.models[0]
            .joint_velocities
            .insert(urdf_name(name)?, *value);
    }
    let table = &loaded.tables[0];
    let model = table
        .model
        .at_joint_positions(&positions)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let first = FirstTable {
        model: &model,
        actuators: &table.actuators,
    };
    roll_scene.assemble_with(
        loaded,
        &|t, copy| roll_scene.models[t].placement(copy),
        Some(&first),
    )
}

/// Steps one roll, sampling after every `settings.log_every`-th step.
fn run_roll(
    scene: &Scene,
    mut world: World,
    roll: usize,
    inputs: &[RollInput],
    settings: &crate::sim::RunSettings,
    frames: &[(usize, nalgebra::Isometry3<f64>)],
    out: &mut RollBuffers<'_>,
) -> anyhow::Result<()> {
    let held: Option<Inputs> = (!inputs.is_empty()).then(|| super::inputs::hold(&mut world));
    let (bodies, joints) = (world.bodies.len(), world.layout.joints.len());
    let inits = std::mem::take(&mut world.bodies);
    let mut sim = Simulation::of_scene(scene, &world, Inits::Owned(inits), 1, settings)?;
    let every = settings.log_every;
    let mut values: Vec<(String, f64)> = Vec::with_capacity(1);
    let mut done = 0;
    while done < settings.steps {
        // With inputs, one step at a time (each holds its own value); else a sample at a time.
        let n = match &held {
            Some(held) => {
                for input in inputs {
                    values.clear();
                    let k = roll * settings.steps as usize + done as usize;
                    values.push((input.joint.clone(), input.values[k]));
                    held.set(input.kind, &values)?;
                }
                1
            }
            None => every.min(settings.steps - done),
        };
        if sim.advance(n)? == Progress::Stopped {
            stopped(&mut sim)?;
        }
        done += n;
        if done.is_multiple_of(every) {
            let s = (done / every - 1) as usize;
            write_frame(&mut sim, frames, out.sample(s, bodies, joints));
        }
    }
    Ok(())
}

/// The guard's stop of a roll as an error (the caller names the roll).
fn stopped(sim: &mut Simulation) -> anyhow::Result<()> {
    let summary = sim.summary();
    match summary.stopped {
        Some(d) => bail!("diverged at step {} (body {}): {}", d.step, d.body, d.cause),
        None => Ok(()),
    }
}

/// The batched path: the rolls cut into one contiguous group per thread, each group's bodies
/// one batch of a bare world (no layout) stepped by its own [`Simulation`] on its thread, its
/// samples read from its batch into its rolls' rows: no meeting of the threads between steps.
fn batched(
    scene: &Scene,
    world: &World,
    starts: &[RollStart],
    settings: &crate::sim::RunSettings,
    threads: usize,
    samples: usize,
    out: RolloutBuffers<'_>,
) -> anyhow::Result<()> {
    let n = world.bodies.len();
    let groups = threads.clamp(1, starts.len().max(1));
    let per_group = starts.len().div_ceil(groups);
    let rows = |width: usize| (per_group * samples * n * width).max(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(groups)
        .build()?;
    let file = scene.source.display().to_string();
    let results: Vec<anyhow::Result<()>> = pool.install(|| {
        out.position
            .par_chunks_mut(rows(3))
            .zip(out.orientation.par_chunks_mut(rows(4)))
            .zip(out.linear_velocity.par_chunks_mut(rows(3)))
            .zip(out.angular_velocity.par_chunks_mut(rows(3)))
            .enumerate()
            .map(|(g, (((p, o), v), w))| {
                let first_roll = g * per_group;
                let group = &starts[first_roll..(first_roll + per_group).min(starts.len())];
                step_group(scene, world, group, settings, [p, o, v, w]).map_err(|e| {
                    match e.downcast_ref::<GroupDiverged>() {
                        Some(d) => anyhow::anyhow!(
                            "{file}: roll {}: diverged at step {} (body {}): {}",
                            first_roll + d.roll,
                            d.step,
                            d.body,
                            d.cause
                        ),
                        None => e,
                    }
                })
            })
            .collect()
    });
    results.into_iter().collect()
}

/// A roll of a group that diverged (roll index within the group).
#[derive(Debug, thiserror::Error)]
#[error("roll {roll} diverged at step {step} (body {body}): {cause}")]
struct GroupDiverged {
    roll: usize,
    step: u64,
    body: usize,
    cause: crate::sim::guard::Cause,
}

/// One group of [`batched`]: `out` = its rows of position, orientation, linear and angular
/// velocity.
fn step_group(
    scene: &Scene,
    world: &World,
    group: &[RollStart],
    settings: &crate::sim::RunSettings,
    out: [&mut [f64]; 4],
) -> anyhow::Result<()> {
    let n = world.bodies.len();
    let mut inits = Vec::with_capacity(n * group.len());
    for start in group {
        let first = inits.len();
        inits.extend_from_slice(&world.bodies);
        start.bodies.apply(&mut inits[first..]);
    }
    let mut sim = Simulation::of_scene(scene, &World::default(), Inits::Owned(inits), 1, settings)?;
    let every = settings.log_every;
    let samples = (settings.steps / every) as usize;
    let [position, orientation, linvel, angvel] = out;
    // Samples are staged step-major for a block of samples, then written roll by roll: the
    // output is roll-major, and writing each step's samples straight into it touches one
    // page per body per step (measured: 90 ns per body-step, three times the step).
    const BLOCK: usize = 8;
    let len = group.len() * n;
    let mut stage = vec![[0.0_f64; 13]; BLOCK.min(samples.max(1)) * len];
    let mut s0 = 0;
    for s in 0..samples {
        if sim.advance(every)? == Progress::Stopped {
            let d = sim
                .summary()
                .stopped
                .expect("a stopped run names its divergence");
            return Err(GroupDiverged {
                roll: d.body / n.max(1),
                step: d.step,
                body: d.body % n.max(1),
                cause: d.cause,
            }
            .into());
        }
        let view = sim.view();
        let batch = view.part(0);
        let k = s - s0;
        for (i, row) in stage[k * len..(k + 1) * len].iter_mut().enumerate() {
            let c = batch.com_world[i];
            let q = batch.world_from_body[i].quaternion().coords;
            let v = batch.linvel_world[i];
            let w = batch.angvel_world(i);
            *row = [
                c.x, c.y, c.z, q.x, q.y, q.z, q.w, v.x, v.y, v.z, w.x, w.y, w.z,
            ];
        }
        if k + 1 == BLOCK || s + 1 == samples {
            // Rows `(r * samples + s) * n + b` of samples s0..=s.
            for r in 0..group.len() {
                for k in 0..=s - s0 {
                    for b in 0..n {
                        let x = &stage[k * len + r * n + b];
                        let row = (r * samples + s0 + k) * n + b;
                        position[3 * row..3 * row + 3].copy_from_slice(&x[0..3]);
                        orientation[4 * row..4 * row + 4].copy_from_slice(&x[3..7]);
                        linvel[3 * row..3 * row + 3].copy_from_slice(&x[7..10]);
                        angvel[3 * row..3 * row + 3].copy_from_slice(&x[10..13]);
                    }
                }
            }
            s0 = s + 1;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulation::inputs::hold;

    fn scene(text: &str) -> Scene {
        let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
        Scene::parse(text, &models.join("scene.toml")).unwrap()
    }

    const HANDLE: &str = "[sim]\ndt = 0.001\nduration = 0.05\ngravity = [0.0, 0.0, -9.81]\n\
        [[model]]\nurdf = \"t_handle.urdf\"\nbodies = \"rigid\"\nposition = [0.0, 0.0, 1.0]\n";

    const ARM: &str = "[sim]\ndt = 0.001\nduration = 0.05\ngravity = [0.0, 0.0, -9.81]\n\
        [[model]]\nurdf = \"arm.urdf\"\nname = \"arm\"\nbodies = \"articulated\"\nbase = \"fixed\"\n\
        [[model.actuator]]\njoint = \"shoulder\"\nkind = \"motor\"\neffort = 0.0\n\
        [[model.actuator]]\njoint = \"elbow\"\nkind = \"motor\"\neffort = 0.0\n";

    /// The state a Simulation of `world` reports after each `every` steps, as rollout arrays
    /// of one roll: (positions, orientations, linear, angular, joint positions, rates).
    fn simulate(
        scene: &Scene,
        mut world: World,
        steps: u64,
        every: u64,
        inputs: &[(usize, Vec<f64>)],
    ) -> [Vec<f64>; 6] {
        let held = hold(&mut world);
        let frames = body_frames(&world);
        let settings = crate::sim::RunSettings {
            steps,
            log_every: every,
            ..scene.run_settings()
        };
        let mut sim = Simulation::of_world(
            &world,
            scene.integrator(),
            scene.sim.dt,
            &scene.variational_settings(),
            1,
            &settings,
        )
        .unwrap();
        let (n, j) = (world.bodies.len(), world.layout.joints.len());
        let samples = (settings.steps / every) as usize;
        let mut out: [Vec<f64>; 6] = [
            vec![0.0; samples * 3 * n],
            vec![0.0; samples * 4 * n],
            vec![0.0; samples * 3 * n],
            vec![0.0; samples * 3 * n],
            vec![0.0; samples * j],
            vec![0.0; samples * j],
        ];
        for k in 0..settings.steps {
            for (input, values) in inputs {
                held.joints[*input].held.set(values[k as usize]);
            }
            sim.advance(1).unwrap();
            if (k + 1) % every == 0 {
                let s = ((k + 1) / every - 1) as usize;
                let [p, o, v, w, jp, jv] = &mut out;
                let mut roll = RollBuffers {
                    position: p,
                    orientation: o,
                    linear_velocity: v,
                    angular_velocity: w,
                    joint_position: jp,
                    joint_velocity: jv,
                };
                write_frame(&mut sim, &frames, roll.sample(s, n, j));
            }
        }
        out
    }

    fn arrays(r: &Rollout, roll: usize) -> [Vec<f64>; 6] {
        let part = |a: &[f64], width: usize| {
            a[roll * r.samples * width..(roll + 1) * r.samples * width].to_vec()
        };
        [
            part(&r.position, 3 * r.bodies),
            part(&r.orientation, 4 * r.bodies),
            part(&r.linear_velocity, 3 * r.bodies),
            part(&r.angular_velocity, 3 * r.bodies),
            part(&r.joint_position, r.joints),
            part(&r.joint_velocity, r.joints),
        ]
    }

    /// Free bodies: the batched path (two threads, three rolls, samples every 5 steps) equals
    /// a Simulation of each start, to round-off (the pose composed through the link frame in
    /// one, read from the body in the other: measured 2.2e-16).
    #[test]
    fn batched_rolls_are_simulations_of_their_starts() {
        let scene = scene(HANDLE);
        let spins = [
            Vector3::new(0.1, 5.0, 0.2),
            Vector3::new(3.0, -1.0, 0.5),
            Vector3::zeros(),
        ];
        let starts: Vec<RollStart> = spins
            .iter()
            .enumerate()
            .map(|(k, w)| RollStart {
                bodies: BodyStarts {
                    angular_velocity: Some(vec![*w]),
                    position: (k == 2).then(|| vec![Vector3::new(0.5, 0.0, 2.0)]),
                    // Not unit: normalised.
                    orientation: (k == 1).then(|| vec![Quaternion::new(2.0, 0.4, -1.0, 0.2)]),
                    ..Default::default()
                },
                ..Default::default()
            })
            .collect();
        // 40 of the scene's 50 steps.
        let options = RolloutOptions {
            steps: 40,
            every: 5,
            threads: 2,
        };
        let out = rollout(&scene, &starts, &[], &options).unwrap();
        assert!(out.batched);
        assert_eq!(
            (out.rolls, out.samples, out.bodies, out.joints),
            (3, 8, 1, 0)
        );
        assert_eq!(out.time_secs.len(), 8);
        assert_eq!(out.time_secs[7], 0.04);
        let q = &out.orientation[8 * 4..8 * 4 + 4];
        assert!((q.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-15);
        for (k, start) in starts.iter().enumerate() {
            let mut world = scene.build().unwrap();
            start.bodies.apply(&mut world.bodies);
            let want = simulate(&scene, world, 40, 5, &[]);
            for (got, want) in arrays(&out, k).iter().zip(&want) {
                assert_eq!(got.len(), want.len());
                for (a, b) in got.iter().zip(want) {
                    assert!(
                        (a - b).abs() <= 1e-14 * (1.0 + b.abs()),
                        "roll {k}: {a} vs {b}"
                    );
                }
            }
        }
        let w0 = &out.angular_velocity[..3];
        let w1 = &out.angular_velocity[30..33];
        assert!((w0[1] - w1[1]).abs() > 1.0, "the starts were used");
    }

    /// An articulated arm: the per-roll path with input sequences equals a held Simulation
    /// bit for bit, and from joint starts a Simulation of the scene placed there.
    #[test]
    fn per_roll_paths_are_the_simulations_of_their_starts() {
        let scene = scene(ARM);
        // 30 of the scene's 50 steps.
        let steps = 30;
        let u: Vec<f64> = (0..2 * steps)
            .map(|k| ((k % 17) as f64 - 8.0) * 0.25)
            .collect();
        let inputs = [RollInput {
            joint: "arm/elbow".into(),
            kind: InputKind::Effort,
            values: u.clone(),
        }];
        let starts = vec![
            RollStart::default(),
            RollStart {
                joint_positions: vec![("arm/shoulder".into(), 0.4), ("arm/elbow".into(), -0.7)],
                joint_velocities: vec![("arm/elbow".into(), 1.5)],
                ..Default::default()
            },
        ];
        let options = RolloutOptions {
            steps,
            every: 1,
            threads: 2,
        };
        let out = rollout(&scene, &starts, &inputs, &options).unwrap();
        assert!(!out.batched);
        assert_eq!(
            (out.rolls, out.samples, out.bodies, out.joints),
            (2, 30, 2, 2)
        );
        let placed = ARM.replace(
            "base = \"fixed\"\n",
            "base = \"fixed\"\njoints = { shoulder = 0.4, elbow = -0.7 }\n\
             joint_velocities = { elbow = 1.5 }\n",
        );
        for (r, text) in [ARM.to_string(), placed].iter().enumerate() {
            let roll_scene = self::scene(text);
            let world = roll_scene.build().unwrap();
            let values = u[r * steps as usize..(r + 1) * steps as usize].to_vec();
            let placed_frames = body_frames(&world);
            let want = simulate(&roll_scene, world, steps, 1, &[(1, values)]);
            let got = arrays(&out, r);
            if r == 0 {
                assert!(got == want, "roll 0: not the same bits");
                continue;
            }
            // From joint starts the roll's model is posed from the loaded one
            // (`Model::at_joint_positions`), the scene's loaded at its `joints`: the same
            // forward kinematics in another order (measured: 5.6e-17 m apart). The upper arm,
            // a cylinder, has a plane of principal axes: each world picks its own, so the
            // orientations are compared as the link frames they place.
            let close = |a: &[f64], b: &[f64]| {
                a.iter()
                    .zip(b)
                    .all(|(x, y)| (x - y).abs() <= 1e-15 * (1.0 + y.abs()))
            };
            for k in [0, 2, 3, 4, 5] {
                assert!(close(&got[k], &want[k]), "roll 1, array {k}");
            }
            let loaded = scene.load_models().unwrap();
            let base = scene.build().unwrap();
            let roll_frames = body_frames(&roll_world(&scene, &loaded, &base, &starts[1]).unwrap());
            let link = |q: &[f64], frames: &[(usize, nalgebra::Isometry3<f64>)], b: usize| {
                let q = UnitQuaternion::from_quaternion(Quaternion::new(q[3], q[0], q[1], q[2]));
                q * frames[b].1.rotation.inverse()
            };
            for (g, w) in got[1]
                .chunks(4)
                .zip(want[1].chunks(4))
                .enumerate()
                .map(|(i, (g, w))| {
                    let b = i % 2;
                    (link(g, &roll_frames, b), link(w, &placed_frames, b))
                })
            {
                // Measured: 2.2e-16 rad.
                assert!(g.angle_to(&w) < 1e-12, "{}", g.angle_to(&w));
            }
        }
        assert!((out.joint_position[0] - out.joint_position[60]).abs() > 0.1);
    }

    /// A roll the guard stops is an error naming the roll (the others ran): a rotor driven
    /// with 1e200 N m from its 5th step.
    #[test]
    fn a_diverging_roll_is_an_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("rotor.urdf"),
            r#"<robot name="rotor"><link name="base"/>
<link name="wheel"><inertial><mass value="2"/><inertia ixx="0.03" iyy="0.04" izz="0.05" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="spin" type="continuous"><parent link="base"/><child link="wheel"/><axis xyz="0 0 1"/></joint>
</robot>"#,
        )
        .unwrap();
        let text = "[sim]\ndt = 0.001\nduration = 0.02\n[[model]]\nurdf = \"rotor.urdf\"\n\
                    bodies = \"articulated\"\nbase = \"fixed\"\n[[model.actuator]]\n\
                    joint = \"spin\"\nkind = \"motor\"\neffort = 0.0\n";
        let scene = Scene::parse(text, &dir.path().join("scene.toml")).unwrap();
        let mut values = vec![0.1; 40];
        for v in &mut values[24..] {
            *v = 1e200;
        }
        let input = RollInput {
            joint: "spin".into(),
            kind: InputKind::Effort,
            values,
        };
        let options = RolloutOptions {
            steps: 20,
            every: 1,
            threads: 1,
        };
        let starts = vec![RollStart::default(); 2];
        let e = format!(
            "{:#}",
            rollout(&scene, &starts, &[input], &options).unwrap_err()
        );
        assert!(e.contains("roll 1: diverged at step 5 (body 0): "), "{e}");
    }

    /// What is refused, with the roll or the input named.
    #[test]
    fn bad_starts_and_inputs_are_refused() {
        let options = RolloutOptions {
            steps: 10,
            every: 1,
            threads: 1,
        };
        let arm = scene(ARM);
        let body_start = RollStart {
            bodies: BodyStarts {
                position: Some(vec![Vector3::zeros(); 2]),
                ..Default::default()
            },
            ..Default::default()
        };
        let e = rollout(&arm, &[body_start], &[], &options)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("roll 0: body states cannot start an articulated model"),
            "{e}"
        );
        let e = rollout(
            &arm,
            &[RollStart {
                joint_positions: vec![("arm/elbw".into(), 0.1)],
                ..Default::default()
            }],
            &[],
            &options,
        )
        .unwrap_err();
        let e = format!("{e:#}");
        assert!(e.contains("roll 0: joint \"arm/elbw\": not a moving joint of the first [[model]] (articulated): did you mean `arm/elbow`?"), "{e}");
        let short = RollInput {
            joint: "arm/elbow".into(),
            kind: InputKind::Effort,
            values: vec![0.0; 9],
        };
        let e = rollout(&arm, &[RollStart::default()], &[short], &options)
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with("the input of arm/elbow: 9 values for 1 rolls of 10 steps"),
            "{e}"
        );
        let handle = scene(HANDLE);
        for (starts, want) in [
            (
                BodyStarts {
                    position: Some(vec![Vector3::zeros(); 2]),
                    ..Default::default()
                },
                "position: 2 entries for 1 bodies",
            ),
            (
                BodyStarts {
                    orientation: Some(vec![Quaternion::new(0.0, 0.0, 0.0, 0.0)]),
                    ..Default::default()
                },
                "orientation: body 0: not a rotation (zero or not finite)",
            ),
            (
                BodyStarts {
                    linear_velocity: Some(vec![Vector3::new(f64::NAN, 0.0, 0.0)]),
                    ..Default::default()
                },
                "linear_velocity: body 0: not finite",
            ),
        ] {
            let start = RollStart {
                bodies: starts,
                ..Default::default()
            };
            let e = format!(
                "{:#}",
                rollout(&handle, &[start], &[], &options).unwrap_err()
            );
            assert!(e.ends_with(want), "{e}");
        }
    }
}
