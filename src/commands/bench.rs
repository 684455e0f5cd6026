//! `tumble bench --bodies N --steps K --integrator NAME [--threads T]`: steps N differently
//! initialised bodies K steps with no recording and prints the cost; the last line is
//! `ns_per_body_step=<median>` (wall time per body-step on T threads).
//!
//! With T threads the batch is split as `simulate --threads T` splits it
//! ([`crate::sim::partition`]), the run guard checks every step, and the threads meet every
//! [`WINDOW_STEPS`] steps (a run recorded at 100 Hz with dt = 1 ms); with T > 1 the same is
//! timed on one thread too and the line `scaling 1 -> T threads: S x` printed before the last.

use crate::sim::IntegratorKind;
use crate::sim::partition::{Partitions, partition_count};
use crate::sim::workload::free_body_batch;
use crate::trade::measure::median;
use anyhow::bail;
use nalgebra::Vector3;
use std::time::Instant;

/// Steps between two meetings of the threads (a 100 Hz recording at dt = 1 ms).
pub const WINDOW_STEPS: u64 = 10;

#[derive(clap::Args, Debug, Clone)]
pub struct BenchArgs {
    /// Number of bodies in the batch.
    #[arg(long, default_value_t = 10_000)]
    pub bodies: usize,
    /// Steps per timed run.
    #[arg(long, default_value_t = 1000)]
    pub steps: u64,
    /// Integrator name.
    #[arg(long, default_value = "variational")]
    pub integrator: String,
    /// Step size, s.
    #[arg(long, default_value_t = 0.001)]
    pub dt: f64,
    /// Timed runs; the median is printed last.
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
    /// Stepping threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Run even when the estimated computing time exceeds 7 days (memory is always checked).
    #[arg(long)]
    pub allow_huge: bool,
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let Some(kind) = IntegratorKind::from_name(&args.integrator) else {
        let names: Vec<_> = IntegratorKind::ALL.iter().map(|k| k.name()).collect();
        bail!(
            "--integrator: unknown integrator {:?} (expected one of: {})",
            args.integrator,
            names.join(", ")
        );
    };
    if args.bodies == 0 || args.steps == 0 || args.repeats == 0 {
        bail!("--bodies, --steps and --repeats must be at least 1");
    }
    if !(args.dt.is_finite() && args.dt > 0.0) {
        bail!(
            "--dt must be a positive number of seconds (got {})",
            args.dt
        );
    }
    crate::budget::Estimate::run(
        args.bodies as f64,
        0.0,
        args.steps as f64 * args.repeats as f64,
        None,
    )
    .check(args.allow_huge)?;
    let threads = crate::commands::simulate::thread_count(args.threads)?;
    let inits = free_body_batch(args.bodies);
    let gravity = Vector3::new(0.0, 0.0, -9.81);
    let settings = Default::default();
    let mut medians = Vec::new();
    let counts: Vec<usize> = if threads > 1 {
        vec![1, threads]
    } else {
        vec![1]
    };
    for &t in &counts {
        let parts = partition_count(args.bodies, t);
        println!(
            "{} x {} steps of {} bodies ({}, dt = {} s), no recording, {t} thread{} ({parts} partition{})",
            args.repeats,
            args.steps,
            args.bodies,
            args.integrator,
            args.dt,
            if t == 1 { "" } else { "s" },
            if parts == 1 { "" } else { "s" },
        );
        let mut samples = Vec::with_capacity(args.repeats);
        for r in 0..args.repeats {
            let mut integrators: Vec<Box<dyn crate::sim::Integrator>> =
                (0..parts).map(|_| kind.build(args.dt, &settings)).collect();
            let borrowed: Vec<&mut dyn crate::sim::Integrator> = integrators
                .iter_mut()
                .map(|b| &mut **b as &mut dyn crate::sim::Integrator)
                .collect();
            let mut batch = Partitions::new(&inits, borrowed, f64::MAX, None)?;
            let started = Instant::now();
            let mut failures = 0u64;
            let mut step = 0;
            while step < args.steps {
                let end = (step + WINDOW_STEPS).min(args.steps);
                failures += u64::from(batch.advance(step, end, &gravity).stats.newton_failures);
                step = end;
            }
            let ns =
                started.elapsed().as_secs_f64() * 1e9 / (args.steps as f64 * args.bodies as f64);
            std::hint::black_box(&batch.parts);
            println!(
                "run {}: {ns:.2} ns per body-step ({failures} non-converged solves)",
                r + 1
            );
            samples.push(ns);
        }
        medians.push(median(&mut samples));
    }
    if let [one, many] = medians[..] {
        println!(
            "ns_per_body_step 1 thread={one:.2} {threads} threads={many:.2}; scaling 1 -> {threads} threads: {:.2}x",
            one / many
        );
    }
    println!(
        "ns_per_body_step={:.2}",
        medians.last().copied().unwrap_or(f64::NAN)
    );
    Ok(())
}
