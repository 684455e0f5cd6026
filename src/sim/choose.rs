//! Which integrator steps a batch: the scheme itself for free bodies, the articulated stepper
//! when the batch holds mechanisms.

use super::Integrator;
use super::integrators::{IntegratorKind, VariationalSettings};
use super::mechanism::{Articulated, Mechanism};
use std::sync::Arc;

/// The integrator of a batch of `body_count` bodies holding `mechanisms` (a whole world, or a
/// partition of one with its mechanisms re-based to it: [`super::partition::rebase`]): `kind`
/// itself when there is no mechanism, else the [`Articulated`] stepper (free bodies and
/// mechanisms), which supports the variational family only (an error naming the model
/// otherwise).
pub fn integrator_for(
    kind: IntegratorKind,
    dt_secs: f64,
    settings: &VariationalSettings,
    mechanisms: &[Arc<Mechanism>],
    body_count: usize,
) -> anyhow::Result<Box<dyn Integrator>> {
    if mechanisms.is_empty() {
        return Ok(kind.build(dt_secs, settings));
    }
    Ok(Box::new(Articulated::new(
        kind, dt_secs, settings, mechanisms, body_count,
    )?))
}
