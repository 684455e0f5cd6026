//! One row of the trade table: cost and errors of one integrator at one step size.

use super::TradeSettings;
use super::reference::{Reference, rotation_error};
use crate::bench::median;
use crate::sim::Loads;
use crate::sim::integrators::VariationalSettings;
use crate::sim::reference::parabola;
use crate::sim::{Bodies, BodyInit, IntegratorKind};
use std::time::Instant;

/// One row of `trade.csv` (column order is the file's, see the module doc of [`crate::trade`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TradeRow {
    pub integrator: String,
    pub dt: f64,
    pub ns_per_body_step: f64,
    pub pos_err: f64,
    pub rot_err: f64,
    pub energy_err_max: f64,
    pub momentum_err: f64,
    pub energy_drift_per_s: f64,
}

impl TradeRow {
    /// Wall time per simulated second per body, s.
    pub fn cost_secs_per_sim_sec(&self) -> f64 {
        self.ns_per_body_step * 1e-9 / self.dt
    }
}

/// `E(t) - E(0)` of the scene, J, sampled over the drift horizon (at most [`SERIES_POINTS`]).
#[derive(Debug, Clone, PartialEq)]
pub struct EnergySeries {
    pub integrator: String,
    pub dt: f64,
    /// `(t, E(t) - E(0))`, s and J.
    pub points: Vec<(f64, f64)>,
}

/// Most points kept per energy series.
pub const SERIES_POINTS: u64 = 2000;

/// Shortest timed sample; shorter runs are repeated within one sample, s.
const MIN_SAMPLE_SECS: f64 = 0.002;

fn total_energy(bodies: &Bodies, g: &Loads) -> f64 {
    (0..bodies.len()).map(|i| bodies.energy(i, g)).sum()
}

/// Number of steps of size `dt` in `secs` (callers check that `dt` divides it).
pub fn steps_in(secs: f64, dt: f64) -> u64 {
    (secs / dt).round() as u64
}

/// Seconds to step `init` `steps` steps on `threads` threads, split as `simulate --threads`
/// splits it ([`crate::bench::time_simulation`]: a [`crate::simulation::Simulation`] with no
/// sinks, the guard after every step, the threads meeting every
/// [`crate::bench::WINDOW_STEPS`] steps, a 100 Hz recording at 1 ms); NaN when it cannot run.
fn timed_partitions(
    init: &[BodyInit],
    kind: IntegratorKind,
    dt: f64,
    variational: &VariationalSettings,
    loads: &Loads,
    steps: u64,
    threads: usize,
) -> f64 {
    let run = crate::bench::TimedRun {
        kind,
        dt_secs: dt,
        variational,
        gravity: *loads.gravity(),
        threads,
        steps,
    };
    // A bare batch of free bodies: a world with no layout and no mechanisms.
    match crate::bench::time_simulation(&crate::world::World::default(), init, &run) {
        Ok(timed) => timed.secs,
        Err(_) => f64::NAN,
    }
}

/// Measures `kind` at step `dt` on the bodies `init` (see the module doc of [`crate::trade`]).
pub fn measure(
    init: &[BodyInit],
    kind: IntegratorKind,
    dt: f64,
    variational: &VariationalSettings,
    loads: &Loads,
    settings: &TradeSettings,
    reference: &Reference,
) -> (TradeRow, EnergySeries) {
    let steps = steps_in(settings.duration_secs, dt);
    let t_end = steps as f64 * dt;
    let start = Bodies::new(init);

    // Errors over the measurement horizon. The integrator is stepped directly, not through a
    // `Simulation`: every step is compared, and with no guard a diverging run reports NaN.
    let mut bodies = start.clone();
    let mut integrator = kind.build(dt, variational);
    integrator.init(&bodies);
    let e0 = total_energy(&bodies, loads);
    let l0: Vec<_> = (0..bodies.len()).map(|i| bodies.angmom_world(i)).collect();
    let mut energy_err_max: f64 = 0.0;
    let mut momentum_err: f64 = 0.0;
    for _ in 0..steps {
        integrator.step(&mut bodies, loads);
        energy_err_max = worst(energy_err_max, (total_energy(&bodies, loads) - e0).abs());
        for (i, l0) in l0.iter().enumerate() {
            momentum_err = worst(momentum_err, (bodies.angmom_world(i) - l0).norm());
        }
    }
    let mut pos_err: f64 = 0.0;
    let mut rot_err: f64 = 0.0;
    for (i, b) in init.iter().enumerate() {
        let (c_exact, _) = parabola(
            &b.world_from_body.translation.vector,
            &b.linvel_world,
            loads,
            t_end,
        );
        pos_err = worst(pos_err, (bodies.com_world[i] - c_exact).norm());
        rot_err = worst(
            rot_err,
            rotation_error(&bodies.world_from_body[i], &reference.world_from_body[i]),
        );
    }

    // Energy drift over the long horizon: least-squares slope of E(t) - E(0) against t.
    let drift_steps = steps_in(settings.drift_horizon_secs, dt);
    let every = drift_steps.div_ceil(SERIES_POINTS).max(1);
    let mut bodies = start.clone();
    let mut integrator = kind.build(dt, variational);
    integrator.init(&bodies);
    let mut fit = LineFit::default();
    let mut points = vec![(0.0, 0.0)];
    for k in 1..=drift_steps {
        integrator.step(&mut bodies, loads);
        let t = k as f64 * dt;
        let de = total_energy(&bodies, loads) - e0;
        fit.add(t, de);
        if k % every == 0 || k == drift_steps {
            points.push((t, de));
        }
    }

    // Cost: the bare stepping loop, repeated; median of the samples.
    let parts = crate::sim::partition::partition_count(init.len(), settings.threads);
    let ns_per_body_step = timed_median(settings.repeats, steps, init.len(), &mut || {
        if parts > 1 {
            timed_partitions(init, kind, dt, variational, loads, steps, settings.threads)
        } else {
            // The bare step (no guard, one thread): what the column times.
            let mut bodies = start.clone();
            let mut integrator = kind.build(dt, variational);
            integrator.init(&bodies);
            let started = Instant::now();
            for _ in 0..steps {
                integrator.step(&mut bodies, loads);
            }
            std::hint::black_box(&bodies);
            started.elapsed().as_secs_f64()
        }
    });
    let row = TradeRow {
        integrator: kind.name().to_string(),
        dt,
        ns_per_body_step,
        pos_err,
        rot_err,
        energy_err_max,
        momentum_err,
        energy_drift_per_s: fit.slope(),
    };
    let series = EnergySeries {
        integrator: kind.name().to_string(),
        dt,
        points,
    };
    (row, series)
}

/// Median over `repeats` samples of the wall time per body-step, ns, of `run_once` (one run of
/// `steps` steps of `bodies` bodies, returning its seconds). A run shorter than
/// [`MIN_SAMPLE_SECS`] is repeated within one sample until the sample is long enough to time.
pub fn timed_median(
    repeats: usize,
    steps: u64,
    bodies: usize,
    run_once: &mut dyn FnMut() -> f64,
) -> f64 {
    let mut samples = Vec::with_capacity(repeats);
    let mut runs_per_sample = 1u32;
    while samples.len() < repeats.max(1) {
        let mut elapsed = 0.0;
        for _ in 0..runs_per_sample {
            elapsed += run_once();
        }
        if elapsed < MIN_SAMPLE_SECS && runs_per_sample < 1 << 20 {
            // Too short to time reliably: lengthen the sample and start over.
            runs_per_sample =
                (runs_per_sample * 2).max((MIN_SAMPLE_SECS / elapsed.max(1e-9)) as u32);
            samples.clear();
            continue;
        }
        let body_steps = f64::from(runs_per_sample) * steps.max(1) as f64 * bodies.max(1) as f64;
        samples.push(elapsed * 1e9 / body_steps);
    }
    median(&mut samples)
}

/// The larger error, where a non-finite error (a run that diverged) wins and stays: `f64::max`
/// would silently drop a NaN.
pub(crate) fn worst(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// Online least-squares line `y = a + b t`.
#[derive(Debug, Clone, Copy, Default)]
pub struct LineFit {
    n: f64,
    st: f64,
    sy: f64,
    stt: f64,
    sty: f64,
}

impl LineFit {
    pub fn add(&mut self, t: f64, y: f64) {
        self.n += 1.0;
        self.st += t;
        self.sy += y;
        self.stt += t * t;
        self.sty += t * y;
    }

    /// `b = (n Σty - Σt Σy) / (n Σt² - (Σt)²)`; 0 with fewer than two points.
    pub fn slope(&self) -> f64 {
        let d = self.n * self.stt - self.st * self.st;
        if self.n < 2.0 || d == 0.0 {
            0.0
        } else {
            (self.n * self.sty - self.st * self.sy) / d
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_fit_recovers_a_line_and_median_is_the_middle() {
        let mut fit = LineFit::default();
        for k in 0..100 {
            let t = k as f64 * 0.1;
            fit.add(t, 3.0 - 0.25 * t);
        }
        // Exact data: round-off only (measured 1e-16).
        assert!((fit.slope() + 0.25).abs() < 1e-12, "{}", fit.slope());
        assert_eq!(median(&mut [5.0, 1.0, 3.0]), 3.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
    }
}
