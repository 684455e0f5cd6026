//! The simulation loop: steps a [`World`]'s bodies and hands decimated frames to the sinks.

use crate::record::{BodyState, Frame, Sink};
use crate::scene::World;
use crate::sim::guard::Divergence;
use crate::sim::partition::Partitions;
use crate::sim::{Bodies, Integrator, StepStats};
use nalgebra::{Isometry3, Vector3};
use rayon::prelude::*;

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

/// The state of body `j` of `bodies`, as recorded.
fn body_state(bodies: &Bodies, j: usize, gravity: &Vector3<f64>) -> BodyState {
    BodyState {
        linvel_world: bodies.linvel_world[j],
        angvel_world: bodies.angvel_world(j),
        angmom_world: bodies.angmom_world(j),
        kinetic_energy: bodies.kinetic_energy(j),
        potential_energy: bodies.potential_energy(j, gravity),
    }
}

/// Items per parallel task when a frame is built from partitions.
const FRAME_TASK_ITEMS: usize = 2048;

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
        self.states
            .extend((0..bodies.len()).map(|i| body_state(bodies, i, gravity)));
        Frame {
            step,
            time_ns: time_ns(step, dt_secs),
            world_from_link: &self.poses,
            bodies: &self.states,
        }
    }

    /// [`Self::frame`] from a partitioned batch, built on its threads (same values).
    pub fn frame_of_parts(
        &mut self,
        parts: &Partitions<'_>,
        gravity: &Vector3<f64>,
        step: u64,
        dt_secs: f64,
    ) -> Frame<'_> {
        let identity = Isometry3::identity();
        self.poses.resize(self.attachments.len(), identity);
        self.states.resize(
            parts.len(),
            BodyState {
                linvel_world: Vector3::zeros(),
                angvel_world: Vector3::zeros(),
                angmom_world: Vector3::zeros(),
                kinetic_energy: 0.0,
                potential_energy: 0.0,
            },
        );
        let (attachments, poses, states) = (&self.attachments, &mut self.poses, &mut self.states);
        let view = parts.view();
        let parts = &view;
        view.install(|| {
            poses
                .par_chunks_mut(FRAME_TASK_ITEMS)
                .zip(attachments.par_chunks(FRAME_TASK_ITEMS))
                .for_each(|(poses, attachments)| {
                    for (pose, a) in poses.iter_mut().zip(attachments) {
                        *pose = parts.world_from_body(a.body) * a.body_from_link;
                    }
                });
            states
                .par_chunks_mut(FRAME_TASK_ITEMS)
                .enumerate()
                .for_each(|(c, states)| {
                    for (k, state) in states.iter_mut().enumerate() {
                        let (bodies, j) = parts.body(c * FRAME_TASK_ITEMS + k);
                        *state = body_state(bodies, j, gravity);
                    }
                });
        });
        Frame {
            step,
            time_ns: time_ns(step, dt_secs),
            world_from_link: &self.poses,
            bodies: &self.states,
        }
    }
}

/// Longest run of steps between two meetings of the stepping threads (a recorded step always
/// ends one; so does this many steps, so an interrupt is seen soon).
pub const MAX_WINDOW_STEPS: u64 = 100;

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
    run_partitions(world, vec![integrator], settings, sinks)
}

/// [`run`] on `threads` threads: the batch split into partitions ([`crate::sim::partition`]),
/// each stepped by an integrator from `make`. The recordings are the same bytes for every
/// thread count.
pub fn run_threaded(
    world: &World,
    make: &dyn Fn() -> Box<dyn Integrator>,
    threads: usize,
    settings: &RunSettings,
    sinks: &mut [Box<dyn Sink>],
) -> anyhow::Result<RunSummary> {
    let n = crate::sim::partition::partition_count(world.bodies.len(), threads);
    let mut integrators: Vec<Box<dyn Integrator>> = (0..n).map(|_| make()).collect();
    let borrowed: Vec<&mut dyn Integrator> = integrators
        .iter_mut()
        .map(|b| &mut **b as &mut dyn Integrator)
        .collect();
    run_partitions(world, borrowed, settings, sinks)
}

fn run_partitions(
    world: &World,
    integrators: Vec<&mut dyn Integrator>,
    settings: &RunSettings,
    sinks: &mut [Box<dyn Sink>],
) -> anyhow::Result<RunSummary> {
    let mut parts = Partitions::new(
        &world.bodies,
        integrators,
        settings.divergence_energy_ratio,
        settings.stop_on_newton_failure,
    )?;
    let dt = parts.dt();
    let g = settings.gravity;
    let angmom0: Vec<Vector3<f64>> = (0..parts.len())
        .map(|i| {
            let (bodies, j) = parts.body(i);
            bodies.angmom_world(j)
        })
        .collect();
    let mut summary = RunSummary {
        energy_initial: parts.sum(|b, j| b.energy(j, &g)),
        ..Default::default()
    };
    let mut frames = FrameBuilder::new(world);
    let log_every = settings.log_every.max(1);

    let mut record =
        |parts: &Partitions<'_>, step: u64, summary: &mut RunSummary| -> anyhow::Result<()> {
            let frame = frames.frame_of_parts(parts, &g, step, dt);
            for sink in sinks.iter_mut() {
                sink.write(&frame)?;
            }
            summary.frames_recorded += 1;
            summary.last_recorded_step = step;
            Ok(())
        };
    record(&parts, 0, &mut summary)?;
    summary.steps = settings.steps;
    let mut step = 0;
    while step < settings.steps {
        let next_record = (step / log_every + 1) * log_every;
        let end = next_record.min(settings.steps).min(step + MAX_WINDOW_STEPS);
        let window = parts.advance(step, end, &g);
        summary.stats = summary.stats.merge(window.stats);
        if let Some(stop) = window.stop {
            summary.stopped = Some(stop);
            summary.steps = stop.step - 1;
            return Ok(summary);
        }
        step = end;
        let stop = settings.stop_on_interrupt && crate::interrupt::requested();
        if step % log_every == 0 || step == settings.steps || stop {
            record(&parts, step, &mut summary)?;
        }
        if stop {
            summary.interrupted = Some(crate::interrupt::signal());
            summary.steps = step;
            break;
        }
    }
    summary.energy_final = parts.sum(|b, j| b.energy(j, &g));
    summary.angmom_rel_change_max = (0..parts.len())
        .map(|i| {
            let l0 = angmom0[i];
            let (bodies, j) = parts.body(i);
            (bodies.angmom_world(j) - l0).norm() / l0.norm().max(f64::MIN_POSITIVE)
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
