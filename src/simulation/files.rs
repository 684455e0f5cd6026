//! A scene run into recording files: the library half of `tumble simulate`. Builds the
//! [`Simulation`] first (integrators checked before any file exists), opens one sink per file
//! the formats name (each pipelined on its own thread), runs, and publishes every file
//! together ([`crate::record::finish_all`]); `--accuracy`'s plan and its a posteriori check.

use super::{Diverged, Inits, RunSummary, Simulation};
use crate::record::mcap::{ChunkCompression, McapOptions};
use crate::record::pipelined::Pipelined;
use crate::record::rerun::RerunOptions;
use crate::record::{Format, FormatSet, OutputFile, Sink, SinkOptions};
use crate::scene::Scene;
use crate::world::World;
use anyhow::Context;
use std::path::{Path, PathBuf};

/// How [`simulate_world`] runs and what it writes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimulateOptions {
    pub rerun: RerunOptions,
    pub formats: FormatSet,
    /// Stepping threads (>= 1; the files do not depend on it).
    pub threads: usize,
    pub mcap_compression: ChunkCompression,
    /// The error model of `--accuracy` (scale 1 as validated).
    pub accuracy_model: crate::sim::accuracy::ErrorModel,
}

/// The files a simulation wrote.
#[derive(Debug, Clone)]
pub struct Outputs {
    /// `STEM.mcap` (written when asked for, as by default).
    pub mcap: PathBuf,
    /// `STEM.rrd` (written when asked for, as by default).
    pub rrd: PathBuf,
    /// `STEM.ros2.mcap`, when asked for.
    pub ros2: Option<PathBuf>,
    /// Every file written, in the order mcap, rrd, ros2, trajectories and bodies Parquet.
    pub written: Vec<PathBuf>,
    pub summary: RunSummary,
    pub bodies: usize,
    /// Threads that stepped the bodies: a small batch uses fewer partitions than threads (and
    /// a scene with mechanisms is cut only between them).
    pub stepping_threads: usize,
    /// `--accuracy`: the plan and its a posteriori check.
    pub accuracy: Option<AccuracyReport>,
}

/// What `--accuracy` chose and what the a posteriori check estimated.
#[derive(Debug, Clone)]
pub struct AccuracyReport {
    pub plan: crate::sim::accuracy::Plan,
    pub checked: Vec<crate::sim::accuracy::Checked>,
}

impl AccuracyReport {
    /// The largest a posteriori estimate, rad.
    pub fn estimated_max(&self) -> f64 {
        self.checked
            .iter()
            .map(|c| c.estimated_rad)
            .fold(0.0, f64::max)
    }
}

/// Runs `f` on a pool of `threads` threads.
fn in_pool<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    match rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
    {
        Ok(pool) => pool.install(f),
        Err(_) => f(),
    }
}

/// The per-body substep factors of `--accuracy TOL` (clear errors for what it does not cover).
fn accuracy_plan(
    scene: &Scene,
    world: &World,
    tol: f64,
    model: &crate::sim::accuracy::ErrorModel,
    threads: usize,
) -> anyhow::Result<crate::sim::accuracy::Plan> {
    let file = scene.source.display();
    let kind = scene.integrator();
    if !world.mechanisms.is_empty() {
        anyhow::bail!(
            "{file}: --accuracy (sim.accuracy) is not supported for articulated models yet \
             ({} articulated model{} in the scene); choose dt by hand (tumble trade, docs/accuracy.md)",
            world.mechanisms.len(),
            if world.mechanisms.len() == 1 { "" } else { "s" }
        );
    }
    if !world.body_loads.is_empty() {
        // The error model is that of torque-free motion (docs/accuracy.md): a load changes it.
        anyhow::bail!(
            "{file}: --accuracy (sim.accuracy) is not supported with applied loads yet \
             ({} [[model.load]] on bodies); choose dt by hand (tumble trade, docs/accuracy.md)",
            world.body_loads.len()
        );
    }
    if world.contact.is_active() {
        // The error model is that of free flight: contact changes the motion it predicts.
        anyhow::bail!(
            "{file}: --accuracy (sim.accuracy) is not supported with contact ([ground] or \
             colliding models); choose dt by hand (docs/contact.md)"
        );
    }
    if !crate::sim::accuracy::model::supports(kind) {
        anyhow::bail!(
            "{file}: --accuracy (sim.accuracy) supports the integrators variational, variational4 \
             and variational6 (got {}; docs/accuracy.md)",
            kind.name()
        );
    }
    let variational = scene.variational_settings();
    let duration = scene.steps() as f64 * scene.sim.dt;
    Ok(in_pool(threads, || {
        crate::sim::accuracy::Plan::new(
            kind,
            &variational,
            model,
            &world.bodies,
            scene.sim.dt,
            duration,
            tol,
        )
    }))
}

/// The sinks of a recording and the files they publish when finished ([`open_recording`]).
pub struct Recording {
    /// One per file, each encoding on its own thread ([`Pipelined`]).
    pub sinks: Vec<Box<dyn Sink>>,
    /// The files, in the order of [`Outputs::written`]: pass them to
    /// [`Simulation::finish`] (or [`Simulation::discard`]).
    pub paths: Vec<PathBuf>,
}

/// Opens the files `options.formats` names under `stem` for `world` (the output folder made,
/// each file under its `.part` name until the run finishes): what `simulate` records, for a
/// [`Simulation`] stepped by its caller (the Python package's `record=`). The visual meshes'
/// triangles are checked first (`scene_file` names the scene in that error); a file that cannot
/// be opened removes the ones opened before it.
pub fn open_recording(
    world: &World,
    scene_file: &Path,
    stem: &Path,
    options: &SimulateOptions,
) -> anyhow::Result<Recording> {
    let formats = options.formats;
    let body_count = world.layout.bodies.len();
    if formats.contains(Format::Mcap) || formats.contains(Format::Rrd) {
        // Both draw every recorded link's visual meshes: bounded per scene before any file.
        crate::scene::triangles::check_recorded(world, scene_file)?;
    }
    if let Some(dir) = stem.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the output folder {}", dir.display()))?;
    }
    let written = formats.paths_of(stem, &world.layout);
    let outputs: Vec<&Path> = written.iter().map(PathBuf::as_path).collect();
    // Each file is encoded on its own thread, beside the stepping; the threads share one copy
    // of each frame (`record::pipelined`).
    let mut sinks: Vec<Box<dyn Sink>> = Vec::new();
    let share = crate::record::pipelined::FrameShare::default();
    let queue = crate::record::pipelined::queue_frames(crate::record::pipelined::frame_bytes(
        world.attachments.len(),
        body_count,
        world.layout.joints.len(),
    ));
    let add = |sinks: &mut Vec<Box<dyn Sink>>,
               sink: anyhow::Result<Box<dyn Sink + Send>>,
               name: &str|
     -> anyhow::Result<()> {
        let pipelined = sink.and_then(|sink| Pipelined::shared(sink, name, &share, queue));
        match pipelined {
            Ok(sink) => {
                sinks.push(Box::new(sink));
                Ok(())
            }
            Err(e) => crate::record::finish_all(std::mem::take(sinks), Err(e), &outputs),
        }
    };
    let sink_options = SinkOptions {
        mcap: McapOptions {
            ellipsoids: options.rerun.ellipsoids,
            compression: options.mcap_compression.resolve(body_count),
        },
        rerun: options.rerun,
        print_mcap_warnings: true,
    };
    for format in formats.iter() {
        for (file, _, sink) in crate::record::open(format, stem, &world.layout, &sink_options) {
            add(&mut sinks, sink, file.thread_name())?;
        }
    }
    Ok(Recording {
        sinks,
        paths: written,
    })
}

/// Runs `scene` and writes `<stem>.mcap` and `<stem>.rrd` (on one thread).
pub fn simulate(
    scene: &Scene,
    stem: &Path,
    rerun_options: &RerunOptions,
) -> anyhow::Result<Outputs> {
    let options = SimulateOptions {
        rerun: *rerun_options,
        formats: FormatSet::default(),
        threads: 1,
        mcap_compression: ChunkCompression::Zstd,
        accuracy_model: Default::default(),
    };
    simulate_world(scene, &mut scene.build()?, stem, &options)
}

/// The files `formats` names for `stem` whatever the scene, in the order of
/// [`Outputs::written`]; a run that can have contacts writes `STEM.contacts.parquet` too
/// ([`FormatSet::paths_of`]).
pub fn output_paths(stem: &Path, formats: &FormatSet) -> Vec<PathBuf> {
    formats.paths(stem)
}

/// Runs the built `world` of `scene` and writes the files `options.formats` names under
/// `stem`. A run the guard stops ([`crate::sim::guard`]) still finishes the files (they end at
/// the last good recorded step) and then returns a [`Diverged`] error. Without `--accuracy`
/// (whose check after the run starts from them) the initial states are moved out of
/// `world.bodies`, which is left empty: the run frees them once the partitions hold theirs
/// ([`crate::simulation::Inits`]).
pub fn simulate_world(
    scene: &Scene,
    world: &mut World,
    stem: &Path,
    options: &SimulateOptions,
) -> anyhow::Result<Outputs> {
    let body_count = world.bodies.len();
    // `--accuracy`: refused before any file exists when it cannot apply; the plan (each body's
    // pilot) is computed on the stepping threads.
    let plan = match scene.sim.accuracy {
        Some(tol) => Some(accuracy_plan(
            scene,
            &*world,
            tol,
            &options.accuracy_model,
            options.threads,
        )?),
        None => None,
    };
    let variational = scene.variational_settings();
    let settings = crate::sim::RunSettings {
        stop_on_interrupt: true,
        ..scene.run_settings()
    };
    // Before any file exists: the partitions and their integrators (an integrator the world
    // cannot use is refused with nothing written).
    let mut sim = if let Some(plan) = &plan {
        Simulation::new(
            &*world,
            Inits::Borrowed(&world.bodies),
            &|part| Ok(plan.integrator(&variational, part.range.clone())),
            options.threads,
            &settings,
        )
        .with_context(|| scene.source.display().to_string())?
    } else {
        // A mechanism's bodies are coupled by its joint rows: the batch is cut between
        // mechanisms, each partition's integrator steps its own (docs/mechanisms.md). The
        // initial states leave the world: the run frees them once the partitions hold theirs.
        let inits = std::mem::take(&mut world.bodies);
        Simulation::of_scene(
            scene,
            &*world,
            Inits::Owned(inits),
            options.threads,
            &settings,
        )
        .with_context(|| scene.source.display().to_string())?
    };
    let formats = options.formats;
    let mcap = OutputFile::Mcap.path(stem);
    let rrd = OutputFile::Rrd.path(stem);
    let ros2 = formats
        .contains(Format::Ros2)
        .then(|| OutputFile::Ros2.path(stem));
    let recording = open_recording(world, &scene.source, stem, options)?;
    let written = recording.paths;
    let outputs: Vec<&Path> = written.iter().map(PathBuf::as_path).collect();
    let sinks = recording.sinks;
    sim.attach_all(sinks)?;
    let stepping_threads = sim.partitions().threads();
    let summary = sim.run_to_end(&outputs)?;
    let accuracy = plan.map(|plan| {
        let sample = plan.check_sample();
        let checked = in_pool(options.threads, || {
            crate::sim::accuracy::plan::check(
                &plan,
                &variational,
                &world.bodies,
                &sample,
                summary.steps,
            )
        });
        AccuracyReport { plan, checked }
    });
    if let Some(signal) = summary.interrupted {
        return Err(crate::interrupt::Interrupted {
            signal,
            what: format!(
                "simulation stopped after step {} of {} (t = {} s)",
                summary.steps,
                settings.steps,
                crate::simulation::time_ns(summary.steps, scene.sim.dt) as f64 / 1e9
            ),
            finished: format!(
                "the recordings end at that step and are complete: {}",
                outputs
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(" ")
            ),
        }
        .into());
    }
    if let Some(divergence) = summary.stopped {
        return Err(Diverged {
            divergence,
            body_name: world.layout.bodies[divergence.body].name.clone(),
            dt_secs: scene.sim.dt,
            last_recorded_step: summary.last_recorded_step,
            outputs: outputs.iter().map(|p| p.to_path_buf()).collect(),
        }
        .into());
    }
    Ok(Outputs {
        mcap: mcap.clone(),
        rrd: rrd.clone(),
        ros2: ros2.clone(),
        written: written.clone(),
        summary,
        bodies: body_count,
        stepping_threads,
        accuracy,
    })
}
