//! Accuracy on demand: an a priori model of each body's orientation error, the per-body substep
//! factors that meet a tolerance, and an a posteriori check.

pub mod orbit;
