//! The stability map as CSV, and the per-integrator summary printed by `tumble stability`.
//!
//! CSV columns, in this order (the first seven are a contract other tools read; the rest are
//! extra detail):
//!
//! | column | meaning |
//! |---|---|
//! | `integrator` | [`IntegratorKind::name`] |
//! | `h_omega` | largest rotation per step `h|Ω|max`, rad (`dt` in s, since `|Ω|max = 1 rad/s`) |
//! | `inertia_ratio` | `J_min / J_max` |
//! | `newton_iters_max` | most Newton iterations of any solve (0 for explicit schemes) |
//! | `substeps` | body-steps split into substeps |
//! | `energy_err_max` | `max |T_k - T_0| / T_0`; `inf` for a state that went non-finite |
//! | `status` | `ok`, `inaccurate`, `substepped`, `newton-failed` or `diverged` ([`Status`]) |
//! | `spin_axis` | `generic` or `near-intermediate` ([`super::SpinAxis`]) |
//! | `shape` | `isotropic`, `asymmetric` or `flat-disk` ([`super::Shape`]) |
//! | `moments` | the principal moments `J_1 J_2 J_3`, space-separated, kg m^2 |
//! | `spin_rate_initial` | `|Ω_0|`, rad/s (`|Ω|max` is 1 rad/s) |
//! | `steps` | steps planned |
//! | `steps_done` | steps completed before the guard stopped the run |
//! | `substep_factor_max` | largest substep split factor (0 when none) |
//!
//! Numbers are printed in Rust's shortest round-trip form (`1e-9`, `0.003`), so reading them
//! back is exact.

use super::{Row, derived_limit, limiting_row};
use crate::sim::IntegratorKind;
use crate::sim::limits::h_omega_limit;
use std::fmt::Write as _;

/// The contracted first columns of `stability.csv`.
pub const CSV_COLUMNS: &str =
    "integrator,h_omega,inertia_ratio,newton_iters_max,substeps,energy_err_max,status";
/// The full header: [`CSV_COLUMNS`] and the extra columns.
pub const CSV_HEADER: &str = "integrator,h_omega,inertia_ratio,newton_iters_max,substeps,energy_err_max,status,spin_axis,shape,moments,spin_rate_initial,steps,steps_done,substep_factor_max";

/// `stability.csv`: the header and one line per row.
pub fn csv(rows: &[Row]) -> String {
    let mut out = format!("{CSV_HEADER}\n");
    for r in rows {
        let j = r.cell.shape.moments();
        let _ = writeln!(
            out,
            "{},{:?},{:?},{},{},{:?},{},{},{},{:?} {:?} {:?},{:?},{},{},{}",
            r.integrator.name(),
            r.cell.h_omega,
            r.cell.shape.inertia_ratio(),
            r.newton_iters_max,
            r.substeps,
            r.energy_err_max,
            r.status.name(),
            r.cell.spin_axis.name(),
            r.cell.shape.name(),
            j.x,
            j.y,
            j.z,
            r.cell.angvel_body().norm(),
            r.steps,
            r.steps_done,
            r.substep_factor_max,
        );
    }
    out
}

/// `1e-3` style for a limit, `none` when there is none.
fn fmt_limit(limit: Option<f64>) -> String {
    limit.map_or_else(|| "none".to_string(), |l| format!("{l:?}"))
}

/// The summary table: per integrator, the limit derived from `rows`, the documented limit of
/// [`h_omega_limit`], and the cell just past the derived limit that sets it.
pub fn summary(rows: &[Row], kinds: &[IntegratorKind]) -> String {
    let mut out = format!(
        "{:<14} {:>9} {:>11}  {}\n",
        "integrator", "derived", "documented", "first cell past the derived limit (worst)"
    );
    for &kind in kinds {
        let derived = derived_limit(rows, kind);
        let next = limiting_row(rows, kind).map_or_else(
            || "none: ok on the whole map".to_string(),
            |r| {
                format!(
                    "h|Ω| = {:?}: {} ({}, {}, energy err {:.2e}, {} substeps)",
                    r.cell.h_omega,
                    r.status.name(),
                    r.cell.shape.label(),
                    r.cell.spin_axis.name(),
                    r.energy_err_max,
                    r.substeps
                )
            },
        );
        let _ = writeln!(
            out,
            "{:<14} {:>9} {:>11}  {}",
            kind.name(),
            fmt_limit(derived),
            format!("{:?}", h_omega_limit(kind)),
            next
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stability::{Cell, Shape, SpinAxis, Status};

    #[test]
    fn header_starts_with_the_contract_and_rows_match_it() {
        assert!(CSV_HEADER.starts_with(&format!("{CSV_COLUMNS},")));
        let row = Row {
            integrator: IntegratorKind::MoserVeselov,
            cell: Cell {
                shape: Shape::Asymmetric { ratio: 1e-3 },
                spin_axis: SpinAxis::NearIntermediate,
                h_omega: 1e-9,
            },
            steps: 20_000,
            steps_done: 12,
            newton_iters_max: 3,
            substeps: 7,
            substep_factor_max: 4,
            energy_err_max: f64::INFINITY,
            status: Status::Diverged,
        };
        let text = csv(std::slice::from_ref(&row));
        let line = text.lines().nth(1).unwrap();
        let spin_rate_initial = row.cell.angvel_body().norm();
        // |Ω_0| = 1 / 1.2244: this orbit's speed peaks 22 % above the initial one.
        assert!(
            (spin_rate_initial - 0.8167).abs() < 1e-4,
            "{spin_rate_initial}"
        );
        assert_eq!(
            line,
            format!(
                "moser-veselov,1e-9,0.001,3,7,inf,diverged,near-intermediate,asymmetric,0.001 0.9995 1.0,{spin_rate_initial:?},20000,12,4"
            )
        );
        assert_eq!(
            line.split(',').count(),
            CSV_HEADER.split(',').count(),
            "one field per column"
        );
        assert_eq!(
            line.split(',').nth(5).unwrap().parse::<f64>(),
            Ok(f64::INFINITY)
        );
    }
}
