//! The Parquet sinks of `simulate --format parquet`: the dataset's tables for this one run, so a
//! big run can be read in pandas or DuckDB.
//!
//! | file | content |
//! |---|---|
//! | `STEM.trajectories.parquet` | the dataset's `trajectories` table ([`super::tables`]): one row per recorded step and body, `run = 0` |
//! | `STEM.bodies.parquet` | the dataset's `bodies.parquet` table: one row per body; its `model` column holds the body's model label (`box_0042`, or the URDF robot name) |
//!
//! Same writer settings as the dataset's files ([`super::files::writer_properties`]:
//! zstd level 1, row groups of 128 Ki rows; same rows, same bytes). Both are written under
//! `<path>.part` and published by [`crate::record::finish_all`] with the other files of the run. The
//! trajectories file is written back and synced while it grows, as the MCAP and Rerun files are
//! ([`crate::record::writeback`]).

use super::files::{ROW_GROUP_ROWS, close_streamed, writer_properties};
use super::tables::{TrajectoryColumns, bodies_rows, trajectories_schema};
use crate::fsutil::part_path;
use crate::record::writeback::WritebackFile;
use crate::record::{Frame, RecordingLayout, Sink};
use anyhow::Context;
use nalgebra::Isometry3;
use parquet::arrow::ArrowWriter;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// Publishes `<path>.part` onto `path` ([`crate::fsutil::publish`]).
fn publish(path: &Path) -> anyhow::Result<()> {
    crate::fsutil::publish(&[path])
}

/// Writes `STEM.trajectories.parquet`.
pub struct TrajectorySink {
    writer: Option<ArrowWriter<BufWriter<WritebackFile>>>,
    path: PathBuf,
    /// Per body: its frame and `link_from_principal` (the row's pose is its principal frame).
    bodies: Vec<(usize, Isometry3<f64>)>,
    name_ids: Vec<u32>,
    rows: TrajectoryColumns,
}

impl TrajectorySink {
    /// Creates `<path>.part`.
    pub fn create(path: &Path, layout: &RecordingLayout) -> anyhow::Result<Self> {
        let part = part_path(path);
        let file = crate::fsutil::create_part(path)?;
        let writer = ArrowWriter::try_new(
            BufWriter::with_capacity(1 << 20, WritebackFile::new(file)),
            trajectories_schema(),
            Some(writer_properties(true)?),
        )
        .with_context(|| format!("cannot start {}", part.display()))?;
        let mut rows = TrajectoryColumns::default();
        let name_ids = layout.bodies.iter().map(|b| rows.intern(&b.name)).collect();
        Ok(Self {
            writer: Some(writer),
            path: path.to_path_buf(),
            bodies: layout
                .bodies
                .iter()
                .map(|b| (b.frame, b.link_from_principal))
                .collect(),
            name_ids,
            rows,
        })
    }

    fn flush(&mut self) -> anyhow::Result<()> {
        if self.rows.is_empty() {
            return Ok(());
        }
        let batch = self.rows.take_batch()?;
        let writer = self.writer.as_mut().context("the file is closed")?;
        writer
            .write(&batch)
            .with_context(|| format!("cannot write {}", part_path(&self.path).display()))
    }
}

impl Sink for TrajectorySink {
    fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
        for ((&(link, link_from_principal), state), &id) in
            self.bodies.iter().zip(frame.bodies).zip(&self.name_ids)
        {
            let pose = frame.world_from_link[link] * link_from_principal;
            self.rows.push(0, frame, id, &pose, state);
        }
        if self.rows.len() >= ROW_GROUP_ROWS {
            self.flush()?;
        }
        Ok(())
    }

    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        let path = self.path.clone();
        self.complete()?;
        publish(&path)
    }

    fn path(&self) -> Option<PathBuf> {
        Some(self.path.clone())
    }

    fn complete(mut self: Box<Self>) -> anyhow::Result<()> {
        self.flush()?;
        let writer = self.writer.take().context("the file is closed")?;
        close_streamed(writer, &part_path(&self.path))
    }
}

impl Drop for TrajectorySink {
    fn drop(&mut self) {
        if self.writer.take().is_some() {
            crate::fsutil::discard(&[&self.path]);
        }
    }
}

/// Writes `STEM.bodies.parquet` when the run completes (its rows do not change). Its `.part`
/// file is this run's from the start ([`crate::fsutil::create_part`]), like every output's.
pub struct BodiesSink {
    path: PathBuf,
    batch: arrow_array::RecordBatch,
    /// The `.part` file, until it is written.
    file: Option<File>,
}

impl BodiesSink {
    /// The table's rows: body `i` of the layout, its model column the body's model label.
    pub fn new(path: &Path, layout: &RecordingLayout) -> anyhow::Result<Self> {
        let batch = bodies_rows(layout.bodies.iter().enumerate().map(|(i, b)| {
            let frame = &layout.frames[b.frame];
            (frame.model.clone(), i, b, frame.frame_id.clone())
        }))?;
        let file = crate::fsutil::create_part(path)?;
        Ok(Self {
            path: path.to_path_buf(),
            batch,
            file: Some(file),
        })
    }
}

impl Drop for BodiesSink {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            crate::fsutil::discard(&[&self.path]);
        }
    }
}

impl Sink for BodiesSink {
    fn write(&mut self, _frame: &Frame<'_>) -> anyhow::Result<()> {
        Ok(())
    }

    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        let path = self.path.clone();
        self.complete()?;
        publish(&path)
    }

    fn path(&self) -> Option<PathBuf> {
        Some(self.path.clone())
    }

    fn complete(mut self: Box<Self>) -> anyhow::Result<()> {
        let part = part_path(&self.path);
        let file = self.file.take().context("the file is closed")?;
        let mut writer = ArrowWriter::try_new(
            BufWriter::new(file),
            super::tables::bodies_schema(),
            Some(writer_properties(false)?),
        )?;
        writer.write(&self.batch)?;
        let file = writer
            .into_inner()?
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(|| format!("cannot write {}", part.display()))?;
        file.sync_all()
            .with_context(|| format!("cannot sync {}", part.display()))
    }
}
