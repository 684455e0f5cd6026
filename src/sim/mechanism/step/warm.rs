//! [`Warm`]: the warm start of a mechanism's step, per step size.

use super::super::Mechanism;
use super::super::rows::RowValues;
use nalgebra::Vector3;

/// Warm start of one step size: the last two steps' `λ`, `μ`, `ξ`. With both, the start is
/// their linear extrapolation `2 x_k − x_{k−1}` (off by O(h²) instead of O(h)), so one Newton
/// update usually meets the tolerance.
#[derive(Debug, Clone)]
pub struct Warm {
    pub lambda: Vec<RowValues>,
    pub mu: Vec<f64>,
    pub xi: Vec<Vector3<f64>>,
    pub(super) lambda_prev: Vec<RowValues>,
    pub(super) mu_prev: Vec<f64>,
    pub(super) xi_prev: Vec<Vector3<f64>>,
    /// Set once a step of this size has converged.
    pub valid: bool,
    /// The previous step of this size converged too (the `_prev` values are its).
    pub(super) history: bool,
}

impl Warm {
    pub fn new(model: &Mechanism) -> Self {
        Self {
            lambda: vec![RowValues::zeros(); model.joints.len()],
            mu: vec![0.0; model.mimics.len()],
            xi: vec![Vector3::zeros(); model.body_count],
            lambda_prev: vec![RowValues::zeros(); model.joints.len()],
            mu_prev: vec![0.0; model.mimics.len()],
            xi_prev: vec![Vector3::zeros(); model.body_count],
            valid: false,
            history: false,
        }
    }

    /// Stores a converged step's values, keeping the previous ones for the extrapolation.
    pub(super) fn push(&mut self, lambda: &[RowValues], mu: &[f64], xi: &[Vector3<f64>]) {
        self.history = self.valid;
        std::mem::swap(&mut self.lambda, &mut self.lambda_prev);
        std::mem::swap(&mut self.mu, &mut self.mu_prev);
        std::mem::swap(&mut self.xi, &mut self.xi_prev);
        self.lambda.copy_from_slice(lambda);
        self.mu.copy_from_slice(mu);
        self.xi.copy_from_slice(xi);
        self.valid = true;
    }

    pub(super) fn scale(&mut self, factor: f64) {
        self.history = false;
        for l in &mut self.lambda {
            *l *= factor;
        }
        for m in &mut self.mu {
            *m *= factor;
        }
        for x in &mut self.xi {
            *x *= factor;
        }
    }
}
