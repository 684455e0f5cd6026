//! `tumble bench --bodies N --steps K --integrator NAME`: steps N differently initialised bodies
//! K steps with no recording and prints the cost; the last line is `ns_per_body_step=<median>`.

use crate::sim::workload::free_body_batch;
use crate::sim::{Bodies, IntegratorKind};
use crate::trade::measure::median;
use anyhow::bail;
use nalgebra::Vector3;
use std::time::Instant;

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
    let start = Bodies::new(&free_body_batch(args.bodies));
    let gravity = Vector3::new(0.0, 0.0, -9.81);
    let settings = Default::default();
    println!(
        "{} x {} steps of {} bodies ({}, dt = {} s), no recording",
        args.repeats, args.steps, args.bodies, args.integrator, args.dt
    );
    let mut samples = Vec::with_capacity(args.repeats);
    for r in 0..args.repeats {
        let mut bodies = start.clone();
        let mut integrator = kind.build(args.dt, &settings);
        integrator.init(&bodies);
        let started = Instant::now();
        let mut failures = 0u64;
        for _ in 0..args.steps {
            failures += u64::from(integrator.step(&mut bodies, &gravity).newton_failures);
        }
        let ns = started.elapsed().as_secs_f64() * 1e9 / (args.steps as f64 * args.bodies as f64);
        std::hint::black_box(&bodies);
        println!(
            "run {}: {ns:.2} ns per body-step ({failures} non-converged solves)",
            r + 1
        );
        samples.push(ns);
    }
    println!("ns_per_body_step={:.2}", median(&mut samples));
    Ok(())
}
