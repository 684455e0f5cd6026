//! The dataset's `runs/part-NNNNN.parquet` table: one row per run, its drawn parameters and
//! outcome (the other tables are in [`crate::record::parquet::tables`]).

use super::sample::RunParams;
use crate::record::parquet::tables::{XYZ, XYZW, f64s, field};
use crate::sim::integrators::EnergyFlow;
use arrow_array::{ArrayRef, Float64Array, Int64Array, RecordBatch, StringArray, UInt64Array};
use arrow_schema::{DataType, Schema, SchemaRef};
use std::sync::{Arc, OnceLock};

/// Schema of `runs/part-NNNNN.parquet`: one row per run.
///
/// | column | type | meaning |
/// |---|---|---|
/// | `run`, `seed` | int64, uint64 | run index; the seed its values were drawn from |
/// | `model` | string | URDF path as written in the spec |
/// | `integrator`, `dt`, `duration`, `steps`, `log_every` | string, float64 (s), float64 (s), int64, int64 | |
/// | `gravity_x/_y/_z` | float64 | m/s², world |
/// | `root_position_x/_y/_z`, `root_orientation_x/_y/_z/_w` | float64 | initial pose of the model's root link frame, world (m; quaternion xyzw) |
/// | `initial_linear_velocity_x/_y/_z`, `initial_angular_velocity_x/_y/_z` | float64 | every body's initial velocities, world (m/s, rad/s) |
/// | `bodies`, `rows` | int64 | bodies simulated; trajectory rows written |
/// | `status` | string | `ok`, or `diverged` (the run guard stopped it: rows end at the last good recorded step) |
/// | `steps_done` | int64 | steps completed (`steps` when ok) |
/// | `energy_initial`, `energy_final` | float64, J | total mechanical energy (final: null when diverged) |
/// | `energy_drift_rel` | float64 | `(E_final − E_initial) / |E_initial|` (null when diverged) |
/// | `angular_momentum_drift_rel` | float64 | largest `|L(T) − L(0)| / |L(0)|` of a conserved angular momentum (a free body's about its centre of mass, a floating robot's total); null when diverged or when none has a reference (all start at rest, or the base is fixed) |
/// | `newton_iters_max`, `substepped` | int64 | Newton iterations of the hardest solve; body-steps substepped |
/// | `diverged_body`, `diverged_cause` | string | null when ok |
/// | `angular_momentum_change_abs` | float64, kg m²/s | largest `|L(T) − L(0)|` of a conserved angular momentum that started at rest (`crate::simulation::summary::AT_REST`); null when none did, or diverged |
/// | `input_work`, `dissipated`, `contact_work` | float64, J | work of the actuators and loads, energy joint damping and friction removed, kinetic energy contact changed |
/// | `energy_balance_residual` | float64, J | `E_final − E_initial − (input_work − dissipated + contact_work)`: the scheme's own energy error (null when diverged) |
/// | `constraint_residual_m`, `constraint_residual_rad` | float64 | largest joint anchor gap and axis misalignment over the recorded frames; null without joints |
pub fn runs_schema() -> SchemaRef {
    static SCHEMA: OnceLock<SchemaRef> = OnceLock::new();
    SCHEMA
        .get_or_init(|| {
            let mut fields = vec![
                field("run", DataType::Int64, false, ""),
                field("seed", DataType::UInt64, false, ""),
                field("model", DataType::Utf8, false, ""),
                field("integrator", DataType::Utf8, false, ""),
                field("dt", DataType::Float64, false, "s"),
                field("duration", DataType::Float64, false, "s"),
                field("steps", DataType::Int64, false, ""),
                field("log_every", DataType::Int64, false, ""),
            ];
            fields.extend(f64s("gravity", XYZ, "m/s^2", false));
            fields.extend(f64s("root_position", XYZ, "m", false));
            fields.extend(f64s("root_orientation", XYZW, "", false));
            fields.extend(f64s("initial_linear_velocity", XYZ, "m/s", false));
            fields.extend(f64s("initial_angular_velocity", XYZ, "rad/s", false));
            fields.extend([
                field("bodies", DataType::Int64, false, ""),
                field("rows", DataType::Int64, false, ""),
                field("status", DataType::Utf8, false, ""),
                field("steps_done", DataType::Int64, false, ""),
                field("energy_initial", DataType::Float64, false, "J"),
                field("energy_final", DataType::Float64, true, "J"),
                field("energy_drift_rel", DataType::Float64, true, ""),
                field("angular_momentum_drift_rel", DataType::Float64, true, ""),
                field("newton_iters_max", DataType::Int64, false, ""),
                field("substepped", DataType::Int64, false, ""),
                field("diverged_body", DataType::Utf8, true, ""),
                field("diverged_cause", DataType::Utf8, true, ""),
                field(
                    "angular_momentum_change_abs",
                    DataType::Float64,
                    true,
                    "kg m^2/s",
                ),
                field("input_work", DataType::Float64, false, "J"),
                field("dissipated", DataType::Float64, false, "J"),
                field("contact_work", DataType::Float64, false, "J"),
                field("energy_balance_residual", DataType::Float64, true, "J"),
                field("constraint_residual_m", DataType::Float64, true, "m"),
                field("constraint_residual_rad", DataType::Float64, true, "rad"),
            ]);
            Arc::new(Schema::new(fields))
        })
        .clone()
}

/// One row of the runs table.
#[derive(Debug, Clone, PartialEq)]
pub struct RunRow {
    pub params: RunParams,
    pub model: String,
    pub steps: u64,
    pub log_every: u64,
    pub bodies: u64,
    pub rows: u64,
    pub steps_done: u64,
    pub energy_initial: f64,
    /// `None` when diverged.
    pub energy_final: Option<f64>,
    /// `None` when diverged or no conserved momentum had a reference.
    pub angmom_drift_rel: Option<f64>,
    /// `None` when diverged or no conserved momentum started at rest.
    pub angmom_change_abs: Option<f64>,
    pub energy_flow: EnergyFlow,
    pub constraint_residual: Option<[f64; 2]>,
    pub newton_iters_max: u32,
    pub substepped: u64,
    /// `(body name, cause)` when the guard stopped the run.
    pub diverged: Option<(String, String)>,
}

/// The runs of one chunk as a batch.
pub fn runs_batch(rows: &[RunRow]) -> anyhow::Result<RecordBatch> {
    let i64s = |f: &dyn Fn(&RunRow) -> i64| -> ArrayRef {
        Arc::new(rows.iter().map(f).collect::<Int64Array>())
    };
    let f64s = |f: &dyn Fn(&RunRow) -> Option<f64>| -> ArrayRef {
        Arc::new(rows.iter().map(f).collect::<Float64Array>())
    };
    let strs = |f: &dyn Fn(&RunRow) -> Option<String>| -> ArrayRef {
        Arc::new(rows.iter().map(f).collect::<StringArray>())
    };
    let mut columns: Vec<ArrayRef> = vec![
        i64s(&|r| r.params.run as i64),
        Arc::new(UInt64Array::from(
            rows.iter().map(|r| r.params.seed).collect::<Vec<_>>(),
        )),
        strs(&|r| Some(r.model.clone())),
        strs(&|r| Some(r.params.integrator.name().to_string())),
        f64s(&|r| Some(r.params.dt_secs)),
        f64s(&|r| Some(r.params.duration_secs)),
        i64s(&|r| r.steps as i64),
        i64s(&|r| r.log_every as i64),
    ];
    for k in 0..3 {
        columns.push(f64s(&|r| Some(r.params.gravity_world[k])));
    }
    for k in 0..3 {
        columns.push(f64s(&|r| Some(r.params.root_position_world[k])));
    }
    for k in 0..4 {
        columns.push(f64s(&|r| Some(r.params.root_orientation_xyzw[k])));
    }
    for k in 0..3 {
        columns.push(f64s(&|r| Some(r.params.linvel_world[k])));
    }
    for k in 0..3 {
        columns.push(f64s(&|r| Some(r.params.angvel_world[k])));
    }
    columns.extend([
        i64s(&|r| r.bodies as i64),
        i64s(&|r| r.rows as i64),
        strs(&|r| {
            Some(
                if r.diverged.is_some() {
                    "diverged"
                } else {
                    "ok"
                }
                .to_string(),
            )
        }),
        i64s(&|r| r.steps_done as i64),
        f64s(&|r| Some(r.energy_initial)),
        f64s(&|r| r.energy_final),
        f64s(&|r| {
            r.energy_final
                .map(|e| (e - r.energy_initial) / r.energy_initial.abs().max(f64::MIN_POSITIVE))
        }),
        f64s(&|r| r.angmom_drift_rel),
        i64s(&|r| i64::from(r.newton_iters_max)),
        i64s(&|r| r.substepped as i64),
        strs(&|r| r.diverged.as_ref().map(|d| d.0.clone())),
        strs(&|r| r.diverged.as_ref().map(|d| d.1.clone())),
        f64s(&|r| r.angmom_change_abs),
        f64s(&|r| Some(r.energy_flow.input_work)),
        f64s(&|r| Some(r.energy_flow.dissipated)),
        f64s(&|r| Some(r.energy_flow.contact_work)),
        f64s(&|r| {
            let flow = &r.energy_flow;
            r.energy_final.map(|e| {
                e - r.energy_initial - (flow.input_work - flow.dissipated + flow.contact_work)
            })
        }),
        f64s(&|r| r.constraint_residual.map(|c| c[0])),
        f64s(&|r| r.constraint_residual.map(|c| c[1])),
    ]);
    Ok(RecordBatch::try_new(runs_schema(), columns)?)
}
