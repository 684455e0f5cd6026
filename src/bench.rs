//! Timing the step, no recording: what `tumble bench` measures and prints
//! ([`crate::commands::bench`] keeps the arguments and the printing), and the partitioned
//! stepping `tumble trade` times ([`crate::trade::measure`]).
//!
//! Two kinds of timed run:
//! - [`time_steps`]: the bare integrator on one batch, one thread, no guard;
//! - [`time_simulation`]: a [`Simulation`] with no sinks, stepped as `simulate` steps it (the
//!   batch cut into partitions between mechanisms, the guard after every step), the threads
//!   meeting every [`WINDOW_STEPS`] steps. Without sinks its windows build no frame
//!   ([`Simulation::advance`]), so the timed region holds the stepping and the meetings alone.
//!
//! And one untimed measurement, [`measure_errors`]: the largest energy and momentum errors of
//! the reported states over a horizon.

use crate::sim::integrators::VariationalSettings;
use crate::sim::{Bodies, BodyInit, Integrator, IntegratorKind, Loads, RunSettings};
use crate::simulation::{Inits, Simulation};
use crate::world::World;
use nalgebra::Vector3;
use std::time::Instant;

/// Steps between two meetings of the threads (a 100 Hz recording at dt = 1 ms).
pub const WINDOW_STEPS: u64 = 10;

/// Times `steps` bare steps of `make`'s integrator from `start` (no guard, this thread),
/// `repeats` times; `per_run(run, ns, failures)` after each run. Returns the median wall time
/// per step, ns.
pub fn time_steps(
    start: &Bodies,
    make: &dyn Fn() -> anyhow::Result<Box<dyn Integrator>>,
    loads: &Loads,
    steps: u64,
    repeats: usize,
    per_run: &mut dyn FnMut(usize, f64, u64),
) -> anyhow::Result<f64> {
    let mut samples = Vec::with_capacity(repeats);
    for r in 0..repeats {
        let mut bodies = start.clone();
        let mut integrator = make()?;
        integrator.init(&bodies);
        let mut loads = loads.clone();
        let dt = integrator.dt();
        let started = Instant::now();
        let mut failures = 0u64;
        for k in 0..steps {
            loads.set_time(k as f64 * dt);
            failures += u64::from(integrator.step(&mut bodies, &loads).newton_failures);
        }
        let ns = started.elapsed().as_secs_f64() * 1e9 / steps as f64;
        std::hint::black_box(&bodies);
        per_run(r, ns, failures);
        samples.push(ns);
    }
    Ok(median(&mut samples))
}

/// How a [`Simulation`] of `world` on `threads` threads is cut: the number of partitions
/// ([`crate::sim::partition::ranges`]) and the threads that step them.
pub fn partitioning(world: &World, threads: usize) -> (usize, usize) {
    let mechanism_ranges: Vec<_> = world.mechanisms.iter().map(|m| m.bodies()).collect();
    let parts = crate::sim::partition::ranges(world.bodies.len(), threads, &mechanism_ranges).len();
    (
        parts,
        crate::sim::partition::stepping_threads(parts, threads),
    )
}

/// One timed run: wall time per step of the whole batch, and the count of non-converged
/// solves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timed {
    /// Wall time of the stepping, s.
    pub secs: f64,
    pub ns_per_step: f64,
    pub failures: u64,
}

/// What [`time_simulation`] steps.
#[derive(Debug, Clone, Copy)]
pub struct TimedRun<'a> {
    pub kind: IntegratorKind,
    pub dt_secs: f64,
    pub variational: &'a VariationalSettings,
    pub gravity: Vector3<f64>,
    pub threads: usize,
    pub steps: u64,
}

/// Steps `inits` (`world`'s bodies, or a bare batch of free bodies with
/// `World::default()`: no layout, no mechanisms) `run.steps` steps through a [`Simulation`]
/// with no sinks on `run.threads` threads, each partition with its own integrator and guard
/// (no energy limit, Newton failures counted, not stopping), the threads meeting every
/// [`WINDOW_STEPS`] steps; times the stepping alone (not the set-up).
pub fn time_simulation(
    world: &World,
    inits: &[BodyInit],
    run: &TimedRun<'_>,
) -> anyhow::Result<Timed> {
    let settings = RunSettings {
        steps: run.steps,
        log_every: WINDOW_STEPS,
        gravity: run.gravity,
        divergence_energy_ratio: f64::MAX,
        stop_on_newton_failure: None,
        stop_on_interrupt: false,
        quiet: false,
    };
    let mut sim = Simulation::new(
        world,
        Inits::Borrowed(inits),
        &|part| {
            crate::sim::integrator_for(
                run.kind,
                run.dt_secs,
                run.variational,
                part.mechanisms,
                part.range.len(),
            )
        },
        run.threads,
        &settings,
    )?;
    let started = Instant::now();
    sim.advance(run.steps)?;
    let secs = started.elapsed().as_secs_f64();
    let ns_per_step = secs * 1e9 / run.steps.max(1) as f64;
    std::hint::black_box(sim.partitions());
    let failures = sim.summary().stats.newton_failures;
    Ok(Timed {
        secs,
        ns_per_step,
        failures: u64::from(failures),
    })
}

/// The largest relative errors of a run's reported states (see [`measure_errors`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Errors {
    pub steps: u64,
    /// Largest `|E − E₀|/|E₀|` of the reported energy.
    pub energy: f64,
    /// Largest relative change of the conserved angular momenta; NaN when none is conserved.
    pub angular: f64,
    /// Largest relative change of the floating models' linear momenta (without gravity);
    /// NaN otherwise.
    pub linear: f64,
}

/// The largest relative errors of the reported energy and the conserved momenta of `world`
/// over `secs`, every step. The integrator steps the whole world directly, with no guard: a
/// run that diverges reports NaN rather than stopping.
pub fn measure_errors(
    world: &World,
    make: &dyn Fn() -> anyhow::Result<Box<dyn Integrator>>,
    loads: &Loads,
    dt: f64,
    secs: f64,
) -> anyhow::Result<Errors> {
    let steps = (secs / dt).round() as u64;
    let mut bodies = Bodies::new(&world.bodies);
    let mut integrator = make()?;
    integrator.init(&bodies);
    let mut frames = crate::simulation::FrameBuilder::new(world);
    let floating: Vec<usize> = world
        .layout
        .mechanisms
        .iter()
        .enumerate()
        .filter(|(_, m)| m.floating)
        .map(|(k, _)| k)
        .collect();
    let frame = frames.frame(&bodies, loads, 0, dt);
    let p0: Vec<Vector3<f64>> = floating
        .iter()
        .map(|&k| frame.mechanisms[k].linear_momentum)
        .collect();
    let e0 = frames.total_energy();
    let mut l0 = Vec::new();
    frames.conserved_angmom(&mut l0, &|_| false);
    let mut l = Vec::new();
    let (mut energy, mut angular, mut linear): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let worst = |a: f64, b: f64| {
        if b.is_nan() || a.is_nan() {
            f64::NAN
        } else {
            a.max(b)
        }
    };
    let mut loads = loads.clone();
    for step in 1..=steps {
        loads.set_time((step - 1) as f64 * dt);
        integrator.step(&mut bodies, &loads);
        loads.set_time(step as f64 * dt);
        let frame = frames.frame(&bodies, &loads, step, dt);
        if loads.gravity().norm() == 0.0 {
            for (i, &k) in floating.iter().enumerate() {
                let p = frame.mechanisms[k].linear_momentum;
                linear = worst(
                    linear,
                    (p - p0[i]).norm() / p0[i].norm().max(f64::MIN_POSITIVE),
                );
            }
        }
        energy = worst(
            energy,
            (frames.total_energy() - e0).abs() / e0.abs().max(f64::MIN_POSITIVE),
        );
        frames.conserved_angmom(&mut l, &|_| false);
        for (a, b) in l.iter().zip(&l0) {
            angular = worst(angular, (a - b).norm() / b.norm().max(f64::MIN_POSITIVE));
        }
    }
    if l0.is_empty() {
        angular = f64::NAN;
    }
    if floating.is_empty() || loads.gravity().norm() != 0.0 {
        linear = f64::NAN;
    }
    Ok(Errors {
        steps,
        energy,
        angular,
        linear,
    })
}

/// Median (mean of the middle two for an even count).
pub fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}
