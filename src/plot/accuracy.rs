//! The validation plot of the accuracy model (docs/accuracy.md): achieved against predicted
//! orientation error, log-log, one colour per integrator, with the line `achieved = predicted`
//! and the band the tests rely on.

use super::{FONT, atomically, draw_err, ensure_font};
use plotters::prelude::*;
use std::path::Path;

/// One validation case.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    pub integrator: String,
    /// rad
    pub predicted: f64,
    /// rad
    pub achieved: f64,
}

const SIZE: (u32, u32) = (900, 800);
const COLOURS: [RGBColor; 3] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
];

/// Writes the PNG (cases with an error below 1e-13, round-off, are left out: they carry no
/// information about the model).
pub fn validation(png: &Path, points: &[Point]) -> anyhow::Result<()> {
    ensure_font()?;
    let shown: Vec<&Point> = points
        .iter()
        .filter(|p| p.predicted > 1e-13 && p.achieved > 1e-13)
        .collect();
    let lo = shown
        .iter()
        .flat_map(|p| [p.predicted, p.achieved])
        .fold(f64::INFINITY, f64::min)
        .log10()
        .floor();
    let hi = shown
        .iter()
        .flat_map(|p| [p.predicted, p.achieved])
        .fold(0.0, f64::max)
        .log10()
        .ceil();
    let (lo, hi) = (10f64.powf(lo), 10f64.powf(hi));
    let mut names: Vec<&str> = shown.iter().map(|p| p.integrator.as_str()).collect();
    names.dedup();
    atomically(png, |path| {
        let root = BitMapBackend::new(path, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "accuracy model: achieved vs predicted orientation error",
                (FONT, 22),
            )
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d((lo..hi).log_scale(), (lo..hi).log_scale())
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("predicted error, rad (pilot, k = 1)")
            .y_desc("achieved error, rad (exact torque-free motion)")
            .label_style((FONT, 15))
            .x_label_formatter(&|v| format!("{v:.0e}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(draw_err)?;
        for (factor, style) in [
            (1.0, BLACK.stroke_width(2)),
            (0.01, BLACK.mix(0.4).stroke_width(1)),
        ] {
            chart
                .draw_series(LineSeries::new(
                    [(lo, lo * factor), (hi, hi * factor)],
                    style,
                ))
                .map_err(draw_err)?
                .label(if factor == 1.0 {
                    "achieved = predicted"
                } else {
                    "achieved = predicted / 100"
                })
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], style));
        }
        for (i, name) in names.iter().enumerate() {
            let colour = COLOURS[i % COLOURS.len()];
            chart
                .draw_series(
                    shown
                        .iter()
                        .filter(|p| p.integrator == *name)
                        .map(|p| Circle::new((p.predicted, p.achieved), 3, colour.filled())),
                )
                .map_err(draw_err)?
                .label(*name)
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, colour.filled()));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font((FONT, 15))
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(draw_err)?;
        root.present().map_err(draw_err)?;
        Ok(())
    })
}
