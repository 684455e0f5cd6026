//! How bodies move: the batch of free rigid bodies and the integrators that step it.

pub mod accuracy;
pub mod bodies;
pub mod choose;
pub mod contact;
pub mod guard;
pub mod integrators;
pub mod limits;
pub mod loads;
pub mod mechanism;
pub mod partition;
pub mod reference;
pub mod run_settings;
pub mod signal;
pub mod simd;
pub mod so3;
pub mod workload;

pub use bodies::{Bodies, BodyInit};
pub use choose::integrator_for;
pub use integrators::{Integrator, IntegratorKind, StepStats};
pub use loads::Loads;
pub use run_settings::RunSettings;
