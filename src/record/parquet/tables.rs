//! The Parquet tables of recorded steps and bodies (a dataset's, and `simulate --format
//! parquet`'s), as Arrow schemas and column buffers. The dataset's third table, `runs`, holds
//! its drawn parameters and is built by the dataset (`dataset::runs`) from the helpers here.
//!
//! **`trajectories/part-NNNNN.parquet`**: one row per recorded step (every `log_every`th, the
//! first and the last) per body. The *body frame* is the body's principal frame: origin at its
//! centre of mass, axes along its principal axes of inertia (`bodies.parquet` gives its pose in
//! the link frame). World frame, SI units.
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `run` | int64 | run index, 0-based |
//! | `step` | int64 | integrator step (0 = initial state) |
//! | `time` | int64 | simulation time, ns (`step · dt` in integer ns) |
//! | `time_secs` | float64 | the same in s |
//! | `body` | string | body name (its link's frame id; a rigid model's name) |
//! | `position_x/_y/_z` | float64 | centre of mass, world, m |
//! | `orientation_x/_y/_z/_w` | float64 | unit quaternion `world_from_body`, Hamilton, scalar last |
//! | `linear_velocity_x/_y/_z` | float64 | velocity of the centre of mass, world, m/s |
//! | `angular_velocity_x/_y/_z` | float64 | angular velocity, world, rad/s |
//!
//! **`runs/part-NNNNN.parquet`**: one row per run, every drawn value and the outcome (the
//! dataset's `runs` module). **`bodies.parquet`**: one row per model choice and body: mass,
//! principal moments, `link_from_body` ([`bodies_schema`]).

use crate::record::{BodyState, Frame, RecordingLayout, Sink};
use arrow_array::{ArrayRef, Float64Array, Int64Array, RecordBatch, StringArray};
use arrow_schema::{DataType, Field, Schema, SchemaRef};
use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;
use std::sync::{Arc, OnceLock};

pub(crate) fn field(name: &str, data_type: DataType, nullable: bool, unit: &str) -> Field {
    let f = Field::new(name, data_type, nullable);
    if unit.is_empty() {
        f
    } else {
        // One entry only: Arrow keeps field metadata in a HashMap, and a single entry is the only
        // size whose encoding order cannot vary between processes.
        f.with_metadata(HashMap::from([("unit".to_string(), unit.to_string())]))
    }
}

pub(crate) fn f64s(prefix: &str, suffixes: &[&str], unit: &str, nullable: bool) -> Vec<Field> {
    suffixes
        .iter()
        .map(|s| field(&format!("{prefix}_{s}"), DataType::Float64, nullable, unit))
        .collect()
}

pub(crate) const XYZ: &[&str] = &["x", "y", "z"];
pub(crate) const XYZW: &[&str] = &["x", "y", "z", "w"];

/// Schema of `trajectories/part-NNNNN.parquet` (module doc).
pub fn trajectories_schema() -> SchemaRef {
    static SCHEMA: OnceLock<SchemaRef> = OnceLock::new();
    SCHEMA
        .get_or_init(|| {
            let mut fields = vec![
                field("run", DataType::Int64, false, ""),
                field("step", DataType::Int64, false, ""),
                field("time", DataType::Int64, false, "ns"),
                field("time_secs", DataType::Float64, false, "s"),
                field("body", DataType::Utf8, false, ""),
            ];
            fields.extend(f64s("position", XYZ, "m", false));
            fields.extend(f64s("orientation", XYZW, "", false));
            fields.extend(f64s("linear_velocity", XYZ, "m/s", false));
            fields.extend(f64s("angular_velocity", XYZ, "rad/s", false));
            Arc::new(Schema::new(fields))
        })
        .clone()
}

/// Trajectory rows, filled by [`RowsSink`] and drained into record batches.
#[derive(Debug, Default)]
pub struct TrajectoryColumns {
    /// Body names seen so far; `body` holds indices into it.
    names: Vec<String>,
    ids: HashMap<String, u32>,
    run: Vec<i64>,
    step: Vec<i64>,
    time_ns: Vec<i64>,
    body: Vec<u32>,
    /// position xyz, orientation xyzw, linear velocity xyz, angular velocity xyz.
    values: [Vec<f64>; 13],
}

impl TrajectoryColumns {
    pub fn len(&self) -> usize {
        self.run.len()
    }

    pub fn is_empty(&self) -> bool {
        self.run.is_empty()
    }

    /// The index of body name `name` in this buffer's name table.
    pub fn intern(&mut self, name: &str) -> u32 {
        if let Some(&id) = self.ids.get(name) {
            return id;
        }
        let id = self.names.len() as u32;
        self.names.push(name.to_string());
        self.ids.insert(name.to_string(), id);
        id
    }

    pub fn push(
        &mut self,
        run: u64,
        frame: &Frame<'_>,
        body: u32,
        pose: &nalgebra::Isometry3<f64>,
        state: &BodyState,
    ) {
        self.run.push(run as i64);
        self.step.push(frame.step as i64);
        self.time_ns.push(frame.time_ns);
        self.body.push(body);
        let t = pose.translation.vector;
        let q = pose.rotation.quaternion().coords;
        let (v, w) = (state.linvel_world, state.angvel_world);
        let row = [
            t.x, t.y, t.z, q.x, q.y, q.z, q.w, v.x, v.y, v.z, w.x, w.y, w.z,
        ];
        for (column, value) in self.values.iter_mut().zip(row) {
            column.push(value);
        }
    }

    /// The buffered rows as a batch; the buffers are emptied (the name table is kept).
    pub fn take_batch(&mut self) -> anyhow::Result<RecordBatch> {
        let body: StringArray = self
            .body
            .iter()
            .map(|&b| Some(self.names[b as usize].as_str()))
            .collect();
        let time_secs: Float64Array = self
            .time_ns
            .iter()
            .map(|&t| Some(t as f64 * 1e-9))
            .collect();
        let mut columns: Vec<ArrayRef> = vec![
            Arc::new(Int64Array::from(std::mem::take(&mut self.run))),
            Arc::new(Int64Array::from(std::mem::take(&mut self.step))),
            Arc::new(Int64Array::from(std::mem::take(&mut self.time_ns))),
            Arc::new(time_secs),
            Arc::new(body),
        ];
        self.body.clear();
        for v in &mut self.values {
            columns.push(Arc::new(Float64Array::from(std::mem::take(v))));
        }
        Ok(RecordBatch::try_new(trajectories_schema(), columns)?)
    }
}

/// A [`Sink`] turning frames into trajectory rows: body `b`'s pose is
/// `world_from_link[frame_b] · link_from_principal_b` (its principal frame, equal to the
/// integrator's state to round-off).
pub struct RowsSink {
    pub run: u64,
    pub layout: Arc<RecordingLayout>,
    /// Per body: its name's index in `rows` ([`TrajectoryColumns::intern`]).
    pub name_ids: Vec<u32>,
    pub rows: Rc<RefCell<TrajectoryColumns>>,
}

impl Sink for RowsSink {
    fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
        let mut rows = self.rows.borrow_mut();
        for ((layout, state), &id) in self
            .layout
            .bodies
            .iter()
            .zip(frame.bodies)
            .zip(&self.name_ids)
        {
            let pose = frame.world_from_link[layout.frame] * layout.link_from_principal;
            rows.push(self.run, frame, id, &pose, state);
        }
        Ok(())
    }

    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        Ok(())
    }
}

/// Schema of `bodies.parquet`: one row per model choice and body.
///
/// | column | type | meaning |
/// |---|---|---|
/// | `model` | string | URDF path as written in the spec (joins `runs.model`) |
/// | `body` | string | body name (joins `trajectories.body`) |
/// | `body_index` | int64 | its index in the run |
/// | `link` | string | frame id of the link frame the body is referred to (a rigid model's root link) |
/// | `mass` | float64 | kg |
/// | `principal_moment_x/_y/_z` | float64 | kg m², about the centre of mass, along the body axes |
/// | `link_from_body_position_x/_y/_z`, `link_from_body_orientation_x/_y/_z/_w` | float64 | pose of the body (principal) frame in the link frame (m; quaternion xyzw) |
pub fn bodies_schema() -> SchemaRef {
    static SCHEMA: OnceLock<SchemaRef> = OnceLock::new();
    SCHEMA
        .get_or_init(|| {
            let mut fields = vec![
                field("model", DataType::Utf8, false, ""),
                field("body", DataType::Utf8, false, ""),
                field("body_index", DataType::Int64, false, ""),
                field("link", DataType::Utf8, false, ""),
                field("mass", DataType::Float64, false, "kg"),
            ];
            fields.extend(f64s("principal_moment", XYZ, "kg m^2", false));
            fields.extend(f64s("link_from_body_position", XYZ, "m", false));
            fields.extend(f64s("link_from_body_orientation", XYZW, "", false));
            Arc::new(Schema::new(fields))
        })
        .clone()
}

/// The bodies of every model choice (`models[i]` is choice `i`'s path, `layouts[i]` its layout).
pub fn bodies_batch(
    models: &[String],
    layouts: &[&RecordingLayout],
) -> anyhow::Result<RecordBatch> {
    bodies_rows(models.iter().zip(layouts).flat_map(|(path, layout)| {
        layout
            .bodies
            .iter()
            .enumerate()
            .map(move |(i, b)| (path.clone(), i, b, layout.frames[b.frame].frame_id.clone()))
    }))
}

/// A bodies table from `(model, body_index, body, link frame id)` rows.
pub fn bodies_rows<'a>(
    rows: impl IntoIterator<Item = (String, usize, &'a crate::record::BodyLayout, String)>,
) -> anyhow::Result<RecordBatch> {
    let mut model = Vec::new();
    let mut body = Vec::new();
    let mut index = Vec::new();
    let mut link = Vec::new();
    let mut values: [Vec<f64>; 11] = Default::default();
    for (path, i, b, frame_id) in rows {
        model.push(path);
        body.push(b.name.clone());
        index.push(i as i64);
        link.push(frame_id);
        let t = b.link_from_principal.translation.vector;
        let q = b.link_from_principal.rotation.quaternion().coords;
        let m = b.principal_moments;
        let row = [b.mass, m.x, m.y, m.z, t.x, t.y, t.z, q.x, q.y, q.z, q.w];
        for (column, v) in values.iter_mut().zip(row) {
            column.push(v);
        }
    }
    let mut columns: Vec<ArrayRef> = vec![
        Arc::new(StringArray::from(model)),
        Arc::new(StringArray::from(body)),
        Arc::new(Int64Array::from(index)),
        Arc::new(StringArray::from(link)),
    ];
    for v in values {
        columns.push(Arc::new(Float64Array::from(v)));
    }
    Ok(RecordBatch::try_new(bodies_schema(), columns)?)
}
