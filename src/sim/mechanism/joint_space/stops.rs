//! Joint limits and Coulomb joint friction in joint coordinates: the physics of
//! [`crate::sim::mechanism::stop`] (its doc gives the modes and their rules), each stop one
//! complementarity condition on its own coordinate.
//!
//! A stop's impulse `ν` acts at the start of the step on its coordinate alone (a generalized
//! impulse: the residual of the joint's equation gains `−ν`), and its mode decides it:
//!
//! ```text
//! free         ν = 0
//! slide(s)     ν = −s F h
//! stick        θ_{k+1} = θ_k,    ν = r_j     (the joint locked: its equation gives ν)
//! upper/lower  θ_{k+1} = bound,  ν = r_j
//! ```
//!
//! A locked coordinate leaves the unknowns: the articulated-body elimination passes its child's
//! articulated inertia whole to the parent (a weld, `d⁻¹ = 0` in [`super::aba`]) and its update
//! is 0, so the Newton matrix of the others is the exact derivative with it held. In maximal
//! coordinates the same stop is a row of the joint's block; here it costs nothing in structure
//! and a stop never bends a coordinate's branch (the angle is the unknown itself, so a joint
//! turning by more than π in one step is still read right, which the maximal step's angle read
//! from the poses cannot). The active set is switched with [`JointStop::next_mode`] (the same
//! rules, the same hysteresis) when Newton has converged, and kept from step to step.

use super::model::TreeModel;
use crate::sim::mechanism::step::DriveWork;
use crate::sim::mechanism::{JointStop, Mechanism, StopMode};

/// Mode switches one attempt may make before it accepts the iterate (each re-solves the step
/// from where it is).
pub(super) const MAX_SWITCHES: u32 = 16;

/// The stops of a tree: per stop its joint, mode and impulse; per joint whether it is locked.
#[derive(Debug, Clone, Default)]
pub(super) struct TreeStops {
    /// Per stop (the mechanism's order): the tree joint it acts on.
    joint: Vec<usize>,
    /// Per stop: the mode kept from the last committed step.
    committed: Vec<StopMode>,
    /// Per stop: the mode of the attempt under way.
    pub mode: Vec<StopMode>,
    /// Per stop: the impulse `ν` at the iterate (N m s, or N s).
    pub nu: Vec<f64>,
    /// Per stop: the last step's rate `(θ_k − θ_{k−1})/h` (the initial state's before the
    /// first step).
    rate_prev: Vec<f64>,
    /// Per tree joint: whether its coordinate is held (stick, upper, lower).
    pub locked: Vec<bool>,
    saved: (Vec<StopMode>, Vec<f64>),
}

impl TreeStops {
    pub(super) fn new(mechanism: &Mechanism, tree: &TreeModel) -> Self {
        let committed: Vec<StopMode> = mechanism.stops.iter().map(|s| s.initial_mode()).collect();
        let n = committed.len();
        Self {
            joint: mechanism
                .stops
                .iter()
                .map(|s| tree.coordinate_joint[s.coordinate])
                .collect(),
            mode: committed.clone(),
            committed,
            nu: vec![0.0; n],
            rate_prev: vec![f64::NAN; n],
            locked: vec![false; tree.joints.len()],
            saved: (Vec::new(), Vec::new()),
        }
    }

    pub(super) fn is_empty(&self) -> bool {
        self.joint.is_empty()
    }

    /// Whether some coordinate is held (its impulse is read from its equation).
    pub(super) fn any_locked(&self) -> bool {
        self.locked.iter().any(|&l| l)
    }

    /// The rates before the first step, `θ̇` per stop's joint (`rates` per tree joint).
    pub(super) fn set_initial_rates(&mut self, rates: &[f64]) {
        for (r, &j) in self.rate_prev.iter_mut().zip(&self.joint) {
            *r = rates[j];
        }
    }

    /// An attempt's start: the committed modes, applied to the predictor `theta_next`.
    pub(super) fn begin(
        &mut self,
        stops: &[JointStop],
        theta: &[f64],
        theta_next: &mut [f64],
        h: f64,
        slack: impl Fn(usize) -> f64,
    ) {
        self.mode.copy_from_slice(&self.committed);
        self.apply(stops, theta, theta_next, h, slack);
    }

    /// Each stop's mode made the iterate's: a held coordinate set to its target and locked, a
    /// free or sliding one's impulse set.
    fn apply(
        &mut self,
        stops: &[JointStop],
        theta: &[f64],
        theta_next: &mut [f64],
        h: f64,
        slack: impl Fn(usize) -> f64,
    ) {
        for (k, s) in stops.iter().enumerate() {
            let j = self.joint[k];
            let [lo, hi] = s.bounds(theta[j], slack(j));
            let target = match self.mode[k] {
                StopMode::Free => {
                    self.nu[k] = 0.0;
                    None
                }
                StopMode::Slide(sign) => {
                    self.nu[k] = -f64::from(sign) * s.friction * h;
                    None
                }
                StopMode::Stick => Some(theta[j]),
                StopMode::Upper => Some(hi),
                StopMode::Lower => Some(lo),
            };
            self.locked[j] = target.is_some();
            if let Some(t) = target {
                theta_next[j] = t;
            }
        }
    }

    /// The stops' impulses in the residual (`nb` base coordinates first): a held coordinate's
    /// equation gives its `ν` and leaves the system (its residual 0), the others gain `−ν`.
    pub(super) fn residual(&mut self, residual: &mut [f64], nb: usize) {
        for (k, &j) in self.joint.iter().enumerate() {
            let r = &mut residual[nb + j];
            if self.locked[j] {
                self.nu[k] = *r;
                *r = 0.0;
            } else {
                *r -= self.nu[k];
            }
        }
    }

    /// The active set at a converged iterate: whether a mode switched (then the iterate was
    /// changed to the new modes and the step must be solved again).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn switch(
        &mut self,
        stops: &[JointStop],
        theta: &[f64],
        theta_next: &mut [f64],
        h: f64,
        slack: impl Fn(usize) -> f64,
        nu_scale: f64,
        tol: f64,
    ) -> bool {
        let mut changed = false;
        for (k, s) in stops.iter().enumerate() {
            let j = self.joint[k];
            let nu = self.nu[k];
            let nu_tol = tol * nu.abs().max(nu_scale);
            if let Some(next) = s.next_mode(
                self.mode[k],
                theta[j],
                theta_next[j],
                nu,
                h,
                slack(j),
                nu_tol,
            ) {
                self.mode[k] = next;
                changed = true;
            }
        }
        if changed {
            self.apply(stops, theta, theta_next, h, slack);
        }
        changed
    }

    /// A solved step: the modes kept, and each impulse's work `−ν (θ̇_before + θ̇_after)/2`
    /// (the rates `Δθ/h`, exact in joint coordinates) as the limits' or friction's dissipation.
    pub(super) fn commit(
        &mut self,
        theta: &[f64],
        theta_next: &[f64],
        h: f64,
        work: &mut DriveWork,
    ) {
        self.committed.copy_from_slice(&self.mode);
        for (k, &j) in self.joint.iter().enumerate() {
            let rate = (theta_next[j] - theta[j]) / h;
            let before = self.rate_prev[k];
            self.rate_prev[k] = rate;
            let nu = self.nu[k];
            if nu == 0.0 {
                continue;
            }
            let before = if before.is_finite() { before } else { rate };
            let removed = -nu * 0.5 * (before + rate);
            if self.mode[k].at_limit() {
                work.limits += removed;
            } else {
                work.friction += removed;
            }
        }
    }

    pub(super) fn save(&mut self) {
        self.saved.0.clone_from(&self.committed);
        self.saved.1.clone_from(&self.rate_prev);
    }

    pub(super) fn restore(&mut self) {
        self.committed.clone_from(&self.saved.0);
        self.rate_prev.clone_from(&self.saved.1);
    }
}
