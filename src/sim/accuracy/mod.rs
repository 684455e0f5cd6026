//! Accuracy on demand: an a priori model of each body's orientation error ([`model`]), the
//! per-body substep factors that meet a tolerance ([`substeps`]), the achieved error against the
//! exact motion ([`measure`]), and a run's plan and a posteriori check ([`plan`]).

pub mod measure;
pub mod model;
pub mod orbit;
pub mod plan;
pub mod substeps;

pub use model::{ErrorModel, Factor};
pub use plan::{Checked, Plan};
pub use substeps::{FactorRule, Substepped};
