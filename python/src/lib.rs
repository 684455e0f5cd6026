//! The Python module `tumble._tumble` (issue 33, a first slice): [`Scene`] (from a file, TOML
//! text or a URDF) and [`Simulation`] (stepping, time, state as numpy arrays, energy), thin
//! wrappers over the library's `Scene` and `Simulation`. Every error is a `TumbleError` carrying
//! the library's message (the CLI's), never a crash of the interpreter.

use numpy::{PyArray1, PyArray2};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

create_exception!(_tumble, TumbleError, PyException);

fn err(e: anyhow::Error) -> PyErr {
    TumbleError::new_err(format!("{e:#}"))
}

/// A scene: what is simulated ([`tumble::scene::Scene`]).
#[pyclass(frozen)]
struct Scene {
    inner: tumble::scene::Scene,
}

#[pymethods]
impl Scene {
    /// Reads a scene file (TOML).
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Self> {
        Ok(Self {
            inner: tumble::scene::Scene::load(&path).map_err(err)?,
        })
    }

    /// Parses scene text; relative paths are relative to `base_dir` (default: the current
    /// folder), errors name `scene.toml` there.
    #[staticmethod]
    #[pyo3(signature = (text, base_dir=None))]
    fn from_toml(text: &str, base_dir: Option<PathBuf>) -> PyResult<Self> {
        let path = base_dir.unwrap_or_default().join("scene.toml");
        Ok(Self {
            inner: tumble::scene::Scene::parse(text, &path).map_err(err)?,
        })
    }

    /// The scene of one URDF: default `[sim]`, the model at the origin; `articulated` keeps its
    /// joints (`base` = "fixed" or "floating").
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

/// A running simulation of a scene ([`tumble::simulation::Simulation`]): the scene's
/// integrator, step and duration; nothing recorded (recordings come next).
#[pyclass(unsendable)]
struct Simulation {
    sim: Option<tumble::simulation::Simulation>,
    body_names: Vec<String>,
    /// Per body: its link frame's index and its principal frame in that link frame.
    body_frames: Vec<(usize, nalgebra::Isometry3<f64>)>,
    joint_names: Vec<String>,
}

impl Simulation {
    fn sim(&mut self) -> PyResult<&mut tumble::simulation::Simulation> {
        self.sim
            .as_mut()
            .ok_or_else(|| TumbleError::new_err("the simulation is finished"))
    }
}

#[pymethods]
impl Simulation {
    #[new]
    #[pyo3(signature = (scene, threads=1))]
    fn new(scene: &Scene, threads: usize) -> PyResult<Self> {
        let s = &scene.inner;
        let world = s.build().map_err(err)?;
        let sim = tumble::simulation::Simulation::of_world(
            &world,
            s.integrator(),
            s.sim.dt,
            &s.variational_settings(),
            threads.max(1),
            &s.run_settings(),
        )
        .map_err(err)?;
        Ok(Self {
            body_names: world.layout.bodies.iter().map(|b| b.name.clone()).collect(),
            body_frames: world
                .layout
                .bodies
                .iter()
                .map(|b| (b.frame, b.link_from_principal))
                .collect(),
            joint_names: world.layout.joints.iter().map(|j| j.name.clone()).collect(),
            sim: Some(sim),
        })
    }

    /// Steps `n` times (at most to the scene's duration); returns the steps done in all.
    #[pyo3(signature = (n=1))]
    fn step(&mut self, n: u64) -> PyResult<u64> {
        let sim = self.sim()?;
        sim.advance(n).map_err(err)?;
        Ok(sim.step())
    }

    /// Simulation time, s.
    #[getter]
    fn time(&mut self) -> PyResult<f64> {
        Ok(self.sim()?.time_secs())
    }

    /// Steps done.
    #[getter]
    fn steps(&mut self) -> PyResult<u64> {
        Ok(self.sim()?.step())
    }

    /// The state: a dict of numpy arrays (world frame, SI units) and names: `body_names`,
    /// `position` (N, 3: each body's centre of mass), `orientation` (N, 4: xyzw, its principal
    /// frame), `linear_velocity`, `angular_velocity` (N, 3), `joint_names`, `joint_position`,
    /// `joint_velocity` (J,).
    fn state<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let body_names = self.body_names.clone();
        let joint_names = self.joint_names.clone();
        let frame = self.sim()?.frame().clone();
        let n = frame.bodies.len();
        let mut position = Vec::with_capacity(n);
        let mut orientation = Vec::with_capacity(n);
        let (mut linvel, mut angvel) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for (b, (f, link_from_principal)) in frame.bodies.iter().zip(&self.body_frames) {
            let pose = frame.world_from_link[*f] * link_from_principal;
            let t = pose.translation.vector;
            let q = pose.rotation.quaternion().coords;
            position.push(vec![t.x, t.y, t.z]);
            orientation.push(vec![q.x, q.y, q.z, q.w]);
            linvel.push(vec![b.linvel_world.x, b.linvel_world.y, b.linvel_world.z]);
            angvel.push(vec![b.angvel_world.x, b.angvel_world.y, b.angvel_world.z]);
        }
        let d = PyDict::new(py);
        d.set_item("body_names", body_names)?;
        for (key, rows, width) in [
            ("position", position, 3),
            ("orientation", orientation, 4),
            ("linear_velocity", linvel, 3),
            ("angular_velocity", angvel, 3),
        ] {
            let array = if rows.is_empty() {
                PyArray2::<f64>::zeros(py, [0, width], false)
            } else {
                PyArray2::from_vec2(py, &rows).map_err(|e| TumbleError::new_err(e.to_string()))?
            };
            d.set_item(key, array)?;
        }
        d.set_item("joint_names", joint_names)?;
        let q: Vec<f64> = frame.joints.iter().map(|j| j.position).collect();
        let v: Vec<f64> = frame.joints.iter().map(|j| j.velocity).collect();
        d.set_item("joint_position", PyArray1::from_vec(py, q))?;
        d.set_item("joint_velocity", PyArray1::from_vec(py, v))?;
        Ok(d)
    }

    /// Total mechanical energy now (kinetic plus gravity's potential), J.
    fn energy(&mut self) -> PyResult<f64> {
        let frame = self.sim()?.frame().clone();
        Ok(frame
            .bodies
            .iter()
            .map(|b| b.kinetic_energy + b.potential_energy)
            .sum())
    }

    /// Ends the simulation; returns the run summary line's figures as a dict.
    fn finish<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let sim = self
            .sim
            .take()
            .ok_or_else(|| TumbleError::new_err("the simulation is finished"))?;
        let s = sim.finish(&[]).map_err(err)?;
        let d = PyDict::new(py);
        d.set_item("steps", s.steps)?;
        d.set_item("energy_initial", s.energy_initial)?;
        d.set_item("energy_final", s.energy_final)?;
        d.set_item(
            "angular_momentum_relative_change_max",
            s.angmom_rel_change_max,
        )?;
        d.set_item("newton_failures", s.stats.newton_failures)?;
        Ok(d)
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    fn __exit__(
        &mut self,
        py: Python<'_>,
        _t: Option<Bound<'_, PyAny>>,
        _v: Option<Bound<'_, PyAny>>,
        _tb: Option<Bound<'_, PyAny>>,
    ) -> PyResult<bool> {
        if self.sim.is_some() {
            self.finish(py)?;
        }
        Ok(false)
    }
}

#[pymodule]
fn _tumble(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Scene>()?;
    m.add_class::<Simulation>()?;
    m.add("TumbleError", m.py().get_type::<TumbleError>())?;
    Ok(())
}
