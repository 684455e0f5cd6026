//! The simulation loop: steps a [`World`]'s bodies and hands decimated frames to the sinks.

use crate::budget::readable;
use crate::record::{BodyState, Frame, FramePool, JointState, MechanismState, OwnedFrame, Sink};
use crate::scene::World;
use crate::sim::guard::Divergence;
use crate::sim::mechanism::Mechanism;
use crate::sim::mechanism::project::Reporter;
use crate::sim::partition::Partitions;
use crate::sim::{Bodies, BodyInit, Integrator, Loads, StepStats};
use nalgebra::{Isometry3, Vector3};
use rayon::prelude::*;
use std::sync::Arc;

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

/// A joint position for a warning: six decimals, or [`readable`] when that would be more
/// than a few dozen digits.
fn position_text(p: f64) -> String {
    if p.abs() < 1e15 {
        format!("{p:.6}")
    } else {
        readable(p)
    }
}

/// Reusable buffers turning the batch state into recorded frames.
///
/// Free bodies report their carried state. Bodies of an articulated model report the momenta
/// projected onto the velocity constraints ([`crate::sim::mechanism::project`]), and each such
/// model its joint coordinates and totals; compound joints' massless links are placed from the
/// report. A joint found outside its URDF range at a recorded step is warned about once (on
/// standard error), naming the joint and the time.
pub struct FrameBuilder {
    attachments: Arc<Vec<crate::scene::Attachment>>,
    interior: Vec<crate::scene::InteriorFrame>,
    mechanisms: Vec<(Arc<Mechanism>, Reporter)>,
    /// Per mechanism, once a partitioned batch was seen: its partition and itself re-based to
    /// it ([`crate::sim::partition::rebase`]).
    located: Vec<(usize, Mechanism)>,
    /// Per mechanism: its bodies and joints in the layout.
    mechanism_ranges: Vec<(std::ops::Range<usize>, std::ops::Range<usize>)>,
    joint_names: Vec<String>,
    warned_range: Vec<bool>,
    /// The frames built: each is written once, straight into a buffer the sinks then share
    /// ([`FrameBuilder::shared`], [`crate::record::owned_frame`]).
    pool: FramePool,
}

/// The state of body `j` of `bodies`, as recorded.
fn body_state(bodies: &Bodies, j: usize, loads: &Loads) -> BodyState {
    BodyState {
        linvel_world: bodies.linvel_world[j],
        angvel_world: bodies.angvel_world(j),
        angmom_world: bodies.angmom_world(j),
        kinetic_energy: bodies.kinetic_energy(j),
        potential_energy: bodies.potential_energy(j, loads),
    }
}

/// Items per parallel task when a frame is built from partitions.
const FRAME_TASK_ITEMS: usize = 2048;

/// A body state of zeros (the slots of a new frame buffer, all overwritten).
const NO_STATE: BodyState = BodyState {
    linvel_world: Vector3::new(0.0, 0.0, 0.0),
    angvel_world: Vector3::new(0.0, 0.0, 0.0),
    angmom_world: Vector3::new(0.0, 0.0, 0.0),
    kinetic_energy: 0.0,
    potential_energy: 0.0,
};

impl FrameBuilder {
    pub fn new(world: &World) -> Self {
        let mechanisms: Vec<_> = world
            .mechanisms
            .iter()
            .map(|m| (Arc::clone(m), Reporter::new(m)))
            .collect();
        let mechanism_ranges = world
            .layout
            .mechanisms
            .iter()
            .map(|m| (m.bodies.clone(), m.joints.clone()))
            .collect();
        Self {
            attachments: Arc::clone(&world.attachments),
            interior: world.interior_frames.clone(),
            mechanisms,
            located: Vec::new(),
            mechanism_ranges,
            joint_names: world.layout.joints.iter().map(|j| j.name.clone()).collect(),
            warned_range: vec![false; world.layout.joints.len()],
            pool: FramePool::default(),
        }
    }

    /// A free frame buffer for step `step`, sized for `bodies` bodies (every slot is then
    /// written).
    fn start(pool: &mut FramePool, sizes: [usize; 4], step: u64, time_ns: i64) -> &mut OwnedFrame {
        let out = pool.next_free();
        out.step = step;
        out.time_ns = time_ns;
        out.world_from_link.resize(sizes[0], Isometry3::identity());
        out.bodies.resize(sizes[1], NO_STATE);
        out.joints.resize(sizes[2], JointState::default());
        out.mechanisms.resize(sizes[3], MechanismState::default());
        out
    }

    fn sizes(&self, bodies: usize) -> [usize; 4] {
        [
            self.attachments.len(),
            bodies,
            self.joint_names.len(),
            self.mechanisms.len(),
        ]
    }

    /// The last frame built.
    fn last(&self) -> Frame<'_> {
        self.pool.current().expect("a frame was built").as_frame()
    }

    /// The last frame built, as the buffer the sinks share ([`Sink::write_shared`]).
    pub fn shared(&mut self) -> &Arc<OwnedFrame> {
        self.pool.shared()
    }

    /// Fills a frame buffer from `bodies` and returns the frame of step `step`.
    pub fn frame(&mut self, bodies: &Bodies, loads: &Loads, step: u64, dt_secs: f64) -> Frame<'_> {
        let time_ns = time_ns(step, dt_secs);
        let time_secs = time_ns as f64 / 1e9;
        let sizes = self.sizes(bodies.len());
        let mut pool = std::mem::take(&mut self.pool);
        let out = Self::start(&mut pool, sizes, step, time_ns);
        for (pose, a) in out.world_from_link.iter_mut().zip(self.attachments.iter()) {
            *pose = if a.body == crate::scene::Attachment::WORLD {
                a.body_from_link
            } else {
                bodies.world_from_body(a.body) * a.body_from_link
            };
        }
        for (i, state) in out.bodies.iter_mut().enumerate() {
            *state = body_state(bodies, i, loads);
        }
        for k in 0..self.mechanisms.len() {
            let (model, reporter) = &mut self.mechanisms[k];
            reporter.report(model, bodies, loads, time_secs);
            let model = Arc::clone(model);
            self.write_mechanism(out, k, &model, bodies, 0, loads, time_secs);
        }
        self.place_interior_frames(out);
        self.pool = pool;
        self.last()
    }

    /// Copies mechanism `k`'s last report into the frame `out`: its bodies' projected states
    /// (`model` is the mechanism as `bodies` index it, `offset` the batch index of `bodies`'
    /// first body), joints and totals; warns once per joint found outside its URDF range.
    #[allow(clippy::too_many_arguments)]
    fn write_mechanism(
        &mut self,
        out: &mut OwnedFrame,
        k: usize,
        model: &Mechanism,
        bodies: &Bodies,
        offset: usize,
        loads: &Loads,
        time_secs: f64,
    ) {
        let report = &self.mechanisms[k].1.report;
        for (i, gi) in model.bodies().enumerate() {
            let q = bodies.world_from_body[gi];
            let m = report.angmom_body[i];
            let omega = m.component_mul(&bodies.inv_inertia_body[gi]);
            let v = report.linvel_world[i];
            let mass = bodies.mass[gi];
            out.bodies[offset + gi] = BodyState {
                linvel_world: v,
                angvel_world: q * omega,
                angmom_world: q * m,
                kinetic_energy: 0.5 * mass * v.norm_squared() + 0.5 * m.dot(&omega),
                potential_energy: bodies.potential_energy(gi, loads),
            };
        }
        let joints = self.mechanism_ranges[k].1.clone();
        for (c, j) in joints.enumerate() {
            out.joints[j] = JointState {
                position: report.position[c],
                velocity: report.velocity[c],
            };
            if let Some([lo, hi]) = model.coordinates[c].limits {
                let p = report.position[c];
                if !self.warned_range[j] && !(lo..=hi).contains(&p) {
                    self.warned_range[j] = true;
                    eprintln!(
                        "warning: joint {:?} left its URDF range [{}, {}] at t = {} s \
                         (position {}); joint limits are not modelled (docs/mechanisms.md)",
                        self.joint_names[j],
                        readable(lo),
                        readable(hi),
                        readable(time_secs),
                        position_text(p)
                    );
                }
            }
        }
        let t = &report.totals;
        out.mechanisms[k] = MechanismState {
            linear_momentum: t.linear_momentum,
            angular_momentum: t.angular_momentum,
            com: t.com,
            kinetic_energy: t.kinetic_energy,
            potential_energy: t.potential_energy,
            residual_m: t.residual_m,
            residual_rad: t.residual_rad,
        };
    }

    /// Places the compound joints' massless links of `out` from the last reports.
    fn place_interior_frames(&self, out: &mut OwnedFrame) {
        for f in &self.interior {
            let report = &self.mechanisms[f.mechanism].1.report;
            out.world_from_link[f.frame] =
                report.interior_world_from_link[f.interior] * f.interior_from_link;
        }
    }

    /// [`Self::frame`] from a partitioned batch, built on its threads (same values).
    pub fn frame_of_parts(
        &mut self,
        batch: &Partitions<'_>,
        loads: &Loads,
        step: u64,
        dt_secs: f64,
    ) -> Frame<'_> {
        let time_ns = time_ns(step, dt_secs);
        let sizes = self.sizes(batch.len());
        let mut pool = std::mem::take(&mut self.pool);
        let out = Self::start(&mut pool, sizes, step, time_ns);
        let attachments = &self.attachments;
        let view = batch.view();
        let parts = &view;
        let (poses, states) = (&mut out.world_from_link, &mut out.bodies);
        let place = |(poses, attachments): (&mut [Isometry3<f64>], &[crate::scene::Attachment])| {
            for (pose, a) in poses.iter_mut().zip(attachments) {
                *pose = if a.body == crate::scene::Attachment::WORLD {
                    a.body_from_link
                } else {
                    parts.world_from_body(a.body) * a.body_from_link
                };
            }
        };
        let fill = |(c, states): (usize, &mut [BodyState])| {
            for (k, state) in states.iter_mut().enumerate() {
                let (bodies, j) = parts.body(c * FRAME_TASK_ITEMS + k);
                *state = body_state(bodies, j, loads);
            }
        };
        // On the stepping pool's threads, or here on one thread (`View::is_threaded`).
        if view.is_threaded() {
            view.install(|| {
                poses
                    .par_chunks_mut(FRAME_TASK_ITEMS)
                    .zip(attachments.par_chunks(FRAME_TASK_ITEMS))
                    .for_each(place);
                states
                    .par_chunks_mut(FRAME_TASK_ITEMS)
                    .enumerate()
                    .for_each(fill);
            });
        } else {
            poses
                .chunks_mut(FRAME_TASK_ITEMS)
                .zip(attachments.chunks(FRAME_TASK_ITEMS))
                .for_each(place);
            states
                .chunks_mut(FRAME_TASK_ITEMS)
                .enumerate()
                .for_each(fill);
        }
        if !self.mechanisms.is_empty() {
            let time_secs = time_ns as f64 / 1e9;
            if self.located.len() != self.mechanisms.len() {
                self.located = self
                    .mechanisms
                    .iter()
                    .map(|(m, _)| {
                        let k = batch.part_of(m.first_body);
                        let start = batch.parts[k].first;
                        let range = start..start + batch.parts[k].bodies.len();
                        let local = crate::sim::partition::rebase(std::slice::from_ref(m), &range);
                        (k, Mechanism::clone(&local[0]))
                    })
                    .collect();
            }
            // The reports (projections, coordinates) on the pool, one task per mechanism; then
            // copied into the frame in order (warnings in joint order).
            let located = &self.located;
            let report = |((_, reporter), (k, local)): (
                &mut (Arc<Mechanism>, Reporter),
                &(usize, Mechanism),
            )| {
                reporter.report(local, view.part(*k), loads, time_secs);
            };
            if view.is_threaded() {
                view.install(|| {
                    self.mechanisms
                        .par_iter_mut()
                        .zip(located.par_iter())
                        .for_each(report);
                });
            } else {
                self.mechanisms.iter_mut().zip(located).for_each(report);
            }
            let located = std::mem::take(&mut self.located);
            for (m, (k, local)) in located.iter().enumerate() {
                let part = &batch.parts[*k];
                self.write_mechanism(out, m, local, &part.bodies, part.first, loads, time_secs);
            }
            self.located = located;
            self.place_interior_frames(out);
        }
        self.pool = pool;
        self.last()
    }

    /// Total mechanical energy of the last frame built (reported states), J.
    pub fn total_energy(&self) -> f64 {
        self.last()
            .bodies
            .iter()
            .map(|s| s.kinetic_energy + s.potential_energy)
            .sum()
    }

    /// Angular momenta whose conservation the run summary checks, from the last frame built:
    /// every free body's (about its centre of mass) and every floating articulated model's
    /// total (about the model's centre of mass); fixed-base models are held by the world and
    /// left out.
    pub fn conserved_angmom(&self, out: &mut Vec<Vector3<f64>>) {
        out.clear();
        let last = self.last();
        let mut in_mechanism = vec![false; last.bodies.len()];
        for (k, (model, _)) in self.mechanisms.iter().enumerate() {
            for i in model.bodies() {
                in_mechanism[i] = true;
            }
            if model.base == crate::sim::mechanism::Base::Floating {
                out.push(last.mechanisms[k].angular_momentum);
            }
        }
        out.extend(
            last.bodies
                .iter()
                .zip(&in_mechanism)
                .filter(|(_, m)| !**m)
                .map(|(s, _)| s.angmom_world),
        );
    }
}

/// Longest run of steps between two meetings of the stepping threads (a recorded step always
/// ends one; so does this many steps, so an interrupt is seen soon).
pub const MAX_WINDOW_STEPS: u64 = 100;

/// Runs the simulation, recording into every sink. Sinks are not finished here: the caller ends
/// the run with [`crate::record::finish_all`]. After every step the [`Guard`] checks each body;
/// a non-finite or diverging body ends the run early with [`RunSummary::stopped`] set (an `Ok`:
/// what was recorded is good and is to be finished), so no bad state reaches a sink.
/// `integrator` steps the whole batch, mechanisms included ([`World::integrator`]).
pub fn run(
    world: &World,
    integrator: &mut dyn Integrator,
    settings: &RunSettings,
    sinks: &mut [Box<dyn Sink>],
) -> anyhow::Result<RunSummary> {
    let whole = 0..world.bodies.len();
    run_partitions(
        world,
        Inits::Borrowed(&world.bodies),
        vec![whole],
        vec![integrator],
        1,
        vec![world.mechanisms.clone()],
        settings,
        sinks,
    )
}

/// One partition of a threaded run, as its integrator is made for it.
#[derive(Debug, Clone)]
pub struct PartSpec<'a> {
    /// Its bodies in the batch.
    pub range: std::ops::Range<usize>,
    /// Its mechanisms, re-based to the partition ([`crate::sim::partition::rebase`]).
    pub mechanisms: &'a [Arc<Mechanism>],
}

/// [`run`] on `threads` threads: the batch cut into partitions between mechanisms
/// ([`crate::sim::partition::ranges`]), each stepped by the integrator `make` builds for it.
/// The recordings are the same bytes for every thread count.
pub fn run_parts(
    world: &World,
    make: &dyn Fn(&PartSpec<'_>) -> anyhow::Result<Box<dyn Integrator>>,
    threads: usize,
    settings: &RunSettings,
    sinks: &mut [Box<dyn Sink>],
) -> anyhow::Result<RunSummary> {
    run_parts_from(
        world,
        Inits::Borrowed(&world.bodies),
        make,
        threads,
        settings,
        sinks,
    )
}

/// The initial states a run starts from: the world's own (borrowed), or taken out of the world
/// (owned: dropped as soon as the partitions hold them, so the run does not keep the
/// 136 bytes per body of [`BodyInit`] beside the stepping batch's own 160).
pub type Inits<'a> = std::borrow::Cow<'a, [BodyInit]>;

/// [`run_parts`] from `inits`, the initial states of `world`'s bodies given apart from it
/// (`world.bodies` may be empty then: `simulate` moves them out, [`Inits`]).
pub fn run_parts_from(
    world: &World,
    inits: Inits<'_>,
    make: &dyn Fn(&PartSpec<'_>) -> anyhow::Result<Box<dyn Integrator>>,
    threads: usize,
    settings: &RunSettings,
    sinks: &mut [Box<dyn Sink>],
) -> anyhow::Result<RunSummary> {
    let mechanism_ranges: Vec<_> = world.mechanisms.iter().map(|m| m.bodies()).collect();
    let ranges = crate::sim::partition::ranges(inits.len(), threads, &mechanism_ranges);
    let mechanisms: Vec<Vec<Arc<Mechanism>>> = ranges
        .iter()
        .map(|r| crate::sim::partition::rebase(&world.mechanisms, r))
        .collect();
    let mut integrators = ranges
        .iter()
        .zip(&mechanisms)
        .map(|(range, mechanisms)| {
            make(&PartSpec {
                range: range.clone(),
                mechanisms,
            })
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let borrowed: Vec<&mut dyn Integrator> = integrators
        .iter_mut()
        .map(|b| &mut **b as &mut dyn Integrator)
        .collect();
    run_partitions(
        world, inits, ranges, borrowed, threads, mechanisms, settings, sinks,
    )
}

/// [`run_parts`] of a scene without mechanisms, every partition's integrator from `make`.
pub fn run_threaded(
    world: &World,
    make: &dyn Fn() -> Box<dyn Integrator>,
    threads: usize,
    settings: &RunSettings,
    sinks: &mut [Box<dyn Sink>],
) -> anyhow::Result<RunSummary> {
    run_threaded_ranges(world, &|_| make(), threads, settings, sinks)
}

/// [`run_threaded`] with integrators made for the bodies they step: `make(range)` builds the
/// integrator of the partition holding bodies `range` of the batch (per-body substep factors,
/// [`crate::sim::accuracy`]). For scenes without mechanisms (an error otherwise: use
/// [`run_parts`]).
pub fn run_threaded_ranges(
    world: &World,
    make: &dyn Fn(std::ops::Range<usize>) -> Box<dyn Integrator>,
    threads: usize,
    settings: &RunSettings,
    sinks: &mut [Box<dyn Sink>],
) -> anyhow::Result<RunSummary> {
    anyhow::ensure!(
        world.mechanisms.is_empty(),
        "a scene with articulated models runs with run_parts (its integrators step mechanisms)"
    );
    run_parts(
        world,
        &|part| Ok(make(part.range.clone())),
        threads,
        settings,
        sinks,
    )
}

#[allow(clippy::too_many_arguments)]
fn run_partitions(
    world: &World,
    inits: Inits<'_>,
    ranges: Vec<std::ops::Range<usize>>,
    integrators: Vec<&mut dyn Integrator>,
    threads: usize,
    mechanisms: Vec<Vec<Arc<Mechanism>>>,
    settings: &RunSettings,
    sinks: &mut [Box<dyn Sink>],
) -> anyhow::Result<RunSummary> {
    let g = Loads::uniform_gravity(settings.gravity);
    let mut parts = Partitions::with_ranges(
        &inits,
        &ranges,
        integrators,
        threads,
        &mechanisms,
        &g,
        settings.divergence_energy_ratio,
        settings.stop_on_newton_failure,
    )?;
    // The partitions hold the states now; owned initial states are freed here.
    drop(inits);
    let dt = parts.dt();
    // With articulated models the summary's energy and momenta are the reported ones
    // (projected momenta; a mechanism's total angular momentum), read from the recorded frames.
    let articulated = !world.mechanisms.is_empty();
    let mut angmom0: Vec<Vector3<f64>> = (0..parts.len())
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

    let mut record = |frames: &mut FrameBuilder,
                      parts: &Partitions<'_>,
                      step: u64,
                      summary: &mut RunSummary|
     -> anyhow::Result<()> {
        frames.frame_of_parts(parts, &g, step, dt);
        // Every sink gets the one buffer the frame was built in (a pipelined sink queues it
        // without a copy).
        let frame = frames.shared();
        for sink in sinks.iter_mut() {
            sink.write_shared(frame)?;
        }
        summary.frames_recorded += 1;
        summary.last_recorded_step = step;
        Ok(())
    };
    record(&mut frames, &parts, 0, &mut summary)?;
    if articulated {
        summary.energy_initial = frames.total_energy();
        frames.conserved_angmom(&mut angmom0);
    }
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
            record(&mut frames, &parts, step, &mut summary)?;
        }
        if stop {
            summary.interrupted = Some(crate::interrupt::signal());
            summary.steps = step;
            break;
        }
    }
    let angmom1: Vec<Vector3<f64>> = if articulated {
        // The last step is always recorded: the frame builder holds the final state.
        summary.energy_final = frames.total_energy();
        let mut l = Vec::new();
        frames.conserved_angmom(&mut l);
        l
    } else {
        summary.energy_final = parts.sum(|b, j| b.energy(j, &g));
        (0..parts.len())
            .map(|i| {
                let (bodies, j) = parts.body(i);
                bodies.angmom_world(j)
            })
            .collect()
    };
    summary.angmom_rel_change_max = angmom0
        .iter()
        .zip(&angmom1)
        .map(|(l0, l1)| (l1 - l0).norm() / l0.norm().max(f64::MIN_POSITIVE))
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
