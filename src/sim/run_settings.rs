//! What a run is asked to do: how many steps, what is recorded, when it stops.

use nalgebra::Vector3;

/// What a run is asked to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSettings {
    pub steps: u64,
    /// Record every Nth step (the initial and the final state are always recorded).
    pub log_every: u64,
    pub gravity: Vector3<f64>,
    /// A body whose rotational kinetic energy exceeds this multiple of its initial value stops
    /// the run ([`super::guard`]).
    pub divergence_energy_ratio: f64,
    /// `Some(max_substeps)`: substepping is on, so a Newton failure is final and stops the run.
    pub stop_on_newton_failure: Option<u32>,
    /// Stop after the current step when SIGINT/SIGTERM arrives ([`crate::interrupt`]): the
    /// step is recorded and `RunSummary::interrupted` (`crate::simulation`) set. Off in `Scene::run_settings` (a
    /// library caller decides); `simulate` turns it on.
    pub stop_on_interrupt: bool,
    /// No joint-range warnings on standard error (`crate::simulation::FrameBuilder`): the
    /// sweeps of `trade` and `stability`, which run many variants of one scene. Off in
    /// `Scene::run_settings`.
    pub quiet: bool,
}
