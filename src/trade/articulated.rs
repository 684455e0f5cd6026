//! `tumble trade` on a scene with articulated models (`bodies = "articulated"`).
//!
//! Only the variational family steps mechanisms ([`SUPPORTED`]); the other integrators of the
//! list are skipped with one line each saying why (or refused, when the user named them:
//! [`crate::trade::run`]). The columns keep their meaning, measured on the *reported* states
//! (momenta projected onto the velocity constraints, [`crate::sim::mechanism::project`]):
//!
//! - `pos_err`, `rot_err`: the largest distance of any body's centre of mass, and the largest
//!   rotation angle of any body's orientation, from the [`reference`] at the end of the horizon
//!   (no closed form exists for a double pendulum; the reference replaces the free-body
//!   parabola for every body of the scene, free bodies included);
//! - `energy_err_max`: largest `|E(t) − E(0)|` of the scene's reported energy, J, every step;
//! - `momentum_err`: largest `|L(t) − L(0)|` of the conserved angular momenta, kg m²/s: every
//!   free body's about its centre of mass and every floating model's total about the model's
//!   centre of mass ([`crate::simulation::FrameBuilder::conserved_angmom`]); `NaN` when the scene
//!   conserves none (fixed-base models only: the world holds them);
//! - `ns_per_body_step`: one bare step of the whole scene on one thread (a mechanism's bodies
//!   are coupled by its rows), divided by the number of bodies.
//!
//! # The reference
//!
//! `variational6` (Yoshida's solution A on the constrained step, order 6, measured in
//! `tests/mechanism/mechanism.rs`) at `h_ref = h_min / REFERENCE_REFINEMENT` (rounded so that it divides
//! the horizon) and at `h_ref / 2`; the finer run is the reference, and Richardson's estimate of
//! its own error for an order-6 method is `|x(h_ref) − x(h_ref/2)| / (2⁶ − 1)` (reported as
//! `own_error_m` and `own_error_rad`). It is the same scheme family as the measured runs (the
//! constrained step is the only one with these constraints), at a higher order and a 4x finer
//! step than the finest measured one; its error must sit well below the measured ones for
//! those to be resolved, which the report lets the user check.

use super::TradeSettings;
use super::measure::{
    EnergySeries, LineFit, SERIES_POINTS, TradeRow, steps_in, timed_median, worst,
};
use super::reference::{Reference, rotation_error};
use crate::sim::Loads;
use crate::sim::integrators::VariationalSettings;
use crate::sim::mechanism::stepper::SUPPORTED;
use crate::sim::{Bodies, IntegratorKind};
use crate::simulation::FrameBuilder;
use crate::world::World;
use nalgebra::Vector3;
use std::time::Instant;

/// The reference step is the finest measured step divided by this.
pub const REFERENCE_REFINEMENT: f64 = 4.0;

/// Why `kind` has no row on an articulated scene, or `None` when it steps mechanisms.
pub fn skip_reason(kind: IntegratorKind, world: &World) -> Option<String> {
    if SUPPORTED.contains(&kind) {
        return None;
    }
    let model = world
        .mechanisms
        .first()
        .map(|m| m.name.as_str())
        .unwrap_or_default();
    Some(format!(
        "skipped {}: model `{model}` is articulated (bodies = \"articulated\"), which only the variational family steps ({})",
        kind.name(),
        SUPPORTED.map(|k| k.name()).join(", ")
    ))
}

/// The state at `t_end_secs` after `steps` steps of `kind`.
fn run_to_end(
    world: &World,
    kind: IntegratorKind,
    steps: u64,
    t_end_secs: f64,
    variational: &VariationalSettings,
    loads: &Loads,
) -> anyhow::Result<Bodies> {
    let mut bodies = Bodies::new(&world.bodies);
    let dt = t_end_secs / steps as f64;
    let mut integrator = world.integrator(kind, dt, variational)?;
    integrator.init(&bodies);
    let mut loads = loads.clone();
    for k in 0..steps {
        loads.set_time(k as f64 * dt);
        integrator.step(&mut bodies, &loads);
    }
    Ok(bodies)
}

/// The reference of an articulated scene (see the module doc).
pub fn reference(
    world: &World,
    variational: &VariationalSettings,
    loads: &Loads,
    t_end_secs: f64,
    finest_dt_secs: f64,
) -> anyhow::Result<Reference> {
    let kind = IntegratorKind::Variational6;
    let coarse_steps = (t_end_secs / (finest_dt_secs / REFERENCE_REFINEMENT))
        .ceil()
        .max(1.0) as u64;
    let coarse = run_to_end(world, kind, coarse_steps, t_end_secs, variational, loads)?;
    let fine = run_to_end(
        world,
        kind,
        2 * coarse_steps,
        t_end_secs,
        variational,
        loads,
    )?;
    let richardson = 1.0 / (2f64.powi(6) - 1.0);
    let mut own_error_m: f64 = 0.0;
    let mut own_error_rad: f64 = 0.0;
    for i in 0..fine.len() {
        own_error_m = worst(
            own_error_m,
            (coarse.com_world[i] - fine.com_world[i]).norm() * richardson,
        );
        own_error_rad = worst(
            own_error_rad,
            rotation_error(&coarse.world_from_body[i], &fine.world_from_body[i]) * richardson,
        );
    }
    let dt_fine = t_end_secs / (2 * coarse_steps) as f64;
    Ok(Reference {
        world_from_body: fine.world_from_body.clone(),
        com_world: Some(fine.com_world.clone()),
        t_end_secs,
        own_error_rad,
        own_error_m,
        method: format!(
            "{} (constrained step) at dt = {:.3e} s and twice that, Richardson error estimate",
            kind.name(),
            dt_fine
        ),
    })
}

/// What the inputs did so far: the work of the loads and actuators less the dissipation, J
/// (zero without inputs), the term the energy balance subtracts from `E(t) − E(0)`.
fn inputs(integrator: &dyn crate::sim::Integrator) -> f64 {
    let flow = integrator.energy_flow();
    flow.input_work - flow.dissipated
}

/// Reported energy of the last frame and the conserved angular momenta, after building the
/// frame of `step`.
fn observe(
    frames: &mut FrameBuilder,
    bodies: &Bodies,
    loads: &Loads,
    step: u64,
    dt: f64,
    angmom: &mut Vec<Vector3<f64>>,
) -> f64 {
    frames.frame(bodies, loads, step, dt);
    frames.conserved_angmom(angmom, &|_| false);
    frames.total_energy()
}

/// Measures `kind` (one of [`SUPPORTED`]) at step `dt` on `world` (see the module doc).
pub fn measure(
    world: &World,
    kind: IntegratorKind,
    dt: f64,
    variational: &VariationalSettings,
    loads: &Loads,
    settings: &TradeSettings,
    reference: &Reference,
) -> anyhow::Result<(TradeRow, EnergySeries)> {
    let steps = steps_in(settings.duration_secs, dt);
    let start = Bodies::new(&world.bodies);
    let mut frames = FrameBuilder::new(world);
    frames.set_quiet(true);
    let (mut l0, mut l) = (Vec::new(), Vec::new());

    // Errors over the measurement horizon, on the reported states. Stepped directly, not
    // through a `Simulation`: every step's frame is compared, and with no guard a diverging
    // run reports NaN.
    let mut bodies = start.clone();
    let mut integrator = world.integrator(kind, dt, variational)?;
    integrator.init(&bodies);
    let mut loads = loads.clone();
    let e0 = observe(&mut frames, &bodies, &loads, 0, dt, &mut l0);
    let mut energy_err_max: f64 = 0.0;
    // Applied loads change the momenta: nothing is conserved to measure.
    let conserved = !l0.is_empty() && world.body_loads.is_empty();
    let mut momentum_err: f64 = if conserved { 0.0 } else { f64::NAN };
    for k in 1..=steps {
        loads.set_time((k - 1) as f64 * dt);
        integrator.step(&mut bodies, &loads);
        loads.set_time(k as f64 * dt);
        // The energy balance's residual: E(t) − E(0) less what the inputs did.
        let e = observe(&mut frames, &bodies, &loads, k, dt, &mut l) - inputs(&*integrator);
        energy_err_max = worst(energy_err_max, (e - e0).abs());
        for (a, b) in l.iter().zip(&l0).filter(|_| conserved) {
            momentum_err = worst(momentum_err, (a - b).norm());
        }
    }
    let com_ref = reference.com_world.as_deref().unwrap_or_default();
    let mut pos_err: f64 = 0.0;
    let mut rot_err: f64 = 0.0;
    for i in 0..bodies.len() {
        pos_err = worst(pos_err, (bodies.com_world[i] - com_ref[i]).norm());
        rot_err = worst(
            rot_err,
            rotation_error(&bodies.world_from_body[i], &reference.world_from_body[i]),
        );
    }

    // Energy drift over the long horizon.
    let drift_steps = steps_in(settings.drift_horizon_secs, dt);
    let every = drift_steps.div_ceil(SERIES_POINTS).max(1);
    let mut bodies = start.clone();
    let mut integrator = world.integrator(kind, dt, variational)?;
    integrator.init(&bodies);
    let mut fit = LineFit::default();
    let mut points = vec![(0.0, 0.0)];
    for k in 1..=drift_steps {
        loads.set_time((k - 1) as f64 * dt);
        integrator.step(&mut bodies, &loads);
        let t = k as f64 * dt;
        loads.set_time(t);
        let de = observe(&mut frames, &bodies, &loads, k, dt, &mut l) - inputs(&*integrator) - e0;
        fit.add(t, de);
        if k % every == 0 || k == drift_steps {
            points.push((t, de));
        }
    }

    // Cost: the bare stepping loop of the whole scene (no guard, no frames: what the column
    // times).
    let mut failed = None;
    let ns_per_body_step = timed_median(settings.repeats, steps, world.bodies.len(), &mut || {
        let mut bodies = start.clone();
        let mut integrator = match world.integrator(kind, dt, variational) {
            Ok(i) => i,
            Err(e) => {
                failed = Some(e);
                return f64::NAN;
            }
        };
        integrator.init(&bodies);
        let mut loads = loads.clone();
        let started = Instant::now();
        for k in 0..steps {
            loads.set_time(k as f64 * dt);
            integrator.step(&mut bodies, &loads);
        }
        std::hint::black_box(&bodies);
        started.elapsed().as_secs_f64()
    });
    if let Some(e) = failed {
        return Err(e);
    }
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
    Ok((row, series))
}
