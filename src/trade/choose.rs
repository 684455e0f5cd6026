//! `tumble trade --accuracy TOL`: the cheapest measured (integrator, step size) that meets an
//! error tolerance, and each integrator's own cheapest.
//!
//! The tolerance is the one of `simulate --accuracy` (docs/accuracy.md): `TOL` radians of
//! orientation error over the error horizon, and `TOL × size` metres of position error, `size`
//! the smallest body's size: the longest axis of its equivalent inertia ellipsoid (the uniform
//! solid ellipsoid with the body's mass and principal moments), the strictest over the scene.
//! A row meets it when its measured `rot_err ≤ TOL` and `pos_err ≤ TOL × size` (both are
//! maxima over every body and the whole horizon, [`super::measure`]). Cost is the measured wall
//! time per simulated second per body ([`TradeRow::cost_secs_per_sim_sec`]): `ns_per_body_step`
//! divided by the step. Only measured rows are chosen (no interpolation between step sizes): the
//! answer is a step size whose error and cost this run measured; a finer `--dt` list refines it.

use super::measure::TradeRow;

/// What `--accuracy` asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Orientation error, rad.
    pub rad: f64,
    /// Position error, m (`rad × size`).
    pub m: f64,
}

impl Tolerance {
    /// `tol_rad` rad and `tol_rad × size_m` m.
    pub fn new(tol_rad: f64, size_m: f64) -> Self {
        Self {
            rad: tol_rad,
            m: tol_rad * size_m,
        }
    }

    pub fn met_by(&self, row: &TradeRow) -> bool {
        row.rot_err <= self.rad && row.pos_err <= self.m
    }
}

/// Per integrator (in the order of first appearance in `rows`): its cheapest row meeting `tol`,
/// or `Err(best)`, the row with the smallest orientation error when none meets it.
pub fn per_integrator<'a>(
    rows: &'a [TradeRow],
    tol: &Tolerance,
) -> Vec<(&'a str, Result<&'a TradeRow, &'a TradeRow>)> {
    let mut names: Vec<&str> = Vec::new();
    for row in rows {
        if !names.contains(&row.integrator.as_str()) {
            names.push(&row.integrator);
        }
    }
    names
        .into_iter()
        .map(|name| {
            let own = rows.iter().filter(|r| r.integrator == name);
            let meeting = own.clone().filter(|r| tol.met_by(r)).min_by(|a, b| {
                a.cost_secs_per_sim_sec()
                    .total_cmp(&b.cost_secs_per_sim_sec())
            });
            let choice = match meeting {
                Some(row) => Ok(row),
                None => Err(own
                    .min_by(|a, b| a.rot_err.total_cmp(&b.rot_err))
                    .expect("an integrator with a name has a row")),
            };
            (name, choice)
        })
        .collect()
}

/// The cheapest row of all that meets `tol`.
pub fn cheapest<'a>(rows: &'a [TradeRow], tol: &Tolerance) -> Option<&'a TradeRow> {
    rows.iter().filter(|r| tol.met_by(r)).min_by(|a, b| {
        a.cost_secs_per_sim_sec()
            .total_cmp(&b.cost_secs_per_sim_sec())
    })
}

/// The report's lines: the choice, then each integrator's cheapest (or why none).
pub fn report(rows: &[TradeRow], tol: &Tolerance) -> String {
    use std::fmt::Write;
    let describe = |r: &TradeRow| {
        format!(
            "{} at dt = {} s: {:.3e} s of wall time per simulated second per body ({:.1} ns per body-step), rot_err {:.2e} rad, pos_err {:.2e} m",
            r.integrator,
            r.dt,
            r.cost_secs_per_sim_sec(),
            r.ns_per_body_step,
            r.rot_err,
            r.pos_err
        )
    };
    let mut out = String::new();
    let _ = writeln!(
        out,
        "accuracy {:e} rad of orientation and {:.3e} m of position error over the horizon:",
        tol.rad, tol.m
    );
    match cheapest(rows, tol) {
        Some(r) => {
            let _ = writeln!(out, "cheapest: {}", describe(r));
        }
        None => {
            let _ = writeln!(
                out,
                "cheapest: none of the measured rows meets it (give smaller step sizes with --dt)"
            );
        }
    }
    let _ = writeln!(out, "each integrator's cheapest step meeting it:");
    for (name, choice) in per_integrator(rows, tol) {
        let _ = match choice {
            Ok(r) => writeln!(out, "  {}", describe(r)),
            Err(best) => writeln!(
                out,
                "  {name}: no measured step meets it (its smallest rot_err {:.2e} rad, at dt = {} s)",
                best.rot_err, best.dt
            ),
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(integrator: &str, dt: f64, ns: f64, rot_err: f64, pos_err: f64) -> TradeRow {
        TradeRow {
            integrator: integrator.into(),
            dt,
            ns_per_body_step: ns,
            pos_err,
            rot_err,
            energy_err_max: 0.0,
            momentum_err: 0.0,
            energy_drift_per_s: 0.0,
        }
    }

    /// The cheapest per simulated second, not per step; position counts; none meeting is said.
    #[test]
    fn the_cheapest_meeting_row_wins_per_simulated_second() {
        let rows = [
            row("a", 0.01, 10.0, 1e-4, 0.0),  // 1e-6 s per sim s
            row("a", 0.02, 10.0, 4e-4, 0.0),  // 5e-7: a's cheapest meeting 1e-3
            row("a", 0.04, 10.0, 2e-3, 0.0),  // fails
            row("b", 0.04, 30.0, 1e-5, 0.0),  // 7.5e-7
            row("b", 0.08, 30.0, 5e-4, 2e-3), // 3.75e-7, but its position fails
            row("c", 0.01, 1.0, 5e-2, 0.0),   // never meets
        ];
        let tol = Tolerance::new(1e-3, 1.0);
        assert_eq!(cheapest(&rows, &tol).unwrap(), &rows[1]);
        let each = per_integrator(&rows, &tol);
        assert_eq!(each[0], ("a", Ok(&rows[1])));
        assert_eq!(each[1], ("b", Ok(&rows[3])));
        assert_eq!(each[2], ("c", Err(&rows[5])));
        // With a larger size the position of b at 0.08 s passes and b becomes the cheapest.
        let loose = Tolerance::new(1e-3, 10.0);
        assert_eq!(cheapest(&rows, &loose).unwrap(), &rows[4]);
        assert!(cheapest(&rows, &Tolerance::new(1e-9, 1.0)).is_none());
        let text = report(&rows, &Tolerance::new(1e-9, 1.0));
        assert!(text.contains("none of the measured rows"), "{text}");
        // Exactly at the tolerance meets it (≤).
        assert!(Tolerance::new(4e-4, 1.0).met_by(&rows[1]));
    }
}
