//! One chunk: runs `[c · runs_per_file, (c + 1) · runs_per_file)` simulated in run order by one
//! thread into `trajectories/part-c.parquet`, `joints/part-c.parquet`, `runs/part-c.parquet`
//! and the chunk's per-run recordings. The chunk is the atomic unit of the dataset: its files are complete, or
//! discarded and recomputed.

use super::manifest::ChunkRecord;
use super::runs::{RunRow, runs_batch};
use super::sample::{ModelCache, RunParams, run_scene};
use super::spec::DatasetSpec;
use crate::record::parquet::files::{FileInfo, PartWriter, recording_info, write_file};
use crate::record::parquet::joints::{JointColumns, JointRowsSink, joints_schema};
use crate::record::parquet::tables::{RowsSink, TrajectoryColumns, trajectories_schema};
use crate::record::{OutputFile, RecordingLayout, Sink, SinkOptions};
use crate::simulation::{Inits, Simulation};
use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;

/// `trajectories/part-NNNNN.parquet`.
pub fn trajectories_name(chunk: u64) -> String {
    format!("trajectories/part-{chunk:05}.parquet")
}

/// `joints/part-NNNNN.parquet`: the joints of articulated models (no rows for a rigid one).
pub fn joints_name(chunk: u64) -> String {
    format!("joints/part-{chunk:05}.parquet")
}

/// `runs/part-NNNNN.parquet`.
pub fn runs_name(chunk: u64) -> String {
    format!("runs/part-{chunk:05}.parquet")
}

/// `recordings/run-NNNNNN.<ext>`.
pub fn recording_name(run: u64, file: OutputFile) -> String {
    format!("recordings/run-{run:06}.{}", file.extension())
}

/// Trajectory rows are handed to the Parquet writer in batches of at least this many rows
/// (fewer, larger writes; the batch boundaries depend on the chunk's rows only).
pub const BATCH_ROWS: usize = 16 * 1024;

/// What a chunk did besides its files.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ChunkStats {
    pub runs: u64,
    pub rows: u64,
    /// Σ steps done × bodies.
    pub body_steps: u64,
    pub diverged: u64,
}

/// Everything the chunks of a dataset share (read-only, one per process).
pub struct Context<'a> {
    pub spec: &'a DatasetSpec,
    pub cache: &'a ModelCache,
    /// Per model choice: its recording layout (frames, bodies) and body names.
    pub layouts: Vec<Arc<RecordingLayout>>,
    pub body_names: Vec<Vec<String>>,
    /// [`DatasetSpec::model_choices`].
    pub models: Vec<String>,
    pub dir: &'a Path,
}

impl<'a> Context<'a> {
    pub fn new(spec: &'a DatasetSpec, cache: &'a ModelCache, dir: &'a Path) -> Self {
        let layouts: Vec<Arc<RecordingLayout>> = cache
            .worlds
            .iter()
            .map(|w| Arc::new(w.layout.clone()))
            .collect();
        let body_names = layouts
            .iter()
            .map(|l| l.bodies.iter().map(|b| b.name.clone()).collect())
            .collect();
        Self {
            spec,
            cache,
            layouts,
            body_names,
            models: spec.model_choices().to_vec(),
            dir,
        }
    }
}

/// Computes chunk `chunk` and writes its files. `after_run` is called after every run (progress).
/// On error or interruption inside a run, the chunk's unfinished files are removed.
pub fn run_chunk(
    ctx: &Context<'_>,
    chunk: u64,
    after_run: &dyn Fn(),
) -> anyhow::Result<(ChunkRecord, ChunkStats)> {
    let spec = ctx.spec;
    let runs = spec.chunk_runs(chunk);
    let mut trajectories = PartWriter::create(
        ctx.dir,
        &trajectories_name(chunk),
        trajectories_schema(),
        true,
    )?;
    let mut joints = PartWriter::create(ctx.dir, &joints_name(chunk), joints_schema(), true)?;
    let rows = Rc::new(RefCell::new(TrajectoryColumns::default()));
    let joint_rows = Rc::new(RefCell::new(JointColumns::default()));
    let mut run_rows = Vec::with_capacity((runs.end - runs.start) as usize);
    let mut recordings: Vec<String> = Vec::new();
    let mut stats = ChunkStats::default();
    for run in runs.clone() {
        let params = ctx.cache.draw(spec, run);
        let rows_before = rows.borrow().len() as u64;
        let mut row = simulate_run(ctx, &params, (&rows, &joint_rows), &mut recordings)?;
        row.rows = rows.borrow().len() as u64 - rows_before;
        if rows.borrow().len() >= BATCH_ROWS {
            trajectories.write(&rows.borrow_mut().take_batch()?)?;
        }
        if joint_rows.borrow().len() >= BATCH_ROWS {
            joints.write(&joint_rows.borrow_mut().take_batch()?)?;
        }
        stats.runs += 1;
        stats.rows += row.rows;
        stats.body_steps += row.steps_done * row.bodies;
        stats.diverged += u64::from(row.diverged.is_some());
        run_rows.push(row);
        after_run();
    }
    if !rows.borrow().is_empty() {
        trajectories.write(&rows.borrow_mut().take_batch()?)?;
    }
    if !joint_rows.borrow().is_empty() {
        joints.write(&joint_rows.borrow_mut().take_batch()?)?;
    }
    let mut files: Vec<FileInfo> = vec![trajectories.finish()?, joints.finish()?];
    files.push(write_file(
        ctx.dir,
        &runs_name(chunk),
        &runs_batch(&run_rows)?,
    )?);
    for name in &recordings {
        files.push(recording_info(ctx.dir, name)?);
    }
    Ok((
        ChunkRecord {
            chunk,
            runs: [runs.start, runs.end],
            files,
        },
        stats,
    ))
}

/// Simulates one run into `rows` (and its recordings, for the first `record_runs` runs).
fn simulate_run(
    ctx: &Context<'_>,
    params: &RunParams,
    (rows, joint_rows): (&Rc<RefCell<TrajectoryColumns>>, &Rc<RefCell<JointColumns>>),
    recordings: &mut Vec<String>,
) -> anyhow::Result<RunRow> {
    let spec = ctx.spec;
    let scene = run_scene(spec, params);
    let world = ctx.cache.world(spec, params)?;
    let layout = &ctx.layouts[params.model];
    let name_ids = {
        let mut rows = rows.borrow_mut();
        ctx.body_names[params.model]
            .iter()
            .map(|name| rows.intern(name))
            .collect()
    };
    let mut sinks: Vec<Box<dyn Sink>> = vec![Box::new(RowsSink {
        run: params.run,
        layout: layout.clone(),
        name_ids,
        rows: rows.clone(),
    })];
    if !layout.joints.is_empty() {
        sinks.push(Box::new(JointRowsSink {
            run: params.run,
            ids: joint_rows.borrow_mut().intern_layout(layout),
            rows: joint_rows.clone(),
        }));
    }
    let mut outputs: Vec<PathBuf> = Vec::new();
    if params.run < spec.record_runs {
        let mut rec_layout = (**layout).clone();
        rec_layout.name = format!("run-{:06}", params.run);
        // The scene's settings, and the URDF texts the build put in the layout.
        let urdfs: Vec<(String, String)> = std::mem::take(&mut rec_layout.metadata)
            .into_iter()
            .filter(|(k, _)| k.starts_with(crate::scene::URDF_METADATA_PREFIX))
            .collect();
        rec_layout.metadata = scene.metadata();
        rec_layout.metadata.extend(urdfs);
        rec_layout
            .metadata
            .insert("scene_file".into(), spec.path.display().to_string());
        rec_layout
            .metadata
            .insert("dataset_run".into(), params.run.to_string());
        rec_layout
            .metadata
            .insert("dataset_run_seed".into(), params.seed.to_string());
        for file in spec.record.iter().flat_map(|format| format.files()) {
            let name = recording_name(params.run, *file);
            let path = ctx.dir.join(&name);
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent)?;
            }
            let sink = crate::record::open_file(*file, &path, &rec_layout, &SinkOptions::default());
            outputs.push(path);
            match sink {
                Ok(sink) => sinks.push(sink),
                // The run's recordings created so far are discarded (no `.part` left behind).
                Err(e) => {
                    let outputs: Vec<&Path> = outputs.iter().map(PathBuf::as_path).collect();
                    return crate::record::finish_all(sinks, Err(e), &outputs);
                }
            }
            recordings.push(name);
        }
    }
    let settings = scene.run_settings();
    let outputs: Vec<&Path> = outputs.iter().map(PathBuf::as_path).collect();
    // One partition on this worker's thread (the chunks are the parallelism).
    let variational = scene.variational_settings();
    let sim = Simulation::new(
        &world,
        Inits::Borrowed(&world.bodies),
        &|part| {
            crate::sim::integrator_for(
                params.integrator,
                params.dt_secs,
                &variational,
                part.mechanisms,
                part.range.len(),
            )
        },
        1,
        &settings,
    )
    .and_then(|mut sim| sim.attach_all(std::mem::take(&mut sinks)).map(|()| sim));
    let summary = match sim {
        Ok(sim) => sim.run_to_end(&outputs)?,
        Err(e) => return crate::record::finish_all(sinks, Err(e), &outputs),
    };
    let diverged = summary.stopped.map(|d| {
        (
            ctx.body_names[params.model][d.body].clone(),
            d.cause.to_string(),
        )
    });
    let ok = diverged.is_none();
    Ok(RunRow {
        params: params.clone(),
        model: ctx.models[params.model].clone(),
        steps: settings.steps,
        log_every: settings.log_every,
        bodies: world.bodies.len() as u64,
        rows: 0, // set by the caller
        steps_done: summary.steps,
        energy_initial: summary.energy_initial,
        energy_final: ok.then_some(summary.energy_final),
        angmom_drift_rel: (ok && summary.angmom_checked[0] > 0)
            .then_some(summary.angmom_rel_change_max),
        angmom_change_abs: (ok && summary.angmom_checked[1] > 0)
            .then_some(summary.angmom_abs_change_max),
        energy_flow: summary.energy_flow,
        constraint_residual: summary.constraint_residual,
        newton_iters_max: summary.stats.newton_iters_max,
        substepped: u64::from(summary.stats.substepped),
        diverged,
    })
}
