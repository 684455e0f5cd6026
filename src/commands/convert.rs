//! `tumble convert LOG.mcap --rrd OUT.rrd`: a tumble recording replayed into Rerun with the
//! entity layout of a fresh run ([`crate::replay::convert`]). A truncated MCAP gives every
//! complete step with a warning saying what was lost (exit 0; `--strict` makes it exit 1).

use crate::fsutil::check_not_overwriting;
use crate::record::rerun::RerunOptions;
use crate::replay::convert;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct ConvertArgs {
    /// A recording written by `tumble simulate` (or `trade`); with --lerobot, a dataset folder
    /// written by `tumble dataset`.
    pub mcap: PathBuf,
    /// The Rerun recording to write.
    #[arg(long, value_name = "OUT.rrd", required_unless_present = "lerobot")]
    pub rrd: Option<PathBuf>,
    /// Convert the dataset folder given (instead of a recording) into a LeRobot v3.0 dataset in
    /// OUT_DIR (meta/, data/; docs/datasets.md). OUT_DIR may be the dataset folder itself.
    #[arg(long, value_name = "OUT_DIR", conflicts_with = "rrd")]
    pub lerobot: Option<PathBuf>,
    /// Replace OUT.rrd (or OUT_DIR's meta/ and data/) if it exists.
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
    if let Some(out) = &args.lerobot {
        return run_lerobot(args, out);
    }
    let Some(rrd) = &args.rrd else {
        anyhow::bail!("usage: tumble convert LOG.mcap --rrd OUT.rrd (see --help)");
    };
    check_not_overwriting(rrd, args.force)?;
    let choice = super::simulate::ellipsoids_choice(args.ellipsoids, args.no_ellipsoids);
    let report = convert::convert_with(&args.mcap, rrd, |layout| RerunOptions {
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
        rrd.display(),
        report.steps,
        report.time_range_ns.0 as f64 / 1e9,
        report.time_range_ns.1 as f64 / 1e9
    );
    Ok(!(args.strict && report.truncation.is_some()))
}

/// `tumble convert DATASET_DIR --lerobot OUT_DIR`.
fn run_lerobot(args: &ConvertArgs, out: &std::path::Path) -> anyhow::Result<bool> {
    let dir = &args.mcap;
    let dir = if dir.file_name().is_some_and(|n| n == "manifest.json") {
        dir.parent().map(|p| p.to_path_buf()).unwrap_or_default()
    } else {
        dir.clone()
    };
    let started = std::time::Instant::now();
    let summary = crate::dataset::lerobot::write(&crate::dataset::lerobot::Options {
        native: dir.clone(),
        out: out.to_path_buf(),
        force: args.force,
        base_dir: None,
        spec_name: format!("the spec of {}", dir.join("manifest.json").display()),
    })?;
    println!(
        "{}",
        super::dataset::lerobot_line(&summary, out, started.elapsed().as_secs_f64())
    );
    Ok(true)
}
