//! Integrators. Every scheme steps the same [`Bodies`] batch with a fixed step `dt`.
//!
//! | name | scheme | order | conserves exactly (to round-off) |
//! |---|---|---|---|
//! | `variational` | exp-map Lie-group variational integrator ([`variational`]) | 2 | spatial angular momentum |
//! | `moser-veselov` | Moser–Veselov discrete rigid body, Cayley solve ([`moser_veselov`]) | 2 | spatial angular momentum, kinetic energy `M^T J^-1 M / 2` |
//! | `variational4` | triple-jump composition of `variational` ([`composition`]) | 4 | spatial angular momentum |
//! | `variational6` | Yoshida's 7-stage composition of `variational` ([`composition`]) | 6 | spatial angular momentum |
//! | `euler` | explicit Euler ([`explicit`]) | 1 | nothing (energy grows) |
//! | `semi-implicit` | semi-implicit (symplectic) Euler ([`explicit`]) | 1 | nothing |
//! | `rk4` | classic Runge–Kutta ([`rk4`]) | 4 | nothing (slow drift) |
//!
//! The variational family (the first four) has bounded energy error with no drift. All but the
//! Euler schemes follow the exact parabola in uniform gravity (with the default symmetric
//! [`Potential`]); the Euler schemes are off by `∓ t h g / 2`.

pub mod composition;
pub mod explicit;
#[cfg(test)]
mod forced_tests;
pub mod moser_veselov;
pub mod rk4;
pub mod translation;
pub mod variational;

pub use composition::Composition;
pub use explicit::{ExplicitEuler, SemiImplicitEuler};
pub use moser_veselov::MoserVeselov;
pub use rk4::Rk4;
pub use translation::Potential;
pub use variational::{Jacobian, Variational, VariationalSettings};

use super::Bodies;
use super::guard::Watch;
use crate::sim::loads::Loads;

/// What one step did, summed or maximised over the batch.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StepStats {
    /// Largest number of Newton iterations any solve needed this step, substeps included
    /// (0 for explicit schemes).
    pub newton_iters_max: u32,
    /// Body-steps whose Newton solve ended without meeting the tolerance: with substepping on
    /// (the default), only those that failed even at `max_substeps`; with it off, every solve
    /// that reached the iteration cap (the unconverged `ξ` is used as is).
    pub newton_failures: u32,
    /// Body-steps that were split into substeps because Newton did not converge at full step.
    pub substepped: u32,
    /// Largest split factor used (a power of two; 0 when no step was split).
    pub substep_factor_max: u32,
    /// The lowest body index among `newton_failures`, if any.
    pub failed_body: Option<usize>,
}

impl StepStats {
    /// Combines the statistics of two steps (max of iterations and split factors, sums of
    /// counts, the lower failed body).
    pub fn merge(self, other: Self) -> Self {
        Self {
            newton_iters_max: self.newton_iters_max.max(other.newton_iters_max),
            newton_failures: self.newton_failures + other.newton_failures,
            substepped: self.substepped + other.substepped,
            substep_factor_max: self.substep_factor_max.max(other.substep_factor_max),
            failed_body: match (self.failed_body, other.failed_body) {
                (Some(a), Some(b)) => Some(a.min(b)),
                (a, b) => a.or(b),
            },
        }
    }

    /// Records one body's solve.
    pub fn add_solve(&mut self, body: usize, iterations: u32, converged: bool) {
        self.newton_iters_max = self.newton_iters_max.max(iterations);
        if !converged {
            self.newton_failures += 1;
            self.failed_body = Some(self.failed_body.map_or(body, |b| b.min(body)));
        }
    }
}

/// Energy that entered or left the bodies through their inputs (applied loads, joint
/// actuators, joint damping), summed over the steps taken: the terms of the energy balance
/// `E(T) − E(0) = input_work − dissipated + contact_work + (the scheme's own error)`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EnergyFlow {
    /// Work of the applied loads and the actuators, J.
    pub input_work: f64,
    /// Energy removed by joint damping (≥ 0), J.
    pub dissipated: f64,
    /// The kinetic energy contact impulses changed (≤ 0 up to round-off: contact never
    /// creates energy), J.
    pub contact_work: f64,
}

impl std::ops::Add for EnergyFlow {
    type Output = Self;
    /// The sum of two flows.
    fn add(self, other: Self) -> Self {
        Self {
            input_work: self.input_work + other.input_work,
            dissipated: self.dissipated + other.dissipated,
            contact_work: self.contact_work + other.contact_work,
        }
    }
}

/// A time-stepping scheme for a batch of free rigid bodies under [`Loads`] (today uniform
/// gravity).
pub trait Integrator: Send {
    /// The name used in scenes and on the command line.
    fn name(&self) -> &'static str;
    /// Prepares scheme-specific state for the batch's current state (e.g. the discrete
    /// Legendre transform). Called once before the first step, and again whenever bodies change.
    fn init(&mut self, bodies: &Bodies);
    /// Advances every body by one step.
    fn step(&mut self, bodies: &mut Bodies, loads: &Loads) -> StepStats;
    /// [`Integrator::step`], then the run guard's per-body test ([`Watch::any_suspect`]) over
    /// the batch: whether any body is suspect. An integrator that can run the test on each
    /// block of bodies right after stepping it, while the block is in cache, overrides this;
    /// the answer must be the same.
    fn step_watched(
        &mut self,
        bodies: &mut Bodies,
        loads: &Loads,
        watch: &Watch,
    ) -> (StepStats, bool) {
        let stats = self.step(bodies, loads);
        (stats, watch.any_suspect(bodies, 0..bodies.len()))
    }
    /// The step size, s.
    fn dt(&self) -> f64;
    /// The energy the inputs brought in and took out so far ([`EnergyFlow`]).
    fn energy_flow(&self) -> EnergyFlow {
        EnergyFlow::default()
    }
    /// The coefficient `α` of the step of a free centre of mass in uniform gravity,
    /// `c_{k+1} = c_k + h v_k + α h² g` (the contact phase predicts the free motion with it:
    /// `sim::contact::phase`). `1/2` for the schemes exact on a parabola.
    fn gravity_drift(&self) -> f64 {
        0.5
    }

    /// The settings of the variational step that moves this integrator's mechanisms (the
    /// contact phase steps a robot once with them to predict its motion:
    /// `sim::contact::robots`); `None` for a scheme that steps no mechanism.
    fn mechanism_settings(&self) -> Option<variational::VariationalSettings> {
        None
    }

    /// The joint coordinates this integrator carries for the mechanism whose first body is
    /// `first_body` (in this integrator's batch), written to `out` in the model's coordinate
    /// order; `false` when it steps no such mechanism. A joint's angle is state, carried
    /// step to step on one continuous branch: every reader (recorders, controllers, rollouts)
    /// takes it from here rather than recovering it from poses at its own rate.
    fn joint_coordinates(&self, first_body: usize, out: &mut [f64]) -> bool {
        let _ = (first_body, out);
        false
    }
}

/// Bodies stepped, then tested by the guard, at a time ([`step_blocks_watched`] and
/// [`Variational::step_range_watched`]): 64 bodies' state (and `ξ`, about 11 KB) stay in a
/// core's 64 KB L1 data cache between the step and the test.
pub const BLOCK_BODIES: usize = 64;

/// [`Integrator::step_watched`] for a scheme that steps every body from that body's state
/// alone: `step_range` steps the bodies of a range (failed bodies reported by batch index), and
/// each block of [`BLOCK_BODIES`] is tested right after its step, while it is in cache. The
/// bits and the statistics are those of one `step_range` over the batch followed by the
/// guard's pass ([`StepStats::merge`] adds counts and keeps maxima and the lowest failed body),
/// and so is the answer.
///
/// Used where it pays: `moser-veselov`, whose guarded stepping of the 10 000-body swarm on one
/// thread ran 1.3 % faster than the step and the pass (median of 6 paired rounds, -0.3 to
/// 2.9 %). The explicit schemes ran 5 % (`euler`) and 8 % (`rk4`) slower blocked than in two
/// passes over the batch (3 rounds each), so they keep the trait's default.
pub fn step_blocks_watched(
    bodies: &mut Bodies,
    watch: &Watch,
    mut step_range: impl FnMut(&mut Bodies, std::ops::Range<usize>) -> StepStats,
) -> (StepStats, bool) {
    let mut stats = StepStats::default();
    let mut any_suspect = false;
    let mut start = 0;
    while start < bodies.len() {
        let block = start..(start + BLOCK_BODIES).min(bodies.len());
        stats = stats.merge(step_range(bodies, block.clone()));
        any_suspect |= watch.any_suspect(bodies, block.clone());
        start = block.end;
    }
    (stats, any_suspect)
}

/// The integrators selectable by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum IntegratorKind {
    /// The exponential-map Lie-group variational integrator (discrete Euler-Lagrange equations,
    /// Newton on SO(3)). Order 2.
    Variational,
    /// The Moser–Veselov discrete rigid body (trace Lagrangian, Newton on the Cayley parameter).
    /// Order 2; conserves the kinetic energy exactly.
    MoserVeselov,
    /// `variational` composed by Yoshida's triple jump. Order 4.
    Variational4,
    /// `variational` composed by Yoshida's 7-stage solution A. Order 6.
    Variational6,
    /// Explicit Euler. Order 1.
    Euler,
    /// Semi-implicit (symplectic) Euler. Order 1.
    SemiImplicit,
    /// Classic Runge–Kutta. Order 4.
    Rk4,
}

impl IntegratorKind {
    pub const ALL: &'static [IntegratorKind] = &[
        IntegratorKind::Variational,
        IntegratorKind::MoserVeselov,
        IntegratorKind::Variational4,
        IntegratorKind::Variational6,
        IntegratorKind::Euler,
        IntegratorKind::SemiImplicit,
        IntegratorKind::Rk4,
    ];

    pub fn name(self) -> &'static str {
        match self {
            IntegratorKind::Variational => "variational",
            IntegratorKind::MoserVeselov => "moser-veselov",
            IntegratorKind::Variational4 => "variational4",
            IntegratorKind::Variational6 => "variational6",
            IntegratorKind::Euler => "euler",
            IntegratorKind::SemiImplicit => "semi-implicit",
            IntegratorKind::Rk4 => "rk4",
        }
    }

    /// The global order of accuracy in orientation (and every other state variable).
    pub fn order(self) -> u32 {
        match self {
            IntegratorKind::Euler | IntegratorKind::SemiImplicit => 1,
            IntegratorKind::Variational | IntegratorKind::MoserVeselov => 2,
            IntegratorKind::Variational4 | IntegratorKind::Rk4 => 4,
            IntegratorKind::Variational6 => 6,
        }
    }

    /// Whether the scheme is variational (symplectic, momentum-exact, bounded energy error).
    pub fn is_variational(self) -> bool {
        matches!(
            self,
            IntegratorKind::Variational
                | IntegratorKind::MoserVeselov
                | IntegratorKind::Variational4
                | IntegratorKind::Variational6
        )
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|k| k.name() == name)
    }

    /// Builds the integrator with step `dt_secs`. `settings` apply to the variational family
    /// (Newton tolerance and cap, translation potential; the Jacobian choice to the `variational`
    /// steps only); the explicit schemes ignore them.
    pub fn build(self, dt_secs: f64, settings: &VariationalSettings) -> Box<dyn Integrator> {
        match self {
            IntegratorKind::Variational => Box::new(Variational::new(dt_secs, *settings)),
            IntegratorKind::MoserVeselov => Box::new(MoserVeselov::new(dt_secs, *settings)),
            IntegratorKind::Variational4 => Box::new(Composition::order4(dt_secs, *settings)),
            IntegratorKind::Variational6 => Box::new(Composition::order6(dt_secs, *settings)),
            IntegratorKind::Euler => Box::new(ExplicitEuler::new(dt_secs)),
            IntegratorKind::SemiImplicit => Box::new(SemiImplicitEuler::new(dt_secs)),
            IntegratorKind::Rk4 => Box::new(Rk4::new(dt_secs)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `name`, `from_name`, serde and the built integrator's `name` all agree.
    #[test]
    fn names_round_trip() {
        let names: Vec<_> = IntegratorKind::ALL.iter().map(|k| k.name()).collect();
        assert_eq!(
            names,
            [
                "variational",
                "moser-veselov",
                "variational4",
                "variational6",
                "euler",
                "semi-implicit",
                "rk4"
            ]
        );
        for &kind in IntegratorKind::ALL {
            assert_eq!(IntegratorKind::from_name(kind.name()), Some(kind));
            let json = serde_json::to_string(&kind).unwrap();
            assert_eq!(json, format!("\"{}\"", kind.name()));
            assert_eq!(serde_json::from_str::<IntegratorKind>(&json).unwrap(), kind);
            let built = kind.build(0.01, &VariationalSettings::default());
            assert_eq!(built.name(), kind.name());
            assert_eq!(built.dt(), 0.01);
        }
        assert_eq!(IntegratorKind::from_name("rk5"), None);
    }

    /// Every integrator's watched step (the blocked one of `variational` and `moser-veselov`,
    /// the trait's step-then-pass of the others) flags exactly what a plain step followed by
    /// the guard's pass flags, over 3 steps of 150 bodies: a suspect body at the start, inside
    /// and at the end of a 64-body block, in the last, partial block, in `variational`'s 4-body
    /// lanes and in the 2 bodies left after them (150 = 37 x 4 + 2), two suspects in two
    /// blocks; for each cause (energy grown 121-fold, NaN position, infinite velocity, NaN
    /// momentum). The guard then names the lowest suspect, and the state and the statistics
    /// are the same bits.
    #[test]
    fn every_watched_step_flags_what_the_guard_pass_flags() {
        use crate::sim::guard::Guard;
        let g = Loads::uniform_gravity(nalgebra::Vector3::new(0.0, 0.0, -9.81));
        let inits = crate::sim::workload::free_body_batch(150);
        let cases: [&[usize]; 10] = [
            &[],
            &[0],
            &[5],
            &[63],
            &[64],
            &[128],
            &[130],
            &[148],
            &[149],
            &[5, 70],
        ];
        let bits = |b: &Bodies, i: usize| {
            let q = b.world_from_body[i].coords.map(f64::to_bits);
            let m = b.angmom_body[i].map(f64::to_bits);
            let c = b.com_world[i].map(f64::to_bits);
            let v = b.linvel_world[i].map(f64::to_bits);
            (q, m, c, v)
        };
        for &kind in IntegratorKind::ALL {
            for suspects in cases {
                for cause in 0..4 {
                    let mut watched = Bodies::new(&inits);
                    let guard = Guard::new(&watched, 100.0, None);
                    for &i in suspects {
                        match cause {
                            0 => watched.angmom_body[i] *= 11.0,
                            1 => watched.com_world[i].y = f64::NAN,
                            2 => watched.linvel_world[i].z = f64::INFINITY,
                            _ => watched.angmom_body[i].x = f64::NAN,
                        }
                    }
                    let mut plain = watched.clone();
                    let settings = VariationalSettings::default();
                    let (mut a, mut b) =
                        (kind.build(0.001, &settings), kind.build(0.001, &settings));
                    a.init(&watched);
                    b.init(&plain);
                    for step in 0..3 {
                        let (stats_a, any) = a.step_watched(&mut watched, &g, guard.watch());
                        let stats_b = b.step(&mut plain, &g);
                        let scanned = guard.watch().any_suspect(&plain, 0..plain.len());
                        let what =
                            format!("{kind:?}, suspects {suspects:?}, cause {cause}, step {step}");
                        assert_eq!(any, !suspects.is_empty(), "{what}");
                        assert_eq!(any, scanned, "{what}");
                        let stop = guard.check_flagged(&watched, &stats_a, step + 1, any);
                        assert_eq!(stop.map(|d| d.body), suspects.first().copied(), "{what}");
                        assert_eq!(stats_a, stats_b, "{what}");
                        for i in 0..150 {
                            assert_eq!(bits(&watched, i), bits(&plain, i), "{what}, body {i}");
                        }
                    }
                }
            }
        }
    }
}
