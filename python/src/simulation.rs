//! `tumble.Simulation`: a running simulation of a scene ([`tumble::simulation::Simulation`]),
//! stepped from Python, read between steps, driven by a controller's efforts and targets, and
//! recorded to the files `simulate` writes.

use crate::scene::Scene;
use crate::{TumbleError, err};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};
use tumble::simulation::inputs::{InputKind, Inputs};
use tumble::simulation::{Progress, Simulation as Run};

/// A `&mut` to the run, movable into [`Python::detach`]'s closure: the closure runs on this
/// thread (detach only releases the GIL), and the pyclass is borrowed mutably for the whole
/// call, so no other thread can reach the run meanwhile (PyO3 refuses a second borrow). The
/// run's sinks share per-thread state (`Rc`) and are not `Send`, which is why this is needed.
struct OnThisThread<'a>(&'a mut Run);
// SAFETY: see the type's doc: the reference never leaves this thread.
unsafe impl Send for OnThisThread<'_> {}

/// Two (J,) arrays: joint positions and rates.
type Pair<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>);

/// A running simulation of a scene.
#[pyclass(unsendable, module = "tumble")]
pub struct Simulation {
    sim: Option<Run>,
    body_names: Vec<String>,
    body_masses: Vec<f64>,
    /// Per body: its link frame's index and its principal frame in that link frame.
    body_frames: Vec<(usize, nalgebra::Isometry3<f64>)>,
    joint_names: Vec<String>,
    inputs: Inputs,
    /// The recording's files (published by `finish`).
    outputs: Vec<PathBuf>,
    /// A robot's Foxglove layout, written beside the MCAP by `finish` (as `simulate` does).
    foxglove_layout: Option<(PathBuf, String)>,
    body_frame_ids: Vec<String>,
    dt_secs: f64,
}

impl Simulation {
    fn sim(&mut self) -> PyResult<&mut Run> {
        self.sim
            .as_mut()
            .ok_or_else(|| TumbleError::new_err("the simulation is finished"))
    }

    /// `values`: `{joint: value}`, or a sequence in the order of the joints of `kind`
    /// (`Simulation.motors` or `Simulation.servos`).
    fn set(&mut self, kind: InputKind, values: &Bound<'_, PyAny>) -> PyResult<()> {
        self.sim()?;
        if let Ok(values) = values.cast::<PyDict>() {
            let mut pairs = Vec::with_capacity(values.len());
            for (k, v) in values.iter() {
                pairs.push((k.extract::<String>()?, v.extract::<f64>()?));
            }
            return self.inputs.set(kind, &pairs).map_err(err);
        }
        if let Ok(array) = values.extract::<numpy::PyReadonlyArray1<'_, f64>>()
            && let Ok(slice) = array.as_slice()
        {
            return self.inputs.set_in_order(kind, slice).map_err(err);
        }
        let in_order: Vec<f64> = values.extract().map_err(|_| {
            TumbleError::new_err(
                "expected {joint: value} or a sequence of floats in the order of \
                 Simulation.motors (efforts) or Simulation.servos (targets)",
            )
        })?;
        self.inputs.set_in_order(kind, &in_order).map_err(err)
    }

    /// Finishes the files and raises the guard's stop, as `simulate` does.
    fn stopped(&mut self) -> PyErr {
        let Some(sim) = self.sim.take() else {
            return TumbleError::new_err("the simulation is finished");
        };
        let outputs: Vec<&Path> = self.outputs.iter().map(PathBuf::as_path).collect();
        match sim.finish(&outputs) {
            Ok(summary) => match summary.stopped {
                Some(divergence) => err(tumble::simulation::Diverged {
                    divergence,
                    body_name: self.body_frame_ids[divergence.body].clone(),
                    dt_secs: self.dt_secs,
                    last_recorded_step: summary.last_recorded_step,
                    outputs: self.outputs.clone(),
                }
                .into()),
                None => TumbleError::new_err("the run stopped"),
            },
            Err(e) => err(e),
        }
    }
}

#[pymethods]
impl Simulation {
    /// A simulation of `scene` on `threads` stepping threads (default: every core, as the
    /// CLI). `record` (e.g. `["mcap", "rrd"]`, any of mcap, rrd, parquet, ros2) writes the
    /// files `tumble simulate --format ... --out OUT` writes, under the stem `out`; existing
    /// files are refused unless `force`. Every actuator's signal is held
    /// ([`tumble::simulation::inputs`]): the scene's until `set_efforts`/`set_targets` name it.
    #[new]
    #[pyo3(signature = (scene, record=None, out=None, threads=None, force=false))]
    fn new(
        scene: &Scene,
        record: Option<Vec<String>>,
        out: Option<PathBuf>,
        threads: Option<usize>,
        force: bool,
    ) -> PyResult<Self> {
        let s = &scene.inner;
        let threads = tumble::commands::simulate::thread_count(threads).map_err(err)?;
        let formats = match &record {
            Some(names) if names.is_empty() => None,
            Some(names) => Some(
                tumble::record::FormatSet::parse(&names.join(","))
                    .map_err(|e| TumbleError::new_err(format!("record: {e}")))?,
            ),
            None => None,
        };
        let stem = match (&formats, out) {
            (Some(_), Some(out)) => Some(out),
            (Some(_), None) => {
                return Err(TumbleError::new_err(
                    "record= needs out= (the files' stem, e.g. out=\"logs/run\" writes logs/run.mcap)",
                ));
            }
            (None, Some(_)) => {
                return Err(TumbleError::new_err(
                    "out= without record= (name the formats, e.g. record=[\"mcap\", \"rrd\"])",
                ));
            }
            (None, None) => None,
        };
        let mut world = s.build().map_err(err)?;
        let inputs = tumble::simulation::inputs::hold(&mut world);
        let body_names = world.layout.bodies.iter().map(|b| b.name.clone()).collect();
        let body_masses = world.layout.bodies.iter().map(|b| b.mass).collect();
        let body_frames = tumble::simulation::rollout::body_frames(&world);
        let body_frame_ids = world
            .layout
            .bodies
            .iter()
            .map(|b| world.layout.frames[b.frame].frame_id.clone())
            .collect();
        let joint_names = world.layout.joints.iter().map(|j| j.name.clone()).collect();
        let mut outputs = Vec::new();
        let mut sinks = Vec::new();
        let mut foxglove_layout = None;
        if let (Some(formats), Some(stem)) = (formats, &stem) {
            use tumble::commands::simulate::{
                FOXGLOVE_LAYOUT_EXTENSION, ellipsoids_choice, robot_foxglove_layout,
            };
            use tumble::record::Format;
            for path in formats.paths_of(stem, &world.layout) {
                tumble::fsutil::check_not_overwriting(&path, force).map_err(err)?;
            }
            if formats.contains(Format::Mcap)
                && let Some(layout) = robot_foxglove_layout(&world)
            {
                let path = tumble::record::format::with_extension(stem, FOXGLOVE_LAYOUT_EXTENSION);
                tumble::fsutil::check_not_overwriting(&path, force).map_err(err)?;
                let text = serde_json::to_string_pretty(&layout)
                    .map_err(|e| TumbleError::new_err(e.to_string()))?;
                foxglove_layout = Some((path, format!("{text}\n")));
            }
            let ellipsoids = ellipsoids_choice(false, false)
                .unwrap_or_else(|| world.layout.default_ellipsoids());
            let options = tumble::simulation::SimulateOptions {
                rerun: tumble::record::rerun::RerunOptions { ellipsoids },
                formats,
                threads,
                mcap_compression: tumble::record::mcap::ChunkCompression::parse("auto")
                    .map_err(TumbleError::new_err)?,
                accuracy_model: Default::default(),
            };
            let recording =
                tumble::simulation::files::open_recording(&world, &s.source, stem, &options)
                    .map_err(err)?;
            outputs = recording.paths;
            sinks = recording.sinks;
        }
        let settings = s.run_settings();
        let inits = std::mem::take(&mut world.bodies);
        let outputs_ref: Vec<&Path> = outputs.iter().map(PathBuf::as_path).collect();
        let mut sim = match Run::of_scene(
            s,
            &world,
            tumble::simulation::Inits::Owned(inits),
            threads,
            &settings,
        ) {
            Ok(sim) => sim,
            Err(e) => {
                let e = tumble::record::finish_all::<()>(sinks, Err(e), &outputs_ref)
                    .expect_err("an error stays one");
                return Err(err(e.context(s.source.display().to_string())));
            }
        };
        sim.attach_all(sinks).map_err(err)?;
        Ok(Self {
            sim: Some(sim),
            body_names,
            body_masses,
            body_frames,
            joint_names,
            inputs,
            outputs,
            foxglove_layout,
            body_frame_ids,
            dt_secs: s.sim.dt,
        })
    }

    /// Steps `n` times (at most to the scene's duration), the GIL released meanwhile; returns
    /// the steps done in all. A recording gets every `log_every`-th step, as from the CLI.
    #[pyo3(signature = (n=1))]
    fn step(&mut self, py: Python<'_>, n: u64) -> PyResult<u64> {
        let run = OnThisThread(self.sim()?);
        let result = py.detach(move || {
            let run = run;
            run.0.advance(n).map(|p| (p, run.0.step()))
        });
        match result {
            Ok((Progress::Stopped, _)) => Err(self.stopped()),
            Ok((_, step)) => Ok(step),
            Err(e) => {
                let outputs: Vec<&Path> = self.outputs.iter().map(PathBuf::as_path).collect();
                let sim = self.sim.take().expect("stepped above");
                Err(err(sim.discard(e, &outputs)))
            }
        }
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

    /// Step size, s.
    #[getter]
    fn dt(&self) -> f64 {
        self.dt_secs
    }

    /// The joints with a motor, in the order `set_efforts` takes a sequence in.
    #[getter]
    fn motors(&self) -> Vec<String> {
        self.inputs
            .names(InputKind::Effort)
            .map(String::from)
            .collect()
    }

    /// The joints with a position or velocity servo, in the order `set_targets` takes a
    /// sequence in.
    #[getter]
    fn servos(&self) -> Vec<String> {
        self.inputs
            .names(InputKind::Target)
            .map(String::from)
            .collect()
    }

    /// The actuated joints: `{name: "motor" | "position" | "velocity"}` (motors take
    /// `set_efforts`, servos `set_targets`).
    #[getter]
    fn actuators<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for j in &self.inputs.joints {
            d.set_item(&j.joint, j.law.name())?;
        }
        Ok(d)
    }

    /// The state: a dict of numpy arrays (world frame, SI units) and names: `body_names`,
    /// `position` (N, 3: each body's centre of mass), `orientation` (N, 4: x y z w, its
    /// principal frame), `linear_velocity`, `angular_velocity` (N, 3), `joint_names`,
    /// `joint_position`, `joint_velocity` (J,): the numbers a recording of this step holds.
    fn state<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let body_names = self.body_names.clone();
        let joint_names = self.joint_names.clone();
        let frame = self.sim()?.frame().clone();
        let n = frame.bodies.len();
        let (mut position, mut orientation) = (vec![0.0; 3 * n], vec![0.0; 4 * n]);
        let (mut linvel, mut angvel) = (vec![0.0; 3 * n], vec![0.0; 3 * n]);
        for (b, (state, (f, link_from_principal))) in
            frame.bodies.iter().zip(&self.body_frames).enumerate()
        {
            let pose = frame.world_from_link[*f] * link_from_principal;
            let q = pose.rotation.quaternion().coords;
            position[3 * b..3 * b + 3].copy_from_slice(pose.translation.vector.as_slice());
            orientation[4 * b..4 * b + 4].copy_from_slice(&[q.x, q.y, q.z, q.w]);
            linvel[3 * b..3 * b + 3].copy_from_slice(state.linvel_world.as_slice());
            angvel[3 * b..3 * b + 3].copy_from_slice(state.angvel_world.as_slice());
        }
        let d = PyDict::new(py);
        d.set_item("body_names", body_names)?;
        for (key, values, width) in [
            ("position", position, 3),
            ("orientation", orientation, 4),
            ("linear_velocity", linvel, 3),
            ("angular_velocity", angvel, 3),
        ] {
            d.set_item(key, matrix(py, values, width)?)?;
        }
        d.set_item("joint_names", joint_names)?;
        let q: Vec<f64> = frame.joints.iter().map(|j| j.position).collect();
        let v: Vec<f64> = frame.joints.iter().map(|j| j.velocity).collect();
        d.set_item("joint_position", PyArray1::from_vec(py, q))?;
        d.set_item("joint_velocity", PyArray1::from_vec(py, v))?;
        Ok(d)
    }

    /// The joints' positions and rates now, `(q, v)`: two (J,) arrays in the order of
    /// `state()["joint_names"]` (what a controller reads every step, without the rest of the
    /// state).
    fn joint_state<'py>(&mut self, py: Python<'py>) -> PyResult<Pair<'py>> {
        let n = self.joint_names.len();
        let (mut q, mut v) = (vec![0.0; n], vec![0.0; n]);
        self.sim()?.joint_state(&mut q, &mut v);
        Ok((PyArray1::from_vec(py, q), PyArray1::from_vec(py, v)))
    }

    /// Sets motor efforts (N m, or N on a slider), held from the next step on (zero-order
    /// hold) until set again: `{joint: effort}` by recorded joint name, or a sequence in the
    /// order of `motors` (no name lookup). Unknown names, servos, a wrong count and
    /// non-finite values raise, and nothing is set then.
    fn set_efforts(&mut self, efforts: &Bound<'_, PyAny>) -> PyResult<()> {
        self.set(InputKind::Effort, efforts)
    }

    /// Sets servo targets (a position servo's rad or m, a velocity servo's rad/s or m/s), as
    /// `set_efforts` does efforts.
    fn set_targets(&mut self, targets: &Bound<'_, PyAny>) -> PyResult<()> {
        self.set(InputKind::Target, targets)
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

    /// Total momentum now: `linear` (3,) `Σ m v`, kg m/s, and `angular` (3,) about the world
    /// origin `Σ (c × m v + L)` (each body's spin `L` about its centre of mass `c`), kg m²/s.
    fn momentum<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let frame = self.sim()?.frame().clone();
        let (mut p, mut l) = (nalgebra::Vector3::zeros(), nalgebra::Vector3::zeros());
        for ((state, (f, link_from_principal)), m) in frame
            .bodies
            .iter()
            .zip(&self.body_frames)
            .zip(&self.body_masses)
        {
            let c = (frame.world_from_link[*f] * link_from_principal)
                .translation
                .vector;
            let pi = state.linvel_world * *m;
            p += pi;
            l += c.cross(&pi) + state.angmom_world;
        }
        let d = PyDict::new(py);
        d.set_item("linear", PyArray1::from_slice(py, p.as_slice()))?;
        d.set_item("angular", PyArray1::from_slice(py, l.as_slice()))?;
        Ok(d)
    }

    /// Ends the run: publishes the recording's files (all or none) and returns the run's
    /// summary figures as a dict (`written`: the files; `warnings`: what `simulate` would warn
    /// of, e.g. an energy balance open by more than 1e-2 of its largest term).
    fn finish<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let sim = self
            .sim
            .take()
            .ok_or_else(|| TumbleError::new_err("the simulation is finished"))?;
        let outputs: Vec<&Path> = self.outputs.iter().map(PathBuf::as_path).collect();
        let s = sim.finish(&outputs).map_err(err)?;
        let mut written = self.outputs.clone();
        if let Some((path, text)) = self.foxglove_layout.take() {
            tumble::fsutil::write_atomic(&path, text.as_bytes()).map_err(err)?;
            written.push(path);
        }
        let d = PyDict::new(py);
        d.set_item("steps", s.steps)?;
        d.set_item("frames_recorded", s.frames_recorded)?;
        d.set_item("energy_initial", s.energy_initial)?;
        d.set_item("energy_final", s.energy_final)?;
        d.set_item("input_work", s.energy_flow.input_work)?;
        d.set_item("dissipated", s.energy_flow.dissipated)?;
        d.set_item("contact_work", s.energy_flow.contact_work)?;
        d.set_item(
            "angular_momentum_relative_change_max",
            s.angmom_rel_change_max,
        )?;
        d.set_item("newton_failures", s.stats.newton_failures)?;
        // What `simulate` prints as warnings (today the energy-balance guard), one string each.
        let warnings: Vec<String> = s.balance_warning().into_iter().collect();
        d.set_item("warnings", warnings)?;
        d.set_item("written", written)?;
        Ok(d)
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    /// Leaving the block finishes the run (its files are published, whatever ended the
    /// block: like an interrupted `simulate`, they end at the last recorded step).
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

impl Drop for Simulation {
    /// A run dropped unfinished publishes its files (as `finish`), errors ignored.
    fn drop(&mut self) {
        if let Some(sim) = self.sim.take() {
            let outputs: Vec<&Path> = self.outputs.iter().map(PathBuf::as_path).collect();
            if sim.finish(&outputs).is_ok()
                && let Some((path, text)) = self.foxglove_layout.take()
            {
                let _ = tumble::fsutil::write_atomic(&path, text.as_bytes());
            }
        }
    }
}

/// An (n / width, width) array of `values`.
pub(crate) fn matrix<'py>(
    py: Python<'py>,
    values: Vec<f64>,
    width: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let rows = values.len() / width;
    PyArray1::from_vec(py, values)
        .reshape([rows, width])
        .map_err(|e| TumbleError::new_err(e.to_string()))
}
