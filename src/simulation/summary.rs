//! What a run did ([`RunSummary`]), the error of a run the guard stopped ([`Diverged`]), and
//! the integer clock of the recordings ([`time_ns`]).

use crate::sim::StepStats;
use crate::sim::guard::Divergence;

/// An initial angular momentum at most this fraction of its scale (the largest principal
/// moment of inertia of its bodies times 1 rad/s) is at rest to round-off: its change is
/// reported as an absolute figure ([`RunSummary::angmom_abs_change_max`]).
pub const AT_REST: f64 = 1e-12;

/// What a run did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunSummary {
    pub steps: u64,
    /// The last step recorded.
    pub last_recorded_step: u64,
    pub frames_recorded: u64,
    pub stats: StepStats,
    /// Total mechanical energy of all bodies at the start and at the end, J.
    pub energy_initial: f64,
    pub energy_final: f64,
    /// What the inputs did over the run ([`crate::sim::integrators::EnergyFlow`]): the work of
    /// the applied loads and actuators, and the energy joint damping removed, J. The energy
    /// balance is `energy_final − energy_initial = input_work − dissipated + residual`; the
    /// residual is the scheme's own energy error (O(h²) for the variational family).
    pub energy_flow: crate::sim::integrators::EnergyFlow,
    /// Largest change of any body's spatial angular momentum about its centre of mass, relative
    /// to that body's initial |L| (conserved exactly by the variational schemes), over the
    /// bodies without colliders (contact changes the others').
    /// It is taken over the quantities with a reference: an initial |L| above
    /// [`AT_REST`] times the quantity's own scale ([`RunSummary::angmom_abs_change_max`]
    /// covers the others); 0 when there is none.
    pub angmom_rel_change_max: f64,
    /// Largest change |L − L₀| of a conserved angular momentum that started at rest (|L₀| at
    /// most [`AT_REST`] times its scale: the largest principal moment of inertia of its
    /// bodies, summed over a mechanism's, times 1 rad/s), kg m²/s: a relative change has no
    /// reference there. 0 when there is none.
    pub angmom_abs_change_max: f64,
    /// How many conserved angular momenta the two figures above cover: relative, absolute.
    pub angmom_checked: [u32; 2],
    /// Whether some articulated model has a fixed base: its angular momentum is not conserved
    /// (the weld exchanges it with the world) and is in neither figure.
    pub fixed_base: bool,
    /// With mechanisms, the largest constraint residual over the frames built in the run (the
    /// recorded ones and the summary's; a run without sinks builds only the first and the
    /// last): anchor gap, m, and axis misalignment, rad
    /// ([`crate::sim::mechanism::Totals::residual_m`]). `None` without mechanisms.
    pub constraint_residual: Option<[f64; 2]>,
    /// Whether contact acted in the run (a ground or colliding bodies): momenta are then
    /// exchanged with the ground, and `energy_flow.contact_work` is its term of the balance.
    pub contact: bool,
    /// Set when the guard stopped the run: `steps` is then the last good step, and the
    /// recordings end at the last recorded step before it.
    pub stopped: Option<Divergence>,
    /// Set when SIGINT/SIGTERM stopped the run (the signal number; 0 for a request from code):
    /// `steps` is then the last step done, and it was recorded.
    pub interrupted: Option<i32>,
}

impl RunSummary {
    /// The angular momentum part of the summary line: the largest relative change over the
    /// conserved momenta with a reference, the largest absolute change (kg m²/s) over those that
    /// started at rest ([`AT_REST`]), and "not conserved: fixed base" when only
    /// fixed-base models (whose weld exchanges momentum with the world) are in the run.
    pub fn momentum_text(&self) -> String {
        let s = self;
        let [relative, absolute] = s.angmom_checked;
        let mut parts = Vec::new();
        if relative > 0 {
            parts.push(format!(
                "angular momentum relative change max {:.2e}",
                s.angmom_rel_change_max
            ));
        }
        if absolute > 0 {
            parts.push(format!(
                "angular momentum absolute change max {:.2e} kg m^2/s (starting at rest)",
                s.angmom_abs_change_max
            ));
        }
        if parts.is_empty() {
            return if s.fixed_base {
                "angular momentum not conserved: fixed base".to_string()
            } else if s.contact {
                "angular momentum not checked: every body has colliders (contact exchanges momenta \
                 with the ground)"
                    .to_string()
            } else {
                "angular momentum not checked: no body".to_string()
            };
        }
        let mut text = parts.join(", ");
        if s.contact {
            text.push_str(
                " over the bodies without colliders (contact exchanges the others' momenta with the \
                 ground)",
            );
        }
        if s.fixed_base {
            text.push_str(" (fixed-base models excluded: not conserved)");
        }
        text
    }
}

/// A run's energy balance `ΔE = W_in − D + W_c + open`: the change of the total energy, the
/// work the applied loads and actuators did, the energy damping, limits and friction took
/// out, the contact term, and what the books leave open (the scheme's own energy error, or a
/// step that did not converge).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyBalance {
    /// `E_final − E_initial`, J.
    pub change: f64,
    pub flow: crate::sim::integrators::EnergyFlow,
    /// `ΔE − (W_in − D + W_c)`, J.
    pub open: f64,
    /// The largest of `|ΔE|`, `|W_in|`, `D`, `|W_c|`, J.
    pub largest_term: f64,
}

/// A run whose energy balance is open by more than this fraction of its largest term warns
/// ([`RunSummary::balance_warning`]): a variational step's own energy error is O(h²) of the
/// energy exchanged, far below it at any step a run should take.
pub const BALANCE_OPEN_WARN: f64 = 1e-2;

/// A balance open by less than this fraction of the run's largest total energy `max(|E_0|,
/// |E_1|)` never warns: a run with almost no exchange (a servo holding still) has terms of
/// round-off size, whose ratio means nothing.
pub const BALANCE_FLOOR: f64 = 1e-9;

impl EnergyBalance {
    /// `|open|` over the largest term (0 when every term is 0).
    pub fn relative_open(&self) -> f64 {
        self.open.abs() / self.largest_term.max(f64::MIN_POSITIVE)
    }
}

impl RunSummary {
    /// The energy balance, when something flows in or out (applied loads, actuators, damping,
    /// limits, friction, contact); `None` for a conservative run, whose balance is its energy
    /// change alone.
    pub fn energy_balance(&self) -> Option<EnergyBalance> {
        let flow = self.energy_flow;
        if flow == Default::default() {
            return None;
        }
        let change = self.energy_final - self.energy_initial;
        let open = change - (flow.input_work - flow.dissipated + flow.contact_work);
        let largest_term = change
            .abs()
            .max(flow.input_work.abs())
            .max(flow.dissipated.abs())
            .max(flow.contact_work.abs());
        Some(EnergyBalance {
            change,
            flow,
            open,
            largest_term,
        })
    }

    /// What the recordings' end-of-run metadata holds (the record
    /// [`crate::record::names::SUMMARY_METADATA_NAME`] of the MCAP files), keys sorted:
    /// `steps`, `energy_initial_J`, `energy_final_J`, the balance's terms when something flows
    /// (`input_work_J`, `dissipated_J`, `contact_work_J`, `energy_balance_open_J`,
    /// `energy_balance_open_relative`: over its largest term), `newton_failures`,
    /// `substepped`, and `warnings` (one per line; empty when there is none).
    pub fn metadata_entries(&self) -> Vec<(String, String)> {
        let mut entries = vec![
            ("steps".to_string(), self.steps.to_string()),
            (
                "energy_initial_J".into(),
                format!("{:e}", self.energy_initial),
            ),
            ("energy_final_J".into(), format!("{:e}", self.energy_final)),
            (
                "newton_failures".into(),
                self.stats.newton_failures.to_string(),
            ),
            ("substepped".into(), self.stats.substepped.to_string()),
            (
                "warnings".into(),
                self.balance_warning().unwrap_or_default(),
            ),
        ];
        if let Some(b) = self.energy_balance() {
            entries.extend([
                ("input_work_J".into(), format!("{:e}", b.flow.input_work)),
                ("dissipated_J".into(), format!("{:e}", b.flow.dissipated)),
                (
                    "contact_work_J".into(),
                    format!("{:e}", b.flow.contact_work),
                ),
                ("energy_balance_open_J".into(), format!("{:e}", b.open)),
                (
                    "energy_balance_open_relative".into(),
                    format!("{:e}", b.relative_open()),
                ),
            ]);
        }
        entries.sort();
        entries
    }

    /// The warning of a run whose energy balance is open by more than [`BALANCE_OPEN_WARN`] of
    /// its largest term (and by more than [`BALANCE_FLOOR`] of its energy), `None` otherwise:
    /// printed by `simulate` and written into the recordings' metadata.
    pub fn balance_warning(&self) -> Option<String> {
        let b = self.energy_balance()?;
        let energy = self.energy_initial.abs().max(self.energy_final.abs());
        let open = b.open.abs();
        let warns = !open.is_finite()
            || (open > BALANCE_OPEN_WARN * b.largest_term && open > BALANCE_FLOOR * energy);
        if !warns {
            return None;
        }
        Some(format!(
            "the energy balance is open by {:.3e} J, {:.2e} of its largest term (more than {:.0e}): \
             the steps did not resolve the motion (a servo or a stop too stiff for dt, a whip, \
             a step that did not converge); a smaller dt closes it",
            b.open,
            b.relative_open(),
            BALANCE_OPEN_WARN
        ))
    }
}

/// Simulation time of step `k` in integer nanoseconds. Exact integer arithmetic when `dt_secs`
/// is a whole number of nanoseconds (to 1e-6 ns), else rounded per step.
pub fn time_ns(step: u64, dt_secs: f64) -> i64 {
    let dt_ns = dt_secs * 1e9;
    if (dt_ns - dt_ns.round()).abs() < 1e-6 && dt_ns >= 1.0 {
        step as i64 * dt_ns.round() as i64
    } else {
        (step as f64 * dt_ns).round() as i64
    }
}

/// The error of a run the guard stopped ([`RunSummary::stopped`]), after its recordings were
/// finished. `tumble` exits with status 3 on it.
#[derive(Debug, Clone)]
pub struct Diverged {
    pub divergence: Divergence,
    /// The body's name (its frame id).
    pub body_name: String,
    pub dt_secs: f64,
    /// Steps recorded, the last one.
    pub last_recorded_step: u64,
    /// The finished recordings.
    pub outputs: Vec<std::path::PathBuf>,
}

impl std::fmt::Display for Diverged {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let d = &self.divergence;
        write!(
            f,
            "body {:?} (index {}) failed at step {} (t = {} s): {}. The run stopped after step {}; \
             the recordings end at step {} (t = {} s) and are complete and readable:",
            self.body_name,
            d.body,
            d.step,
            time_ns(d.step, self.dt_secs) as f64 / 1e9,
            d.cause,
            d.step.saturating_sub(1),
            self.last_recorded_step,
            time_ns(self.last_recorded_step, self.dt_secs) as f64 / 1e9,
        )?;
        for path in &self.outputs {
            write!(f, " {}", path.display())?;
        }
        Ok(())
    }
}

impl std::error::Error for Diverged {}
