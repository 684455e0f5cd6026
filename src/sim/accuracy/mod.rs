//! Accuracy on demand: an a priori model of each body's orientation error ([`model`]), the
//! per-body substep factors that meet a tolerance ([`substeps`]), the achieved error against the
//! exact motion ([`measure`]) and the a posteriori check of a run ([`check`]).

pub mod measure;
pub mod model;
pub mod orbit;
pub mod substeps;

pub use model::{ErrorModel, Factor};
pub use substeps::{FactorRule, Substepped};
