//! The joints table of `simulate --format parquet` (`STEM.joints.parquet`) and of a dataset
//! (`joints/part-NNNNN.parquet`): one row per
//! recorded step and joint of the articulated models, long form like the trajectories table
//! (no rows for a run without articulated models; the file is written all the same, so a
//! format always writes the same files).
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `run` | int64 | run index (0 for `simulate`; a dataset's run) |
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
use std::cell::RefCell;
use std::collections::HashMap;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::rc::Rc;
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

/// Rows of the joints table, filled by [`JointsSink`] (one run) or [`JointRowsSink`] (a
/// dataset chunk's runs) and drained into record batches.
#[derive(Debug, Default)]
pub struct JointColumns {
    /// Joint names seen so far (with their drives); `joint` holds indices into them.
    names: Vec<String>,
    drives: Vec<Option<&'static str>>,
    ids: HashMap<String, u32>,
    run: Vec<i64>,
    step: Vec<i64>,
    time_ns: Vec<i64>,
    joint: Vec<u32>,
    position: Vec<f64>,
    velocity: Vec<f64>,
    effort: Vec<f64>,
    target: Vec<Option<f64>>,
    saturated: Vec<bool>,
    at_limit: Vec<bool>,
}

impl JointColumns {
    pub fn len(&self) -> usize {
        self.step.len()
    }

    pub fn is_empty(&self) -> bool {
        self.step.is_empty()
    }

    /// The index of the joint `name` driven by `drive` in this buffer's name table. A name is
    /// interned with its drive: the same name with another drive (another model choice of a
    /// dataset) is another entry.
    pub fn intern(&mut self, name: &str, drive: Option<&'static str>) -> u32 {
        let key = format!("{name}\0{}", drive.unwrap_or(""));
        if let Some(&id) = self.ids.get(&key) {
            return id;
        }
        let id = self.names.len() as u32;
        self.names.push(name.to_string());
        self.drives.push(drive);
        self.ids.insert(key, id);
        id
    }

    /// The ids ([`JointColumns::intern`]) of `layout`'s joints, in layout order.
    pub fn intern_layout(&mut self, layout: &RecordingLayout) -> Vec<u32> {
        (0..layout.joints.len())
            .map(|j| {
                let drive = layout.drive_of(j).map(|d| d.kind_name());
                self.intern(&layout.joints[j].name, drive)
            })
            .collect()
    }

    /// Appends the rows of `frame` (one per joint, `ids` from [`JointColumns::intern_layout`]).
    pub fn push(&mut self, run: u64, frame: &Frame<'_>, ids: &[u32]) -> anyhow::Result<()> {
        if frame.joints.len() != ids.len() {
            anyhow::bail!(
                "frame has {} joint states, the layout {}",
                frame.joints.len(),
                ids.len()
            );
        }
        for (s, &id) in frame.joints.iter().zip(ids) {
            self.run.push(run as i64);
            self.step.push(frame.step as i64);
            self.time_ns.push(frame.time_ns);
            self.joint.push(id);
            self.position.push(s.position);
            self.velocity.push(s.velocity);
            self.effort.push(s.effort);
            self.target.push(s.target);
            self.saturated.push(s.saturated);
            self.at_limit.push(s.at_limit);
        }
        Ok(())
    }

    /// The buffered rows as a batch; the buffers are emptied (the name table is kept).
    pub fn take_batch(&mut self) -> anyhow::Result<RecordBatch> {
        let time_secs: Float64Array = self
            .time_ns
            .iter()
            .map(|&t| Some(t as f64 * 1e-9))
            .collect();
        let joint: StringArray = self
            .joint
            .iter()
            .map(|&j| Some(self.names[j as usize].as_str()))
            .collect();
        let drive: StringArray = self
            .joint
            .iter()
            .map(|&j| self.drives[j as usize])
            .collect();
        self.joint.clear();
        let columns: Vec<ArrayRef> = vec![
            Arc::new(Int64Array::from(std::mem::take(&mut self.run))),
            Arc::new(Int64Array::from(std::mem::take(&mut self.step))),
            Arc::new(Int64Array::from(std::mem::take(&mut self.time_ns))),
            Arc::new(time_secs),
            Arc::new(joint),
            Arc::new(Float64Array::from(std::mem::take(&mut self.position))),
            Arc::new(Float64Array::from(std::mem::take(&mut self.velocity))),
            Arc::new(Float64Array::from(std::mem::take(&mut self.effort))),
            Arc::new(Float64Array::from(std::mem::take(&mut self.target))),
            Arc::new(BooleanArray::from(std::mem::take(&mut self.saturated))),
            Arc::new(drive),
            Arc::new(BooleanArray::from(std::mem::take(&mut self.at_limit))),
        ];
        Ok(RecordBatch::try_new(joints_schema(), columns)?)
    }
}

/// A [`Sink`] turning frames into joint rows of a shared buffer: a dataset chunk's
/// `joints/part-NNNNN.parquet`, filled run after run.
pub struct JointRowsSink {
    pub run: u64,
    /// Per joint of the layout: its id in `rows` ([`JointColumns::intern_layout`]).
    pub ids: Vec<u32>,
    pub rows: Rc<RefCell<JointColumns>>,
}

impl Sink for JointRowsSink {
    fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
        self.rows.borrow_mut().push(self.run, frame, &self.ids)
    }

    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        Ok(())
    }
}

/// Writes `STEM.joints.parquet` (module doc), with the trajectories table's writer settings.
pub struct JointsSink {
    writer: Option<ArrowWriter<BufWriter<WritebackFile>>>,
    path: PathBuf,
    ids: Vec<u32>,
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
        let mut rows = JointColumns::default();
        Ok(Self {
            writer: Some(writer),
            path: path.to_path_buf(),
            ids: rows.intern_layout(layout),
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

impl Sink for JointsSink {
    fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
        self.rows.push(0, frame, &self.ids)?;
        if self.rows.len() >= ROW_GROUP_ROWS {
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
