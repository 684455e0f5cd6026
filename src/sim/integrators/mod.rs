//! Integrators. Every scheme steps the same [`Bodies`] batch with a fixed step `dt`.

pub mod translation;
pub mod variational;

pub use translation::Potential;
pub use variational::{Jacobian, Variational, VariationalSettings};

use super::Bodies;
use nalgebra::Vector3;

/// What one step did, summed or maximised over the batch.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StepStats {
    /// Largest number of Newton iterations any body needed this step (0 for explicit schemes).
    pub newton_iters_max: u32,
    /// Bodies whose Newton solve reached the iteration cap without meeting the tolerance.
    pub newton_failures: u32,
}

impl StepStats {
    /// Combines the statistics of two steps (max of iterations, sum of failures).
    pub fn merge(self, other: Self) -> Self {
        Self {
            newton_iters_max: self.newton_iters_max.max(other.newton_iters_max),
            newton_failures: self.newton_failures + other.newton_failures,
        }
    }
}

/// A time-stepping scheme for a batch of free rigid bodies in uniform gravity.
pub trait Integrator: Send {
    /// The name used in scenes and on the command line.
    fn name(&self) -> &'static str;
    /// Prepares scheme-specific state for the batch's current state (e.g. the discrete
    /// Legendre transform). Called once before the first step, and again whenever bodies change.
    fn init(&mut self, bodies: &Bodies);
    /// Advances every body by one step.
    fn step(&mut self, bodies: &mut Bodies, gravity: &Vector3<f64>) -> StepStats;
    /// The step size, s.
    fn dt(&self) -> f64;
}

/// The integrators selectable by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum IntegratorKind {
    /// The exponential-map Lie-group variational integrator (discrete Euler-Lagrange equations,
    /// Newton on SO(3)).
    Variational,
}

impl IntegratorKind {
    pub const ALL: &'static [IntegratorKind] = &[IntegratorKind::Variational];

    pub fn name(self) -> &'static str {
        match self {
            IntegratorKind::Variational => "variational",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|k| k.name() == name)
    }

    /// Builds the integrator with step `dt_secs`.
    pub fn build(self, dt_secs: f64, settings: &VariationalSettings) -> Box<dyn Integrator> {
        match self {
            IntegratorKind::Variational => Box::new(Variational::new(dt_secs, *settings)),
        }
    }
}
