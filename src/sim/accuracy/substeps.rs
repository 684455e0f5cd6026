//! Per-body substeps: body `i` of the batch takes `k_i` steps of `dt / k_i` per step `dt` of
//! the run (the recording keeps `dt`).
//!
//! Each substep is a full step of the scheme (for `variational4`/`variational6` a whole
//! composition of `dt / k`, so the order is kept: splitting each stage instead would shrink the
//! leading error by `k^2` only), taken by the scheme's own integrator built with `dt / k`
//! ([`IntegratorKind::build`]): the step is not written twice, and its Newton-failure guard
//! (which splits a step further when Newton does not converge, [`VariationalSettings::substep`])
//! stays on top. The bodies sharing a factor form a group with its own integrator and its own
//! copy of their state (a structure of arrays, so the group is stepped by the batched lanes);
//! after each step the group's state is written back to the caller's batch. A batch with one
//! factor is stepped in place (no copies). Momentum stays exact: every substep rotates `R` and
//! `M` by the same `exp(ξ)`.
//!
//! The factors come from the body's own state at [`Integrator::init`] ([`FactorRule`]), so a
//! body's trajectory is the same bits whichever partition of the batch it is in
//! (`--threads`): its group integrator steps it as one body would (the lanes round alike).

use super::model::{ErrorModel, Factor};
use crate::sim::integrators::VariationalSettings;
use crate::sim::loads::Loads;
use crate::sim::{Bodies, Integrator, IntegratorKind, StepStats};
use nalgebra::Vector3;

/// How each body's substep factor is chosen.
#[derive(Debug, Clone, PartialEq)]
pub enum FactorRule {
    /// The same factor for every body.
    Uniform(u32),
    /// Given factors, one per body of the batch.
    PerBody(std::sync::Arc<Vec<u32>>),
    /// The smallest factor whose predicted orientation error over `duration_secs` is at most
    /// `tol_rad` ([`ErrorModel::factor`]).
    Tolerance {
        model: ErrorModel,
        tol_rad: f64,
        duration_secs: f64,
    },
}

impl FactorRule {
    /// The factor of a body with principal moments `inertia_body` and body momentum
    /// `angmom_body`, for `kind` at step `dt_secs`.
    pub fn factor(
        &self,
        body: usize,
        kind: IntegratorKind,
        settings: &VariationalSettings,
        inertia_body: &Vector3<f64>,
        angmom_body: &Vector3<f64>,
        dt_secs: f64,
    ) -> Factor {
        match self {
            &FactorRule::Uniform(k) => Factor {
                k: k.max(1),
                predicted_rad: f64::NAN,
            },
            FactorRule::PerBody(ks) => Factor {
                k: ks.get(body).copied().unwrap_or(1).max(1),
                predicted_rad: f64::NAN,
            },
            &FactorRule::Tolerance {
                model,
                tol_rad,
                duration_secs,
            } => model.factor(
                kind,
                settings,
                inertia_body,
                angmom_body,
                dt_secs,
                duration_secs,
                tol_rad,
            ),
        }
    }
}

/// Bodies sharing one factor.
struct Group {
    k: u32,
    /// Their indices in the caller's batch, ascending.
    indices: Vec<usize>,
    /// Their state (unused when the group is the whole batch, stepped in place).
    bodies: Bodies,
    integrator: Box<dyn Integrator>,
}

/// An integrator stepping each body with its own number of substeps.
pub struct Substepped {
    kind: IntegratorKind,
    dt_secs: f64,
    settings: VariationalSettings,
    rule: FactorRule,
    factors: Vec<u32>,
    groups: Vec<Group>,
    /// One group holding every body in order: stepped in place.
    in_place: bool,
}

impl Substepped {
    pub fn new(
        kind: IntegratorKind,
        dt_secs: f64,
        settings: &VariationalSettings,
        rule: FactorRule,
    ) -> Self {
        Self {
            kind,
            dt_secs,
            settings: *settings,
            rule,
            factors: Vec::new(),
            groups: Vec::new(),
            in_place: false,
        }
    }

    /// Every body with `k` substeps.
    pub fn uniform(
        kind: IntegratorKind,
        dt_secs: f64,
        k: u32,
        settings: &VariationalSettings,
    ) -> Self {
        Self::new(kind, dt_secs, settings, FactorRule::Uniform(k))
    }

    /// Body `i` of the batch with `factors[i]` substeps.
    pub fn with_factors(
        kind: IntegratorKind,
        dt_secs: f64,
        settings: &VariationalSettings,
        factors: Vec<u32>,
    ) -> Self {
        Self::new(
            kind,
            dt_secs,
            settings,
            FactorRule::PerBody(std::sync::Arc::new(factors)),
        )
    }

    /// The factor of each body of the batch last initialised.
    pub fn factors(&self) -> &[u32] {
        &self.factors
    }
}

/// Copies the moving state of body `from` of `src` to body `to` of `dst`.
fn copy_state(src: &Bodies, from: usize, dst: &mut Bodies, to: usize) {
    dst.world_from_body[to] = src.world_from_body[from];
    dst.angmom_body[to] = src.angmom_body[from];
    dst.com_world[to] = src.com_world[from];
    dst.linvel_world[to] = src.linvel_world[from];
}

/// The bodies `indices` of `bodies`, as a batch of their own.
fn subset(bodies: &Bodies, indices: &[usize]) -> Bodies {
    let pick = |v: &Vec<Vector3<f64>>| indices.iter().map(|&i| v[i]).collect();
    Bodies {
        mass: indices.iter().map(|&i| bodies.mass[i]).collect(),
        inertia_body: pick(&bodies.inertia_body),
        inv_inertia_body: pick(&bodies.inv_inertia_body),
        world_from_body: indices.iter().map(|&i| bodies.world_from_body[i]).collect(),
        angmom_body: pick(&bodies.angmom_body),
        com_world: pick(&bodies.com_world),
        linvel_world: pick(&bodies.linvel_world),
    }
}

impl Integrator for Substepped {
    fn name(&self) -> &'static str {
        self.kind.name()
    }

    fn dt(&self) -> f64 {
        self.dt_secs
    }

    fn init(&mut self, bodies: &Bodies) {
        self.factors = (0..bodies.len())
            .map(|i| {
                self.rule
                    .factor(
                        i,
                        self.kind,
                        &self.settings,
                        &bodies.inertia_body[i],
                        &bodies.angmom_body[i],
                        self.dt_secs,
                    )
                    .k
            })
            .collect();
        let mut distinct: Vec<u32> = self.factors.clone();
        distinct.sort_unstable();
        distinct.dedup();
        self.in_place = distinct.len() <= 1;
        self.groups = distinct
            .into_iter()
            .map(|k| {
                let indices: Vec<usize> = (0..bodies.len())
                    .filter(|&i| self.factors[i] == k)
                    .collect();
                let group_bodies = if self.in_place {
                    Bodies::default()
                } else {
                    subset(bodies, &indices)
                };
                let mut integrator = self.kind.build(self.dt_secs / f64::from(k), &self.settings);
                integrator.init(if self.in_place { bodies } else { &group_bodies });
                Group {
                    k,
                    indices,
                    bodies: group_bodies,
                    integrator,
                }
            })
            .collect();
    }

    fn step(&mut self, bodies: &mut Bodies, loads: &Loads) -> StepStats {
        if self.factors.len() != bodies.len() {
            self.init(bodies);
        }
        let mut stats = StepStats::default();
        for group in &mut self.groups {
            let target = if self.in_place {
                &mut *bodies
            } else {
                &mut group.bodies
            };
            for _ in 0..group.k {
                let mut s = group.integrator.step(target, loads);
                if !self.in_place {
                    s.failed_body = s.failed_body.map(|b| group.indices[b]);
                }
                stats = stats.merge(s);
            }
            if !self.in_place {
                for (local, &i) in group.indices.iter().enumerate() {
                    copy_state(&group.bodies, local, bodies, i);
                }
            }
        }
        stats
    }
}
