//! `tumble stability`: the documented step limits against a freshly computed map, the physics
//! the map must show, and the command's output contract.
//!
//! The full map (7 integrators x 272 cells, ≈ 1.3 s in release on 2 threads) is computed once
//! and shared by the tests of this file.

use crate::common;

use common::{text, tumble};
use std::path::Path;
use std::sync::OnceLock;
use tumble::sim::IntegratorKind;
use tumble::sim::limits::{ENERGY_ERROR_BOUND, h_omega_limit};
use tumble::stability::{self, Grid, Row, Shape, SpinAxis, Status};

/// The contracted first columns of `stability.csv`, spelled out (not taken from the library).
const CONTRACT: &str =
    "integrator,h_omega,inertia_ratio,newton_iters_max,substeps,energy_err_max,status";

fn full_map() -> &'static [Row] {
    static ROWS: OnceLock<Vec<Row>> = OnceLock::new();
    ROWS.get_or_init(|| {
        stability::sweep(
            &Grid::full(),
            IntegratorKind::ALL,
            stability::default_threads(),
        )
    })
}

fn rows_of(kind: IntegratorKind) -> impl Iterator<Item = &'static Row> {
    full_map().iter().filter(move |r| r.integrator == kind)
}

fn cell(kind: IntegratorKind, h_omega: f64, shape: Shape, axis: SpinAxis) -> &'static Row {
    rows_of(kind)
        .find(|r| r.cell.h_omega == h_omega && r.cell.shape == shape && r.cell.spin_axis == axis)
        .unwrap_or_else(|| panic!("no cell {kind:?} {h_omega} {shape:?} {axis:?}"))
}

/// The constants of `limits::h_omega_limit` are the limits the map derives: if an integrator
/// changes, this fails until the map in docs/stability and the constants are regenerated.
#[test]
fn documented_limits_are_the_derived_limits() {
    let rows = full_map();
    assert_eq!(
        rows.len(),
        IntegratorKind::ALL.len() * Grid::full().cells().len()
    );
    for &kind in IntegratorKind::ALL {
        let derived = stability::derived_limit(rows, kind);
        assert_eq!(
            derived,
            Some(h_omega_limit(kind)),
            "{}: the map derives {derived:?}, limits.rs documents {}; first cell past it: {:?}",
            kind.name(),
            h_omega_limit(kind),
            stability::limiting_row(rows, kind)
        );
    }
}

/// An isotropic body's exact step is `ξ = hΩ` (with `J = I`, `T(ξ)^T M = M` for `ξ ∥ M`), so
/// every scheme of the variational family conserves its energy to round-off at any step, even
/// beyond `π`.
#[test]
fn isotropic_body_keeps_its_energy_at_every_step_size() {
    for kind in [
        IntegratorKind::Variational,
        IntegratorKind::Variational4,
        IntegratorKind::Variational6,
    ] {
        let rows: Vec<_> = rows_of(kind)
            .filter(|r| r.cell.shape == Shape::Isotropic)
            .collect();
        assert_eq!(rows.len(), 17 * 2);
        for r in rows {
            // Measured at most 6.7e-16 (variational), 3.3e-16 (4), 2.7e-15 (6).
            assert!(
                r.energy_err_max <= 1e-14 && r.status == Status::Ok,
                "{}: {r:?}",
                kind.name()
            );
        }
    }
}

/// Moser–Veselov conserves the kinetic energy exactly, so wherever its Newton solve converged
/// the error is at the level of the Newton tolerance (1e-12 relative per solve), and it never
/// fails or diverges on the map: for `h|Ω| >= 1`, where the Cayley equation has no solution at
/// the full step, it substeps.
#[test]
fn moser_veselov_energy_error_is_at_the_newton_tolerance() {
    for r in rows_of(IntegratorKind::MoserVeselov) {
        match r.status {
            // Measured at most 5.3e-12 over 20 000 steps.
            Status::Ok => assert!(r.energy_err_max <= 2e-11, "{r:?}"),
            // Up to 200 steps of 8 substeps each: measured at most 1.4e-10.
            Status::Substepped => {
                assert!(r.cell.h_omega >= 1.0, "{r:?}");
                assert!(r.energy_err_max <= 1e-9, "{r:?}");
            }
            _ => panic!("moser-veselov did not converge: {r:?}"),
        }
    }
}

/// The energy error of `variational` is O(h^2) with no drift: a step 10x larger gives a 100x
/// larger error. Both cells cover the same 10 turns (6284 and 629 steps); the next term of the
/// error is O(h^2) relative to the first, ≈ 1 % at `h|Ω|` = 0.1, hence the ±10 % band.
#[test]
fn variational_energy_error_scales_with_h_squared() {
    for ratio in [0.5, 0.1, 1e-2, 1e-3] {
        for axis in SpinAxis::ALL {
            let shape = Shape::Asymmetric { ratio };
            let small = cell(IntegratorKind::Variational, 0.01, shape, axis);
            let large = cell(IntegratorKind::Variational, 0.1, shape, axis);
            assert_eq!((small.status, large.status), (Status::Ok, Status::Ok));
            let growth = large.energy_err_max / small.energy_err_max;
            // Measured 99.99 to 100.03 on these eight cells.
            assert!(
                (90.0..=110.0).contains(&growth),
                "r = {ratio}, {axis:?}: {growth}"
            );
        }
    }
}

/// Explicit Euler (and semi-implicit Euler, which updates `M` the same way) gains energy every
/// step on an asymmetric body, by `|ΔM|^2 = h^2 |M × Ω|^2`: from `h|Ω|` = 0.3 on, every
/// asymmetric cell is inaccurate or diverged, and at 6 rad per step the generic spins of every
/// non-isotropic shape diverge. (The flat disk spun about a diameter is the mild exception: `M`
/// is nearly parallel to `Ω`, error 0.19 % at 0.3 and 0.5 % at 0.5.) RK4 diverges past its
/// linear stability bound `2√2` on the imaginary axis.
#[test]
fn explicit_schemes_fail_at_large_steps() {
    for kind in [IntegratorKind::Euler, IntegratorKind::SemiImplicit] {
        for r in rows_of(kind) {
            if r.cell.h_omega >= 0.3 && matches!(r.cell.shape, Shape::Asymmetric { .. }) {
                assert!(
                    matches!(r.status, Status::Inaccurate | Status::Diverged),
                    "{r:?}"
                );
                assert!(r.energy_err_max > ENERGY_ERROR_BOUND, "{r:?}");
            }
            if r.cell.h_omega == 6.0
                && r.cell.spin_axis == SpinAxis::Generic
                && r.cell.shape != Shape::Isotropic
            {
                assert_eq!(r.status, Status::Diverged, "{r:?}");
            }
        }
        // Isotropic: `M × Ω = 0`, nothing changes (measured exactly 0).
        for r in rows_of(kind).filter(|r| r.cell.shape == Shape::Isotropic) {
            assert_eq!(r.energy_err_max, 0.0, "{r:?}");
        }
    }
    for r in rows_of(IntegratorKind::Rk4).filter(|r| {
        r.cell.h_omega == 6.0
            && r.cell.spin_axis == SpinAxis::Generic
            && r.cell.shape != Shape::Isotropic
    }) {
        assert_eq!(r.status, Status::Diverged, "{r:?}");
    }
}

/// Checks `dir/stability.csv` and `dir/stability.png`; returns the CSV's data lines.
fn check_outputs(dir: &Path, integrators: &[&str]) -> Vec<Vec<String>> {
    let csv = std::fs::read_to_string(dir.join("stability.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    let columns: Vec<&str> = header.split(',').collect();
    assert_eq!(columns[..7].join(","), CONTRACT, "header: {header}");
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    let grid = Grid::quick();
    assert_eq!(rows.len(), integrators.len() * grid.cells().len());
    for row in &rows {
        assert_eq!(row.len(), columns.len(), "{row:?}");
        assert!(integrators.contains(&row[0].as_str()), "{row:?}");
        let h_omega: f64 = row[1].parse().unwrap();
        assert!(grid.h_omegas.contains(&h_omega), "{row:?}");
        let ratio: f64 = row[2].parse().unwrap();
        assert!(ratio > 0.0 && ratio <= 1.0, "{row:?}");
        row[3].parse::<u32>().unwrap();
        row[4].parse::<u64>().unwrap();
        let err: f64 = row[5].parse().unwrap();
        assert!(err >= 0.0, "{row:?}"); // NaN fails too
        assert!(Status::from_name(&row[6]).is_some(), "{row:?}");
    }
    let png = std::fs::read(dir.join("stability.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    // A 1750 x 2170 (7 integrators) heat map of flat cells compresses to ≈ 200-400 kB.
    assert!(png.len() > 20_000, "{} bytes", png.len());
    rows
}

#[test]
fn command_writes_the_csv_and_the_heat_map() {
    let dir = tempfile::tempdir().unwrap();
    let out = tumble(&["stability", "--quick", "--out", "map"], dir.path());
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    let names: Vec<&str> = IntegratorKind::ALL.iter().map(|k| k.name()).collect();
    check_outputs(&dir.path().join("map"), &names);
    for name in names {
        assert!(
            stdout.lines().any(|l| l.starts_with(name)),
            "no summary line for {name}: {stdout}"
        );
    }
    assert!(stdout.contains("map/stability.png"), "{stdout}");
}

#[test]
fn command_defaults_to_logs_stability_and_filters_integrators() {
    let dir = tempfile::tempdir().unwrap();
    let out = tumble(
        &["stability", "--quick", "--integrators", "rk4,euler"],
        dir.path(),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let rows = check_outputs(&dir.path().join("logs/stability"), &["rk4", "euler"]);
    assert_eq!(rows[0][0], "rk4", "rows follow the --integrators order");
}

#[test]
fn unknown_integrator_is_one_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = tumble(
        &[
            "stability",
            "--quick",
            "--integrators",
            "rk4,rk5",
            "--out",
            "m",
        ],
        dir.path(),
    );
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.starts_with("error: "), "{stderr}");
    assert_eq!(stderr.matches("error").count(), 1, "{stderr}");
    assert!(
        stderr.contains("\"rk5\"") && stderr.contains("moser-veselov"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        !dir.path().join("m").exists(),
        "nothing written on bad input"
    );
}

/// Every entry of `limits::LIMITS_BY_RATIO` (the per-shape limits the step warning uses) is the
/// limit the map derives for that inertia ratio, and the overall limit is their minimum.
#[test]
fn limits_by_ratio_are_the_derived_limits() {
    let rows = full_map();
    for (ratio, limits) in tumble::sim::limits::LIMITS_BY_RATIO {
        for (&kind, &limit) in IntegratorKind::ALL.iter().zip(&limits) {
            let derived = stability::derived_limit_at_ratio(rows, kind, ratio);
            assert_eq!(derived, Some(limit), "{} at ratio {ratio}", kind.name());
        }
    }
    for (col, &kind) in IntegratorKind::ALL.iter().enumerate() {
        let min = tumble::sim::limits::LIMITS_BY_RATIO
            .iter()
            .map(|(_, l)| l[col])
            .fold(f64::INFINITY, f64::min);
        assert_eq!(min, h_omega_limit(kind), "{}", kind.name());
    }
}
