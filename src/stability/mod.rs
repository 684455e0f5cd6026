//! The stability map (`tumble stability`): where each integrator stays accurate, where its
//! Newton solve needs substeps or fails, and where it diverges, as a function of the rotation
//! per step `h|Ω|`, the inertia ratio and the spin direction. The limits of
//! [`crate::sim::limits::h_omega_limit`] are read off this map ([`derived_limit`]).
//!
//! # Why the map is dimensionless
//!
//! Torque-free rigid-body motion obeys Euler's equations `J dΩ/dt = JΩ × Ω` and
//! `dR/dt = R Ω^`. Scaling time by `s` scales `Ω` by `1/s`; scaling all moments by `c` changes
//! nothing in `Ω(t)` (mass and size only enter through `J`, and only ratios of moments matter).
//! A one-step scheme with step `h` applied to `(J, Ω_0)` therefore produces the same sequence of
//! orientations and the same relative energy errors as with step `h·s` applied to
//! `(J / J_max, Ω_0 / s)` for any speed scale `s`. The scale used is `|Ω|max`, the largest
//! angular speed on the exact orbit ([`spin_rate_max`]; it exceeds `|Ω_0|` by up to 22 % on
//! this map's asymmetric shapes), because that is what [`crate::sim::limits::check_step`]
//! compares with the limit. Each cell is thus one body with `|Ω|max = 1 rad/s`,
//! `J_max = 1 kg m^2`, `dt = h_omega` seconds, no gravity; what is left is
//!
//! - `h_omega = h|Ω|max`, the largest rotation per step, rad ([`H_OMEGA_FULL`]);
//! - the shape: the principal moments, labelled by the inertia ratio `r = J_min / J_max`
//!   ([`Shape`]): isotropic `(1, 1, 1)`; asymmetric `(r, 1 - r/2, 1)` for `r < 1` (the
//!   intermediate moment halfway between the triangle bound `J_1 + J_2 >= J_3`, i.e.
//!   `1 - r`, and `J_max`, so always physical; rod-like as `r → 0`); and a flat disk
//!   `(1/2, 1/2, 1)`, where the triangle inequality holds with equality (the Moser–Veselov
//!   matrix `J_d = tr(J)/2 - J` is then singular);
//! - the spin direction in the body frame ([`SpinAxis`]): `generic`, `Ω_0 ∝ (1, 1, 1)`, and
//!   `near-intermediate`, `Ω_0 ∝ (0.01, 1, 0.01)`, next to the Dzhanibekov separatrix (the
//!   intermediate-axis flip), the hardest case for a fixed step.
//!
//! # What a cell measures
//!
//! Each cell runs `steps = clamp(ceil(20π / h_omega), 200, 20000)` steps (about 10 turns,
//! fewer when capped) with the integrator's default settings (substepping on), under the run
//! guard of [`crate::sim::guard`] (stop on a non-finite state, on rotational energy above
//! [`DEFAULT_DIVERGENCE_ENERGY_RATIO`](crate::sim::guard::DEFAULT_DIVERGENCE_ENERGY_RATIO) times the initial one, or on a Newton failure at
//! `max_substeps`). Recorded: `newton_iters_max` (max over steps), `substeps` (body-steps split
//! into substeps, the sum of [`crate::sim::StepStats::substepped`]), `substep_factor_max`, and
//!
//! `energy_err_max = max_k |T_k - T_0| / T_0`, `T = M^T J^-1 M / 2`
//!
//! over the steps run. A diverged cell reports the error of the step at which the guard stopped
//! it (finite, ≥ 99 for energy growth), or `inf` when that state was not finite; a Newton
//! failure reports the error up to the last good step. The [`Status`] follows from these.

pub mod cell;
pub mod output;
pub mod plot;
pub mod scene;

pub use cell::run_cell;

use crate::sim::IntegratorKind;
use crate::sim::limits::spin_rate_max;
use nalgebra::Vector3;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Rotations per step of the full map, rad: from round-off territory (1e-9, where the series
/// branches of the coefficient functions run) to beyond `π` (where a per-step rotation aliases).
pub const H_OMEGA_FULL: [f64; 17] = [
    1e-9, 1e-6, 1e-4, 1e-3, 3e-3, 0.01, 0.03, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 2.0, 3.0, 4.0, 6.0,
];
/// Inertia ratios `J_min / J_max` of the asymmetric shapes of the full map (1 is isotropic).
pub const INERTIA_RATIOS_FULL: [f64; 7] = [1.0, 0.5, 0.1, 1e-2, 1e-3, 1e-4, 1e-6];
/// `h|Ω|` of the quick map (`--quick`).
pub const H_OMEGA_QUICK: [f64; 8] = [1e-9, 1e-3, 0.01, 0.1, 0.3, 1.0, 3.0, 6.0];
/// Inertia ratios of the quick map.
pub const INERTIA_RATIOS_QUICK: [f64; 4] = [1.0, 0.1, 1e-3, 1e-6];

/// Fewest and most steps of a cell.
pub const STEPS_MIN: u64 = 200;
pub const STEPS_MAX: u64 = 20_000;
/// Turns a cell aims to cover: `steps ≈ TURNS · 2π / h_omega` before clamping.
pub const TURNS: f64 = 10.0;

/// Principal moments of a cell's body, `J_max = 1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// `(1, 1, 1)`: every direction is principal, `Ω` is constant.
    Isotropic,
    /// `(r, 1 - r/2, 1)` with `0 < r < 1`: three distinct moments, rod-like as `r → 0`.
    Asymmetric { ratio: f64 },
    /// `(1/2, 1/2, 1)`: a thin flat disk (triangle equality `J_1 + J_2 = J_3`), axisymmetric.
    FlatDisk,
}

impl Shape {
    /// The shape of inertia ratio `r` (isotropic at 1).
    pub fn from_ratio(r: f64) -> Self {
        if r >= 1.0 {
            Shape::Isotropic
        } else {
            Shape::Asymmetric { ratio: r }
        }
    }

    /// `J_min / J_max`.
    pub fn inertia_ratio(self) -> f64 {
        match self {
            Shape::Isotropic => 1.0,
            Shape::Asymmetric { ratio } => ratio,
            Shape::FlatDisk => 0.5,
        }
    }

    /// Principal moments, kg m^2 (`J_max = 1`).
    pub fn moments(self) -> Vector3<f64> {
        match self {
            Shape::Isotropic => Vector3::new(1.0, 1.0, 1.0),
            Shape::Asymmetric { ratio } => Vector3::new(ratio, 1.0 - ratio / 2.0, 1.0),
            Shape::FlatDisk => Vector3::new(0.5, 0.5, 1.0),
        }
    }

    /// The `shape` column.
    pub fn name(self) -> &'static str {
        match self {
            Shape::Isotropic => "isotropic",
            Shape::Asymmetric { .. } => "asymmetric",
            Shape::FlatDisk => "flat-disk",
        }
    }

    /// A short label for the plot's rows.
    pub fn label(self) -> String {
        match self {
            Shape::Isotropic => "isotropic".to_string(),
            Shape::Asymmetric { ratio } => format!("r = {ratio:?}"),
            Shape::FlatDisk => "disk (½,½,1)".to_string(),
        }
    }
}

/// Direction of the initial body-frame angular velocity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpinAxis {
    /// `Ω_0 ∝ (1, 1, 1)`.
    Generic,
    /// `Ω_0 ∝ (0.01, 1, 0.01)`: next to the intermediate axis, on a wide orbit near the
    /// separatrix (the Dzhanibekov flip).
    NearIntermediate,
}

impl SpinAxis {
    pub const ALL: [SpinAxis; 2] = [SpinAxis::Generic, SpinAxis::NearIntermediate];

    /// The `spin_axis` column.
    pub fn name(self) -> &'static str {
        match self {
            SpinAxis::Generic => "generic",
            SpinAxis::NearIntermediate => "near-intermediate",
        }
    }

    /// Unit direction in the body (principal) frame.
    pub fn direction(self) -> Vector3<f64> {
        match self {
            SpinAxis::Generic => Vector3::new(1.0, 1.0, 1.0),
            SpinAxis::NearIntermediate => Vector3::new(0.01, 1.0, 0.01),
        }
        .normalize()
    }
}

/// One cell of the map (the integrator aside).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    pub shape: Shape,
    pub spin_axis: SpinAxis,
    /// `h|Ω|max`, rad; also the step in seconds, since `|Ω|max = 1 rad/s`.
    pub h_omega: f64,
}

impl Cell {
    /// The initial body-frame angular velocity, rad/s: along the spin axis, scaled so that the
    /// largest `|Ω|` on the exact orbit ([`spin_rate_max`]) is 1 rad/s.
    pub fn angvel_body(&self) -> Vector3<f64> {
        let j = self.shape.moments();
        let d = self.spin_axis.direction();
        d / spin_rate_max(&j, &j.component_mul(&d))
    }

    /// `clamp(ceil(TURNS · 2π / h_omega), STEPS_MIN, STEPS_MAX)`.
    pub fn steps(&self) -> u64 {
        let n = (TURNS * std::f64::consts::TAU / self.h_omega).ceil();
        if n.is_finite() {
            (n as u64).clamp(STEPS_MIN, STEPS_MAX)
        } else {
            STEPS_MAX
        }
    }
}

/// How a cell ended, from best to worst (the derived `Ord` is that order; a cell's status is
/// the worst that applies).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Status {
    /// No substeps, no failure, `energy_err_max <= ENERGY_ERROR_BOUND`.
    Ok,
    /// Ran to the end without substeps, energy error above the bound.
    Inaccurate,
    /// Newton needed substeps at least once; the run finished.
    Substepped,
    /// Newton failed even at `max_substeps`; the guard stopped the run.
    NewtonFailed,
    /// The guard stopped the run: a non-finite state or energy growth past its ratio.
    Diverged,
}

impl Status {
    pub const ALL: [Status; 5] = [
        Status::Ok,
        Status::Inaccurate,
        Status::Substepped,
        Status::NewtonFailed,
        Status::Diverged,
    ];

    /// The `status` column.
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Inaccurate => "inaccurate",
            Status::Substepped => "substepped",
            Status::NewtonFailed => "newton-failed",
            Status::Diverged => "diverged",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }

    /// The letter marking the cell on the heat map (none for `ok` and `inaccurate`: the
    /// colour scale shows the latter).
    pub fn mark(self) -> Option<&'static str> {
        match self {
            Status::Ok | Status::Inaccurate => None,
            Status::Substepped => Some("S"),
            Status::NewtonFailed => Some("F"),
            Status::Diverged => Some("D"),
        }
    }
}

/// The result of one integrator on one cell.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub integrator: IntegratorKind,
    pub cell: Cell,
    /// Steps planned ([`Cell::steps`]).
    pub steps: u64,
    /// Steps completed before the guard stopped the run (= `steps` when it did not).
    pub steps_done: u64,
    /// Largest Newton iteration count of any solve (0 for explicit schemes).
    pub newton_iters_max: u32,
    /// Body-steps split into substeps (a composition counts each of its stages).
    pub substeps: u64,
    /// Largest split factor used (0 when none).
    pub substep_factor_max: u32,
    /// `max_k |T_k - T_0| / T_0`; see the module documentation for stopped runs.
    pub energy_err_max: f64,
    pub status: Status,
}

/// The axes of a map.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Increasing.
    pub h_omegas: Vec<f64>,
    /// Rows of the heat map, top to bottom.
    pub shapes: Vec<Shape>,
    pub spin_axes: Vec<SpinAxis>,
}

impl Grid {
    /// The full map: [`H_OMEGA_FULL`] × ([`INERTIA_RATIOS_FULL`] + flat disk) × both axes.
    pub fn full() -> Self {
        Self::with(&H_OMEGA_FULL, &INERTIA_RATIOS_FULL)
    }

    /// A coarser map for a quick look (`--quick`): [`H_OMEGA_QUICK`] ×
    /// ([`INERTIA_RATIOS_QUICK`] + flat disk) × both axes, a subset of the full map. Its
    /// derived limits are indicative only: fewer step sizes and fewer shapes.
    pub fn quick() -> Self {
        Self::with(&H_OMEGA_QUICK, &INERTIA_RATIOS_QUICK)
    }

    fn with(h_omegas: &[f64], ratios: &[f64]) -> Self {
        let mut shapes: Vec<Shape> = ratios.iter().map(|&r| Shape::from_ratio(r)).collect();
        // The disk sits next to its ratio's asymmetric row.
        let at = shapes
            .iter()
            .position(|s| s.inertia_ratio() < 0.5)
            .unwrap_or(shapes.len());
        shapes.insert(at, Shape::FlatDisk);
        Self {
            h_omegas: h_omegas.to_vec(),
            shapes,
            spin_axes: SpinAxis::ALL.to_vec(),
        }
    }

    /// Every cell, ordered by spin axis, shape, then `h_omega`.
    pub fn cells(&self) -> Vec<Cell> {
        let mut cells = Vec::new();
        for &spin_axis in &self.spin_axes {
            for &shape in &self.shapes {
                for &h_omega in &self.h_omegas {
                    cells.push(Cell {
                        shape,
                        spin_axis,
                        h_omega,
                    });
                }
            }
        }
        cells
    }
}

/// Runs every integrator of `kinds` on every cell of `grid` on `threads` worker threads (at
/// least one). Rows come back ordered by integrator (in `kinds` order), then as
/// [`Grid::cells`]; the result does not depend on `threads`.
pub fn sweep(grid: &Grid, kinds: &[IntegratorKind], threads: usize) -> Vec<Row> {
    let cells = grid.cells();
    let jobs: Vec<(IntegratorKind, Cell)> = kinds
        .iter()
        .flat_map(|&k| cells.iter().map(move |&c| (k, c)))
        .collect();
    let next = AtomicUsize::new(0);
    let done: Mutex<Vec<Option<Row>>> = Mutex::new(vec![None; jobs.len()]);
    std::thread::scope(|scope| {
        for _ in 0..threads.max(1) {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&(kind, cell)) = jobs.get(i) else {
                        break;
                    };
                    let row = run_cell(kind, cell);
                    if let Ok(mut done) = done.lock() {
                        done[i] = Some(row);
                    }
                }
            });
        }
    });
    done.into_inner()
        .unwrap_or_default()
        .into_iter()
        .flatten()
        .collect()
}

/// Worker threads for [`sweep`]: the machine's available parallelism.
pub fn default_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The grid values of `h_omega` in `rows` for `kind`, increasing.
fn h_omegas_of(rows: &[Row], kind: IntegratorKind) -> Vec<f64> {
    let mut hs: Vec<f64> = rows
        .iter()
        .filter(|r| r.integrator == kind)
        .map(|r| r.cell.h_omega)
        .collect();
    hs.sort_by(f64::total_cmp);
    hs.dedup();
    hs
}

/// The derived limit of `kind`: the largest grid `h_omega` such that every row of `kind` with
/// `h_omega` at or below it (every shape and spin axis in `rows`) has status [`Status::Ok`].
/// `None` when even the smallest `h_omega` has a cell that is not `ok` (or `kind` has no rows).
pub fn derived_limit(rows: &[Row], kind: IntegratorKind) -> Option<f64> {
    let mut limit = None;
    for h in h_omegas_of(rows, kind) {
        let all_ok = rows
            .iter()
            .filter(|r| r.integrator == kind && r.cell.h_omega == h)
            .all(|r| r.status == Status::Ok);
        if !all_ok {
            break;
        }
        limit = Some(h);
    }
    limit
}

/// [`derived_limit`] over the rows of one inertia ratio (`J_min / J_max`; at 0.5 the flat disk
/// and the asymmetric body together): the entries of [`crate::sim::limits::LIMITS_BY_RATIO`].
pub fn derived_limit_at_ratio(
    rows: &[Row],
    kind: IntegratorKind,
    inertia_ratio: f64,
) -> Option<f64> {
    let subset: Vec<Row> = rows
        .iter()
        .filter(|r| r.cell.shape.inertia_ratio() == inertia_ratio)
        .cloned()
        .collect();
    derived_limit(&subset, kind)
}

/// The first grid `h_omega` above the derived limit of `kind` and its worst row (the one that
/// sets the limit), if the map goes that far.
pub fn limiting_row(rows: &[Row], kind: IntegratorKind) -> Option<&Row> {
    let limit = derived_limit(rows, kind);
    let next = h_omegas_of(rows, kind)
        .into_iter()
        .find(|&h| limit.is_none_or(|l| h > l))?;
    rows.iter()
        .filter(|r| r.integrator == kind && r.cell.h_omega == next)
        .max_by(|a, b| {
            a.status
                .cmp(&b.status)
                .then(a.energy_err_max.total_cmp(&b.energy_err_max))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_cover_ten_turns_within_the_caps() {
        let cell = |h_omega| Cell {
            shape: Shape::Isotropic,
            spin_axis: SpinAxis::Generic,
            h_omega,
        };
        assert_eq!(cell(1e-9).steps(), STEPS_MAX);
        assert_eq!(cell(0.01).steps(), 6284); // ceil(20π / 0.01) = ceil(6283.19)
        assert_eq!(cell(0.1).steps(), 629);
        assert_eq!(cell(6.0).steps(), STEPS_MIN);
    }

    #[test]
    fn shapes_are_physical() {
        for r in INERTIA_RATIOS_FULL {
            let j = Shape::from_ratio(r).moments();
            let (lo, hi) = (j.min(), j.max());
            assert_eq!(hi, 1.0);
            assert_eq!(lo, r);
            // Triangle inequality J_1 + J_2 >= J_3 (each pair against the third).
            assert!(j[0] + j[1] >= j[2] && j[1] + j[2] >= j[0] && j[0] + j[2] >= j[1]);
        }
        let disk = Shape::FlatDisk.moments();
        assert_eq!(disk[0] + disk[1], disk[2]);
    }

    #[test]
    fn grid_puts_the_disk_next_to_its_ratio() {
        let names: Vec<String> = Grid::full().shapes.iter().map(|s| s.label()).collect();
        assert_eq!(
            names[..4],
            ["isotropic", "r = 0.5", "disk (½,½,1)", "r = 0.1"]
        );
        assert_eq!(Grid::full().cells().len(), 17 * 8 * 2);
    }

    fn row(h_omega: f64, status: Status) -> Row {
        Row {
            integrator: IntegratorKind::Rk4,
            cell: Cell {
                shape: Shape::Isotropic,
                spin_axis: SpinAxis::Generic,
                h_omega,
            },
            steps: 200,
            steps_done: 200,
            newton_iters_max: 0,
            substeps: 0,
            substep_factor_max: 0,
            energy_err_max: 0.0,
            status,
        }
    }

    /// The limit is the end of the leading run of all-ok columns, not the largest ok cell.
    #[test]
    fn derived_limit_stops_at_the_first_bad_column() {
        let rows = [
            row(0.1, Status::Ok),
            row(0.2, Status::Ok),
            row(0.2, Status::Inaccurate),
            row(0.3, Status::Ok),
            row(1e-3, Status::Ok),
        ];
        let k = IntegratorKind::Rk4;
        assert_eq!(derived_limit(&rows, k), Some(0.1));
        assert_eq!(limiting_row(&rows, k).unwrap().status, Status::Inaccurate);
        assert_eq!(derived_limit(&rows[2..3], k), None);
        assert_eq!(derived_limit(&rows, IntegratorKind::Euler), None);
        assert!(limiting_row(&rows, IntegratorKind::Euler).is_none());
    }
}
