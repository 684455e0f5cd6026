//! The Python module `tumble._tumble` (issue 33): thin wrappers over the library, no physics.
//!
//! - [`scene::Scene`]: a scene from a file, TOML text or a URDF; `inspect()`;
//! - [`simulation::Simulation`]: stepping, state as numpy arrays, energy and momentum, a
//!   controller's efforts and targets ([`tumble::simulation::inputs`]), recordings
//!   ([`tumble::simulation::files::open_recording`]);
//! - [`rollout::rollout`]: many runs at once on all cores, the GIL released
//!   ([`tumble::simulation::rollout`]);
//! - [`read::read`]: a tumble MCAP recording as columns per topic
//!   ([`tumble::replay::steps::StepReader`]).
//!
//! Every error is a `TumbleError` carrying the library's message (the CLI's), never a crash of
//! the interpreter.

mod columns;
mod read;
mod rollout;
mod scene;
mod simulation;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    _tumble,
    TumbleError,
    PyException,
    "Any error of the tumble library, with the message the CLI prints (the file, the key)."
);

/// The library's error as a `TumbleError` (its whole chain, as the CLI prints it).
pub(crate) fn err(e: anyhow::Error) -> PyErr {
    TumbleError::new_err(format!("{e:#}"))
}

#[pymodule]
fn _tumble(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<scene::Scene>()?;
    m.add_class::<simulation::Simulation>()?;
    m.add_function(wrap_pyfunction!(rollout::rollout, m)?)?;
    m.add_function(wrap_pyfunction!(read::read, m)?)?;
    m.add("TumbleError", m.py().get_type::<TumbleError>())?;
    Ok(())
}
