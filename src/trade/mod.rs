//! The speed/accuracy trade: every integrator at a range of step sizes on one scene, measured
//! for cost and error (`tumble trade`).
//!
//! For each integrator and step size `dt`:
//!
//! | column               | meaning (SI units, errors absolute)                                              |
//! |----------------------|----------------------------------------------------------------------------------|
//! | `ns_per_body_step`   | wall time of one step of one body, ns: median over repeated timed runs of the whole scene (no recording, no error bookkeeping) |
//! | `pos_err`            | largest distance of any centre of mass from the exact parabola at the end, m      |
//! | `rot_err`            | largest rotation angle between any body's orientation and the reference at the end, rad |
//! | `energy_err_max`     | largest `|E(t) - E(0)|` of the scene's total energy over the run, J                |
//! | `momentum_err`       | largest `|L(t) - L(0)|` of any body's angular momentum about its centre of mass, world frame, kg m²/s |
//! | `energy_drift_per_s` | least-squares slope of `E(t) - E(0)` over the long horizon, J/s (signed)         |
//!
//! A run that diverges (the state overflows) reports `NaN` for the errors it spoils (`null` in
//! JSON), never a finite number; its energy curve stops where it diverged.
//!
//! Cost per simulated second per body is `ns_per_body_step / dt`. The orientation reference is
//! [`reference`]: a high-accuracy solution whose own error is estimated and reported, so a
//! measured error below it is flagged rather than trusted.

pub mod articulated;
pub mod choose;
pub mod measure;
pub mod output;
pub mod plot;
pub mod recording;
pub mod reference;

pub use measure::{EnergySeries, TradeRow, measure};

use crate::scene::Scene;
use crate::sim::IntegratorKind;

/// What `tumble trade` measures.
#[derive(Debug, Clone, PartialEq)]
pub struct TradeSettings {
    pub integrators: Vec<IntegratorKind>,
    /// Step sizes, s.
    pub dts: Vec<f64>,
    /// Horizon of the error measurement (the scene's duration), s.
    pub duration_secs: f64,
    /// Horizon of the energy-drift fit, s.
    pub drift_horizon_secs: f64,
    /// Timed repeats per integrator and step size (the median is reported).
    pub repeats: usize,
    /// Threads of the timed stepping loop: a batch of more than
    /// [`crate::sim::partition::MIN_BODIES_PER_PARTITION`] bodies is split as `simulate
    /// --threads` splits it, and `ns_per_body_step` is the wall time per body-step on them.
    pub threads: usize,
    /// The user named `integrators` (rather than taking the default list): on an articulated
    /// scene an integrator outside the variational family is then an error, not a skip.
    pub integrators_named: bool,
}

/// Everything `tumble trade` measured.
#[derive(Debug, Clone)]
pub struct TradeReport {
    /// Simulated bodies in the scene.
    pub bodies: usize,
    pub rows: Vec<TradeRow>,
    /// Energy error against time over the drift horizon, per integrator, at [`Self::series_dt`].
    pub energy_series: Vec<EnergySeries>,
    pub series_dt: f64,
    pub reference: reference::Reference,
    /// The URDF oddities the scene's models loaded with (docs/urdf.md).
    pub warnings: Vec<crate::model::urdf::LoadWarning>,
    /// One line per integrator of the list that has no rows, saying why (an articulated scene
    /// and an integrator outside the variational family).
    pub skipped: Vec<String>,
    /// The integrators measured (the list minus the skipped ones), in list order.
    pub integrators: Vec<IntegratorKind>,
}

/// Runs every measurement. `progress` is called once per finished row.
///
/// On a scene with articulated models ([`articulated`]) the integrators outside the variational
/// family are skipped ([`TradeReport::skipped`]), or refused with one error when
/// [`TradeSettings::integrators_named`].
pub fn run(
    scene: &Scene,
    settings: &TradeSettings,
    mut progress: impl FnMut(&TradeRow),
) -> anyhow::Result<TradeReport> {
    let world = scene.build()?;
    let loads = world.loads(scene.gravity());
    crate::scene::refuse_contact(scene, &world, "trade")?;
    // Applied loads on free bodies: no closed form; the numerical reference and the energy
    // balance of the articulated path (which also steps free bodies) measure them.
    let numerical = !world.mechanisms.is_empty() || !world.body_loads.is_empty();
    let variational = scene.variational_settings();
    let series_dt = series_dt(&settings.dts);
    let mut skipped = Vec::new();
    let mut integrators = Vec::new();
    for &kind in &settings.integrators {
        if world.mechanisms.is_empty() {
            integrators.push(kind);
            continue;
        }
        match articulated::skip_reason(kind, &world) {
            None => integrators.push(kind),
            Some(_) if settings.integrators_named => {
                // The stepper's own refusal names the model and the supported integrators.
                world.integrator(kind, series_dt, &variational)?;
            }
            Some(why) => skipped.push(why),
        }
    }
    let reference = if !numerical {
        reference::Reference::compute(&world.bodies, settings.duration_secs)
    } else {
        let finest = settings.dts.iter().copied().fold(f64::INFINITY, f64::min);
        articulated::reference(&world, &variational, &loads, settings.duration_secs, finest)?
    };
    let mut rows = Vec::new();
    let mut energy_series = Vec::new();
    for &kind in &integrators {
        for &dt in &settings.dts {
            let (row, series) = if !numerical {
                measure(
                    &world.bodies,
                    kind,
                    dt,
                    &variational,
                    &loads,
                    settings,
                    &reference,
                )
            } else {
                articulated::measure(&world, kind, dt, &variational, &loads, settings, &reference)?
            };
            progress(&row);
            rows.push(row);
            if dt == series_dt {
                energy_series.push(series);
            }
        }
    }
    Ok(TradeReport {
        bodies: world.bodies.len(),
        rows,
        energy_series,
        series_dt,
        reference,
        warnings: world.warnings,
        skipped,
        integrators,
    })
}

/// The step size whose runs are plotted against time and recorded: the middle one.
pub fn series_dt(dts: &[f64]) -> f64 {
    let mut sorted = dts.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted[sorted.len() / 2]
}
