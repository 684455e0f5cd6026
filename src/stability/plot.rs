//! `stability.png`: the map as heat maps, one panel per integrator (rows) and spin axis
//! (columns). In a panel, x is `h|Ω|` (one column per grid value, log-spaced), y the shape
//! (isotropic at the top, then decreasing `J_min / J_max`), colour `log10 energy_err_max`:
//! blues and greens at or below the bound `ENERGY_ERROR_BOUND` = 1e-2, orange to red above it
//! (clamped at 1, i.e. 100 %); exact zeros are drawn at 1e-16. Letters mark
//! `S` substepped, `F` Newton failed, `D` diverged (grey cell). A black vertical line closes
//! the derived limit ([`super::derived_limit`]) of the panel's integrator. The font comes from
//! [`crate::trade::plot`] (`$TUMBLE_FONT` or the usual system locations).

use super::{Grid, Row, Status, derived_limit};
use crate::plot::{FONT, atomically, draw_err, ensure_font};
use crate::sim::IntegratorKind;
use crate::sim::limits::ENERGY_ERROR_BOUND;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// Bottom of the colour scale: `log10` of the smallest error drawn (round-off is ~1e-16).
pub const LOG_ERR_MIN: f64 = -16.0;
/// Top of the colour scale (100 % error and more).
pub const LOG_ERR_MAX: f64 = 0.0;

const PANEL: (u32, u32) = (780, 300);
const TITLE_HEIGHT: u32 = 70;
const COLOUR_BAR_WIDTH: u32 = 190;
const DIVERGED_GREY: RGBColor = RGBColor(110, 110, 110);

/// Colour stops `(log10 error, colour)` at and below the bound: dark blue to pale green.
const BELOW: [(f64, RGBColor); 5] = [
    (-16.0, RGBColor(37, 52, 148)),
    (-12.0, RGBColor(44, 127, 184)),
    (-8.0, RGBColor(65, 182, 196)),
    (-4.0, RGBColor(127, 205, 187)),
    (-2.0, RGBColor(214, 239, 179)),
];
/// Colour stops above the bound: orange to dark red.
const ABOVE: [(f64, RGBColor); 3] = [
    (-2.0, RGBColor(254, 178, 76)),
    (-1.0, RGBColor(240, 59, 32)),
    (0.0, RGBColor(150, 0, 38)),
];

fn lerp(stops: &[(f64, RGBColor)], v: f64) -> RGBColor {
    let v = v.clamp(stops[0].0, stops[stops.len() - 1].0);
    for w in stops.windows(2) {
        let ((a, ca), (b, cb)) = (w[0], w[1]);
        if v <= b {
            let t = if b > a { (v - a) / (b - a) } else { 0.0 };
            let mix =
                |x: u8, y: u8| (f64::from(x) + t * (f64::from(y) - f64::from(x))).round() as u8;
            return RGBColor(mix(ca.0, cb.0), mix(ca.1, cb.1), mix(ca.2, cb.2));
        }
    }
    stops[stops.len() - 1].1
}

/// The colour of `log10` of an error (clamped to the scale; NaN and +inf at the top).
pub fn colour_of_log(log_err: f64) -> RGBColor {
    let bound = ENERGY_ERROR_BOUND.log10();
    if log_err.is_nan() || log_err > bound {
        lerp(
            &ABOVE,
            if log_err.is_nan() {
                LOG_ERR_MAX
            } else {
                log_err
            },
        )
    } else {
        lerp(&BELOW, log_err)
    }
}

/// `log10 err`, zeros at [`LOG_ERR_MIN`].
fn log_err(err: f64) -> f64 {
    if err > 0.0 {
        err.log10().max(LOG_ERR_MIN)
    } else if err == 0.0 {
        LOG_ERR_MIN
    } else {
        f64::NAN
    }
}

/// Black on light cells, white on dark ones.
fn ink_on(c: RGBColor) -> &'static RGBColor {
    let luma = 0.299 * f64::from(c.0) + 0.587 * f64::from(c.1) + 0.114 * f64::from(c.2);
    if luma > 140.0 { &BLACK } else { &WHITE }
}

/// `h|Ω|` tick label.
fn h_label(h: f64) -> String {
    if h < 1e-3 {
        format!("{h:.0e}")
    } else {
        format!("{h}")
    }
}

/// Index of the grid value nearest to the axis coordinate `v`, when `v` is at a cell centre.
fn centre_index(v: f64, n: usize) -> Option<usize> {
    let i = v.round();
    ((v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < n).then_some(i as usize)
}

/// One panel: the rows of `kind` on `spin_axis`.
fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    grid: &Grid,
    rows: &[Row],
    kind: IntegratorKind,
    spin_axis: super::SpinAxis,
    limit: Option<f64>,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let (nx, ny) = (grid.h_omegas.len(), grid.shapes.len());
    let limit_text = limit.map_or_else(|| "none".to_string(), h_label);
    let dir = spin_axis.direction();
    let mut chart = ChartBuilder::on(area)
        .caption(
            format!(
                "{}, {} spin Ω0 ∝ ({:.2}, {:.2}, {:.2}): limit h|Ω| = {limit_text}",
                kind.name(),
                spin_axis.name(),
                dir.x / dir.y,
                1.0,
                dir.z / dir.y
            ),
            (FONT, 17),
        )
        .margin(8)
        .x_label_area_size(40)
        .y_label_area_size(100)
        .build_cartesian_2d(-0.5..nx as f64 - 0.5, -0.5..ny as f64 - 0.5)
        .map_err(draw_err)?;
    let shape_label = |v: &f64| {
        centre_index(*v, ny).map_or_else(String::new, |i| grid.shapes[ny - 1 - i].label())
    };
    let h_tick =
        |v: &f64| centre_index(*v, nx).map_or_else(String::new, |i| h_label(grid.h_omegas[i]));
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(nx)
        .y_labels(ny)
        .x_label_formatter(&h_tick)
        .y_label_formatter(&shape_label)
        .x_desc("h|Ω| [rad per step]")
        .y_desc("J_min / J_max")
        .label_style((FONT, 12))
        .axis_desc_style((FONT, 13))
        .draw()
        .map_err(draw_err)?;
    let mut cells = Vec::new();
    let mut marks = Vec::new();
    for r in rows
        .iter()
        .filter(|r| r.integrator == kind && r.cell.spin_axis == spin_axis)
    {
        let Some(ix) = grid.h_omegas.iter().position(|&h| h == r.cell.h_omega) else {
            continue;
        };
        let Some(iy) = grid.shapes.iter().position(|&s| s == r.cell.shape) else {
            continue;
        };
        let (x, y) = (ix as f64, (ny - 1 - iy) as f64);
        let fill = if r.status == Status::Diverged {
            DIVERGED_GREY
        } else {
            colour_of_log(log_err(r.energy_err_max))
        };
        cells.push(Rectangle::new(
            [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)],
            fill.filled(),
        ));
        if let Some(mark) = r.status.mark() {
            let style = TextStyle::from((FONT, 15).into_font())
                .color(ink_on(fill))
                .pos(Pos::new(HPos::Center, VPos::Center));
            marks.push(Text::new(mark, (x, y), style));
        }
    }
    chart.draw_series(cells).map_err(draw_err)?;
    chart.draw_series(marks).map_err(draw_err)?;
    if let Some(ix) = limit.and_then(|l| grid.h_omegas.iter().position(|&h| h == l)) {
        let x = ix as f64 + 0.5;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(x, -0.5), (x, ny as f64 - 0.5)],
                BLACK.stroke_width(3),
            )))
            .map_err(draw_err)?;
    }
    Ok(())
}

/// The colour bar and the legend of the marks.
fn colour_bar<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let (upper, lower) = area.split_vertically(area.dim_in_pixel().1 / 2);
    let mut chart = ChartBuilder::on(&upper)
        .caption("log10 energy_err_max", (FONT, 14))
        .margin(12)
        .margin_top(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..1.0, LOG_ERR_MIN..LOG_ERR_MAX + 0.5)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(9)
        .y_label_formatter(&|v| format!("{v:.0}"))
        .label_style((FONT, 12))
        .draw()
        .map_err(draw_err)?;
    let slices = 340;
    let span = LOG_ERR_MAX + 0.5 - LOG_ERR_MIN;
    chart
        .draw_series((0..slices).map(|k| {
            let lo = LOG_ERR_MIN + span * k as f64 / slices as f64;
            let hi = LOG_ERR_MIN + span * (k + 1) as f64 / slices as f64;
            Rectangle::new([(0.0, lo), (1.0, hi)], colour_of_log(lo).filled())
        }))
        .map_err(draw_err)?;
    let bound = ENERGY_ERROR_BOUND.log10();
    chart
        .draw_series(std::iter::once(PathElement::new(
            vec![(0.0, bound), (1.0, bound)],
            BLACK.stroke_width(2),
        )))
        .map_err(draw_err)?;
    let legend = [
        format!("— bound {ENERGY_ERROR_BOUND:.0e}"),
        "  (above: orange/red".to_string(),
        "   = inaccurate)".to_string(),
        "zeros drawn at 1e-16".to_string(),
        String::new(),
        "S  substepped".to_string(),
        "F  Newton failed".to_string(),
        "D  diverged (grey)".to_string(),
        "┃  derived limit".to_string(),
    ];
    for (i, line) in legend.iter().enumerate() {
        lower
            .draw(&Text::new(
                line.as_str(),
                (10, 10 + 22 * i as i32),
                (FONT, 14).into_font(),
            ))
            .map_err(draw_err)?;
    }
    Ok(())
}

fn heat_map_on<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    grid: &Grid,
    rows: &[Row],
    kinds: &[IntegratorKind],
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(draw_err)?;
    let (title, body) = root.split_vertically(TITLE_HEIGHT);
    title
        .draw(&Text::new(
            "tumble stability: largest relative energy error |T - T0| / T0 of torque-free motion, \
             |Ω|max = 1 rad/s on the exact orbit, ≈ 10 turns (200 to 20000 steps)",
            (16, 14),
            (FONT, 20).into_font(),
        ))
        .map_err(draw_err)?;
    title
        .draw(&Text::new(
            "rows: J_min/J_max, moments (r, 1 - r/2, 1); the disk is (½, ½, 1). \
             Limit: largest h|Ω| up to which every cell is ok (no substeps, error ≤ 1e-2).",
            (16, 42),
            (FONT, 15).into_font(),
        ))
        .map_err(draw_err)?;
    let (maps, bar) = body.split_horizontally(body.dim_in_pixel().0 - COLOUR_BAR_WIDTH);
    let panels = maps.split_evenly((kinds.len().max(1), grid.spin_axes.len().max(1)));
    for (k, &kind) in kinds.iter().enumerate() {
        let limit = derived_limit(rows, kind);
        for (a, &axis) in grid.spin_axes.iter().enumerate() {
            panel(
                &panels[k * grid.spin_axes.len() + a],
                grid,
                rows,
                kind,
                axis,
                limit,
            )?;
        }
    }
    colour_bar(&bar)?;
    root.present().map_err(draw_err)?;
    Ok(())
}

/// Writes the heat map of `rows` (measured on `grid` for `kinds`) to `png`.
pub fn heat_map(
    png: &Path,
    grid: &Grid,
    rows: &[Row],
    kinds: &[IntegratorKind],
) -> anyhow::Result<()> {
    ensure_font()?;
    let size = (
        PANEL.0 * grid.spin_axes.len().max(1) as u32 + COLOUR_BAR_WIDTH,
        TITLE_HEIGHT + PANEL.1 * kinds.len().max(1) as u32,
    );
    atomically(png, |p| {
        heat_map_on(
            BitMapBackend::new(p, size).into_drawing_area(),
            grid,
            rows,
            kinds,
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_split_at_the_bound() {
        let bound = ENERGY_ERROR_BOUND.log10();
        assert_eq!(colour_of_log(LOG_ERR_MIN - 5.0), BELOW[0].1);
        assert_eq!(colour_of_log(bound), BELOW[4].1);
        assert_eq!(colour_of_log(bound + 1e-9), ABOVE[0].1);
        assert_eq!(colour_of_log(f64::INFINITY), ABOVE[2].1);
        assert_eq!(colour_of_log(f64::NAN), ABOVE[2].1);
        assert_eq!(log_err(0.0), LOG_ERR_MIN);
        assert_eq!(centre_index(3.0, 4), Some(3));
        assert_eq!(centre_index(3.5, 4), None);
        assert_eq!(centre_index(4.0, 4), None);
    }
}
