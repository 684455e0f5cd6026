//! The simulation loop: steps a [`World`]'s bodies and hands decimated frames to the sinks.

use crate::record::{BodyState, Frame, Sink};
use crate::scene::World;
use crate::sim::guard::{Divergence, Guard};
use crate::sim::{Bodies, Integrator, StepStats};
use nalgebra::{Isometry3, Vector3};

/// What a run is asked to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSettings {
    pub steps: u64,
    /// Record every Nth step (the initial and the final state are always recorded).
    pub log_every: u64,
    pub gravity: Vector3<f64>,
    /// A body whose rotational kinetic energy exceeds this multiple of its initial value stops
    /// the run ([`crate::sim::guard`]).
    pub divergence_energy_ratio: f64,
    /// `Some(max_substeps)`: substepping is on, so a Newton failure is final and stops the run.
    pub stop_on_newton_failure: Option<u32>,
    /// Stop after the current step when SIGINT/SIGTERM arrives ([`crate::interrupt`]): the
    /// step is recorded and [`RunSummary::interrupted`] set. Off in `Scene::run_settings` (a
    /// library caller decides); `simulate` turns it on.
    pub stop_on_interrupt: bool,
}

/// What a run did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunSummary {
    pub steps: u64,
    /// The last step recorded.
    pub last_recorded_step: u64,
    pub frames_recorded: u64,
    pub stats: StepStats,
    /// Total mechanical energy of all bodies at the start and at the end, J.
    pub energy_initial: f64,
    pub energy_final: f64,
    /// Largest change of any body's spatial angular momentum about its centre of mass, relative
    /// to that body's initial |L| (conserved exactly by the variational schemes).
    pub angmom_rel_change_max: f64,
    /// Set when the guard stopped the run: `steps` is then the last good step, and the
    /// recordings end at the last recorded step before it.
    pub stopped: Option<Divergence>,
    /// Set when SIGINT/SIGTERM stopped the run (the signal number; 0 for a request from code):
    /// `steps` is then the last step done, and it was recorded.
    pub interrupted: Option<i32>,
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
/// the run with [`crate::record::finish_all`]. After every step the [`Guard`] checks each body;
/// a non-finite or diverging body ends the run early with [`RunSummary::stopped`] set (an `Ok`:
/// what was recorded is good and is to be finished), so no bad state reaches a sink.
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
    let guard = Guard::new(
        &bodies,
        settings.divergence_energy_ratio,
        settings.stop_on_newton_failure,
    );
    let mut frames = FrameBuilder::new(world);
    let log_every = settings.log_every.max(1);

    let mut record = |bodies: &Bodies, step: u64, summary: &mut RunSummary| -> anyhow::Result<()> {
        let frame = frames.frame(bodies, &g, step, dt);
        for sink in sinks.iter_mut() {
            sink.write(&frame)?;
        }
        summary.frames_recorded += 1;
        summary.last_recorded_step = step;
        Ok(())
    };
    record(&bodies, 0, &mut summary)?;
    summary.steps = settings.steps;
    for step in 1..=settings.steps {
        let stats = integrator.step(&mut bodies, &g);
        summary.stats = summary.stats.merge(stats);
        if let Some(stop) = guard.check(&bodies, &stats, step) {
            summary.stopped = Some(stop);
            summary.steps = step - 1;
            return Ok(summary);
        }
        let stop = settings.stop_on_interrupt && crate::interrupt::requested();
        if step % log_every == 0 || step == settings.steps || stop {
            record(&bodies, step, &mut summary)?;
        }
        if stop {
            summary.interrupted = Some(crate::interrupt::signal());
            summary.steps = step;
            break;
        }
    }
    summary.energy_final = total_energy(&bodies, &g);
    summary.angmom_rel_change_max = (0..bodies.len())
        .map(|i| {
            let l0 = angmom0[i];
            (bodies.angmom_world(i) - l0).norm() / l0.norm().max(f64::MIN_POSITIVE)
        })
        .fold(0.0, f64::max);
    Ok(summary)
}

/// The error of a run the guard stopped ([`RunSummary::stopped`]), after its recordings were
/// finished. `tumble` exits with status 3 on it.
#[derive(Debug, Clone)]
pub struct Diverged {
    pub divergence: Divergence,
    /// The body's name (its frame id).
    pub body_name: String,
    pub dt_secs: f64,
    /// Steps recorded, the last one.
    pub last_recorded_step: u64,
    /// The finished recordings.
    pub outputs: Vec<std::path::PathBuf>,
}

impl std::fmt::Display for Diverged {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let d = &self.divergence;
        write!(
            f,
            "body {:?} (index {}) failed at step {} (t = {} s): {}. The run stopped after step {}; \
             the recordings end at step {} (t = {} s) and are complete and readable:",
            self.body_name,
            d.body,
            d.step,
            time_ns(d.step, self.dt_secs) as f64 / 1e9,
            d.cause,
            d.step.saturating_sub(1),
            self.last_recorded_step,
            time_ns(self.last_recorded_step, self.dt_secs) as f64 / 1e9,
        )?;
        for path in &self.outputs {
            write!(f, " {}", path.display())?;
        }
        Ok(())
    }
}

impl std::error::Error for Diverged {}
