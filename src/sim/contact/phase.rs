//! The contact phase of a step.

use super::{ContactModel, ContactPoint};

/// The contact phase of every step of a batch: its model, the last step's contacts.
#[derive(Debug, Clone, Default)]
pub struct ContactPhase {
    pub model: ContactModel,
    /// The contacts of the last step.
    pub contacts: Vec<ContactPoint>,
    /// The kinetic energy the impulses changed so far, J.
    pub work: f64,
}

impl ContactPhase {
    /// The phase of `model` for a batch of `bodies` bodies.
    pub fn new(model: ContactModel, _bodies: usize) -> Self {
        Self {
            model,
            contacts: Vec::new(),
            work: 0.0,
        }
    }
}
