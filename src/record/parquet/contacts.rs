//! The contacts table of `simulate --format parquet` (`STEM.contacts.parquet`): one row per
//! recorded step and contact, long form like the joints table. Written only for runs that can
//! have contacts ([`crate::record::RecordingLayout::contacts`]: a ground or bodies that
//! collide), so a run without contact writes the files it wrote before contact existed; such a
//! run with no contact at all writes the file with no rows.
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `run` | int64 | run index, 0 |
//! | `step` | int64 | integrator step (the contacts of the step that ended there) |
//! | `time` | int64 | simulation time, ns |
//! | `time_secs` | float64 | the same in s |
//! | `body_a` | string | the body the impulse acts on (its recorded name, as in the trajectories table) |
//! | `body_b` | string | the other body, or `ground` |
//! | `ground` | bool | whether `b` is the ground (tells it from a body named `ground`) |
//! | `point_x`, `point_y`, `point_z` | float64 | the contact point on `b`'s surface, m, world |
//! | `normal_x`, `normal_y`, `normal_z` | float64 | unit normal from `b` toward `a`, world |
//! | `force_x`, `force_y`, `force_z` | float64 | the mean force on `a` over the step, impulse / dt, N, world |
//! | `impulse_x`, `impulse_y`, `impulse_z` | float64 | the impulse on `a` over the step, N s, world |
//! | `gap_m` | float64 | signed gap at the start of the step, m (negative: penetration) |
//!
//! Values are the frame's ([`crate::record::ContactState`]), the same as the MCAP `/contacts`.

use super::files::{ROW_GROUP_ROWS, close_streamed, writer_properties};
use super::tables::{f64s, field};
use crate::fsutil::part_path;
use crate::record::contacts::GROUND_NAME;
use crate::record::writeback::WritebackFile;
use crate::record::{Frame, RecordingLayout, Sink};
use anyhow::Context;
use arrow_array::{ArrayRef, BooleanArray, Float64Array, Int64Array, RecordBatch, StringArray};
use arrow_schema::{DataType, Schema, SchemaRef};
use nalgebra::Vector3;
use parquet::arrow::ArrowWriter;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

const XYZ: [&str; 3] = ["x", "y", "z"];

/// Schema of the contacts table (module doc).
pub fn contacts_schema() -> SchemaRef {
    static SCHEMA: OnceLock<SchemaRef> = OnceLock::new();
    SCHEMA
        .get_or_init(|| {
            let mut fields = vec![
                field("run", DataType::Int64, false, ""),
                field("step", DataType::Int64, false, ""),
                field("time", DataType::Int64, false, "ns"),
                field("time_secs", DataType::Float64, false, "s"),
                field("body_a", DataType::Utf8, false, ""),
                field("body_b", DataType::Utf8, false, ""),
                field("ground", DataType::Boolean, false, ""),
            ];
            fields.extend(f64s("point", &XYZ, "m", false));
            fields.extend(f64s("normal", &XYZ, "", false));
            fields.extend(f64s("force", &XYZ, "N", false));
            fields.extend(f64s("impulse", &XYZ, "N s", false));
            fields.push(field("gap_m", DataType::Float64, false, "m"));
            Arc::new(Schema::new(fields))
        })
        .clone()
}

/// Buffered rows of the contacts table.
#[derive(Debug, Default)]
struct ContactColumns {
    step: Vec<i64>,
    time_ns: Vec<i64>,
    /// Indices into the sink's body names.
    body_a: Vec<usize>,
    /// `None`: the ground.
    body_b: Vec<Option<usize>>,
    /// Per vector quantity (point, normal, force, impulse), per component.
    vectors: [[Vec<f64>; 3]; 4],
    gap_m: Vec<f64>,
}

impl ContactColumns {
    fn push_vector(&mut self, k: usize, v: &Vector3<f64>) {
        for (column, value) in self.vectors[k].iter_mut().zip(v.iter()) {
            column.push(*value);
        }
    }
}

/// Writes `STEM.contacts.parquet` (module doc), with the trajectories table's writer settings.
pub struct ContactsSink {
    writer: Option<ArrowWriter<BufWriter<WritebackFile>>>,
    path: PathBuf,
    names: Vec<String>,
    rows: ContactColumns,
}

impl ContactsSink {
    /// Creates `<path>.part`.
    pub fn create(path: &Path, layout: &RecordingLayout) -> anyhow::Result<Self> {
        let part = part_path(path);
        let file = crate::fsutil::create_part(path)?;
        let writer = ArrowWriter::try_new(
            BufWriter::with_capacity(1 << 20, WritebackFile::new(file)),
            contacts_schema(),
            Some(writer_properties(true)?),
        )
        .with_context(|| format!("cannot start {}", part.display()))?;
        Ok(Self {
            writer: Some(writer),
            path: path.to_path_buf(),
            names: layout.bodies.iter().map(|b| b.name.clone()).collect(),
            rows: ContactColumns::default(),
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
        let name = |b: usize| Some(self.names[b].as_str());
        let body_a: StringArray = rows.body_a.iter().map(|&b| name(b)).collect();
        let body_b: StringArray = rows
            .body_b
            .iter()
            .map(|b| b.map_or(Some(GROUND_NAME), name))
            .collect();
        let ground: BooleanArray = rows.body_b.iter().map(|b| Some(b.is_none())).collect();
        let mut columns: Vec<ArrayRef> = vec![
            Arc::new(Int64Array::from(vec![0; n])),
            Arc::new(Int64Array::from(rows.step)),
            Arc::new(Int64Array::from(rows.time_ns)),
            Arc::new(time_secs),
            Arc::new(body_a),
            Arc::new(body_b),
            Arc::new(ground),
        ];
        for vector in rows.vectors {
            for component in vector {
                columns.push(Arc::new(Float64Array::from(component)));
            }
        }
        columns.push(Arc::new(Float64Array::from(rows.gap_m)));
        let batch = RecordBatch::try_new(contacts_schema(), columns)?;
        let writer = self.writer.as_mut().context("the file is closed")?;
        writer
            .write(&batch)
            .with_context(|| format!("cannot write {}", part_path(&self.path).display()))
    }
}

impl Sink for ContactsSink {
    fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
        crate::record::contacts::check(frame.contacts, self.names.len())?;
        let rows = &mut self.rows;
        for c in frame.contacts {
            rows.step.push(frame.step as i64);
            rows.time_ns.push(frame.time_ns);
            rows.body_a.push(c.body_a);
            rows.body_b.push(c.body_b);
            rows.push_vector(0, &c.point_world);
            rows.push_vector(1, &c.normal_world);
            rows.push_vector(2, &c.force_world);
            rows.push_vector(3, &c.impulse_world);
            rows.gap_m.push(c.gap_m);
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

impl Drop for ContactsSink {
    fn drop(&mut self) {
        if self.writer.take().is_some() {
            crate::fsutil::discard(&[&self.path]);
        }
    }
}
