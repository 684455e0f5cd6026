//! One cell of the stability map: one body, one integrator, guarded like `tumble simulate`.

use super::{Cell, Row, Status};
use crate::sim::guard::{Cause, DEFAULT_DIVERGENCE_ENERGY_RATIO};
use crate::sim::integrators::VariationalSettings;
use crate::sim::limits::ENERGY_ERROR_BOUND;
use crate::sim::{BodyInit, IntegratorKind, RunSettings};
use crate::simulation::{Inits, Progress, Simulation};
use crate::world::World;
use nalgebra::{Isometry3, Vector3};

/// The cell's body: `J` of its shape, at rest in position, `Ω_0` = [`Cell::angvel_body`]
/// (body frame = world frame at `t = 0`).
pub fn body_init(cell: &Cell) -> BodyInit {
    BodyInit {
        mass: 1.0,
        principal_moments: cell.shape.moments(),
        world_from_body: Isometry3::identity(),
        linvel_world: Vector3::zeros(),
        angvel_world: cell.angvel_body(),
    }
}

/// Runs `kind` with its default settings on `cell` for [`Cell::steps`] steps with `dt` =
/// `h_omega` s and no gravity, stopping where the guard of [`crate::sim::guard`] stops a run
/// (a [`Simulation`] of the one body, stepped one step at a time: every step's energy is
/// measured). Never panics on a bad state: NaN and overflow end up in the row's status.
pub fn run_cell(kind: IntegratorKind, cell: Cell) -> Row {
    let settings = VariationalSettings::default();
    let steps = cell.steps();
    let run = RunSettings {
        steps,
        log_every: steps,
        gravity: Vector3::zeros(),
        divergence_energy_ratio: DEFAULT_DIVERGENCE_ENERGY_RATIO,
        stop_on_newton_failure: settings.substep.then_some(settings.max_substeps),
        stop_on_interrupt: false,
        quiet: true,
    };
    let mut row = Row {
        integrator: kind,
        cell,
        steps,
        steps_done: steps,
        newton_iters_max: 0,
        substeps: 0,
        substep_factor_max: 0,
        energy_err_max: 0.0,
        status: Status::Ok,
    };
    // One free body: a world with no layout, the body given as the initial state.
    let mut sim = match Simulation::new(
        &World::default(),
        Inits::Owned(vec![body_init(&cell)]),
        &|_| Ok(kind.build(cell.h_omega, &settings)),
        1,
        &run,
    ) {
        Ok(sim) => sim,
        Err(e) => unreachable!("one free body, one integrator: {e}"),
    };
    let energy = |sim: &Simulation| {
        let (bodies, j) = sim.partitions().body(0);
        bodies.rotational_energy(j)
    };
    let energy_0 = energy(&sim);
    let relative_error = |t: f64| (t - energy_0).abs() / energy_0;
    loop {
        // Without sinks `advance` has no write to fail.
        let Ok(progress) = sim.advance(1) else { break };
        if progress == Progress::Stopped {
            break;
        }
        row.energy_err_max = row.energy_err_max.max(relative_error(energy(&sim)));
        if progress != Progress::Running {
            break;
        }
    }
    let summary = sim.summary();
    row.newton_iters_max = summary.stats.newton_iters_max;
    row.substeps = u64::from(summary.stats.substepped);
    row.substep_factor_max = summary.stats.substep_factor_max;
    if let Some(stop) = summary.stopped {
        row.steps_done = stop.step - 1;
        row.status = match stop.cause {
            // The unconverged step's state is not a result: keep the error so far.
            Cause::NewtonFailed { .. } => Status::NewtonFailed,
            Cause::NonFinite { .. }
            | Cause::OutOfRange { .. }
            | Cause::EnergyGrowth { .. }
            | Cause::MechanismEnergyGrowth { .. } => {
                let t = energy(&sim);
                row.energy_err_max = if t.is_finite() {
                    row.energy_err_max.max(relative_error(t))
                } else {
                    f64::INFINITY
                };
                Status::Diverged
            }
        };
        return row;
    }
    row.status = if row.substeps > 0 {
        Status::Substepped
    } else if row.energy_err_max > ENERGY_ERROR_BOUND {
        Status::Inaccurate
    } else {
        Status::Ok
    };
    row
}
