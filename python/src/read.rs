//! `tumble.read(path)`: a tumble MCAP recording as one table per topic, read back by the
//! library's reader ([`tumble::replay::steps::StepReader`]: every topic group merged, a step cut
//! off at the end of a truncated file dropped). Columns follow the Parquet tables
//! (docs/datasets.md): `step`, `time` (ns), `time_secs`, then the topic's fields, vectors as
//! `_x _y _z (_w)` columns.

use crate::columns::Columns;
use crate::err;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// Vector columns `name_x`, `name_y`, `name_z` (and `name_w`).
struct Vectors<const N: usize> {
    values: [Vec<f64>; N],
}

impl<const N: usize> Vectors<N> {
    fn new() -> Self {
        Self {
            values: std::array::from_fn(|_| Vec::new()),
        }
    }
    fn push(&mut self, v: [f64; N]) {
        for (column, x) in self.values.iter_mut().zip(v) {
            column.push(x);
        }
    }
    fn into(self, c: &mut Columns, names: [&'static str; N]) {
        for (name, v) in names.into_iter().zip(self.values) {
            c.f64(name, v);
        }
    }
}

/// The step columns of a table.
#[derive(Default)]
struct Clock {
    step: Vec<i64>,
    time: Vec<i64>,
    secs: Vec<f64>,
}

impl Clock {
    fn push(&mut self, step: u64, time_ns: i64) {
        self.step.push(step as i64);
        self.time.push(time_ns);
        self.secs.push(time_ns as f64 / 1e9);
    }
    fn into(self, c: &mut Columns) {
        c.i64("step", self.step);
        c.i64("time", self.time);
        c.f64("time_secs", self.secs);
    }
}

/// Reads a tumble MCAP recording (`STEM.mcap`, not the ROS 2 one) into `{topic: DataFrame}`:
/// `/tf` (every link frame's pose), `/bodies` (each body's centre of mass, principal frame,
/// velocities, spin, energies), and when the run has them `/joints`, `/mechanisms`,
/// `/contacts`. The GIL is released while reading.
#[pyfunction]
pub fn read<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let tables = py.detach(|| tables(&path)).map_err(err)?;
    let d = PyDict::new(py);
    for (topic, columns) in tables {
        d.set_item(topic, columns.into_frame(py)?)?;
    }
    Ok(d)
}

fn tables(path: &std::path::Path) -> anyhow::Result<Vec<(&'static str, Columns)>> {
    let mut reader = tumble::replay::steps::StepReader::open(path)?;
    let layout = reader.layout().clone();
    let (mut tf_clock, mut tf_frame) = (Clock::default(), Vec::new());
    let (mut tf_t, mut tf_q) = (Vectors::<3>::new(), Vectors::<4>::new());
    let (mut b_clock, mut b_name) = (Clock::default(), Vec::new());
    let (mut b_p, mut b_q) = (Vectors::<3>::new(), Vectors::<4>::new());
    let (mut b_v, mut b_w, mut b_l) = (
        Vectors::<3>::new(),
        Vectors::<3>::new(),
        Vectors::<3>::new(),
    );
    let (mut b_ke, mut b_pe) = (Vec::new(), Vec::new());
    let (mut j_clock, mut j_name) = (Clock::default(), Vec::new());
    let (mut j_pos, mut j_vel, mut j_eff, mut j_tgt) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut j_sat, mut j_lim) = (Vec::new(), Vec::new());
    let (mut m_clock, mut m_name) = (Clock::default(), Vec::new());
    let (mut m_p, mut m_l, mut m_c) = (
        Vectors::<3>::new(),
        Vectors::<3>::new(),
        Vectors::<3>::new(),
    );
    let (mut m_ke, mut m_pe, mut m_rm, mut m_rr) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut c_clock, mut c_a, mut c_b) = (Clock::default(), Vec::new(), Vec::new());
    let (mut c_p, mut c_n, mut c_f, mut c_i) = (
        Vectors::<3>::new(),
        Vectors::<3>::new(),
        Vectors::<3>::new(),
        Vectors::<3>::new(),
    );
    let mut c_gap = Vec::new();
    let xyz = |v: &nalgebra::Vector3<f64>| [v.x, v.y, v.z];
    while let Some(s) = reader.next_step()? {
        for (f, pose) in layout.frames.iter().zip(&s.world_from_link) {
            tf_clock.push(s.step, s.time_ns);
            tf_frame.push(f.frame_id.clone());
            tf_t.push(xyz(&pose.translation.vector));
            let q = pose.rotation.quaternion().coords;
            tf_q.push([q.x, q.y, q.z, q.w]);
        }
        for (b, state) in layout.bodies.iter().zip(&s.bodies) {
            b_clock.push(s.step, s.time_ns);
            b_name.push(b.name.clone());
            let pose = s.world_from_link[b.frame] * b.link_from_principal;
            b_p.push(xyz(&pose.translation.vector));
            let q = pose.rotation.quaternion().coords;
            b_q.push([q.x, q.y, q.z, q.w]);
            b_v.push(xyz(&state.linvel_world));
            b_w.push(xyz(&state.angvel_world));
            b_l.push(xyz(&state.angmom_world));
            b_ke.push(state.kinetic_energy);
            b_pe.push(state.potential_energy);
        }
        for (j, state) in layout.joints.iter().zip(&s.joints) {
            j_clock.push(s.step, s.time_ns);
            j_name.push(j.name.clone());
            j_pos.push(state.position);
            j_vel.push(state.velocity);
            j_eff.push(state.effort);
            j_tgt.push(state.target.unwrap_or(f64::NAN));
            j_sat.push(state.saturated);
            j_lim.push(state.at_limit);
        }
        for (m, state) in layout.mechanisms.iter().zip(&s.mechanisms) {
            m_clock.push(s.step, s.time_ns);
            m_name.push(m.name.clone());
            m_p.push(xyz(&state.linear_momentum));
            m_l.push(xyz(&state.angular_momentum));
            m_c.push(xyz(&state.com));
            m_ke.push(state.kinetic_energy);
            m_pe.push(state.potential_energy);
            m_rm.push(state.residual_m);
            m_rr.push(state.residual_rad);
        }
        for c in &s.contacts {
            c_clock.push(s.step, s.time_ns);
            c_a.push(layout.bodies[c.body_a].name.clone());
            c_b.push(
                c.body_b
                    .map_or_else(|| "ground".to_string(), |b| layout.bodies[b].name.clone()),
            );
            c_p.push(xyz(&c.point_world));
            c_n.push(xyz(&c.normal_world));
            c_f.push(xyz(&c.force_world));
            c_i.push(xyz(&c.impulse_world));
            c_gap.push(c.gap_m);
        }
    }
    let mut out = Vec::new();
    let mut tf = Columns::default();
    tf_clock.into(&mut tf);
    tf.text("frame_id", tf_frame);
    tf_t.into(&mut tf, ["translation_x", "translation_y", "translation_z"]);
    tf_q.into(
        &mut tf,
        ["rotation_x", "rotation_y", "rotation_z", "rotation_w"],
    );
    out.push(("/tf", tf));
    let mut bodies = Columns::default();
    b_clock.into(&mut bodies);
    bodies.text("body", b_name);
    b_p.into(&mut bodies, ["position_x", "position_y", "position_z"]);
    b_q.into(
        &mut bodies,
        [
            "orientation_x",
            "orientation_y",
            "orientation_z",
            "orientation_w",
        ],
    );
    b_v.into(
        &mut bodies,
        [
            "linear_velocity_x",
            "linear_velocity_y",
            "linear_velocity_z",
        ],
    );
    b_w.into(
        &mut bodies,
        [
            "angular_velocity_x",
            "angular_velocity_y",
            "angular_velocity_z",
        ],
    );
    b_l.into(
        &mut bodies,
        [
            "angular_momentum_x",
            "angular_momentum_y",
            "angular_momentum_z",
        ],
    );
    bodies.f64("kinetic_energy", b_ke);
    bodies.f64("potential_energy", b_pe);
    out.push(("/bodies", bodies));
    if !layout.joints.is_empty() {
        let mut joints = Columns::default();
        j_clock.into(&mut joints);
        joints.text("joint", j_name);
        joints.f64("position", j_pos);
        joints.f64("velocity", j_vel);
        joints.f64("effort", j_eff);
        joints.f64("target", j_tgt);
        joints.bool("saturated", j_sat);
        joints.bool("at_limit", j_lim);
        out.push(("/joints", joints));
    }
    if !layout.mechanisms.is_empty() {
        let mut m = Columns::default();
        m_clock.into(&mut m);
        m.text("model", m_name);
        m_p.into(
            &mut m,
            [
                "linear_momentum_x",
                "linear_momentum_y",
                "linear_momentum_z",
            ],
        );
        m_l.into(
            &mut m,
            [
                "angular_momentum_x",
                "angular_momentum_y",
                "angular_momentum_z",
            ],
        );
        m_c.into(&mut m, ["com_x", "com_y", "com_z"]);
        m.f64("kinetic_energy", m_ke);
        m.f64("potential_energy", m_pe);
        m.f64("residual_m", m_rm);
        m.f64("residual_rad", m_rr);
        out.push(("/mechanisms", m));
    }
    if layout.contacts {
        let mut c = Columns::default();
        c_clock.into(&mut c);
        c.text("body_a", c_a);
        c.text("body_b", c_b);
        c_p.into(&mut c, ["point_x", "point_y", "point_z"]);
        c_n.into(&mut c, ["normal_x", "normal_y", "normal_z"]);
        c_f.into(&mut c, ["force_x", "force_y", "force_z"]);
        c_i.into(&mut c, ["impulse_x", "impulse_y", "impulse_z"]);
        c.f64("gap_m", c_gap);
        out.push(("/contacts", c));
    }
    Ok(out)
}
