//! [`RerunSink`]: creating a recording ([`create`]: the file, the recording stream, the static
//! layout), taking frames into the column buffer, and closing it (blueprint, footer, sync,
//! publication). See [`super`] for what the file holds.

use super::batched::{Batches, is_batched};
use super::blueprint::{
    PlotView, SceneBounds, blueprint_chunks, blueprint_messages, default_plot_views,
};
use super::columns::{Buffer, batch_frames};
use super::footer::{FooterHold, FooterWriter};
use super::joints;
use super::paths::{BodyTrack, FrameTrack};
use super::paths::{application_id, recording_id, recording_seed};
use super::statics::frame_reach;
use super::values::{f32x3, f64c, nonzero, quat_xyzw};
use super::writer::{ChunkWriter, FileState, RrdFileSink, lock};
use crate::fsutil::part_path;
use crate::record::scene_update::MeshCache;
use crate::record::{Frame, RecordingLayout, Sink};
use anyhow::{Context, Result, anyhow, bail};
use rerun::external::re_log_encoding::{CrateVersion, Encoder, EncodingOptions};
use rerun::log::Chunk;
use rerun::{EntityPath, RecordingStream, RecordingStreamBuilder};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// What to write besides the trajectories.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RerunOptions {
    /// Write the equivalent inertia ellipsoid of every body (`/<model>/inertia/<link>`).
    pub ellipsoids: bool,
}

impl Default for RerunOptions {
    fn default() -> Self {
        Self { ellipsoids: true }
    }
}

/// Writes a [`RecordingLayout`] and its frames as a Rerun `.rrd` file (see the module doc).
pub struct RerunSink {
    pub(super) rec: Option<RecordingStream>,
    pub(super) state: Arc<Mutex<FileState>>,
    pub(super) part_path: PathBuf,
    pub(super) final_path: PathBuf,
    pub(super) frames: Vec<FrameTrack>,
    pub(super) bodies: Vec<BodyTrack>,
    pub(super) buffer: Buffer,
    /// [`super::batch_frames`] of the layout.
    pub(super) batch_frames: usize,
    pub(super) last_time_ns: Option<i64>,
    pub(super) warnings: Vec<String>,
    /// Holds the encoder's footer back for [`super::footer`].
    pub(super) footer_hold: FooterHold,
    /// Entities of [`RerunSink::write_series`] whose series names were sent.
    pub(super) series_named: BTreeSet<EntityPath>,
    /// Meshes read so far (each file once): Collada triangles, and the accepted bytes of STL
    /// and OBJ files.
    pub(super) meshes: MeshCache,
    /// The recording's store, from which the blueprint store's id derives.
    pub(super) store_info: rerun::external::re_log_types::StoreInfo,
    /// Per frame: how far its geometry reaches from the frame origin, m (for [`SceneBounds`]).
    pub(super) frame_reach: Vec<f64>,
    /// Every frame origin of every recorded step, with its reach: what the 3D view frames.
    pub(super) bounds: SceneBounds,
    /// The blueprint's plots ([`Self::set_plot_views`]).
    pub(super) plot_views: Vec<PlotView>,
    /// First recorded total energy and angular momenta: the reference of the change plots.
    pub(super) energy0: Option<f64>,
    pub(super) angmom0: Vec<nalgebra::Vector3<f64>>,
    /// The series of articulated models ([`super::joints`]).
    pub(super) joint_plots: joints::JointPlots,
    /// The contacts' rows ([`super::contacts`]).
    pub(super) contacts: super::contacts::ContactSeries,
    /// Link frames and bodies of the layout.
    pub(super) frame_count: usize,
    pub(super) body_count: usize,
    /// The big-scene layout ([`super::batched`]), when the layout is big.
    pub(super) batched: Option<Batches>,
    /// The robot the 3D view opens on ([`RecordingLayout::robot_root`]), if any.
    pub(super) robot: Option<RobotView>,
    pub(super) done: bool,
}

/// What the blueprint's 3D view frames and follows when the recording holds a robot: the
/// robot's link frames at its first recorded step, and an entity drawn in its root frame; for a
/// fixed-base robot ([`RecordingLayout::robot_is_fixed`]) its link frames over the whole run
/// and no tracking.
pub(super) struct RobotView {
    /// The root frame ([`RecordingLayout::robot_root`]).
    pub root: usize,
    /// Indices of the robot's link frames (those of the root frame's model).
    pub frames: Vec<usize>,
    /// The box around those frames at the first recorded step (empty until then); for a
    /// fixed-base robot, over every recorded step.
    pub start: SceneBounds,
    /// Whether the robot is welded to the world.
    pub fixed: bool,
    /// The entity the eye tracks: the root frame's first visual, else the first visual of
    /// another of the robot's frames (set by the layout writer).
    pub tracked: Option<EntityPath>,
    /// Whether [`Self::tracked`] is drawn in the root frame itself.
    pub root_tracked: bool,
}

/// Opens `<path>.part` and writes the static layout. See the module doc for what is written.
impl RerunSink {
    /// Replaces the time series views of the blueprint (default: [`default_plot_views`]);
    /// `tumble diff` shows its error plots this way.
    pub fn set_plot_views(&mut self, views: Vec<PlotView>) {
        self.plot_views = views;
    }

    /// The time series views of the blueprint (written when the recording finishes).
    pub fn plot_views(&self) -> &[PlotView] {
        &self.plot_views
    }

    /// Opens `<path>.part` and writes the static layout. See the module doc for what is written.
    pub fn create(path: &Path, layout: &RecordingLayout, options: &RerunOptions) -> Result<Self> {
        create(path, layout, options)
    }
}

/// Opens `<path>.part` and writes the static layout. See the module doc for what is written.
pub fn create(path: &Path, layout: &RecordingLayout, options: &RerunOptions) -> Result<RerunSink> {
    let part_path = part_path(path);
    let file = crate::fsutil::create_part(path)?;
    let (footer_writer, footer_hold) = FooterWriter::new(file);
    let encoder = Encoder::new_eager(
        CrateVersion::LOCAL,
        EncodingOptions::PROTOBUF_COMPRESSED,
        footer_writer,
    );
    let state = Arc::new(Mutex::new(FileState {
        encoder: None,
        last_id: 0,
        error: None,
    }));
    let batched = is_batched(layout).then(|| Batches::new(layout, options.ellipsoids));
    // From here on, an early return drops `sink`, which removes the part file.
    let mut sink = RerunSink {
        rec: None,
        state: state.clone(),
        part_path,
        final_path: path.to_owned(),
        frames: Vec::new(),
        bodies: Vec::new(),
        buffer: if batched.is_some() {
            Buffer::new(0, 0)
        } else {
            Buffer::new(layout.frames.len(), layout.bodies.len())
        },
        batch_frames: match &batched {
            Some(b) => b.rows_per_send,
            None => batch_frames(layout.frames.len(), layout.bodies.len()),
        },
        last_time_ns: None,
        warnings: Vec::new(),
        footer_hold,
        series_named: BTreeSet::new(),
        meshes: MeshCache::default(),
        store_info: rerun::external::re_log_types::StoreInfo::new(
            rerun::external::re_log_types::StoreId::recording("tumble", "tumble"),
            rerun::external::re_log_types::StoreSource::Unknown,
        ),
        frame_reach: layout.frames.iter().map(frame_reach).collect(),
        bounds: SceneBounds::default(),
        plot_views: default_plot_views(),
        energy0: None,
        angmom0: Vec::new(),
        joint_plots: joints::JointPlots::new(layout),
        contacts: super::contacts::ContactSeries::new(layout),
        frame_count: layout.frames.len(),
        body_count: layout.bodies.len(),
        robot: if batched.is_some() {
            None
        } else {
            layout.robot_root().map(|root| RobotView {
                root,
                frames: (0..layout.frames.len())
                    .filter(|&i| layout.frames[i].model == layout.frames[root].model)
                    .collect(),
                start: SceneBounds::default(),
                fixed: layout.robot_is_fixed(),
                tracked: None,
                root_tracked: false,
            })
        },
        batched,
        done: false,
    };
    if !sink.joint_plots.is_empty() && !sink.joint_plots.conserves_angmom() {
        // Fixed-base models only: no conserved angular momentum, no plot of its change (the
        // series stays, at 0, for tools that read it).
        sink.plot_views.retain(|v| {
            !v.contents
                .iter()
                .any(|c| c.contains("angular_momentum_change"))
        });
    }
    let extra_views = sink.joint_plots.plot_views(layout);
    sink.plot_views.extend(extra_views);
    lock(&state).encoder = Some(encoder.context("cannot write the .rrd header")?);

    let app_id = rerun::ApplicationId::try_new(application_id(&layout.name))
        .map_err(|e| anyhow!("recording name {:?}: {e}", layout.name))?;
    let builder = RecordingStreamBuilder::new(app_id)
        .enabled(true)
        .recording_id(recording_id(layout))
        .send_properties(true);
    let (_enabled, store_info, _properties, batcher_config, batcher_hooks, _blueprint) =
        builder.into_args();
    // The builder's properties hold `Timestamp::now()`: replace them by the name alone.
    let properties = rerun::RecordingInfo::new().with_name(layout.name.clone());
    sink.store_info = store_info.clone();
    let rec = RecordingStream::new(
        store_info,
        Some(properties),
        batcher_config,
        batcher_hooks,
        Box::new(RrdFileSink { state }),
    )
    .context("cannot start the Rerun recording stream")?;
    rec.set_log_time_enabled(false);
    rec.set_log_tick_enabled(false);
    // The store info and properties are in the file before the first chunk ([`ChunkWriter`]).
    rec.flush_blocking()
        .with_context(|| format!("writing {}", sink.part_path.display()))?;
    sink.rec = Some(rec);
    sink.check_sink()?;

    sink.write_layout(layout, options)?;
    Ok(sink)
}

impl RerunSink {
    /// Meshes that were skipped (DAE, unresolved or unreadable files), one line each.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    pub(super) fn send(&self, chunk: Chunk) -> Result<()> {
        self.writer().send(chunk)
    }

    /// Where chunks go ([`ChunkWriter`]).
    pub(super) fn writer(&self) -> ChunkWriter<'_> {
        ChunkWriter {
            state: &self.state,
            store_id: &self.store_info.store_id,
            path: &self.part_path,
        }
    }

    /// Surfaces an error the recording stream's forwarding thread met writing the store info,
    /// the properties or the blueprint ([`RrdFileSink`]); chunks report theirs directly
    /// ([`ChunkWriter`]).
    pub(super) fn check_sink(&self) -> Result<()> {
        match &lock(&self.state).error {
            Some(err) => bail!("writing {}: {err}", self.part_path.display()),
            None => Ok(()),
        }
    }

    pub(super) fn warn(&mut self, message: String) {
        eprintln!("warning: {message}");
        self.warnings.push(message);
    }

    /// Flushes, closes the stream, writes the footer and syncs `<path>.part` (a complete file).
    fn close(&mut self) -> Result<()> {
        self.flush_buffer()?;
        let rec = self.rec.take().context("the Rerun recording is closed")?;
        rec.flush_blocking()
            .with_context(|| format!("flushing {}", self.part_path.display()))?;
        // Dropping the last handle joins Rerun's threads; the file sink is dropped with them.
        drop(rec);
        // The blueprint store, after the recording (so its bytes do not depend on thread timing).
        let (bounds, tracked) = match &self.robot {
            Some(robot) if !robot.start.is_empty() => (
                &robot.start,
                robot.tracked.as_ref().filter(|_| !robot.fixed),
            ),
            _ => (&self.bounds, None),
        };
        let chunks = blueprint_chunks(
            recording_seed(&self.store_info),
            bounds,
            tracked,
            &self.plot_views,
        )?;
        {
            let mut state = lock(&self.state);
            for msg in blueprint_messages(&self.store_info, chunks)? {
                state
                    .write(msg)
                    .with_context(|| format!("writing {}", self.part_path.display()))?;
            }
        }
        let encoder = {
            let mut state = lock(&self.state);
            if let Some(err) = &state.error {
                bail!("writing {}: {err}", self.part_path.display());
            }
            state.encoder.take().context("the .rrd encoder is gone")?
        };
        let mut encoder = encoder;
        encoder.flush_blocking()?;
        self.footer_hold.hold();
        encoder
            .finish()
            .with_context(|| format!("writing the footer of {}", self.part_path.display()))?;
        let file = encoder
            .into_inner()?
            .finish()
            .with_context(|| format!("writing the footer of {}", self.part_path.display()))?;
        file.sync_all()
            .with_context(|| format!("syncing {}", self.part_path.display()))?;
        drop(file);
        self.done = true;
        Ok(())
    }

    /// [`Self::close`], then publishes `<path>.part` onto `<path>`
    /// ([`crate::fsutil::publish`]).
    fn close_and_rename(&mut self) -> Result<()> {
        self.close()?;
        crate::fsutil::publish(&[&self.final_path])
    }
}

impl Sink for RerunSink {
    fn write(&mut self, frame: &Frame<'_>) -> Result<()> {
        if frame.world_from_link.len() != self.frame_count {
            bail!(
                "frame has {} link poses, the layout {}",
                frame.world_from_link.len(),
                self.frame_count
            );
        }
        if frame.bodies.len() != self.body_count {
            bail!(
                "frame has {} body states, the layout {}",
                frame.bodies.len(),
                self.body_count
            );
        }
        if let Some(last) = self.last_time_ns
            && frame.time_ns <= last
        {
            bail!("frame time {} ns is not after {} ns", frame.time_ns, last);
        }
        self.last_time_ns = Some(frame.time_ns);
        let buffer = &mut self.buffer;
        buffer.time_ns.push(frame.time_ns);
        buffer
            .step
            .push(i64::try_from(frame.step).context("step does not fit an i64")?);
        let per_body = self.batched.is_none();
        crate::record::contacts::check(frame.contacts, self.body_count)?;
        self.contacts.push(frame);
        if let Some(batched) = &mut self.batched {
            batched.push(frame);
        }
        for (i, pose) in frame.world_from_link.iter().enumerate() {
            if per_body {
                buffer.translation[i].push(f32x3(&pose.translation.vector));
                buffer.quaternion[i].push(quat_xyzw(pose));
            }
            self.bounds
                .add(&pose.translation.vector, self.frame_reach[i]);
        }
        if let Some(robot) = &mut self.robot
            && (robot.fixed || robot.start.is_empty())
        {
            for &i in &robot.frames {
                robot.start.add(
                    &frame.world_from_link[i].translation.vector,
                    self.frame_reach[i],
                );
            }
        }
        let angmom_change = if self.joint_plots.is_empty() {
            if self.angmom0.is_empty() {
                self.angmom0 = frame.bodies.iter().map(|b| b.angmom_world).collect();
            }
            frame
                .bodies
                .iter()
                .zip(&self.angmom0)
                .map(|(b, l0)| (b.angmom_world - l0).norm() / nonzero(l0.norm()))
                .fold(0.0, f64::max)
        } else {
            self.joint_plots.push(frame)?;
            let angmom = self.joint_plots.conserved_angmom(frame);
            if self.angmom0.is_empty() {
                self.angmom0 = angmom.clone();
            }
            angmom
                .iter()
                .zip(&self.angmom0)
                .map(|(l, l0)| (l - l0).norm() / nonzero(l0.norm()))
                .fold(0.0, f64::max)
        };
        let (mut kinetic, mut potential) = (0.0, 0.0);
        for (i, body) in frame.bodies.iter().enumerate() {
            if per_body {
                let total = body.kinetic_energy + body.potential_energy;
                buffer.energy[i].extend([
                    f64c(body.kinetic_energy),
                    f64c(body.potential_energy),
                    f64c(total),
                ]);
                buffer.angular_momentum[i].push(f64c(body.angmom_world.norm()));
            }
            kinetic += body.kinetic_energy;
            potential += body.potential_energy;
        }
        buffer
            .scene_energy
            .extend([kinetic, potential, kinetic + potential]);
        let energy0 = *self.energy0.get_or_insert(kinetic + potential);
        buffer.scene_energy_change.push(f64c(
            (kinetic + potential - energy0) / nonzero(energy0.abs()),
        ));
        buffer.scene_angmom_change.push(f64c(angmom_change));
        if buffer.len() >= self.batch_frames {
            self.flush_buffer()?;
        }
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> Result<()> {
        self.close_and_rename()
    }

    fn path(&self) -> Option<PathBuf> {
        Some(self.final_path.clone())
    }

    fn complete(mut self: Box<Self>) -> Result<()> {
        self.close()
    }
}

impl Drop for RerunSink {
    fn drop(&mut self) {
        if !self.done {
            // Unfinished (error or early return): stop Rerun's threads, then remove the part file.
            drop(self.rec.take());
            lock(&self.state).encoder = None;
            crate::fsutil::discard(&[&self.final_path]);
        }
    }
}
