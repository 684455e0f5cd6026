//! Work-precision and energy-error plots (PNG and SVG, drawn with `plotters`).
//!
//! Fonts and atomic writes are [`crate::plot`]'s. Errors of exactly 0 cannot sit on a log axis:
//! they are drawn at [`FLOOR`] and the caption says so.

use super::{EnergySeries, TradeRow};
pub(crate) use crate::plot::{FONT, atomically, draw_err, ensure_font};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Smallest value drawn on a log axis; exact zeros are drawn here.
pub const FLOOR: f64 = 1e-17;

const SIZE: (u32, u32) = (1400, 620);

fn colour(i: usize) -> RGBColor {
    const COLOURS: [RGBColor; 8] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(23, 190, 207),
    ];
    COLOURS[i % COLOURS.len()]
}

/// `|v|` raised to [`FLOOR`]; NaN for a diverged value (not drawn).
fn floor(v: f64) -> f64 {
    if v.is_finite() {
        v.abs().max(FLOOR)
    } else {
        f64::NAN
    }
}

/// Log range covering `values` with some margin.
fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0_f64);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return FLOOR..1.0;
    }
    if hi <= lo * 1.0001 {
        hi = lo * 10.0;
    }
    lo / 2.0..hi * 2.0
}

/// Integrator names in first-appearance order.
fn integrators(rows: &[TradeRow]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for r in rows {
        if !names.contains(&r.integrator) {
            names.push(r.integrator.clone());
        }
    }
    names
}

/// One log-log panel: `error(row)` against cost, one line per integrator (points in dt order).
fn error_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    rows: &[TradeRow],
    title: &str,
    y_label: &str,
    error: impl Fn(&TradeRow) -> f64,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let x_range = log_range(rows.iter().map(TradeRow::cost_secs_per_sim_sec));
    let y_range = log_range(rows.iter().map(|r| floor(error(r))));
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 22))
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(78)
        .build_cartesian_2d(x_range.log_scale(), y_range.log_scale())
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_labels(5)
        .y_labels(8)
        .x_desc("cost: wall time per simulated second per body [s]")
        .y_desc(y_label)
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 17))
        .draw()
        .map_err(draw_err)?;
    for (i, name) in integrators(rows).iter().enumerate() {
        let mut points: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| &r.integrator == name)
            .map(|r| (r.cost_secs_per_sim_sec(), floor(error(r))))
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .collect();
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let c = colour(i);
        chart
            .draw_series(LineSeries::new(points.clone(), c.stroke_width(2)))
            .map_err(draw_err)?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(3)));
        chart
            .draw_series(points.iter().map(|&p| Circle::new(p, 4, c.filled())))
            .map_err(draw_err)?;
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(draw_err)?;
    Ok(())
}

fn work_precision_on<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    rows: &[TradeRow],
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(draw_err)?;
    let (left, right) = root.split_horizontally(SIZE.0 / 2);
    error_panel(
        &left,
        rows,
        "orientation error at the end",
        "rot_err [rad]",
        |r| r.rot_err,
    )?;
    error_panel(
        &right,
        rows,
        "largest energy error",
        "energy_err_max [J]",
        |r| r.energy_err_max,
    )?;
    root.present().map_err(draw_err)?;
    Ok(())
}

fn energy_on<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    series: &[EnergySeries],
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(draw_err)?;
    let t_max = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .fold(0.0, f64::max)
        .max(1e-9);
    let y_range = log_range(
        series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| floor(p.1))),
    );
    let dt = series.first().map_or(0.0, |s| s.dt);
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("energy error |E(t) - E(0)| at dt = {dt} s (zeros drawn at {FLOOR:.0e})"),
            (FONT, 22),
        )
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(78)
        .build_cartesian_2d(0.0..t_max, y_range.log_scale())
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("simulated time [s]")
        .y_desc("|E(t) - E(0)| [J]")
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 17))
        .draw()
        .map_err(draw_err)?;
    for (i, s) in series.iter().enumerate() {
        let c = colour(i);
        chart
            .draw_series(LineSeries::new(
                s.points
                    .iter()
                    .map(|&(t, de)| (t, floor(de)))
                    .take_while(|p| p.1.is_finite()),
                c.stroke_width(1),
            ))
            .map_err(draw_err)?
            .label(s.integrator.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(3)));
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerRight)
        .draw()
        .map_err(draw_err)?;
    root.present().map_err(draw_err)?;
    Ok(())
}

/// `work_precision.png` and `.svg`: error against cost, log-log, one line per integrator.
pub fn work_precision(png: &Path, svg: &Path, rows: &[TradeRow]) -> anyhow::Result<()> {
    ensure_font()?;
    atomically(png, |p| {
        work_precision_on(BitMapBackend::new(p, SIZE).into_drawing_area(), rows)
    })?;
    atomically(svg, |p| {
        work_precision_on(SVGBackend::new(p, SIZE).into_drawing_area(), rows)
    })
}

/// `energy.png` (and `.svg`): energy error against time, one line per integrator.
pub fn energy(png: &Path, svg: &Path, series: &[EnergySeries]) -> anyhow::Result<()> {
    ensure_font()?;
    atomically(png, |p| {
        energy_on(BitMapBackend::new(p, SIZE).into_drawing_area(), series)
    })?;
    atomically(svg, |p| {
        energy_on(SVGBackend::new(p, SIZE).into_drawing_area(), series)
    })
}
