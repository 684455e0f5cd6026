//! The trade table as terminal text, CSV and JSON.

use super::{TradeReport, TradeRow};
use std::fmt::Write as _;

/// The CSV header: exactly these columns, in this order (a contract other tools read).
pub const CSV_HEADER: &str =
    "integrator,dt,ns_per_body_step,pos_err,rot_err,energy_err_max,momentum_err,energy_drift_per_s";

/// `trade.csv`: the header and one row per integrator and step size. Numbers are printed in
/// Rust's shortest round-trip form (`1e-15`, `0.005`), so reading them back is exact.
pub fn csv(rows: &[TradeRow]) -> String {
    let mut out = format!("{CSV_HEADER}\n");
    for r in rows {
        let _ = writeln!(
            out,
            "{},{:?},{:?},{:?},{:?},{:?},{:?},{:?}",
            r.integrator,
            r.dt,
            r.ns_per_body_step,
            r.pos_err,
            r.rot_err,
            r.energy_err_max,
            r.momentum_err,
            r.energy_drift_per_s
        );
    }
    out
}

/// `trade.json`: `{"rows": [...same fields as the CSV...], "scene", "duration_secs",
/// "drift_horizon_secs", "series_dt", "reference": {"method", "own_error_rad", "own_error_m"},
/// "skipped": [one line per integrator left out], "tool_version"}`.
pub fn json(
    report: &TradeReport,
    scene: &str,
    duration_secs: f64,
    drift_horizon_secs: f64,
) -> String {
    let doc = serde_json::json!({
        "rows": report.rows,
        "scene": scene,
        "duration_secs": duration_secs,
        "drift_horizon_secs": drift_horizon_secs,
        "series_dt": report.series_dt,
        "reference": {
            "method": report.reference.method,
            "own_error_rad": report.reference.own_error_rad,
            "own_error_m": report.reference.own_error_m,
        },
        "skipped": report.skipped,
        "tool_version": crate::VERSION,
    });
    let mut text = serde_json::to_string_pretty(&doc).unwrap_or_default();
    text.push('\n');
    text
}

/// A fixed-width table for the terminal.
pub fn table(rows: &[TradeRow]) -> String {
    let mut out = format!(
        "{:<14} {:>9} {:>10} {:>10} {:>10} {:>10} {:>10} {:>11}\n",
        "integrator",
        "dt [s]",
        "ns/body-st",
        "pos [m]",
        "rot [rad]",
        "|dE| [J]",
        "|dL|",
        "drift [J/s]"
    );
    for r in rows {
        let _ = writeln!(
            out,
            "{:<14} {:>9.2e} {:>10.1} {:>10.2e} {:>10.2e} {:>10.2e} {:>10.2e} {:>11.2e}",
            r.integrator,
            r.dt,
            r.ns_per_body_step,
            r.pos_err,
            r.rot_err,
            r.energy_err_max,
            r.momentum_err,
            r.energy_drift_per_s
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_round_trips_exactly() {
        let row = TradeRow {
            integrator: "rk4".into(),
            dt: 0.005,
            ns_per_body_step: 123.456,
            pos_err: 1.234_567_890_123e-15,
            rot_err: 0.1 + 0.2,
            energy_err_max: 0.0,
            momentum_err: 3e-300,
            energy_drift_per_s: -2.5e-9,
        };
        let text = csv(std::slice::from_ref(&row));
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some(CSV_HEADER));
        let cells: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(cells.len(), 8);
        assert_eq!(cells[0], "rk4");
        let parsed: Vec<f64> = cells[1..].iter().map(|c| c.parse().unwrap()).collect();
        let want = [
            row.dt,
            row.ns_per_body_step,
            row.pos_err,
            row.rot_err,
            row.energy_err_max,
            row.momentum_err,
            row.energy_drift_per_s,
        ];
        assert_eq!(parsed, want);
    }
}
