//! `tumble.Scene`: what is simulated ([`tumble::scene::Scene`]), and `inspect()`: its bodies'
//! mass properties and its joints as tables.

use crate::columns::Columns;
use crate::err;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// A scene: what is simulated (a scene TOML's `[sim]` and `[[model]]` tables).
#[pyclass(frozen, module = "tumble")]
pub struct Scene {
    pub(crate) inner: tumble::scene::Scene,
}

#[pymethods]
impl Scene {
    /// Reads a scene file (TOML); relative paths in it are relative to its folder.
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Self> {
        Ok(Self {
            inner: tumble::scene::Scene::load(&path).map_err(err)?,
        })
    }

    /// Parses scene text; relative paths are relative to `base_dir` (default: the current
    /// folder), and errors name `scene.toml` there.
    #[staticmethod]
    #[pyo3(signature = (text, base_dir=None))]
    fn from_toml(text: &str, base_dir: Option<PathBuf>) -> PyResult<Self> {
        let path = base_dir.unwrap_or_default().join("scene.toml");
        Ok(Self {
            inner: tumble::scene::Scene::parse(text, &path).map_err(err)?,
        })
    }

    /// The scene of one URDF (Pinocchio's `buildModelFromUrdf`): default `[sim]`, the model at
    /// the origin; `articulated` keeps its joints, `base` = "fixed" or "floating".
    #[staticmethod]
    #[pyo3(signature = (path, articulated=false, base=None))]
    fn from_urdf(path: PathBuf, articulated: bool, base: Option<&str>) -> PyResult<Self> {
        let file = path
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut text = format!("[[model]]\nurdf = {}\n", toml_quote(&file));
        if articulated {
            text.push_str("bodies = \"articulated\"\n");
        }
        if let Some(b) = base {
            text.push_str(&format!("base = {}\n", toml_quote(b)));
        }
        let dir = path.parent().map(PathBuf::from).unwrap_or_default();
        Self::from_toml(&text, Some(dir))
    }

    /// Step size, s.
    #[getter]
    fn dt(&self) -> f64 {
        self.inner.sim.dt
    }

    /// Duration, s.
    #[getter]
    fn duration(&self) -> f64 {
        self.inner.sim.duration
    }

    /// Steps in the run (duration / dt).
    #[getter]
    fn steps(&self) -> u64 {
        self.inner.steps()
    }

    /// The file the scene came from (for `from_toml`, `scene.toml` in its `base_dir`).
    #[getter]
    fn source(&self) -> PathBuf {
        self.inner.source.clone()
    }

    /// The scene built, as tables (pandas DataFrames): `bodies` (name, model, link frame,
    /// mass kg, principal moments kg m², the principal frame in the link frame: centre of mass
    /// `com_link_*` m and axes `principal_q*` (x y z w), the initial centre of mass `com_*` m,
    /// world) and `joints` (the
    /// moving joints recorded: name, model, URDF type, limits, actuator law, effort limit,
    /// damping). Errors as `Simulation(scene)` would raise them.
    fn inspect<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let world = self.inner.build().map_err(err)?;
        let layout = &world.layout;
        let mut bodies = Columns::default();
        bodies.text(
            "name",
            layout.bodies.iter().map(|b| b.name.clone()).collect(),
        );
        bodies.text(
            "model",
            layout
                .bodies
                .iter()
                .map(|b| layout.frames[b.frame].model.clone())
                .collect(),
        );
        bodies.text(
            "frame_id",
            layout
                .bodies
                .iter()
                .map(|b| layout.frames[b.frame].frame_id.clone())
                .collect(),
        );
        bodies.f64("mass", layout.bodies.iter().map(|b| b.mass).collect());
        for (name, k) in [("moment_1", 0), ("moment_2", 1), ("moment_3", 2)] {
            bodies.f64(
                name,
                layout
                    .bodies
                    .iter()
                    .map(|b| b.principal_moments[k])
                    .collect(),
            );
        }
        // The principal frame in the link frame: the centre of mass and the axes of the moments.
        for (name, k) in [("com_link_x", 0), ("com_link_y", 1), ("com_link_z", 2)] {
            bodies.f64(
                name,
                layout
                    .bodies
                    .iter()
                    .map(|b| b.link_from_principal.translation.vector[k])
                    .collect(),
            );
        }
        for (name, k) in [
            ("principal_qx", 0),
            ("principal_qy", 1),
            ("principal_qz", 2),
            ("principal_qw", 3),
        ] {
            bodies.f64(
                name,
                layout
                    .bodies
                    .iter()
                    .map(|b| b.link_from_principal.rotation.coords[k])
                    .collect(),
            );
        }
        for (name, k) in [("com_x", 0), ("com_y", 1), ("com_z", 2)] {
            bodies.f64(
                name,
                world
                    .bodies
                    .iter()
                    .map(|b| b.world_from_body.translation.vector[k])
                    .collect(),
            );
        }
        let mut joints = Columns::default();
        joints.text(
            "name",
            layout.joints.iter().map(|j| j.name.clone()).collect(),
        );
        joints.text(
            "model",
            layout.joints.iter().map(|j| j.model.clone()).collect(),
        );
        joints.text(
            "type",
            layout.joints.iter().map(|j| j.kind.clone()).collect(),
        );
        let limit = |k: usize| -> Vec<f64> {
            layout
                .joints
                .iter()
                .map(|j| j.limits.map_or(f64::NAN, |l| l[k]))
                .collect()
        };
        joints.f64("lower", limit(0));
        joints.f64("upper", limit(1));
        let n = layout.joints.len();
        let (mut law, mut effort_limit, mut damping) =
            (vec![String::new(); n], vec![f64::NAN; n], vec![0.0; n]);
        for d in &layout.drives {
            law[d.joint] = d
                .actuator
                .map_or_else(String::new, |a| a.name().to_string());
            effort_limit[d.joint] = d.effort_limit.unwrap_or(f64::NAN);
            damping[d.joint] = d.damping;
        }
        let mut limited = vec![false; n];
        for &j in &layout.limited {
            limited[j] = true;
        }
        joints.text("actuator", law);
        joints.f64("effort_limit", effort_limit);
        joints.f64("damping", damping);
        joints.bool("limited", limited);
        let d = PyDict::new(py);
        d.set_item("bodies", bodies.into_frame(py)?)?;
        d.set_item("joints", joints.into_frame(py)?)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene({}: {} model table(s), dt {} s, {} s)",
            self.inner.source.display(),
            self.inner.models.len(),
            self.inner.sim.dt,
            self.inner.sim.duration
        )
    }
}

/// A TOML basic string.
fn toml_quote(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}
