//! `tumble trade [SCENE.toml] [--out DIR]`: the speed/accuracy trade of every integrator on one
//! scene (see [`crate::trade`]); writes `DIR/trade.csv`, `trade.json`, `work_precision.png`
//! and `.svg`, `energy.png` and `.svg`, `trade.rrd` and `trade.mcap`.

use crate::fsutil::write_atomic;
use crate::scene::Scene;
use crate::trade::{self, TradeSettings};
use anyhow::bail;
use std::path::{Path, PathBuf};

/// The bundled default scene of `trade`, relative to the repository root.
pub const DEFAULT_TRADE_SCENE: &str = "models/trade.toml";
/// Default step sizes, s.
pub const DEFAULT_DTS: [f64; 5] = [0.02, 0.01, 0.005, 0.0025, 0.00125];

#[derive(clap::Args, Debug, Clone, Default)]
pub struct TradeArgs {
    /// A scene file. Without it, the bundled `models/trade.toml` runs (an asymmetric box
    /// tumbling near its intermediate axis under gravity).
    pub scene: Option<PathBuf>,
    /// Output folder.
    #[arg(long, default_value = "logs/trade")]
    pub out: PathBuf,
    /// Step sizes to measure, s, comma-separated (each must divide the duration).
    #[arg(long = "dt", value_delimiter = ',', num_args = 1..)]
    pub dts: Vec<f64>,
    /// Integrators to measure, comma-separated (default: all).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub integrators: Vec<String>,
    /// Error horizon, s (default: the scene's duration).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Horizon of the energy-drift fit, s (default: 10 x the error horizon).
    #[arg(long)]
    pub drift_horizon: Option<f64>,
    /// Timed repeats per integrator and step size; the median is reported.
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
    /// Threads of the timed stepping loop (default: all cores; a scene of at most 256 bodies is
    /// stepped on one). The errors do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Replace the output files if they exist (without it, an existing output is an error).
    #[arg(long)]
    pub force: bool,
    /// Also print the cheapest measured integrator and step size whose orientation error stays
    /// within TOL rad (and position error within TOL x the smallest body's size) over the
    /// error horizon, and each integrator's cheapest (docs/accuracy.md).
    #[arg(long, value_name = "TOL")]
    pub accuracy: Option<f64>,
    /// Refuse the URDF oddities urdfdom loads instead of loading them with a warning; sets
    /// strict = true on every [[model]] (docs/urdf.md).
    #[arg(long)]
    pub strict: bool,
    /// Also read mesh files from DIR (repeatable). By default a mesh is read only when its real
    /// path (links resolved) is inside the URDF's folder (its parent for a folder named urdf, or
    /// the ROS package holding it), a package path, ROS_PACKAGE_PATH or the scene's folder; any
    /// other is refused (exit 2). Adds to every [[model]]'s allow_mesh_paths.
    #[arg(long = "allow-mesh-path", value_name = "DIR")]
    pub allow_mesh_paths: Vec<PathBuf>,
}

/// `path` if present, else its copy in the source tree the binary was built from.
fn bundled(path: &str) -> PathBuf {
    let local = PathBuf::from(path);
    if local.is_file() {
        local
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
    }
}

/// `dt` divides `secs` to 1e-9 relative.
fn divides(dt: f64, secs: f64) -> bool {
    let n = (secs / dt).round();
    n >= 1.0 && (n * dt - secs).abs() <= 1e-9 * secs
}

/// The scene and the settings the arguments ask for, validated.
pub fn settings_from_args(args: &TradeArgs) -> anyhow::Result<(Scene, TradeSettings)> {
    let path = args
        .scene
        .clone()
        .unwrap_or_else(|| bundled(DEFAULT_TRADE_SCENE));
    let mut scene = Scene::load(&path)?;
    if args.strict {
        scene.set_strict();
    }
    scene.allow_mesh_paths(&args.allow_mesh_paths)?;
    let integrators = super::parse_integrators(&args.integrators)?;
    let dts = if args.dts.is_empty() {
        DEFAULT_DTS.to_vec()
    } else {
        args.dts.clone()
    };
    let duration_secs = args.duration.unwrap_or(scene.sim.duration);
    let drift_horizon_secs = args.drift_horizon.unwrap_or(10.0 * duration_secs);
    if !(duration_secs.is_finite() && duration_secs > 0.0) {
        bail!(
            "--duration: the error horizon must be a positive number of seconds (got {duration_secs})"
        );
    }
    if !(drift_horizon_secs.is_finite() && drift_horizon_secs > 0.0) {
        bail!("--drift-horizon must be a positive number of seconds (got {drift_horizon_secs})");
    }
    if args.repeats == 0 {
        bail!("--repeats must be at least 1");
    }
    for &dt in &dts {
        if !(dt.is_finite() && dt > 0.0) {
            bail!("--dt: step sizes must be positive (got {dt})");
        }
        if !divides(dt, duration_secs) || !divides(dt, drift_horizon_secs) {
            bail!(
                "--dt {dt}: must divide the error horizon ({duration_secs} s) and the drift horizon ({drift_horizon_secs} s) into whole steps"
            );
        }
    }
    Ok((
        scene,
        TradeSettings {
            integrators,
            dts,
            duration_secs,
            drift_horizon_secs,
            repeats: args.repeats,
            threads: crate::commands::simulate::thread_count(args.threads)?,
            integrators_named: !args.integrators.is_empty(),
        },
    ))
}

/// The files `tumble trade` writes into its output folder.
pub const OUTPUT_FILES: [&str; 8] = [
    "trade.csv",
    "trade.json",
    "work_precision.png",
    "work_precision.svg",
    "energy.png",
    "energy.svg",
    "trade.rrd",
    "trade.mcap",
];

pub fn run(args: &TradeArgs) -> anyhow::Result<()> {
    let (scene, settings) = settings_from_args(args)?;
    if let Some(tol) = args.accuracy
        && !(tol.is_finite() && tol > 0.0)
    {
        bail!("--accuracy must be a positive number of radians (got {tol})");
    }
    for name in OUTPUT_FILES {
        crate::fsutil::check_not_overwriting(&args.out.join(name), args.force)?;
    }
    std::fs::create_dir_all(&args.out)
        .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", args.out.display()))?;
    println!(
        "trade on {}: {} integrators x {} step sizes, error horizon {} s, drift horizon {} s",
        scene.source.display(),
        settings.integrators.len(),
        settings.dts.len(),
        settings.duration_secs,
        settings.drift_horizon_secs
    );
    let report = trade::run(&scene, &settings, |row| {
        eprintln!("  measured {} at dt = {} s", row.integrator, row.dt);
    })?;
    for warning in &report.warnings {
        eprintln!("warning: {warning}");
    }
    for line in &report.skipped {
        println!("{line}");
    }
    println!("simulated bodies per run: {}", report.bodies);
    print!("{}", trade::output::table(&report.rows));
    println!(
        "orientation reference: {}; its own error ~ {:.1e} rad (rot_err below that is not resolved)",
        report.reference.method, report.reference.own_error_rad
    );
    if report.reference.com_world.is_some() {
        println!(
            "position reference: the same runs; its own error ~ {:.1e} m (pos_err below that is not resolved)",
            report.reference.own_error_m
        );
    }
    if let Some(tol) = args.accuracy {
        let world = scene.build()?;
        // The smallest body's size: the longest axis of its equivalent inertia ellipsoid.
        let size_m = world
            .layout
            .bodies
            .iter()
            .map(|b| 2.0 * b.inertia_ellipsoid_radii().max())
            .fold(f64::INFINITY, f64::min);
        print!(
            "{}",
            trade::choose::report(&report.rows, &trade::choose::Tolerance::new(tol, size_m))
        );
    }
    let out = &args.out;
    let file = |name: &str| out.join(name);
    write_atomic(
        &file("trade.csv"),
        trade::output::csv(&report.rows).as_bytes(),
    )?;
    write_atomic(
        &file("trade.json"),
        trade::output::json(
            &report,
            &scene.source.display().to_string(),
            settings.duration_secs,
            settings.drift_horizon_secs,
        )
        .as_bytes(),
    )?;
    trade::plot::work_precision(
        &file("work_precision.png"),
        &file("work_precision.svg"),
        &report.rows,
    )?;
    trade::plot::energy(
        &file("energy.png"),
        &file("energy.svg"),
        &report.energy_series,
    )?;
    let stopped = trade::recording::record(
        &scene,
        &report.integrators,
        report.series_dt,
        settings.duration_secs,
        &file("trade.rrd"),
        &file("trade.mcap"),
    )?;
    if let Some((kind, d, body)) = stopped {
        eprintln!(
            "warning: trade.rrd and trade.mcap end before step {} (t = {} s): {} failed on body {body:?} there: {}",
            d.step,
            crate::simulation::time_ns(d.step, report.series_dt) as f64 / 1e9,
            kind.name(),
            d.cause
        );
    }
    println!("wrote");
    for name in OUTPUT_FILES {
        println!("  {}", file(name).display());
    }
    println!(
        "replay every integrator side by side (dt = {} s): rerun {}",
        report.series_dt,
        file("trade.rrd").display()
    );
    Ok(())
}
