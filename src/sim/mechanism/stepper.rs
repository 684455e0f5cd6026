//! The [`Integrator`] of a batch holding mechanisms: free bodies between them step with the
//! free-body [`Variational`] lanes, each mechanism with the constrained step ([`super::step`]).
//!
//! `variational` is one step; `variational4` and `variational6` compose it (Yoshida's triple
//! jump and solution A, [`crate::sim::integrators::composition`]): every substep `γ_k h` steps
//! the free bodies and every mechanism. The constrained step is symmetric (its discrete
//! Lagrangian is, and the constraint is imposed at both ends alike: `L_d(q₁, q₀, −h) =
//! −L_d(q₀, q₁, h)` with `λ ↦ −λ`), so the compositions have orders 4 and 6
//! (`tests/mechanism/mechanism.rs` measures them). One warm start per distinct substep size.
//! Other integrators have no constrained form: [`Articulated::new`] refuses them.

use super::Mechanism;
use super::step::{self, MechanismState, Warm};
use crate::sim::Bodies;
use crate::sim::integrators::composition::{triple_jump, yoshida6_solution_a};
use crate::sim::integrators::{
    EnergyFlow, Integrator, IntegratorKind, StepStats, Variational, VariationalSettings,
};
use crate::sim::loads::Loads;
use std::ops::Range;
use std::sync::Arc;

/// The integrators that step mechanisms.
pub const SUPPORTED: [IntegratorKind; 3] = [
    IntegratorKind::Variational,
    IntegratorKind::Variational4,
    IntegratorKind::Variational6,
];

/// An integrator without a constrained form asked to step a mechanism.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "model `{model}` is articulated (bodies = \"articulated\"), which integrator `{integrator}` \
     cannot step: use one of {} (or bodies = \"links\" / \"rigid\" for this model)",
    SUPPORTED.map(|k| format!("`{}`", k.name())).join(", ")
)]
pub struct UnsupportedIntegrator {
    pub model: String,
    pub integrator: &'static str,
}

struct MechanismSlot {
    model: Arc<Mechanism>,
    state: MechanismState,
    /// One warm start per distinct substep size.
    warm: Vec<Warm>,
}

/// Free bodies and mechanisms stepped together (see the module doc).
pub struct Articulated {
    name: &'static str,
    dt_secs: f64,
    settings: VariationalSettings,
    /// Distinct substep sizes `γ h`, and per substep the index of its size.
    stage_dt: Vec<f64>,
    substeps: Vec<usize>,
    /// Free-body ranges of the batch, one [`Variational`] per stage each.
    free: Vec<(Range<usize>, Vec<Variational>)>,
    mechanisms: Vec<MechanismSlot>,
}

impl Articulated {
    /// The stepper for a batch of `body_count` bodies holding `mechanisms` (disjoint body
    /// ranges); every other body is free. Errors for integrators outside [`SUPPORTED`].
    pub fn new(
        kind: IntegratorKind,
        dt_secs: f64,
        settings: &VariationalSettings,
        mechanisms: &[Arc<Mechanism>],
        body_count: usize,
    ) -> Result<Self, UnsupportedIntegrator> {
        let gammas: Vec<f64> = match kind {
            IntegratorKind::Variational => vec![1.0],
            IntegratorKind::Variational4 => triple_jump().to_vec(),
            IntegratorKind::Variational6 => yoshida6_solution_a().to_vec(),
            other => {
                return Err(UnsupportedIntegrator {
                    model: mechanisms
                        .first()
                        .map(|m| m.name.clone())
                        .unwrap_or_default(),
                    integrator: other.name(),
                });
            }
        };
        let mut distinct: Vec<f64> = Vec::new();
        let substeps = gammas
            .iter()
            .map(|&g| match distinct.iter().position(|&d| d == g) {
                Some(k) => k,
                None => {
                    distinct.push(g);
                    distinct.len() - 1
                }
            })
            .collect();
        let stage_dt: Vec<f64> = distinct.iter().map(|g| g * dt_secs).collect();
        let mut sorted: Vec<&Arc<Mechanism>> = mechanisms.iter().collect();
        sorted.sort_by_key(|m| m.first_body);
        let mut free = Vec::new();
        let mut next = 0;
        for m in &sorted {
            if m.first_body > next {
                free.push(next..m.first_body);
            }
            next = m.first_body + m.body_count;
        }
        if body_count > next {
            free.push(next..body_count);
        }
        let free = free
            .into_iter()
            .map(|r| {
                let stages = stage_dt
                    .iter()
                    .map(|&h| Variational::new(h, *settings))
                    .collect();
                (r, stages)
            })
            .collect();
        let mechanisms = sorted
            .into_iter()
            .map(|m| MechanismSlot {
                state: MechanismState::new(m),
                warm: stage_dt.iter().map(|_| Warm::new(m)).collect(),
                model: Arc::clone(m),
            })
            .collect();
        Ok(Self {
            name: kind.name(),
            dt_secs,
            settings: *settings,
            stage_dt,
            substeps,
            free,
            mechanisms,
        })
    }
}

impl Integrator for Articulated {
    fn name(&self) -> &'static str {
        self.name
    }

    fn dt(&self) -> f64 {
        self.dt_secs
    }

    fn init(&mut self, bodies: &Bodies) {
        for (range, stages) in &mut self.free {
            for s in stages {
                s.init_range(bodies, range.clone());
            }
        }
        for slot in &mut self.mechanisms {
            slot.state = MechanismState::new(&slot.model);
            for w in &mut slot.warm {
                *w = Warm::new(&slot.model);
            }
        }
    }

    fn step(&mut self, bodies: &mut Bodies, loads: &Loads) -> StepStats {
        let mut stats = StepStats::default();
        // Each substep `γ_s h` starts at `t_k + (γ_1 + … + γ_{s−1}) h` (the drives' and the
        // applied loads' time).
        let mut stage_loads = loads.clone();
        for &k in &self.substeps {
            let loads = &stage_loads;
            for (range, stages) in &mut self.free {
                stats = stats.merge(stages[k].step_range(bodies, range.clone(), loads));
            }
            for slot in &mut self.mechanisms {
                stats = stats.merge(step::step(
                    &slot.model,
                    &mut slot.state,
                    &mut slot.warm[k],
                    bodies,
                    self.stage_dt[k],
                    loads,
                    &self.settings,
                ));
            }
            let t = stage_loads.time_secs() + self.stage_dt[k];
            stage_loads.set_time(t);
        }
        stats
    }

    fn mechanism_settings(&self) -> Option<VariationalSettings> {
        Some(self.settings)
    }

    fn energy_flow(&self) -> EnergyFlow {
        let free = self
            .free
            .iter()
            .flat_map(|(_, stages)| stages.iter())
            .fold(EnergyFlow::default(), |a, s| a + s.energy_flow());
        self.mechanisms.iter().fold(free, |a, slot| {
            let ws = &slot.state.ws;
            a + EnergyFlow {
                input_work: ws.drive_work.actuators + ws.load_work.work,
                dissipated: ws.drive_work.dissipated(),
                ..Default::default()
            }
        })
    }
}
