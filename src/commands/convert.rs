//! `tumble convert LOG.mcap --rrd OUT.rrd`: a tumble recording replayed into Rerun with the
//! entity layout of a fresh run ([`crate::replay::convert`]). A truncated MCAP gives every
//! complete step with a warning saying what was lost (exit 0; `--strict` makes it exit 1).

use crate::fsutil::check_not_overwriting;
use crate::record::rerun::RerunOptions;
use crate::replay::convert;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct ConvertArgs {
    /// A recording written by `tumble simulate` (or `trade`).
    pub mcap: PathBuf,
    /// The Rerun recording to write.
    #[arg(long, value_name = "OUT.rrd")]
    pub rrd: PathBuf,
    /// Replace OUT.rrd if it exists.
    #[arg(long)]
    pub force: bool,
    /// Leave the inertia ellipsoids out (as `simulate --no-ellipsoids`; the default when a model
    /// has meshes).
    #[arg(long, conflicts_with = "ellipsoids")]
    pub no_ellipsoids: bool,
    /// Write the inertia ellipsoids even though a model has meshes (as `simulate --ellipsoids`).
    #[arg(long)]
    pub ellipsoids: bool,
    /// Exit 1 when the MCAP was truncated (the readable part is still converted).
    #[arg(long)]
    pub strict: bool,
}

/// Converts; `Ok(false)` when `--strict` and the input was truncated.
pub fn run(args: &ConvertArgs) -> anyhow::Result<bool> {
    check_not_overwriting(&args.rrd, args.force)?;
    let choice = super::simulate::ellipsoids_choice(args.ellipsoids, args.no_ellipsoids);
    let report = convert::convert_with(&args.mcap, &args.rrd, |layout| RerunOptions {
        ellipsoids: choice.unwrap_or_else(|| layout.default_ellipsoids()),
    })?;
    if let Some(t) = &report.truncation {
        eprintln!("warning: {t}");
    }
    if report.incomplete_steps > 0 {
        eprintln!(
            "warning: {} step(s) had only part of their messages and were left out",
            report.incomplete_steps
        );
    }
    println!(
        "wrote {}: {} steps, t = {} .. {} s",
        args.rrd.display(),
        report.steps,
        report.time_range_ns.0 as f64 / 1e9,
        report.time_range_ns.1 as f64 / 1e9
    );
    Ok(!(args.strict && report.truncation.is_some()))
}
