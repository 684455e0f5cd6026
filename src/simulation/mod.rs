//! A running simulation, as a library object: built from a [`World`], stepped `n` steps at a
//! time, read between steps, recorded into the sinks attached to it, finished.
//!
//! ```text
//! let mut sim = Simulation::of_world(&world, kind, dt, &variational, threads, &settings)?;
//! sim.attach(sink)?;                  // before the first step
//! sim.advance(100)?;                  // steps 1..=100, recording every log_every-th
//! let pose = sim.view().world_from_body(0);
//! let summary = sim.finish(&outputs)?; // the final totals; every sink's files published
//! ```
//!
//! It owns everything a run needs: the partitions of the batch with their integrators and
//! guards ([`crate::sim::partition`]), the frame builder, the sinks. The stepping is the one
//! `simulate` always did: frame 0 recorded first, then windows of at most
//! [`MAX_WINDOW_STEPS`] steps ending at every recorded step, the guard after every step, an
//! interrupt seen at a window's end. How far each call to [`Simulation::advance`] goes does not
//! change a bit of what is recorded: the partitions step the same steps in the same order, and
//! only the steps `log_every` names (and the last) are recorded.

pub mod files;
mod frames;
pub mod inputs;
pub mod rollout;
mod summary;
#[cfg(test)]
mod tests;

pub use files::{AccuracyReport, Outputs, SimulateOptions, output_paths, simulate, simulate_world};
pub use frames::{FrameBuilder, contact_states};
pub use summary::{
    AT_REST, BALANCE_FLOOR, BALANCE_OPEN_WARN, Diverged, EnergyBalance, RunSummary, time_ns,
};

use crate::record::{OwnedFrame, Sink};
use crate::sim::integrators::{IntegratorKind, VariationalSettings};
use crate::sim::mechanism::Mechanism;
use crate::sim::partition::{Partitions, View};
use crate::sim::{BodyInit, Integrator, Loads, RunSettings};
use crate::world::World;
use nalgebra::Vector3;
use std::sync::Arc;

/// Longest run of steps between two meetings of the stepping threads (a recorded step always
/// ends one; so does this many steps, so an interrupt is seen soon).
pub const MAX_WINDOW_STEPS: u64 = 100;

/// The initial states a run starts from: the world's own (borrowed), or taken out of the world
/// (owned: dropped as soon as the partitions hold them, so the run does not keep the
/// 136 bytes per body of [`BodyInit`] beside the stepping batch's own 160).
pub type Inits<'a> = std::borrow::Cow<'a, [BodyInit]>;

/// One partition of a run, as its integrator is made for it.
#[derive(Debug, Clone)]
pub struct PartSpec<'a> {
    /// Its bodies in the batch.
    pub range: std::ops::Range<usize>,
    /// Its mechanisms, re-based to the partition ([`crate::sim::partition::rebase`]).
    pub mechanisms: &'a [Arc<Mechanism>],
}

/// Where a simulation stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// Steps remain.
    Running,
    /// Every step of [`RunSettings::steps`] is done.
    Done,
    /// The guard stopped the run ([`RunSummary::stopped`]).
    Stopped,
    /// A signal stopped the run ([`RunSummary::interrupted`]).
    Interrupted,
}

/// A simulation: see the module doc.
pub struct Simulation {
    parts: Partitions<'static>,
    frames: FrameBuilder,
    sinks: Vec<Box<dyn Sink>>,
    settings: RunSettings,
    /// What acts on the bodies during a step (gravity today).
    loads: Loads,
    /// The last step done.
    step: u64,
    /// The step the frame builder last built (`None` before the first).
    built: Option<u64>,
    /// Whether frame 0 went to the sinks.
    started: bool,
    progress: Progress,
    /// With mechanisms, the reported energy and momenta (read from the recorded frames).
    articulated: bool,
    /// Per conserved quantity, its initial angular momentum ([`RunSummary::angmom_rel_change_max`]).
    angmom0: Vec<Vector3<f64>>,
    /// Per conserved quantity, whether it started at rest ([`summary::AT_REST`]).
    at_rest: Vec<bool>,
    summary: RunSummary,
}

impl Simulation {
    /// A simulation of `world` from the initial states `inits` (`world.bodies`, or the same
    /// states moved out of it: [`Inits`]), on `threads` threads: the batch cut into partitions
    /// between mechanisms ([`crate::sim::partition::ranges`]), each stepped by the integrator
    /// `make` builds for it (an error there, e.g. an integrator a mechanism cannot use, is
    /// returned before anything is stepped or written).
    pub fn new(
        world: &World,
        inits: Inits<'_>,
        make: &dyn Fn(&PartSpec<'_>) -> anyhow::Result<Box<dyn Integrator>>,
        threads: usize,
        settings: &RunSettings,
    ) -> anyhow::Result<Self> {
        // The recorders learn what drives the joints, and whether there is a ground and
        // contacts, from the layout alone.
        world.check_drive_layout()?;
        world.check_contact_layout()?;
        let mechanism_ranges: Vec<_> = world.mechanisms.iter().map(|m| m.bodies()).collect();
        let ranges = crate::sim::partition::ranges(inits.len(), threads, &mechanism_ranges);
        let mechanisms: Vec<Vec<Arc<Mechanism>>> = ranges
            .iter()
            .map(|r| crate::sim::partition::rebase(&world.mechanisms, r))
            .collect();
        let integrators = ranges
            .iter()
            .zip(&mechanisms)
            .map(|(range, mechanisms)| {
                make(&PartSpec {
                    range: range.clone(),
                    mechanisms,
                })
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let loads = world.loads(settings.gravity);
        let mut parts = Partitions::with_ranges(
            &inits,
            &ranges,
            integrators,
            threads,
            &mechanisms,
            &loads,
            settings.divergence_energy_ratio,
            settings.stop_on_newton_failure,
        )?;
        parts.set_contact(world.contact.clone(), &world.mechanisms)?;
        // The partitions hold the states now; owned initial states are freed here.
        drop(inits);
        let articulated = !world.mechanisms.is_empty();
        let angmom0 = (0..parts.len())
            .map(|i| {
                let (bodies, j) = parts.body(i);
                bodies.angmom_world(j)
            })
            .collect();
        let summary = RunSummary {
            energy_initial: parts.sum(|b, j| b.energy(j, &loads)),
            steps: settings.steps,
            ..Default::default()
        };
        let mut frames = FrameBuilder::new(world);
        frames.set_quiet(settings.quiet);
        let mut sim = Self {
            parts,
            frames,
            sinks: Vec::new(),
            settings: *settings,
            loads,
            step: 0,
            built: None,
            started: false,
            progress: Progress::Running,
            articulated,
            angmom0,
            at_rest: Vec::new(),
            summary,
        };
        // Frame 0 is built now (an articulated run's initial totals are the reported ones);
        // it reaches the sinks before the first step.
        sim.build_frame();
        if articulated {
            sim.summary.energy_initial = sim.frames.total_energy();
            let parts = &sim.parts;
            sim.frames
                .conserved_angmom(&mut sim.angmom0, &|i| parts.collides(i));
        }
        let body_scale = |i: usize| {
            let (bodies, j) = sim.parts.body(i);
            bodies.inertia_body[j].max() * 1.0
        };
        let scales: Vec<f64> = if articulated {
            let parts = &sim.parts;
            sim.frames
                .conserved_scales(&|i| parts.collides(i), &body_scale)
        } else {
            (0..sim.parts.len()).map(body_scale).collect()
        };
        sim.at_rest = sim
            .angmom0
            .iter()
            .zip(&scales)
            .map(|(l0, scale)| l0.norm() <= summary::AT_REST * scale)
            .collect();
        sim.summary.fixed_base = world
            .mechanisms
            .iter()
            .any(|m| m.base == crate::sim::mechanism::Base::Fixed);
        if settings.steps == 0 {
            sim.progress = Progress::Done;
        }
        Ok(sim)
    }

    /// [`Simulation::new`] from the world's own initial states, every partition stepped by
    /// `kind` at `dt_secs` ([`crate::sim::integrator_for`]: the articulated stepper where the
    /// partition holds mechanisms).
    pub fn of_world(
        world: &World,
        kind: IntegratorKind,
        dt_secs: f64,
        variational: &VariationalSettings,
        threads: usize,
        settings: &RunSettings,
    ) -> anyhow::Result<Self> {
        Self::new(
            world,
            Inits::Borrowed(&world.bodies),
            &|part| {
                crate::sim::integrator_for(
                    kind,
                    dt_secs,
                    variational,
                    part.mechanisms,
                    part.range.len(),
                )
            },
            threads,
            settings,
        )
    }

    /// [`Simulation::new`] from `inits` with `scene`'s integrator at its step on `threads`
    /// threads (a `simulate` run, a Python simulation, a rollout's roll).
    pub fn of_scene(
        scene: &crate::scene::Scene,
        world: &World,
        inits: Inits<'_>,
        threads: usize,
        settings: &RunSettings,
    ) -> anyhow::Result<Self> {
        let (kind, dt, variational) = (
            scene.integrator(),
            scene.sim.dt,
            scene.variational_settings(),
        );
        Self::new(
            world,
            inits,
            &|part| {
                crate::sim::integrator_for(
                    kind,
                    dt,
                    &variational,
                    part.mechanisms,
                    part.range.len(),
                )
            },
            threads,
            settings,
        )
    }

    /// [`Simulation::new`] with one partition stepped by `integrator` on this thread (e.g. an
    /// integrator made by hand, or one that needs the whole batch).
    pub fn with_integrator(
        world: &World,
        integrator: Box<dyn Integrator>,
        settings: &RunSettings,
    ) -> anyhow::Result<Self> {
        let slot = std::sync::Mutex::new(Some(integrator));
        Self::new(
            world,
            Inits::Borrowed(&world.bodies),
            &|_| {
                slot.lock()
                    .expect("not poisoned")
                    .take()
                    .ok_or_else(|| anyhow::anyhow!("one integrator steps one partition"))
            },
            1,
            settings,
        )
    }

    /// Adds a sink: it receives frame 0 and every recorded frame after it. Only before the
    /// first step (a sink attached later would miss frames; an error then).
    pub fn attach(&mut self, sink: Box<dyn Sink>) -> anyhow::Result<()> {
        anyhow::ensure!(
            !self.started,
            "a sink can only be attached before the first step (the simulation is at step {})",
            self.step
        );
        self.sinks.push(sink);
        Ok(())
    }

    /// [`Simulation::attach`] for each of `sinks`.
    pub fn attach_all(&mut self, sinks: Vec<Box<dyn Sink>>) -> anyhow::Result<()> {
        for sink in sinks {
            self.attach(sink)?;
        }
        Ok(())
    }

    /// Steps up to `n` more steps (fewer when the run ends first: all its steps done, the
    /// guard's stop, an interrupt when [`RunSettings::stop_on_interrupt`]), recording every
    /// `log_every`-th step and the last. An `Err` is a sink's write error: end the run then
    /// with [`Simulation::discard`]. Without sinks no frame is built here (a timed run's
    /// windows hold the stepping alone); [`Simulation::frame`] builds one when asked.
    pub fn advance(&mut self, n: u64) -> anyhow::Result<Progress> {
        self.start()?;
        let target = self.step.saturating_add(n).min(self.settings.steps);
        let log_every = self.settings.log_every.max(1);
        while self.progress == Progress::Running && self.step < target {
            let step = self.step;
            let next_record = (step / log_every + 1) * log_every;
            let end = next_record
                .min(self.settings.steps)
                .min(step + MAX_WINDOW_STEPS)
                .min(target);
            let window = self.parts.advance(step, end, &self.loads);
            self.summary.stats = self.summary.stats.merge(window.stats);
            if let Some(stop) = window.stop {
                self.summary.stopped = Some(stop);
                self.summary.steps = stop.step - 1;
                self.step = stop.step - 1;
                self.progress = Progress::Stopped;
                return Ok(self.progress);
            }
            self.step = end;
            let interrupted = self.settings.stop_on_interrupt && crate::interrupt::requested();
            if end.is_multiple_of(log_every) || end == self.settings.steps || interrupted {
                self.record()?;
            }
            if interrupted {
                self.summary.interrupted = Some(crate::interrupt::signal());
                self.summary.steps = end;
                self.progress = Progress::Interrupted;
            } else if end == self.settings.steps {
                self.progress = Progress::Done;
            }
        }
        Ok(self.progress)
    }

    /// Steps to the end of the run ([`Simulation::advance`] of every remaining step).
    pub fn run(&mut self) -> anyhow::Result<Progress> {
        self.advance(u64::MAX)
    }

    /// The last step done (0 before the first).
    pub fn step(&self) -> u64 {
        self.step
    }

    /// Simulation time of the last step done, s (the recordings' integer clock, [`time_ns`]).
    pub fn time_secs(&self) -> f64 {
        time_ns(self.step, self.dt_secs()) as f64 / 1e9
    }

    /// The step size, s.
    pub fn dt_secs(&self) -> f64 {
        self.parts.dt()
    }

    /// Where the run stands.
    pub fn progress(&self) -> Progress {
        self.progress
    }

    /// What the run is asked to do.
    pub fn settings(&self) -> &RunSettings {
        &self.settings
    }

    /// The bodies' current state (carried state of each body, by batch index).
    pub fn view(&self) -> View<'_> {
        self.parts.view()
    }

    /// The partitions (read access: per-partition batches, body lookup).
    pub fn partitions(&self) -> &Partitions<'static> {
        &self.parts
    }

    /// The frame of the current state, as the sinks receive it (projected momenta, joints and
    /// per-model totals for mechanisms): the last recorded one when it is current, else built
    /// now (not sent to the sinks).
    pub fn frame(&mut self) -> &Arc<OwnedFrame> {
        if self.built != Some(self.step) {
            self.build_frame();
        }
        self.frames.shared()
    }

    /// The joints' positions and rates now (rad or m, rad/s or m/s; the layout's joints in
    /// order), the numbers [`Simulation::frame`] would hold, without building the rest of a
    /// frame: what a controller reads every step. Both slices hold one value per joint.
    pub fn joint_state(&mut self, position: &mut [f64], velocity: &mut [f64]) {
        if self.built == Some(self.step) {
            let frame = self.frames.shared();
            for ((p, v), j) in position
                .iter_mut()
                .zip(velocity.iter_mut())
                .zip(&frame.joints)
            {
                (*p, *v) = (j.position, j.velocity);
            }
            return;
        }
        let dt = self.parts.dt();
        self.frames
            .joints_of_parts(&self.parts, &self.loads, self.step, dt, position, velocity);
    }

    /// What the run did so far; after the last step, its final energy and the largest change
    /// of a conserved angular momentum (a stopped run keeps them at 0, as before the first
    /// step: its state is the diverged one).
    pub fn summary(&mut self) -> RunSummary {
        let mut summary = self.summary;
        if self.progress == Progress::Stopped {
            return summary;
        }
        let angmom1: Vec<Vector3<f64>> = if self.articulated {
            if self.built != Some(self.step) {
                self.build_frame();
            }
            summary.energy_final = self.frames.total_energy();
            let mut l = Vec::new();
            let parts = &self.parts;
            self.frames.conserved_angmom(&mut l, &|i| parts.collides(i));
            l
        } else {
            let loads = &self.loads;
            summary.energy_final = self.parts.sum(|b, j| b.energy(j, loads));
            (0..self.parts.len())
                .map(|i| {
                    let (bodies, j) = self.parts.body(i);
                    bodies.angmom_world(j)
                })
                .collect()
        };
        summary.energy_flow = self.parts.energy_flow();
        summary.contact = self.parts.has_contact();
        let (mut rel, mut abs, mut checked) = (0.0_f64, 0.0_f64, [0_u32; 2]);
        for (i, (l0, l1)) in self.angmom0.iter().zip(&angmom1).enumerate() {
            if !self.articulated && self.parts.collides(i) {
                continue;
            }
            let change = (l1 - l0).norm();
            if self.at_rest[i] {
                abs = abs.max(change);
                checked[1] += 1;
            } else {
                rel = rel.max(change / l0.norm());
                checked[0] += 1;
            }
        }
        summary.angmom_rel_change_max = rel;
        summary.angmom_abs_change_max = abs;
        summary.angmom_checked = checked;
        if self.articulated {
            summary.constraint_residual = Some(self.frames.residual_max());
        }
        summary
    }

    /// Ends the run: the summary, and every sink completed and published together under
    /// `outputs` ([`crate::record::finish_all`]: all the files or none). Frame 0 reaches the
    /// sinks even when no step was taken.
    pub fn finish(mut self, outputs: &[&std::path::Path]) -> anyhow::Result<RunSummary> {
        let result = self.start().map(|()| self.summary()).and_then(|summary| {
            let entries = summary.metadata_entries();
            for sink in &mut self.sinks {
                sink.write_summary(&entries)?;
            }
            Ok(summary)
        });
        crate::record::finish_all(std::mem::take(&mut self.sinks), result, outputs)
    }

    /// Ends a run that failed with `error`: nothing is published, the `.part` files of
    /// `outputs` are removed; returns `error`.
    pub fn discard(mut self, error: anyhow::Error, outputs: &[&std::path::Path]) -> anyhow::Error {
        crate::record::finish_all::<()>(std::mem::take(&mut self.sinks), Err(error), outputs)
            .err()
            .unwrap_or_else(|| anyhow::anyhow!("the run failed and its files were discarded"))
    }

    /// Runs every remaining step and finishes ([`Simulation::run`], then
    /// [`Simulation::finish`], or [`Simulation::discard`] on a write error).
    pub fn run_to_end(mut self, outputs: &[&std::path::Path]) -> anyhow::Result<RunSummary> {
        match self.run() {
            Ok(_) => self.finish(outputs),
            Err(e) => Err(self.discard(e, outputs)),
        }
    }

    /// Sends frame 0 to the sinks, once.
    fn start(&mut self) -> anyhow::Result<()> {
        if self.started {
            return Ok(());
        }
        self.started = true;
        // Frame 0 was built by `new` and is still the builder's last frame: nothing steps
        // before the first `start`, and a frame asked for at step 0 is that same frame.
        self.send()
    }

    /// Builds the frame of the current step and sends it to every sink. Without sinks the
    /// step only counts as recorded: its frame is built when asked for ([`Simulation::frame`],
    /// [`Simulation::summary`]), so a run without sinks (a timed one) builds no frame between
    /// its steps.
    fn record(&mut self) -> anyhow::Result<()> {
        if self.sinks.is_empty() {
            self.summary.frames_recorded += 1;
            self.summary.last_recorded_step = self.step;
            return Ok(());
        }
        if self.built != Some(self.step) {
            self.build_frame();
        }
        self.send()
    }

    fn build_frame(&mut self) {
        let dt = self.parts.dt();
        self.frames
            .frame_of_parts(&self.parts, &self.loads, self.step, dt);
        self.built = Some(self.step);
    }

    /// Every sink gets the one buffer the frame was built in (a pipelined sink queues it
    /// without a copy).
    fn send(&mut self) -> anyhow::Result<()> {
        let frame = self.frames.shared();
        for sink in self.sinks.iter_mut() {
            sink.write_shared(frame)?;
        }
        self.summary.frames_recorded += 1;
        self.summary.last_recorded_step = self.step;
        Ok(())
    }
}
