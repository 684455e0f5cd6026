//! One cell of the stability map: one body, one integrator, guarded like `tumble simulate`.

use super::{Cell, Row, Status};
use crate::sim::Loads;
use crate::sim::guard::{Cause, DEFAULT_DIVERGENCE_ENERGY_RATIO, Guard};
use crate::sim::integrators::VariationalSettings;
use crate::sim::limits::ENERGY_ERROR_BOUND;
use crate::sim::{Bodies, BodyInit, IntegratorKind};
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
/// `h_omega` s and no gravity, stopping where the guard of [`crate::sim::guard`] stops a run.
/// Never panics on a bad state: NaN and overflow end up in the row's status.
pub fn run_cell(kind: IntegratorKind, cell: Cell) -> Row {
    let settings = VariationalSettings::default();
    let mut bodies = Bodies::new(&[body_init(&cell)]);
    let mut integrator = kind.build(cell.h_omega, &settings);
    integrator.init(&bodies);
    let guard = Guard::new(
        &bodies,
        DEFAULT_DIVERGENCE_ENERGY_RATIO,
        settings.substep.then_some(settings.max_substeps),
    );
    let loads = Loads::none();
    let energy_0 = bodies.rotational_energy(0);
    let relative_error = |t: f64| (t - energy_0).abs() / energy_0;
    let steps = cell.steps();
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
    for step in 1..=steps {
        let stats = integrator.step(&mut bodies, &loads);
        row.newton_iters_max = row.newton_iters_max.max(stats.newton_iters_max);
        row.substeps += u64::from(stats.substepped);
        row.substep_factor_max = row.substep_factor_max.max(stats.substep_factor_max);
        if let Some(stop) = guard.check(&bodies, &stats, step) {
            row.steps_done = step - 1;
            row.status = match stop.cause {
                // The unconverged step's state is not a result: keep the error so far.
                Cause::NewtonFailed { .. } => Status::NewtonFailed,
                Cause::NonFinite { .. }
                | Cause::OutOfRange { .. }
                | Cause::EnergyGrowth { .. }
                | Cause::MechanismEnergyGrowth { .. } => {
                    let t = bodies.rotational_energy(0);
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
        row.energy_err_max = row
            .energy_err_max
            .max(relative_error(bodies.rotational_energy(0)));
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
