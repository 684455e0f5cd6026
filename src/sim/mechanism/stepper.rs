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
use super::joint_space::{self, TreeModel, TreeState, TreeWarm};
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

/// Which step a mechanism takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coordinates {
    /// Joint coordinates ([`super::joint_space`]) for every mechanism that is a tree of hinges
    /// and sliders, the maximal step for the others.
    Joint,
    /// The maximal-coordinate step ([`super::step`]) for every mechanism (the default).
    Maximal,
}

impl Coordinates {
    /// The default, `Maximal`, or `Joint` when the environment sets `TUMBLE_ARTICULATED=joint`.
    /// The joint-space step is opt-in until its Newton iteration is as robust as the maximal
    /// one's on whips and large steps (docs/mechanisms.md, "The joint-space step").
    pub fn from_env() -> Self {
        match std::env::var("TUMBLE_ARTICULATED") {
            Ok(v) if v.eq_ignore_ascii_case("joint") => Coordinates::Joint,
            _ => Coordinates::Maximal,
        }
    }
}

enum Stepping {
    Maximal {
        state: Box<MechanismState>,
        /// One warm start per distinct substep size.
        warm: Vec<Warm>,
    },
    Joint {
        state: Box<TreeState>,
        warm: Vec<TreeWarm>,
    },
}

struct MechanismSlot {
    model: Arc<Mechanism>,
    stepping: Stepping,
}

impl MechanismSlot {
    fn new(model: &Arc<Mechanism>, stages: usize, coordinates: Coordinates) -> Self {
        let tree = match coordinates {
            Coordinates::Joint => TreeModel::of(model).ok(),
            Coordinates::Maximal => None,
        };
        let stepping = match tree {
            Some(tree) => Stepping::Joint {
                warm: (0..stages).map(|_| TreeWarm::new(&tree)).collect(),
                state: Box::new(TreeState::new(model, tree)),
            },
            None => Stepping::Maximal {
                state: Box::new(MechanismState::new(model)),
                warm: (0..stages).map(|_| Warm::new(model)).collect(),
            },
        };
        Self {
            model: Arc::clone(model),
            stepping,
        }
    }
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
        Self::with_coordinates(
            kind,
            dt_secs,
            settings,
            mechanisms,
            body_count,
            Coordinates::from_env(),
        )
    }

    /// [`Articulated::new`] with the step chosen by `coordinates`.
    pub fn with_coordinates(
        kind: IntegratorKind,
        dt_secs: f64,
        settings: &VariationalSettings,
        mechanisms: &[Arc<Mechanism>],
        body_count: usize,
        coordinates: Coordinates,
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
            .map(|m| MechanismSlot::new(m, stage_dt.len(), coordinates))
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
            let stages = self.stage_dt.len();
            let coordinates = match slot.stepping {
                Stepping::Joint { .. } => Coordinates::Joint,
                Stepping::Maximal { .. } => Coordinates::Maximal,
            };
            *slot = MechanismSlot::new(&slot.model, stages, coordinates);
            if let Stepping::Joint { state, .. } = &mut slot.stepping {
                state.init(&slot.model, bodies);
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
                let h = self.stage_dt[k];
                stats = stats.merge(match &mut slot.stepping {
                    Stepping::Maximal { state, warm } => step::step(
                        &slot.model,
                        state,
                        &mut warm[k],
                        bodies,
                        h,
                        loads,
                        &self.settings,
                    ),
                    Stepping::Joint { state, warm } => joint_space::step(
                        &slot.model,
                        state,
                        &mut warm[k],
                        bodies,
                        h,
                        loads,
                        &self.settings,
                    ),
                });
            }
            let t = stage_loads.time_secs() + self.stage_dt[k];
            stage_loads.set_time(t);
        }
        stats
    }

    fn mechanism_settings(&self) -> Option<VariationalSettings> {
        Some(self.settings)
    }

    fn joint_coordinates(&self, first_body: usize, out: &mut [f64]) -> bool {
        let Some(slot) = self
            .mechanisms
            .iter()
            .find(|s| s.model.first_body == first_body)
        else {
            return false;
        };
        match &slot.stepping {
            Stepping::Maximal { state, .. } => out.copy_from_slice(state.coordinates()),
            Stepping::Joint { state, .. } => state.coordinates_into(out),
        }
        true
    }

    fn energy_flow(&self) -> EnergyFlow {
        let free = self
            .free
            .iter()
            .flat_map(|(_, stages)| stages.iter())
            .fold(EnergyFlow::default(), |a, s| a + s.energy_flow());
        self.mechanisms.iter().fold(free, |a, slot| {
            let (drive, load) = match &slot.stepping {
                Stepping::Maximal { state, .. } => (&state.ws.drive_work, &state.ws.load_work),
                Stepping::Joint { state, .. } => (&state.drive_work, &state.load_work),
            };
            a + EnergyFlow {
                input_work: drive.actuators + load.work,
                dissipated: drive.dissipated(),
                ..Default::default()
            }
        })
    }
}
