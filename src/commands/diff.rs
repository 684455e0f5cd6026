//! `tumble diff A.mcap B.mcap`: per-frame position and orientation error over time between two
//! recordings ([`crate::replay::diff`]), and per joint the position difference
//! ([`crate::replay::joint_diff`]). Exit 0 when the errors are within the tolerances (and
//! the two have the same frames and time span), 1 when not, 2 on an error.

use crate::fsutil::check_not_overwriting;
use crate::replay::diff::{self, DiffReport, DiffSettings, JointsReport};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct DiffArgs {
    /// The first recording (its frame order is the report's).
    pub a: PathBuf,
    /// The second recording.
    pub b: PathBuf,
    /// Largest error still counted as equal, for both position (m) and orientation (rad).
    /// Default 0: any difference makes the exit status 1.
    #[arg(long, value_name = "T", value_parser = parse_tolerance)]
    pub tolerance: Option<f64>,
    /// Position tolerance, m (overrides --tolerance for positions).
    #[arg(long, value_name = "METRES", value_parser = parse_tolerance)]
    pub pos_tolerance: Option<f64>,
    /// Orientation tolerance, rad (overrides --tolerance for orientations).
    #[arg(long, value_name = "RADIANS", value_parser = parse_tolerance)]
    pub rot_tolerance: Option<f64>,
    /// Print {"pos_err_max", "rot_err_max", "bodies": [{"name", "pos_err_max", "rot_err_max",
    /// "pos_err_rms", "rot_err_rms", ...}], ...} (metres, radians).
    #[arg(long)]
    pub json: bool,
    /// Also write both runs overlaid (a blue, b orange) and the error series to this .rrd.
    #[arg(long, value_name = "OUT.rrd")]
    pub rrd: Option<PathBuf>,
    /// Replace OUT.rrd if it exists.
    #[arg(long)]
    pub force: bool,
    /// Topic of the frame transforms in both files.
    #[arg(long, default_value = "/tf")]
    pub topic: String,
    /// Topic of the joint states in both files (tumble's protobuf `tumble.JointStates` or ROS 2
    /// `sensor_msgs/msg/JointState`). Default: each file's `/joints`, else `/joint_states`.
    #[arg(long, value_name = "TOPIC")]
    pub joint_topic: Option<String>,
    /// Largest joint position difference still counted as equal, rad or m. Without it the
    /// joints are reported but judged only when no frames are compared (then against 0).
    #[arg(long, value_name = "T", value_parser = parse_tolerance)]
    pub joint_tolerance: Option<f64>,
    /// Take each file's joint times from its first joints message (the clock a scene's `log`
    /// signal reads a log on): a run against the log that drove it.
    #[arg(long)]
    pub zero_start: bool,
}

fn parse_tolerance(s: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|e| format!("{s:?}: {e}"))?;
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("must be a finite number >= 0, got {s}"))
    }
}

/// Compares and prints; `Ok(false)` when the runs differ beyond the tolerances.
pub fn run(args: &DiffArgs) -> anyhow::Result<bool> {
    if let Some(rrd) = &args.rrd {
        check_not_overwriting(rrd, args.force)?;
    }
    let both = args.tolerance.unwrap_or(0.0);
    let settings = DiffSettings {
        topic: args.topic.clone(),
        pos_tolerance_m: args.pos_tolerance.unwrap_or(both),
        rot_tolerance_rad: args.rot_tolerance.unwrap_or(both),
        joint_topic: args.joint_topic.clone(),
        joint_tolerance: args.joint_tolerance,
        joint_zero_start: args.zero_start,
    };
    let report = diff::diff(&args.a, &args.b, &settings, args.rrd.as_deref())?;
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", text(&report));
    }
    Ok(report.within_tolerance)
}

fn text(r: &DiffReport) -> String {
    let mut out = format!(
        "a: {} ({} samples, {} .. {} s, integrator {}, dt {})\nb: {} ({} samples, {} .. {} s, integrator {}, dt {})\n",
        r.a.path.display(),
        r.a.samples,
        r.a.time_start,
        r.a.time_end,
        r.a.integrator.as_deref().unwrap_or("?"),
        r.a.dt.as_deref().unwrap_or("?"),
        r.b.path.display(),
        r.b.samples,
        r.b.time_start,
        r.b.time_end,
        r.b.integrator.as_deref().unwrap_or("?"),
        r.b.dt.as_deref().unwrap_or("?"),
    );
    if r.frames_compared {
        out.push_str(&frames_text(r));
    }
    if let Some(j) = &r.joints {
        out.push_str(&joints_text(j));
    }
    out
}

fn frames_text(r: &DiffReport) -> String {
    let mut out = format!(
        "compared {} samples on {} .. {} s, aligned on {}{}\n",
        r.samples_compared,
        r.time_start,
        r.time_end,
        r.aligned_on,
        if r.interpolated > 0 {
            format!(" ({} poses interpolated)", r.interpolated)
        } else {
            String::new()
        }
    );
    out.push_str(&format!(
        "{:<28} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12}\n",
        "frame", "pos_max_m", "pos_rms_m", "pos_end_m", "rot_max_rad", "rot_rms_rad", "rot_end_rad"
    ));
    for b in &r.bodies {
        out.push_str(&format!(
            "{:<28} {:>12.4e} {:>12.4e} {:>12.4e} {:>12.4e} {:>12.4e} {:>12.4e}\n",
            b.name,
            b.pos_err_max,
            b.pos_err_rms,
            b.pos_err_end,
            b.rot_err_max,
            b.rot_err_rms,
            b.rot_err_end
        ));
    }
    for (side, names) in [("a", &r.unmatched_a), ("b", &r.unmatched_b)] {
        if !names.is_empty() {
            out.push_str(&format!("only in {side}: {}\n", names.join(", ")));
        }
    }
    out.push_str(&format!(
        "max position error {:.4e} m (tolerance {:e}), max orientation error {:.4e} rad (tolerance {:e}): {}\n",
        r.pos_err_max,
        r.pos_tolerance,
        r.rot_err_max,
        r.rot_tolerance,
        if r.frames_within_tolerance {
            "same"
        } else {
            "DIFFERENT"
        }
    ));
    out
}

fn joints_text(j: &JointsReport) -> String {
    let mut out = format!(
        "joints ({} in a, {} in b): compared {} samples on {} .. {} s, aligned on {}{}\n",
        j.topic_a,
        j.topic_b,
        j.samples_compared,
        j.time_start,
        j.time_end,
        j.aligned_on,
        if j.interpolated > 0 {
            format!(" ({} positions interpolated)", j.interpolated)
        } else {
            String::new()
        }
    );
    out.push_str(&format!(
        "{:<28} {:>12} {:>12} {:>12} {:>12}\n",
        "joint", "max", "max_at_s", "rms", "end"
    ));
    for d in &j.joints {
        out.push_str(&format!(
            "{:<28} {:>12.4e} {:>12} {:>12.4e} {:>12.4e}\n",
            d.name, d.err_max, d.err_max_time, d.err_rms, d.err_end
        ));
    }
    for (side, names) in [("a", &j.unmatched_a), ("b", &j.unmatched_b)] {
        if !names.is_empty() {
            out.push_str(&format!("joints only in {side}: {}\n", names.join(", ")));
        }
    }
    out.push_str(&format!(
        "max joint difference {:.4e} (rad or m){}\n",
        j.err_max,
        match (j.tolerance, j.within_tolerance) {
            (Some(t), Some(ok)) => format!(
                " (tolerance {t:e}): {}",
                if ok { "same" } else { "DIFFERENT" }
            ),
            _ => ", not judged (--joint-tolerance to judge it)".to_string(),
        }
    ));
    out
}
