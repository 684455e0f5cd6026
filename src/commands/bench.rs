//! `tumble bench`: the cost of the bare step, no recording.
//!
//! - `tumble bench --bodies N --steps K --integrator NAME [--threads T]`: steps N differently
//!   initialised free bodies K steps; the last line is `ns_per_body_step=<median>` (wall time
//!   per body-step on T threads). With T threads the batch is split as `simulate --threads T`
//!   splits it ([`crate::sim::partition`]), the run guard checks every step, and the threads
//!   meet every [`crate::bench::WINDOW_STEPS`] steps (a run recorded at 100 Hz with dt = 1 ms); with T > 1
//!   the same is timed on one thread too and the line `scaling 1 -> T threads: S x` printed
//!   before the last.
//! - `tumble bench --scene SCENE.toml [--steps K] [--integrator NAME] [--dt DT]`: steps any
//!   scene (articulated models included) with its own integrator and step unless given; the
//!   last two lines are `ns_per_step=<median>` (one step of the whole scene) and
//!   `ns_per_body_step=<median>` (that over the scene's bodies): the integrator alone on one
//!   thread, or with T > 1 threads the batch cut as `simulate --threads T` cuts it, timed
//!   against the same guarded, windowed stepping on one thread (one partition), the two taking
//!   turns, and the line `scaling 1 -> T threads: S x` printed before them. With `--errors-over SECS`, an
//!   untimed run of SECS first prints `energy_err_max=` (largest `|E − E₀|/|E₀|` of the
//!   reported energy, every step), `momentum_err_max=` (largest relative change of the
//!   conserved angular momenta: free bodies', floating models' totals about their centre of
//!   mass; `nan` when nothing is conserved) and `linear_momentum_err_max=` (floating models'
//!   total linear momentum, without gravity), for side-by-side comparisons
//!   (`scripts/bench_mechanism.sh`).

use crate::bench::median;
use crate::bench::{TimedRun, measure_errors, partitioning, time_simulation, time_steps};
use crate::scene::Scene;
use crate::sim::Bodies;
use crate::sim::IntegratorKind;
use crate::sim::partition::{partition_count, stepping_threads};
use crate::sim::workload::free_body_batch;
use crate::world::World;
use anyhow::bail;
use nalgebra::Vector3;
use std::path::PathBuf;

#[derive(clap::Args, Debug, Clone)]
pub struct BenchArgs {
    /// Number of bodies in the synthetic free-body batch (ignored with --scene).
    #[arg(long, default_value_t = 10_000)]
    pub bodies: usize,
    /// Time this scene's step instead of the synthetic batch.
    #[arg(long, value_name = "SCENE.toml")]
    pub scene: Option<PathBuf>,
    /// With --scene: also read mesh files from DIR (repeatable). By default a mesh is read only
    /// when its real path (links resolved) is inside the URDF's folder (its parent for a folder
    /// named urdf, or the ROS package holding it), a package path, ROS_PACKAGE_PATH or the scene's
    /// folder; any other is refused (exit 2). Adds to every [[model]]'s allow_mesh_paths.
    #[arg(long = "allow-mesh-path", value_name = "DIR", requires = "scene")]
    pub allow_mesh_paths: Vec<PathBuf>,
    /// Steps per timed run.
    #[arg(long, default_value_t = 1000)]
    pub steps: u64,
    /// Integrator name (default: the scene's, else variational).
    #[arg(long)]
    pub integrator: Option<String>,
    /// Step size, s (default: the scene's, else 0.001).
    #[arg(long)]
    pub dt: Option<f64>,
    /// Timed runs; the median is printed last.
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
    /// With --scene: first measure the energy and momentum errors over this many seconds
    /// (untimed).
    #[arg(long, value_name = "SECS")]
    pub errors_over: Option<f64>,
    /// Stepping threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Run even when the estimated computing time exceeds 7 days (memory is always checked).
    #[arg(long)]
    pub allow_huge: bool,
}

fn integrator_kind(name: &str) -> anyhow::Result<IntegratorKind> {
    IntegratorKind::from_name(name).ok_or_else(|| {
        let names: Vec<_> = IntegratorKind::ALL.iter().map(|k| k.name()).collect();
        anyhow::anyhow!(
            "--integrator: unknown integrator {name:?} (expected one of: {})",
            names.join(", ")
        )
    })
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    if args.steps == 0 || args.repeats == 0 || (args.scene.is_none() && args.bodies == 0) {
        bail!("--bodies, --steps and --repeats must be at least 1");
    }
    if let Some(dt) = args.dt
        && !(dt.is_finite() && dt > 0.0)
    {
        bail!("--dt must be a positive number of seconds (got {dt})");
    }
    match &args.scene {
        Some(path) => run_scene(args, path),
        None => run_batch(args),
    }
}

fn run_batch(args: &BenchArgs) -> anyhow::Result<()> {
    let name = args.integrator.as_deref().unwrap_or("variational");
    let kind = integrator_kind(name)?;
    let dt = args.dt.unwrap_or(0.001);
    crate::budget::Estimate::run(
        args.bodies as f64,
        0.0,
        args.steps as f64 * args.repeats as f64,
        None,
    )
    .check(args.allow_huge)?;
    // A batch too small for several partitions steps on one thread: nothing to scale.
    let asked = crate::commands::simulate::thread_count(args.threads)?;
    let threads = stepping_threads(partition_count(args.bodies, asked), asked);
    let inits = free_body_batch(args.bodies);
    let settings = Default::default();
    // A bare batch of free bodies: a world with no layout and no mechanisms, the bodies given
    // as the initial states.
    let world = World::default();
    let counts: Vec<usize> = if threads > 1 {
        vec![1, threads]
    } else {
        vec![1]
    };
    for &t in &counts {
        let parts = partition_count(args.bodies, t);
        println!(
            "{} x {} steps of {} bodies ({}, dt = {} s), no recording, {t} thread{} ({parts} partition{}), vector unit {} (TUMBLE_SIMD caps it)",
            args.repeats,
            args.steps,
            args.bodies,
            name,
            dt,
            if t == 1 { "" } else { "s" },
            if parts == 1 { "" } else { "s" },
            crate::sim::simd::active().name(),
        );
    }
    // The thread counts take turns, run after run, so that a slow spell of the (shared) machine
    // falls on both alike.
    let mut samples = vec![Vec::with_capacity(args.repeats); counts.len()];
    for r in 0..args.repeats {
        for (c, &t) in counts.iter().enumerate() {
            let run = TimedRun {
                kind,
                dt_secs: dt,
                variational: &settings,
                gravity: Vector3::new(0.0, 0.0, -9.81),
                threads: t,
                steps: args.steps,
            };
            let timed = time_simulation(&world, &inits, &run)?;
            let (ns, failures) = (timed.ns_per_step / args.bodies as f64, timed.failures);
            println!(
                "run {} ({t} thread{}): {ns:.2} ns per body-step ({failures} non-converged solves)",
                r + 1,
                if t == 1 { "" } else { "s" },
            );
            samples[c].push(ns);
        }
    }
    let best: Vec<f64> = samples
        .iter()
        .map(|s| s.iter().copied().fold(f64::INFINITY, f64::min))
        .collect();
    let medians: Vec<f64> = samples.iter_mut().map(|s| median(s)).collect();
    if let ([one, many], [best_one, best_many]) = (&medians[..], &best[..]) {
        println!(
            "best runs: 1 thread={best_one:.2} {threads} threads={best_many:.2}; best-run scaling {:.2}x",
            best_one / best_many
        );
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

fn run_scene(args: &BenchArgs, path: &std::path::Path) -> anyhow::Result<()> {
    let mut scene = Scene::load(path)?;
    scene.allow_mesh_paths(&args.allow_mesh_paths)?;
    scene.apply(&crate::scene::SimOverrides {
        integrator: args.integrator.clone(),
        dt: args.dt,
        ..Default::default()
    })?;
    let kind = scene.integrator();
    let dt = scene.sim.dt;
    let settings = scene.variational_settings();
    let world = scene.build()?;
    crate::scene::refuse_contact(&scene, &world, "bench --scene")?;
    let bodies = world.bodies.len();
    crate::budget::Estimate::run(
        bodies as f64,
        0.0,
        args.steps as f64 * args.repeats as f64,
        None,
    )
    .check(args.allow_huge)?;
    let loads = world.loads(scene.gravity());
    let start = Bodies::new(&world.bodies);
    let make = || world.integrator(kind, dt, &settings);
    make()?;
    println!(
        "{} x {} steps of {} ({bodies} bodies, {} articulated models, {}, dt = {dt} s), no recording, vector unit {} (TUMBLE_SIMD caps it)",
        args.repeats,
        args.steps,
        path.display(),
        world.mechanisms.len(),
        kind.name(),
        crate::sim::simd::active().name(),
    );
    if let Some(secs) = args.errors_over {
        if !(secs.is_finite() && secs > 0.0) {
            bail!("--errors-over must be a positive number of seconds (got {secs})");
        }
        let errors = measure_errors(&world, &make, &loads, dt, secs)?;
        println!("errors over {secs} s ({} steps):", errors.steps);
        println!("energy_err_max={:e}", errors.energy);
        println!("momentum_err_max={:e}", errors.angular);
        println!("linear_momentum_err_max={:e}", errors.linear);
    }
    let ns = time_steps(
        &start,
        &make,
        &loads,
        args.steps,
        args.repeats,
        &mut |r, ns, failures| {
            println!(
                "run {}: {ns:.1} ns per step, {:.2} ns per body-step ({failures} non-converged solves)",
                r + 1,
                ns / bodies as f64
            )
        },
    )?;
    // On several threads: the batch cut between mechanisms as `simulate --threads` cuts it,
    // and, for the scaling, the same run on one thread (one partition, as `simulate --threads
    // 1` steps it: the guard after every step, the meetings every window), the two thread
    // counts taking turns run after run so that a slow spell of the shared machine falls on
    // both alike. The scaling compares the same work: the runs above time the integrator
    // alone, without the guard that every simulated step pays.
    let threads = crate::commands::simulate::thread_count(args.threads)?;
    let (parts, used) = partitioning(&world, threads);
    let ns = if parts > 1 {
        println!(
            "{} x {} steps, 1 thread (1 partition) and {used} threads ({parts} partitions, cut \
             between mechanisms), taking turns, the guard checking every step",
            args.repeats, args.steps
        );
        let mut samples = [
            Vec::with_capacity(args.repeats),
            Vec::with_capacity(args.repeats),
        ];
        for r in 0..args.repeats {
            for (c, t) in [1, used].into_iter().enumerate() {
                // `threads` cuts the batch as `simulate --threads` does, stepped on `used`.
                let run = TimedRun {
                    kind,
                    dt_secs: dt,
                    variational: &settings,
                    gravity: scene.gravity(),
                    threads: if t == 1 { 1 } else { threads },
                    steps: args.steps,
                };
                let timed = time_simulation(&world, &world.bodies, &run)?;
                let (ns, failures) = (timed.ns_per_step, timed.failures);
                println!(
                    "run {} ({t} thread{}): {ns:.1} ns per step, {:.2} ns per body-step \
                     ({failures} non-converged solves)",
                    r + 1,
                    if t == 1 { "" } else { "s" },
                    ns / bodies as f64
                );
                samples[c].push(ns);
            }
        }
        let best = samples
            .each_ref()
            .map(|s| s.iter().copied().fold(f64::INFINITY, f64::min));
        let [one, many] = samples.map(|mut s| median(&mut s));
        println!(
            "best runs: 1 thread={:.1} {used} threads={:.1}; best-run scaling {:.2}x",
            best[0],
            best[1],
            best[0] / best[1]
        );
        println!(
            "ns_per_step 1 thread={one:.1} {used} threads={many:.1}; scaling 1 -> {used} threads: {:.2}x",
            one / many
        );
        many
    } else {
        ns
    };
    println!("ns_per_step={ns:.1}");
    println!("ns_per_body_step={:.2}", ns / bodies as f64);
    Ok(())
}
