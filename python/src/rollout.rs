//! `tumble.rollout`: many runs of one scene on all cores, the GIL released while they step
//! ([`tumble::simulation::rollout`], MuJoCo's `rollout` shape: `(rolls, samples, ...)`).

use crate::scene::Scene;
use crate::{TumbleError, err};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tumble::simulation::inputs::InputKind;
use tumble::simulation::rollout::{
    BodyStarts, RollInput, RollStart, RolloutBuffers, RolloutOptions,
};

/// A `(rolls, ..., width)` float array as its rolls' rows of `width` values each.
fn rows(
    name: &str,
    array: &Bound<'_, PyAny>,
    width: Option<usize>,
) -> PyResult<(Vec<usize>, Vec<f64>)> {
    let a: PyReadonlyArrayDyn<'_, f64> = array
        .extract()
        .map_err(|_| TumbleError::new_err(format!("{name}: expected a float array")))?;
    let shape = a.shape().to_vec();
    if let Some(w) = width
        && (shape.len() != 3 || shape[2] != w)
    {
        return Err(TumbleError::new_err(format!(
            "{name}: expected shape (rolls, bodies, {w}), got {shape:?}"
        )));
    }
    let values = a.as_array().iter().copied().collect();
    Ok((shape, values))
}

fn vectors3(v: &[f64]) -> Vec<nalgebra::Vector3<f64>> {
    v.chunks_exact(3)
        .map(|c| nalgebra::Vector3::new(c[0], c[1], c[2]))
        .collect()
}

/// Runs `rolls` copies of `scene` for `steps` steps (default: the scene's), each from its own
/// initial state, optionally driven by its own inputs, on `threads` threads (default: every
/// core), the GIL released; returns the states after every `every`-th step as arrays.
///
/// `initial_states` (dict, each entry optional, the scene's where missing): free bodies'
/// `position` (R, N, 3: centres of mass), `orientation` (R, N, 4: x y z w), `linear_velocity`,
/// `angular_velocity` (R, N, 3); an articulated first model's `joint_position`,
/// `joint_velocity` (R, J) in the order of `joint_names` (its joints; or `joint_names` given
/// in the dict). `inputs`: `{joint: (R, steps)}`, a motor's effort or a servo's target held
/// over each step. Returns `time` (S,), `position` (R, S, N, 3), `orientation` (R, S, N, 4),
/// `linear_velocity`, `angular_velocity` (R, S, N, 3), `joint_position`, `joint_velocity`
/// (R, S, J), `body_names`, `joint_names`. `out`: a previous result of the same shapes, whose
/// arrays are filled again instead of new ones (MuJoCo's `state=`: fresh memory costs the
/// kernel's zeroing of every page, more than the sampling itself).
#[pyfunction]
#[pyo3(signature = (scene, initial_states=None, steps=None, inputs=None, threads=None, every=1, rolls=None, out=None))]
#[allow(clippy::too_many_arguments)]
pub fn rollout<'py>(
    py: Python<'py>,
    scene: &Scene,
    initial_states: Option<&Bound<'py, PyDict>>,
    steps: Option<u64>,
    inputs: Option<&Bound<'py, PyDict>>,
    threads: Option<usize>,
    every: u64,
    rolls: Option<usize>,
    out: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let s = &scene.inner;
    let steps = steps.unwrap_or_else(|| s.steps());
    if every == 0 {
        return Err(TumbleError::new_err("every: must be at least 1"));
    }
    let threads = tumble::commands::simulate::thread_count(threads).map_err(err)?;
    let world = s.build().map_err(err)?;
    let body_names: Vec<String> = world.layout.bodies.iter().map(|b| b.name.clone()).collect();
    let joint_names: Vec<String> = world.layout.joints.iter().map(|j| j.name.clone()).collect();
    let n = body_names.len();
    let mut counts: Vec<(String, usize)> = Vec::new();
    let mut parts: Vec<(&'static str, Vec<f64>, usize)> = Vec::new();
    let mut joint_parts: Vec<(&'static str, Vec<f64>, usize)> = Vec::new();
    let mut start_joint_names = joint_names.clone();
    if let Some(states) = initial_states {
        for (key, _) in states.iter() {
            let key: String = key.extract()?;
            let known = [
                "position",
                "orientation",
                "linear_velocity",
                "angular_velocity",
                "joint_position",
                "joint_velocity",
                "joint_names",
            ];
            if !known.contains(&key.as_str()) {
                return Err(TumbleError::new_err(format!(
                    "initial_states: unknown key {key:?} (expected {})",
                    known.join(", ")
                )));
            }
        }
        if let Some(names) = states.get_item("joint_names")? {
            start_joint_names = names.extract()?;
        }
        for (key, width) in [
            ("position", 3),
            ("orientation", 4),
            ("linear_velocity", 3),
            ("angular_velocity", 3),
        ] {
            if let Some(a) = states.get_item(key)? {
                let (shape, values) = rows(&format!("initial_states[{key:?}]"), &a, Some(width))?;
                if shape[1] != n {
                    return Err(TumbleError::new_err(format!(
                        "initial_states[{key:?}]: {} bodies, the scene has {n}",
                        shape[1]
                    )));
                }
                counts.push((key.to_string(), shape[0]));
                parts.push((key, values, width));
            }
        }
        for key in ["joint_position", "joint_velocity"] {
            if let Some(a) = states.get_item(key)? {
                let (shape, values) = rows(&format!("initial_states[{key:?}]"), &a, None)?;
                if shape.len() != 2 || shape[1] != start_joint_names.len() {
                    return Err(TumbleError::new_err(format!(
                        "initial_states[{key:?}]: expected shape (rolls, {}), got {shape:?}",
                        start_joint_names.len()
                    )));
                }
                counts.push((key.to_string(), shape[0]));
                joint_parts.push((key, values, shape[1]));
            }
        }
    }
    let mut roll_inputs = Vec::new();
    if let Some(inputs) = inputs {
        for (k, v) in inputs.iter() {
            let joint: String = k.extract()?;
            let (shape, values) = rows(&format!("inputs[{joint:?}]"), &v, None)?;
            if shape.len() != 2 || shape[1] as u64 != steps {
                return Err(TumbleError::new_err(format!(
                    "inputs[{joint:?}]: expected shape (rolls, {steps}), got {shape:?}"
                )));
            }
            counts.push((format!("inputs[{joint:?}]"), shape[0]));
            let law = world
                .layout
                .drives
                .iter()
                .find(|d| world.layout.joints[d.joint].name == joint)
                .and_then(|d| d.actuator);
            let kind = match law {
                Some(tumble::record::ActuatorLaw::Motor) => InputKind::Effort,
                Some(_) => InputKind::Target,
                None => {
                    let actuated: Vec<&str> = world
                        .layout
                        .drives
                        .iter()
                        .filter(|d| d.actuator.is_some())
                        .map(|d| world.layout.joints[d.joint].name.as_str())
                        .collect();
                    return Err(TumbleError::new_err(format!(
                        "inputs: {joint}: no actuated joint of that name{}",
                        tumble::message::did_you_mean(&joint, actuated)
                    )));
                }
            };
            roll_inputs.push(RollInput {
                joint,
                kind,
                values,
            });
        }
    }
    let r = match (counts.first(), rolls) {
        (Some((_, r)), _) => *r,
        (None, Some(r)) => r,
        (None, None) => 1,
    };
    if let Some((name, c)) = counts
        .iter()
        .map(|(k, c)| (k.clone(), *c))
        .chain(rolls.map(|x| ("rolls".to_string(), x)))
        .find(|(_, c)| *c != r)
    {
        return Err(TumbleError::new_err(format!(
            "{name}: {c} rolls, but {} has {r}",
            counts.first().map_or("rolls", |(k, _)| k.as_str())
        )));
    }
    let mut starts = vec![RollStart::default(); r];
    for (key, values, width) in parts {
        for (roll, start) in starts.iter_mut().enumerate() {
            let v = &values[roll * n * width..(roll + 1) * n * width];
            let b: &mut BodyStarts = &mut start.bodies;
            match key {
                "position" => b.position = Some(vectors3(v)),
                "linear_velocity" => b.linear_velocity = Some(vectors3(v)),
                "angular_velocity" => b.angular_velocity = Some(vectors3(v)),
                _ => {
                    b.orientation = Some(
                        v.chunks_exact(4)
                            .map(|c| nalgebra::Quaternion::new(c[3], c[0], c[1], c[2]))
                            .collect(),
                    )
                }
            }
        }
    }
    for (key, values, width) in joint_parts {
        for (roll, start) in starts.iter_mut().enumerate() {
            let row = &values[roll * width..(roll + 1) * width];
            let named = start_joint_names.iter().cloned().zip(row.iter().copied());
            match key {
                "joint_position" => start.joint_positions = named.collect(),
                _ => start.joint_velocities = named.collect(),
            }
        }
    }
    let options = RolloutOptions {
        steps,
        every,
        threads,
    };
    // The arrays are numpy's (its allocator asks for huge pages: a fresh 100 MB output costs
    // a tenth of what 4 KiB pages do), filled in place with the GIL released.
    let samples = (steps / every) as usize;
    let jn = joint_names.len();
    let shape4 = |w: usize| [r, samples, n, w];
    let (p, o, v, w, jp, jv) = match out {
        Some(out) => {
            let get4 = |key: &str, width: usize| -> PyResult<Bound<'py, numpy::PyArray4<f64>>> {
                let a = out.get_item(key)?.ok_or_else(|| {
                    TumbleError::new_err(format!("out: no {key:?} array (pass a rollout's result)"))
                })?;
                let a = a.cast_into::<numpy::PyArray4<f64>>().map_err(|_| {
                    TumbleError::new_err(format!("out[{key:?}]: not a 4-d float64 array"))
                })?;
                if a.shape() != shape4(width) {
                    return Err(TumbleError::new_err(format!(
                        "out[{key:?}]: shape {:?}, this rollout's is {:?}",
                        a.shape(),
                        shape4(width)
                    )));
                }
                Ok(a)
            };
            let get3 = |key: &str| -> PyResult<Bound<'py, numpy::PyArray3<f64>>> {
                let a = out.get_item(key)?.ok_or_else(|| {
                    TumbleError::new_err(format!("out: no {key:?} array (pass a rollout's result)"))
                })?;
                let a = a.cast_into::<numpy::PyArray3<f64>>().map_err(|_| {
                    TumbleError::new_err(format!("out[{key:?}]: not a 3-d float64 array"))
                })?;
                if a.shape() != [r, samples, jn] {
                    return Err(TumbleError::new_err(format!(
                        "out[{key:?}]: shape {:?}, this rollout's is {:?}",
                        a.shape(),
                        [r, samples, jn]
                    )));
                }
                Ok(a)
            };
            (
                get4("position", 3)?,
                get4("orientation", 4)?,
                get4("linear_velocity", 3)?,
                get4("angular_velocity", 3)?,
                get3("joint_position")?,
                get3("joint_velocity")?,
            )
        }
        // SAFETY: every element is written by `rollout_into` before the arrays are returned;
        // on an error they are dropped unread.
        None => unsafe {
            (
                numpy::PyArray4::<f64>::new(py, shape4(3), false),
                numpy::PyArray4::<f64>::new(py, shape4(4), false),
                numpy::PyArray4::<f64>::new(py, shape4(3), false),
                numpy::PyArray4::<f64>::new(py, shape4(3), false),
                numpy::PyArray3::<f64>::new(py, [r, samples, jn], false),
                numpy::PyArray3::<f64>::new(py, [r, samples, jn], false),
            )
        },
    };
    let shape = {
        let busy = |e: numpy::BorrowError| {
            TumbleError::new_err(format!("out: an array is not writable or in use ({e})"))
        };
        let (mut pw, mut ow) = (
            p.try_readwrite().map_err(busy)?,
            o.try_readwrite().map_err(busy)?,
        );
        let (mut vw, mut ww) = (
            v.try_readwrite().map_err(busy)?,
            w.try_readwrite().map_err(busy)?,
        );
        let (mut jpw, mut jvw) = (
            jp.try_readwrite().map_err(busy)?,
            jv.try_readwrite().map_err(busy)?,
        );
        let buffers = RolloutBuffers {
            position: pw
                .as_slice_mut()
                .map_err(|e| TumbleError::new_err(e.to_string()))?,
            orientation: ow
                .as_slice_mut()
                .map_err(|e| TumbleError::new_err(e.to_string()))?,
            linear_velocity: vw
                .as_slice_mut()
                .map_err(|e| TumbleError::new_err(e.to_string()))?,
            angular_velocity: ww
                .as_slice_mut()
                .map_err(|e| TumbleError::new_err(e.to_string()))?,
            joint_position: jpw
                .as_slice_mut()
                .map_err(|e| TumbleError::new_err(e.to_string()))?,
            joint_velocity: jvw
                .as_slice_mut()
                .map_err(|e| TumbleError::new_err(e.to_string()))?,
        };
        py.detach(|| {
            tumble::simulation::rollout::rollout_into(s, &starts, &roll_inputs, &options, buffers)
        })
        .map_err(err)?
    };
    let d = PyDict::new(py);
    d.set_item("time", PyArray1::from_vec(py, shape.time_secs))?;
    d.set_item("position", p)?;
    d.set_item("orientation", o)?;
    d.set_item("linear_velocity", v)?;
    d.set_item("angular_velocity", w)?;
    d.set_item("joint_position", jp)?;
    d.set_item("joint_velocity", jv)?;
    d.set_item("body_names", body_names)?;
    d.set_item("joint_names", joint_names)?;
    d.set_item("batched", shape.batched)?;
    Ok(d)
}
