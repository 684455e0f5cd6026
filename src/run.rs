//! The simulation loop: steps a [`World`]'s bodies and hands decimated frames to the sinks.

use crate::record::{BodyState, Frame, Sink};
use crate::scene::World;
use crate::sim::{Bodies, Integrator, StepStats};
use nalgebra::{Isometry3, Vector3};

/// What a run is asked to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSettings {
    pub steps: u64,
    /// Record every Nth step (the initial and the final state are always recorded).
    pub log_every: u64,
    pub gravity: Vector3<f64>,
}

/// What a run did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunSummary {
    pub steps: u64,
    pub frames_recorded: u64,
    pub stats: StepStats,
    /// Total mechanical energy of all bodies at the start and at the end, J.
    pub energy_initial: f64,
    pub energy_final: f64,
    /// Largest change of any body's spatial angular momentum about its centre of mass, relative
    /// to that body's initial |L| (conserved exactly by the variational schemes).
    pub angmom_rel_change_max: f64,
}

/// Simulation time of step `k` in integer nanoseconds. Exact integer arithmetic when `dt_secs`
/// is a whole number of nanoseconds (to 1e-6 ns), else rounded per step.
pub fn time_ns(step: u64, dt_secs: f64) -> i64 {
    let dt_ns = dt_secs * 1e9;
    if (dt_ns - dt_ns.round()).abs() < 1e-6 && dt_ns >= 1.0 {
        step as i64 * dt_ns.round() as i64
    } else {
        (step as f64 * dt_ns).round() as i64
    }
}

/// Reusable buffers turning the batch state into recorded frames.
pub struct FrameBuilder {
    attachments: Vec<crate::scene::Attachment>,
    poses: Vec<Isometry3<f64>>,
    states: Vec<BodyState>,
}

impl FrameBuilder {
    pub fn new(world: &World) -> Self {
        Self {
            attachments: world.attachments.clone(),
            poses: Vec::with_capacity(world.attachments.len()),
            states: Vec::with_capacity(world.bodies.len()),
        }
    }

    /// Fills the buffers from `bodies` and returns the frame of step `step`.
    pub fn frame(
        &mut self,
        bodies: &Bodies,
        gravity: &Vector3<f64>,
        step: u64,
        dt_secs: f64,
    ) -> Frame<'_> {
        self.poses.clear();
        self.poses.extend(
            self.attachments
                .iter()
                .map(|a| bodies.world_from_body(a.body) * a.body_from_link),
        );
        self.states.clear();
        self.states.extend((0..bodies.len()).map(|i| BodyState {
            linvel_world: bodies.linvel_world[i],
            angvel_world: bodies.angvel_world(i),
            angmom_world: bodies.angmom_world(i),
            kinetic_energy: bodies.kinetic_energy(i),
            potential_energy: bodies.potential_energy(i, gravity),
        }));
        Frame {
            step,
            time_ns: time_ns(step, dt_secs),
            world_from_link: &self.poses,
            bodies: &self.states,
        }
    }
}

fn total_energy(bodies: &Bodies, gravity: &Vector3<f64>) -> f64 {
    (0..bodies.len()).map(|i| bodies.energy(i, gravity)).sum()
}

/// Runs the simulation, recording into every sink. Sinks are not finished here: the caller ends
/// the run with [`crate::record::finish_all`].
pub fn run(
    world: &World,
    integrator: &mut dyn Integrator,
    settings: &RunSettings,
    sinks: &mut [Box<dyn Sink>],
) -> anyhow::Result<RunSummary> {
    let mut bodies = Bodies::new(&world.bodies);
    integrator.init(&bodies);
    let dt = integrator.dt();
    let g = settings.gravity;
    let angmom0: Vec<Vector3<f64>> = (0..bodies.len()).map(|i| bodies.angmom_world(i)).collect();
    let mut summary = RunSummary {
        energy_initial: total_energy(&bodies, &g),
        ..Default::default()
    };
    let mut frames = FrameBuilder::new(world);
    let log_every = settings.log_every.max(1);

    let mut record = |bodies: &Bodies, step: u64, summary: &mut RunSummary| -> anyhow::Result<()> {
        let frame = frames.frame(bodies, &g, step, dt);
        for sink in sinks.iter_mut() {
            sink.write(&frame)?;
        }
        summary.frames_recorded += 1;
        Ok(())
    };
    record(&bodies, 0, &mut summary)?;
    for step in 1..=settings.steps {
        let stats = integrator.step(&mut bodies, &g);
        summary.stats = summary.stats.merge(stats);
        if step % log_every == 0 || step == settings.steps {
            record(&bodies, step, &mut summary)?;
        }
    }
    summary.steps = settings.steps;
    summary.energy_final = total_energy(&bodies, &g);
    summary.angmom_rel_change_max = (0..bodies.len())
        .map(|i| {
            let l0 = angmom0[i];
            (bodies.angmom_world(i) - l0).norm() / l0.norm().max(f64::MIN_POSITIVE)
        })
        .fold(0.0, f64::max);
    Ok(summary)
}
