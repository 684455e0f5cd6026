//! `tumble stability --scene SCENE.toml`: where each integrator stays accurate on one scene,
//! as a function of the step size alone.
//!
//! The dimensionless map of [`crate::stability`] is a property of one free body; a mechanism's
//! fastest motion depends on its masses, lengths and state, so a scene is mapped along `dt`
//! itself. Each row runs the scene for the horizon (its duration unless given) at one `dt`
//! under the run guard of [`crate::sim::guard`] with the scene's settings (mechanisms
//! watched), and measures on the *reported* states (projected momenta):
//!
//! `energy_err_max = max_k |r_k| / E_scale` with the energy balance's residual
//! `r_k = E_k − E_0 − (W_k − D_k + C_k)` (`W_k` the work the applied loads and actuators did up
//! to step `k`, `D_k` what damping, limits and friction took out, `C_k` contact's term:
//! [`crate::sim::integrators::EnergyFlow`]; all zero for a conservative scene, where `r_k` is the
//! energy error), so that a servo's work or a limit's dissipation is not counted as the
//! scheme's error; `E_scale = max_k max(T_k, |W_k|, D_k)` (the largest total kinetic energy
//! reached or energy exchanged with the inputs, whatever the potential's zero; `|E_0|`
//! when nothing moves), the largest joint gap (m) and axis misalignment (rad) of any
//! articulated model at any step, the Newton iterations and substeps, and a [`Status`] from
//! these, as for a map cell (`ok` needs `energy_err_max ≤` [`ENERGY_ERROR_BOUND`], no
//! substeps, no failure). The summary names, per integrator, the largest `dt` up to which every
//! row is `ok`.
//!
//! On a scene with articulated models only the variational family runs (the others are skipped
//! with one line, or refused when named). No heat map is drawn: one axis is a line, printed.

use super::Status;
use crate::record::Frame;
use crate::scene::Scene;
use crate::sim::guard::Cause;
use crate::sim::limits::ENERGY_ERROR_BOUND;
use crate::sim::{IntegratorKind, RunSettings};
use crate::simulation::{Progress, Simulation};
use crate::world::World;
use std::fmt::Write as _;

/// Default step sizes: the scene's `dt` times these.
pub const DT_FACTORS: [f64; 8] = [0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0];

/// The header of `stability_scene.csv` (a contract other tools read).
pub const CSV_HEADER: &str = "integrator,dt,steps,steps_done,newton_iters_max,substeps,substep_factor_max,energy_err_max,residual_m_max,residual_rad_max,status";

/// One integrator at one step size on the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneRow {
    pub integrator: IntegratorKind,
    pub dt: f64,
    pub steps: u64,
    pub steps_done: u64,
    pub newton_iters_max: u32,
    /// Body-steps split into substeps.
    pub substeps: u64,
    pub substep_factor_max: u32,
    /// See the module doc; `inf` for a state that went non-finite.
    pub energy_err_max: f64,
    /// Largest joint gap of any articulated model at any recorded step, m (0 without one).
    pub residual_m_max: f64,
    /// Largest joint axis misalignment, rad.
    pub residual_rad_max: f64,
    pub status: Status,
}

/// What the sweep measured.
#[derive(Debug, Clone)]
pub struct SceneMap {
    pub rows: Vec<SceneRow>,
    /// One line per integrator left out, saying why.
    pub skipped: Vec<String>,
}

/// Runs every integrator of `kinds` at every step of `dts` on `scene` for `duration_secs`.
/// On an articulated scene integrators outside the variational family are skipped, or refused
/// when `named` (the user listed them).
pub fn sweep(
    scene: &Scene,
    kinds: &[IntegratorKind],
    named: bool,
    dts: &[f64],
    duration_secs: f64,
    mut progress: impl FnMut(&SceneRow),
) -> anyhow::Result<SceneMap> {
    let world = scene.build()?;
    crate::scene::refuse_contact(scene, &world, "stability --scene")?;
    let mut skipped = Vec::new();
    let mut rows = Vec::new();
    for &kind in kinds {
        if !world.mechanisms.is_empty()
            && let Some(why) = crate::trade::articulated::skip_reason(kind, &world)
        {
            if named {
                world.integrator(kind, dts[0], &scene.variational_settings())?;
            }
            skipped.push(why);
            continue;
        }
        for &dt in dts {
            let row = run_row(scene, &world, kind, dt, duration_secs)?;
            progress(&row);
            rows.push(row);
        }
    }
    Ok(SceneMap { rows, skipped })
}

fn totals(frame: &Frame<'_>) -> (f64, f64, f64, f64) {
    let kinetic: f64 = frame.bodies.iter().map(|b| b.kinetic_energy).sum();
    let potential: f64 = frame.bodies.iter().map(|b| b.potential_energy).sum();
    let gap = frame
        .mechanisms
        .iter()
        .map(|m| m.residual_m)
        .fold(0.0, f64::max);
    let angle = frame
        .mechanisms
        .iter()
        .map(|m| m.residual_rad)
        .fold(0.0, f64::max);
    (kinetic, kinetic + potential, gap, angle)
}

/// One row (see the module doc): the scene stepped through a [`Simulation`] on this thread,
/// its guard after every step, the reported frame read after every step.
pub fn run_row(
    scene: &Scene,
    world: &World,
    kind: IntegratorKind,
    dt: f64,
    duration_secs: f64,
) -> anyhow::Result<SceneRow> {
    let steps = ((duration_secs / dt).ceil() as u64).max(1);
    let settings = RunSettings {
        steps,
        log_every: steps,
        quiet: true,
        ..scene.run_settings()
    };
    let mut sim =
        Simulation::of_world(world, kind, dt, &scene.variational_settings(), 1, &settings)?;
    let (t0, e0, gap0, angle0) = totals(&sim.frame().as_frame());
    let mut row = SceneRow {
        integrator: kind,
        dt,
        steps,
        steps_done: steps,
        newton_iters_max: 0,
        substeps: 0,
        substep_factor_max: 0,
        energy_err_max: 0.0,
        residual_m_max: gap0,
        residual_rad_max: angle0,
        status: Status::Ok,
    };
    let mut kinetic_max = t0;
    let mut de_max: f64 = 0.0;
    let relative = |de: f64, t_max: f64| {
        let scale = if t_max > 0.0 { t_max } else { e0.abs() };
        if scale > 0.0 { de / scale } else { de }
    };
    // One step at a time: every step's reported frame is measured.
    loop {
        let progress = sim.advance(1)?;
        if progress == Progress::Stopped {
            break;
        }
        let (t, e, gap, angle) = totals(&sim.frame().as_frame());
        let flow = sim.partitions().energy_flow();
        kinetic_max = kinetic_max
            .max(t)
            .max(flow.input_work.abs())
            .max(flow.dissipated.abs());
        let residual = e - e0 - (flow.input_work - flow.dissipated + flow.contact_work);
        de_max = de_max.max(residual.abs());
        row.residual_m_max = row.residual_m_max.max(gap);
        row.residual_rad_max = row.residual_rad_max.max(angle);
        if progress != Progress::Running {
            break;
        }
    }
    let summary = sim.summary();
    row.newton_iters_max = summary.stats.newton_iters_max;
    row.substeps = u64::from(summary.stats.substepped);
    row.substep_factor_max = summary.stats.substep_factor_max;
    row.energy_err_max = relative(de_max, kinetic_max);
    if let Some(stop) = summary.stopped {
        row.steps_done = stop.step - 1;
        row.status = match stop.cause {
            Cause::NewtonFailed { .. } => Status::NewtonFailed,
            Cause::NonFinite { .. } | Cause::OutOfRange { .. } => {
                row.energy_err_max = f64::INFINITY;
                Status::Diverged
            }
            Cause::EnergyGrowth { .. } | Cause::MechanismEnergyGrowth { .. } => Status::Diverged,
        };
        return Ok(row);
    }
    row.status = if row.substeps > 0 {
        Status::Substepped
    } else if row.energy_err_max.is_nan() || row.energy_err_max > ENERGY_ERROR_BOUND {
        Status::Inaccurate
    } else {
        Status::Ok
    };
    Ok(row)
}

/// The largest `dt` of `kind`'s rows up to which every row is `ok` (`None` when the smallest
/// is not).
pub fn largest_ok_dt(rows: &[SceneRow], kind: IntegratorKind) -> Option<f64> {
    let mut mine: Vec<&SceneRow> = rows.iter().filter(|r| r.integrator == kind).collect();
    mine.sort_by(|a, b| a.dt.total_cmp(&b.dt));
    mine.iter()
        .take_while(|r| r.status == Status::Ok)
        .last()
        .map(|r| r.dt)
}

/// `stability_scene.csv`: [`CSV_HEADER`] and one line per row (shortest round-trip numbers).
pub fn csv(rows: &[SceneRow]) -> String {
    let mut out = format!("{CSV_HEADER}\n");
    for r in rows {
        let _ = writeln!(
            out,
            "{},{:?},{},{},{},{},{},{:?},{:?},{:?},{}",
            r.integrator.name(),
            r.dt,
            r.steps,
            r.steps_done,
            r.newton_iters_max,
            r.substeps,
            r.substep_factor_max,
            r.energy_err_max,
            r.residual_m_max,
            r.residual_rad_max,
            r.status.name()
        );
    }
    out
}

/// The terminal table and, per integrator, the largest `ok` step.
pub fn summary(map: &SceneMap) -> String {
    let mut out = format!(
        "{:<14} {:>9} {:>8} {:>6} {:>9} {:>10} {:>10} {:>10}  status\n",
        "integrator", "dt [s]", "steps", "iters", "substeps", "|dE|/Tmax", "gap [m]", "axis [rad]"
    );
    for r in &map.rows {
        let _ = writeln!(
            out,
            "{:<14} {:>9.2e} {:>8} {:>6} {:>9} {:>10.2e} {:>10.2e} {:>10.2e}  {}",
            r.integrator.name(),
            r.dt,
            r.steps_done,
            r.newton_iters_max,
            r.substeps,
            r.energy_err_max,
            r.residual_m_max,
            r.residual_rad_max,
            r.status.name()
        );
    }
    let mut kinds: Vec<IntegratorKind> = map.rows.iter().map(|r| r.integrator).collect();
    kinds.dedup();
    for kind in kinds {
        match largest_ok_dt(&map.rows, kind) {
            Some(dt) => {
                let _ = writeln!(
                    out,
                    "{}: ok (energy error <= {ENERGY_ERROR_BOUND}, no substeps, no failure) up to dt = {dt} s",
                    kind.name()
                );
            }
            None => {
                let _ = writeln!(out, "{}: not ok even at the smallest dt", kind.name());
            }
        }
    }
    out
}
