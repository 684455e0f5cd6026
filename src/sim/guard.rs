//! The run-time guard against divergence: after every step, each body's state must be finite
//! and its rotational kinetic energy `T = M^T J^-1 M / 2` must stay below
//! `divergence_energy_ratio · T_0` (torque-free motion conserves `T` exactly, the variational
//! schemes keep it within O(h^2), so growth by a factor means the scheme is unstable at this
//! step: explicit Euler at large `h|Ω|`, RK4 beyond its stability bound). A body whose Newton
//! solve failed even after substepping ([`StepStats::newton_failures`] with substepping on) is
//! stopped too. The first body that fails, the step and the cause are reported; the run ends
//! at the previous step, so nothing non-finite is ever recorded.
//!
//! Inputs do work: a body under an applied load ([`crate::sim::loads::BodyLoad`]) and an
//! articulated model with an actuator or a loaded body are watched for non-finite and
//! out-of-range values and Newton failures only, not for energy growth (their energy may grow
//! by the inputs' work, which the run summary's energy balance reports). Joint damping alone
//! only removes energy and keeps the energy test.

use super::{Bodies, StepStats};
use crate::sim::loads::Loads;
use std::cmp::Ordering;
use std::fmt;

/// Default of `sim.divergence_energy_ratio`.
pub const DEFAULT_DIVERGENCE_ENERGY_RATIO: f64 = 100.0;

/// Why a body was stopped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Cause {
    /// Newton did not converge, not even with the step split into `max_substeps` substeps.
    NewtonFailed { max_substeps: u32 },
    /// A state variable became NaN or infinite.
    NonFinite { what: &'static str },
    /// Every state variable is finite but they are too large to compute with: the sum the
    /// per-body test takes of the position and velocity components overflows (components
    /// near the largest `f64`, 1.8e308). Not an energy growth.
    OutOfRange { what: &'static str },
    /// The rotational kinetic energy grew to `ratio` times its initial value (> the limit).
    EnergyGrowth { ratio: f64, limit: f64 },
    /// An articulated model's kinetic energy (relative to its centre of mass with a floating
    /// base) grew to `ratio` times its reference (the initial value plus the potential energy
    /// the model could release), over the limit.
    MechanismEnergyGrowth { ratio: f64, limit: f64 },
}

impl fmt::Display for Cause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Cause::NewtonFailed { max_substeps } => write!(
                f,
                "the implicit step's Newton solve did not converge, not even split into {max_substeps} substeps"
            ),
            Cause::NonFinite { what } => write!(f, "its {what} is not finite (NaN or infinite)"),
            Cause::OutOfRange { what } => write!(
                f,
                "its {what} went out of range: the values are finite but too large to add up \
                 in f64 arithmetic (near 1.8e308); a value out of range reached the integrator"
            ),
            Cause::EnergyGrowth { ratio, limit } => write!(
                f,
                "its rotational kinetic energy grew to {ratio:.3e} times the initial value \
                 (limit sim.divergence_energy_ratio = {}): the integrator is unstable at this step size",
                crate::budget::readable(*limit)
            ),
            Cause::MechanismEnergyGrowth { ratio, limit } => write!(
                f,
                "its articulated model's kinetic energy grew to {ratio:.3e} times its initial value \
                 plus the potential energy it can release (limit sim.divergence_energy_ratio = \
                 {}): the step is unstable at this step size",
                crate::budget::readable(*limit)
            ),
        }
    }
}

/// A stopped run: body index (in the batch), the step at which the state went bad, the cause.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Divergence {
    pub body: usize,
    pub step: u64,
    pub cause: Cause,
}

/// The guard's per-body test, one pass with no branches and no early exit:
/// body `i` is suspect when its rotational energy `2T = M·(J^-1 M)` is above twice the limit
/// or NaN, or any of its pose and velocity values is not finite (their sum is then not finite).
///
/// The test reads the state after a step only, so an integrator may run it on each block of
/// bodies right after stepping that block, while the block is still in the core's cache,
/// instead of in a second pass over the batch ([`crate::sim::Integrator::step_watched`]): at
/// 10 000 bodies the second pass cost 8-10 % of the variational step (`tumble bench --scene`,
/// 16 partitions on one thread with and without it).
#[derive(Debug, Clone)]
pub struct Watch {
    /// Per body: twice the largest rotational energy allowed, J (infinite for the bodies of
    /// a mechanism, which exchange energy through their joints).
    two_t_max: Vec<f64>,
}

impl Watch {
    /// Whether body `i` is suspect.
    #[inline(always)]
    fn suspect_at(&self, bodies: &Bodies, i: usize) -> bool {
        let m = bodies.angmom_body[i];
        let ij = bodies.inv_inertia_body[i];
        let two_t = m.x * (m.x * ij.x) + m.y * (m.y * ij.y) + m.z * (m.z * ij.z);
        let q = bodies.world_from_body[i].coords;
        let sum = q.x + q.y + q.z + q.w + bodies.com_world[i].sum() + bodies.linvel_world[i].sum();
        (two_t.partial_cmp(&self.two_t_max[i]) == Some(Ordering::Greater) || two_t.is_nan())
            | !sum.is_finite()
    }

    /// Whether any body of `range` (batch indices) is suspect.
    #[inline]
    pub fn any_suspect(&self, bodies: &Bodies, range: std::ops::Range<usize>) -> bool {
        range.fold(false, |acc, i| acc | self.suspect_at(bodies, i))
    }

    /// The lowest suspect body.
    fn first_suspect(&self, bodies: &Bodies) -> Option<usize> {
        (0..bodies.len()).find(|&i| self.suspect_at(bodies, i))
    }
}

/// Per-run guard state.
#[derive(Debug, Clone)]
pub struct Guard {
    energy_ratio: f64,
    watch: Watch,
    initial_energy: Vec<f64>,
    /// `Some(max_substeps)` when a Newton failure stops the run (substepping on).
    stop_on_newton_failure: Option<u32>,
    mechanisms: Vec<MechanismWatch>,
}

/// The energy guard of one articulated model (its bodies' own energies are not conserved:
/// they exchange it through the joints).
#[derive(Debug, Clone)]
struct MechanismWatch {
    bodies: std::ops::Range<usize>,
    /// Measure the kinetic energy relative to the centre of mass (floating base).
    relative: bool,
    /// The reference energy, J: initial kinetic energy plus the potential energy the model
    /// can release (fixed base: `Σ m_i |g| 2 R`, `R` the largest distance of a centre of mass
    /// from the base anchor plus the model's length scale; floating base in uniform gravity:
    /// none, the internal motion does not feel it). Zero: no energy check (only finiteness).
    reference: f64,
}

fn mechanism_kinetic_energy(bodies: &Bodies, range: std::ops::Range<usize>, relative: bool) -> f64 {
    let mut t = 0.0;
    let mut p = nalgebra::Vector3::zeros();
    let mut m = 0.0;
    for i in range {
        t += bodies.kinetic_energy(i);
        p += bodies.linvel_world[i] * bodies.mass[i];
        m += bodies.mass[i];
    }
    if relative {
        t - p.norm_squared() / (2.0 * m)
    } else {
        t
    }
}

impl Guard {
    /// `stop_on_newton_failure`: `Some(max_substeps)` when substepping is on (a failure is then
    /// final), `None` when off (failures are counted, the run goes on).
    pub fn new(bodies: &Bodies, energy_ratio: f64, stop_on_newton_failure: Option<u32>) -> Self {
        let initial_energy: Vec<f64> = (0..bodies.len())
            .map(|i| bodies.rotational_energy(i))
            .collect();
        Self {
            energy_ratio,
            watch: Watch {
                two_t_max: initial_energy
                    .iter()
                    .map(|t| 2.0 * (t * energy_ratio))
                    .collect(),
            },
            initial_energy,
            stop_on_newton_failure,
            mechanisms: Vec::new(),
        }
    }

    /// Watches articulated models by their total kinetic energy instead of their bodies' own
    /// rotational energies (see [`MechanismWatch`]).
    pub fn watch_mechanisms(
        &mut self,
        mechanisms: &[std::sync::Arc<crate::sim::mechanism::Mechanism>],
        bodies: &Bodies,
        loads: &Loads,
    ) {
        use crate::sim::mechanism::Base;
        for m in mechanisms {
            let range = m.bodies();
            for i in range.clone() {
                self.watch.two_t_max[i] = f64::INFINITY;
            }
            let driven = m.drives.iter().any(|d| d.actuator.is_some());
            if driven || loads.loads_any(&range) {
                // Inputs do work: finiteness only (see the module doc).
                self.mechanisms.push(MechanismWatch {
                    bodies: range,
                    relative: false,
                    reference: 0.0,
                });
                continue;
            }
            let relative = m.base == Base::Floating;
            let mut reference = mechanism_kinetic_energy(bodies, range.clone(), relative);
            if m.base == Base::Fixed {
                let anchor = m.world_pose.com + m.world_pose.rot * m.joints[0].rows.anchor_parent;
                let reach = range
                    .clone()
                    .map(|i| (bodies.com_world[i] - anchor).norm())
                    .fold(0.0, f64::max)
                    + m.length_scale;
                let mass: f64 = range.clone().map(|i| bodies.mass[i]).sum();
                reference += mass * loads.gravity().norm() * 2.0 * reach;
            }
            self.mechanisms.push(MechanismWatch {
                bodies: range,
                relative,
                reference,
            });
        }
    }

    /// Exempts the bodies under applied loads from the energy test (finiteness only; see the
    /// module doc). `loads` indexes the same bodies as the guard.
    pub fn exempt_loaded_bodies(&mut self, loads: &Loads) {
        for l in loads.body_loads() {
            if let Some(t) = self.watch.two_t_max.get_mut(l.body) {
                *t = f64::INFINITY;
            }
        }
    }

    /// Exempts the bodies `local` (indices of this guard's batch) from the energy test: their
    /// rotational energy changes by contact (a ball rolling down a slope); they are watched
    /// for finiteness only.
    pub fn exempt_bodies(&mut self, local: impl IntoIterator<Item = usize>) {
        for i in local {
            if let Some(t) = self.watch.two_t_max.get_mut(i) {
                *t = f64::INFINITY;
            }
        }
    }

    /// Exempts the articulated models holding body `local` (an index of this guard's batch)
    /// from the energy test: contact changes their kinetic energy (a landing robot's fall
    /// turns into its legs' motion), as inputs do; like driven models they are watched for
    /// finiteness only.
    pub fn exempt_mechanism_of(&mut self, local: usize) {
        for w in &mut self.mechanisms {
            if w.bodies.contains(&local) {
                w.reference = 0.0;
            }
        }
    }

    /// The per-body test ([`Watch`]), for an integrator that runs it inside its step.
    pub fn watch(&self) -> &Watch {
        &self.watch
    }

    /// Checks the state after step `step`; the first failing body (lowest index) wins.
    pub fn check(&self, bodies: &Bodies, stats: &StepStats, step: u64) -> Option<Divergence> {
        let any = self.watch.any_suspect(bodies, 0..bodies.len());
        self.check_flagged(bodies, stats, step, any)
    }

    /// [`Guard::check`] when the per-body test has already run over the whole batch and
    /// found a suspect body or not (`any_suspect`, from [`crate::sim::Integrator::step_watched`]).
    pub fn check_flagged(
        &self,
        bodies: &Bodies,
        stats: &StepStats,
        step: u64,
        any_suspect: bool,
    ) -> Option<Divergence> {
        let newton =
            self.stop_on_newton_failure
                .zip(stats.failed_body)
                .map(|(max_substeps, body)| Divergence {
                    body,
                    step,
                    cause: Cause::NewtonFailed { max_substeps },
                });
        let suspect = if any_suspect {
            self.watch.first_suspect(bodies)
        } else {
            None
        };
        let state = suspect.map(|body| Divergence {
            body,
            step,
            cause: self.classify(bodies, body),
        });
        let state = state.or_else(|| {
            self.mechanisms.iter().find_map(|w| {
                if w.reference <= 0.0 {
                    return None;
                }
                let t = mechanism_kinetic_energy(bodies, w.bodies.clone(), w.relative);
                let ratio = t / w.reference;
                let cause = if !t.is_finite() {
                    Cause::NonFinite {
                        what: "articulated model's kinetic energy",
                    }
                } else {
                    Cause::MechanismEnergyGrowth {
                        ratio,
                        limit: self.energy_ratio,
                    }
                };
                (ratio > self.energy_ratio || ratio.is_nan()).then_some(Divergence {
                    body: w.bodies.start,
                    step,
                    cause,
                })
            })
        });
        match (newton, state) {
            (Some(a), Some(b)) => Some(if b.body < a.body { b } else { a }),
            (a, b) => a.or(b),
        }
    }

    fn classify(&self, bodies: &Bodies, i: usize) -> Cause {
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !finite(bodies.angmom_body[i].as_slice()) {
            return Cause::NonFinite {
                what: "angular momentum",
            };
        }
        if !finite(bodies.world_from_body[i].coords.as_slice()) {
            return Cause::NonFinite {
                what: "orientation",
            };
        }
        if !finite(bodies.com_world[i].as_slice()) {
            return Cause::NonFinite { what: "position" };
        }
        if !finite(bodies.linvel_world[i].as_slice()) {
            return Cause::NonFinite {
                what: "linear velocity",
            };
        }
        let t = bodies.rotational_energy(i);
        if !t.is_finite() {
            return Cause::NonFinite {
                what: "rotational kinetic energy",
            };
        }
        // Every value is finite; the per-body test may still have flagged the body because its
        // sum of the position and velocity components overflowed (not an energy growth).
        let q = bodies.world_from_body[i].coords;
        let sum = q.x + q.y + q.z + q.w + bodies.com_world[i].sum() + bodies.linvel_world[i].sum();
        if !sum.is_finite() {
            return Cause::OutOfRange {
                what: "position or linear velocity",
            };
        }
        Cause::EnergyGrowth {
            ratio: t / self.initial_energy[i],
            limit: self.energy_ratio,
        }
    }
}
