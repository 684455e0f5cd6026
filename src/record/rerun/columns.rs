//! The time-varying columns: the frames buffered since the last send ([`Buffer`], sized by
//! [`batch_frames`]) and their sending as one chunk per entity on both timelines
//! ([`RerunSink::flush_buffer`], [`RerunSink::write_series`]).

use super::chunks::static_chunk;
use super::paths::{
    SIM_TIME_TIMELINE, STEP_TIMELINE, scene_angmom_change_entity_path,
    scene_energy_change_entity_path, scene_energy_entity_path,
};
use super::sink::RerunSink;
use super::writer::ChunkWriter;
use crate::record::names::WORLD_FRAME;
use anyhow::{Result, bail};
use rerun::{EntityPath, TimeColumn};

/// Bytes of columns buffered before a batch is sent (see [`batch_frames`]).
pub const BATCH_BYTES: usize = 1 << 20;
/// Fewest and most frames per batch.
pub const BATCH_FRAMES_MIN: usize = 256;
pub const BATCH_FRAMES_MAX: usize = 65_536;

/// Frames per batch for a layout: about [`BATCH_BYTES`] of buffered columns (per frame: 28 bytes
/// of f32 pose per link, 32 of f64 plots per body, 16 of times), within [`BATCH_FRAMES_MIN`] ..
/// [`BATCH_FRAMES_MAX`]. Every batch becomes one Rerun chunk per entity, and Rerun's footer keeps
/// a manifest row per chunk, so large batches keep long recordings' footers (and the memory
/// that builds them) small, while the byte bound keeps the buffer small for many bodies.
pub fn batch_frames(frames: usize, bodies: usize) -> usize {
    let row_bytes = 16 + 28 * frames + 32 * bodies + 24;
    (BATCH_BYTES / row_bytes).clamp(BATCH_FRAMES_MIN, BATCH_FRAMES_MAX)
}

/// Columns of the frames not yet sent.
#[derive(Default)]
pub(super) struct Buffer {
    pub(super) time_ns: Vec<i64>,
    pub(super) step: Vec<i64>,
    /// `[frame][row]`
    pub(super) translation: Vec<Vec<[f32; 3]>>,
    pub(super) quaternion: Vec<Vec<[f32; 4]>>,
    /// `[body]`: kinetic, potential, total per row, flattened.
    pub(super) energy: Vec<Vec<f64>>,
    pub(super) angular_momentum: Vec<Vec<f64>>,
    pub(super) scene_energy: Vec<f64>,
    pub(super) scene_energy_change: Vec<f64>,
    pub(super) scene_angmom_change: Vec<f64>,
}

impl Buffer {
    pub(super) fn new(frames: usize, bodies: usize) -> Self {
        Self {
            translation: vec![Vec::new(); frames],
            quaternion: vec![Vec::new(); frames],
            energy: vec![Vec::new(); bodies],
            angular_momentum: vec![Vec::new(); bodies],
            ..Self::default()
        }
    }

    pub(super) fn len(&self) -> usize {
        self.time_ns.len()
    }

    pub(super) fn clear(&mut self) {
        self.time_ns.clear();
        self.step.clear();
        self.scene_energy.clear();
        self.scene_energy_change.clear();
        self.scene_angmom_change.clear();
        for v in &mut self.translation {
            v.clear();
        }
        for v in &mut self.quaternion {
            v.clear();
        }
        for v in &mut self.energy {
            v.clear();
        }
        for v in &mut self.angular_momentum {
            v.clear();
        }
    }
}

impl RerunSink {
    /// Sends the buffered frames as one chunk per entity.
    pub(super) fn flush_buffer(&mut self) -> Result<()> {
        if self.buffer.len() == 0 {
            return Ok(());
        }
        let writer = ChunkWriter {
            state: &self.state,
            store_id: &self.store_info.store_id,
            path: &self.part_path,
        };
        let buffer = &self.buffer;
        let n = buffer.len();
        let times = || {
            [
                TimeColumn::new_duration_nanos(SIM_TIME_TIMELINE, buffer.time_ns.iter().copied()),
                TimeColumn::new_sequence(STEP_TIMELINE, buffer.step.iter().copied()),
            ]
        };
        if let Some(batched) = &mut self.batched {
            for b in 0..batched.list.len() {
                let columns = super::batched::pose_columns(batched, b, n)?;
                writer.send_columns(batched.list[b].entity.clone(), times(), columns)?;
            }
        }
        for (i, track) in self.frames.iter().enumerate() {
            let transforms = rerun::Transform3D::update_fields()
                .with_many_translation(buffer.translation[i].iter().copied())
                .with_many_quaternion(
                    buffer.quaternion[i]
                        .iter()
                        .map(|q| rerun::Quaternion::from_xyzw(*q)),
                )
                .with_many_parent_frame(std::iter::repeat_n(WORLD_FRAME, n))
                .with_many_child_frame(std::iter::repeat_n(track.frame_id.as_str(), n));
            writer.send_columns(
                track.entity.clone(),
                times(),
                transforms.columns_of_unit_batches()?,
            )?;
        }
        for (i, track) in self.bodies.iter().enumerate() {
            writer.send_columns(
                track.energy.clone(),
                times(),
                rerun::Scalars::new(buffer.energy[i].iter().copied())
                    .columns(std::iter::repeat_n(3, n))?,
            )?;
            writer.send_columns(
                track.angular_momentum.clone(),
                times(),
                rerun::Scalars::new(buffer.angular_momentum[i].iter().copied())
                    .columns_of_unit_batches()?,
            )?;
        }
        if self.body_count > 0 {
            writer.send_columns(
                scene_energy_entity_path(),
                times(),
                rerun::Scalars::new(buffer.scene_energy.iter().copied())
                    .columns(std::iter::repeat_n(3, n))?,
            )?;
            writer.send_columns(
                scene_energy_change_entity_path(),
                times(),
                rerun::Scalars::new(buffer.scene_energy_change.iter().copied())
                    .columns_of_unit_batches()?,
            )?;
            writer.send_columns(
                scene_angmom_change_entity_path(),
                times(),
                rerun::Scalars::new(buffer.scene_angmom_change.iter().copied())
                    .columns_of_unit_batches()?,
            )?;
        }
        self.joint_plots.send(&writer, &times, n)?;
        self.contacts.send(&writer, &times)?;
        self.buffer.clear();
        if let Some(batched) = &mut self.batched {
            batched.clear();
        }
        self.check_sink()
    }

    /// Sends extra scalar series (e.g. `tumble diff`'s errors) to `entity` on both timelines:
    /// `values` holds `names.len()` values per row, rows at `time_ns` / `step`. The series names
    /// are sent once per entity as a static `SeriesLines`. Frames buffered so far are sent first,
    /// so every entity's rows stay in time order.
    pub fn write_series(
        &mut self,
        entity: &EntityPath,
        names: &[&str],
        time_ns: &[i64],
        step: &[i64],
        values: &[f64],
    ) -> Result<()> {
        if time_ns.len() != step.len() || values.len() != time_ns.len() * names.len() {
            bail!(
                "series {entity}: {} times, {} steps, {} values for {} names",
                time_ns.len(),
                step.len(),
                values.len(),
                names.len()
            );
        }
        if self.series_named.insert(entity.clone()) {
            self.send(static_chunk(
                entity.clone(),
                &[&rerun::SeriesLines::new().with_names(names.iter().copied())],
            )?)?;
        }
        if time_ns.is_empty() {
            return Ok(());
        }
        self.flush_buffer()?;
        self.writer().send_columns(
            entity.clone(),
            [
                TimeColumn::new_duration_nanos(SIM_TIME_TIMELINE, time_ns.iter().copied()),
                TimeColumn::new_sequence(STEP_TIMELINE, step.iter().copied()),
            ],
            rerun::Scalars::new(values.iter().copied())
                .columns(std::iter::repeat_n(names.len(), time_ns.len()))?,
        )?;
        self.check_sink()
    }
}
