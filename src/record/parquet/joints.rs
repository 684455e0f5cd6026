//! The joints table of `simulate --format parquet` (`STEM.joints.parquet`): one row per
//! recorded step and joint of the articulated models, long form like the trajectories table
//! (no rows for a run without articulated models; the file is written all the same, so a
//! format always writes the same files).
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `run` | int64 | run index, 0 |
//! | `step` | int64 | integrator step (0 = initial state) |
//! | `time` | int64 | simulation time, ns |
//! | `time_secs` | float64 | the same in s |
//! | `joint` | string | the joint's recorded name (the URDF joint name, `name/`-prefixed like frame ids) |
//! | `position` | float64 | rad (continuous joints unwrapped) or m |
//! | `velocity` | float64 | rad/s or m/s |
//! | `effort` | float64 | the effort applied, actuator plus damping, N m or N; 0 for an undriven joint |
//! | `target` | float64, nullable | a position servo's target (rad or m), a velocity servo's (rad/s or m/s); null otherwise |
//! | `saturated` | bool | whether the effort limit clamped the actuator's effort |
//! | `drive` | string, nullable | `position`, `velocity`, `motor`, `damping` (damping alone), null for an undriven joint |
//! | `at_limit` | bool | whether the joint is at a bound of its range with its limit on (joint limits) |
//!
//! Values are the frame's ([`crate::record::JointState`]), the same as the MCAP `/joints`.

use super::files::{ROW_GROUP_ROWS, close_streamed, writer_properties};
use super::tables::field;
use crate::fsutil::part_path;
use crate::record::writeback::WritebackFile;
use crate::record::{Frame, RecordingLayout, Sink};
use anyhow::Context;
use arrow_array::{ArrayRef, BooleanArray, Float64Array, Int64Array, RecordBatch, StringArray};
use arrow_schema::{DataType, Schema, SchemaRef};
use parquet::arrow::ArrowWriter;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

/// Schema of the joints table (module doc).
pub fn joints_schema() -> SchemaRef {
    static SCHEMA: OnceLock<SchemaRef> = OnceLock::new();
    SCHEMA
        .get_or_init(|| {
            Arc::new(Schema::new(vec![
                field("run", DataType::Int64, false, ""),
                field("step", DataType::Int64, false, ""),
                field("time", DataType::Int64, false, "ns"),
                field("time_secs", DataType::Float64, false, "s"),
                field("joint", DataType::Utf8, false, ""),
                field("position", DataType::Float64, false, "rad or m"),
                field("velocity", DataType::Float64, false, "rad/s or m/s"),
                field("effort", DataType::Float64, false, "N m or N"),
                field(
                    "target",
                    DataType::Float64,
                    true,
                    "rad or m (position servo), rad/s or m/s (velocity servo)",
                ),
                field("saturated", DataType::Boolean, false, ""),
                field("drive", DataType::Utf8, true, ""),
                field("at_limit", DataType::Boolean, false, ""),
            ]))
        })
        .clone()
}

/// Buffered rows of the joints table.
#[derive(Debug, Default)]
struct JointColumns {
    step: Vec<i64>,
    time_ns: Vec<i64>,
    /// Index into the sink's joint names.
    joint: Vec<u32>,
    position: Vec<f64>,
    velocity: Vec<f64>,
    effort: Vec<f64>,
    target: Vec<Option<f64>>,
    saturated: Vec<bool>,
    at_limit: Vec<bool>,
}

/// Writes `STEM.joints.parquet` (module doc), with the trajectories table's writer settings.
pub struct JointsSink {
    writer: Option<ArrowWriter<BufWriter<WritebackFile>>>,
    path: PathBuf,
    names: Vec<String>,
    /// Per joint: its drive's name, if it is driven.
    drives: Vec<Option<&'static str>>,
    rows: JointColumns,
}

impl JointsSink {
    /// Creates `<path>.part`.
    pub fn create(path: &Path, layout: &RecordingLayout) -> anyhow::Result<Self> {
        let part = part_path(path);
        let file = crate::fsutil::create_part(path)?;
        let writer = ArrowWriter::try_new(
            BufWriter::with_capacity(1 << 20, WritebackFile::new(file)),
            joints_schema(),
            Some(writer_properties(true)?),
        )
        .with_context(|| format!("cannot start {}", part.display()))?;
        Ok(Self {
            writer: Some(writer),
            path: path.to_path_buf(),
            names: layout.joints.iter().map(|j| j.name.clone()).collect(),
            drives: (0..layout.joints.len())
                .map(|j| layout.drive_of(j).map(|d| d.kind_name()))
                .collect(),
            rows: JointColumns::default(),
        })
    }

    fn flush(&mut self) -> anyhow::Result<()> {
        if self.rows.step.is_empty() {
            return Ok(());
        }
        let rows = std::mem::take(&mut self.rows);
        let n = rows.step.len();
        let time_secs: Float64Array = rows
            .time_ns
            .iter()
            .map(|&t| Some(t as f64 * 1e-9))
            .collect();
        let joint: StringArray = rows
            .joint
            .iter()
            .map(|&j| Some(self.names[j as usize].as_str()))
            .collect();
        let drive: StringArray = rows
            .joint
            .iter()
            .map(|&j| self.drives[j as usize])
            .collect();
        let columns: Vec<ArrayRef> = vec![
            Arc::new(Int64Array::from(vec![0; n])),
            Arc::new(Int64Array::from(rows.step)),
            Arc::new(Int64Array::from(rows.time_ns)),
            Arc::new(time_secs),
            Arc::new(joint),
            Arc::new(Float64Array::from(rows.position)),
            Arc::new(Float64Array::from(rows.velocity)),
            Arc::new(Float64Array::from(rows.effort)),
            Arc::new(Float64Array::from(rows.target)),
            Arc::new(BooleanArray::from(rows.saturated)),
            Arc::new(drive),
            Arc::new(BooleanArray::from(rows.at_limit)),
        ];
        let batch = RecordBatch::try_new(joints_schema(), columns)?;
        let writer = self.writer.as_mut().context("the file is closed")?;
        writer
            .write(&batch)
            .with_context(|| format!("cannot write {}", part_path(&self.path).display()))
    }
}

impl Sink for JointsSink {
    fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
        if frame.joints.len() != self.names.len() {
            anyhow::bail!(
                "frame has {} joint states, the layout {}",
                frame.joints.len(),
                self.names.len()
            );
        }
        let rows = &mut self.rows;
        for (j, s) in frame.joints.iter().enumerate() {
            rows.step.push(frame.step as i64);
            rows.time_ns.push(frame.time_ns);
            rows.joint.push(j as u32);
            rows.position.push(s.position);
            rows.velocity.push(s.velocity);
            rows.effort.push(s.effort);
            rows.target.push(s.target);
            rows.saturated.push(s.saturated);
            rows.at_limit.push(s.at_limit);
        }
        if rows.step.len() >= ROW_GROUP_ROWS {
            self.flush()?;
        }
        Ok(())
    }

    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        let path = self.path.clone();
        self.complete()?;
        crate::fsutil::publish(&[&path])
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

impl Drop for JointsSink {
    fn drop(&mut self) {
        if self.writer.take().is_some() {
            crate::fsutil::discard(&[&self.path]);
        }
    }
}
