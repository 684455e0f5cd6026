//! `tumble stability [--out DIR] [--integrators a,b] [--quick]`: the stability map of
//! [`crate::stability`]; writes `DIR/stability.csv` and `DIR/stability.png` and prints, per
//! integrator, the limit of `h|Ω|` derived from the map beside the documented one
//! ([`crate::sim::limits::h_omega_limit`]).
//!
//! `tumble stability --scene SCENE.toml [--dt a,b,...] [--duration SECS]`: the scene itself at
//! a ladder of step sizes (articulated models included, [`crate::stability::scene`]); writes
//! `DIR/stability_scene.csv` and prints the rows and, per integrator, the largest `ok` step.

use crate::commands::parse_integrators;
use crate::fsutil::write_atomic;
use crate::stability::{self, Grid};
use anyhow::Context;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args, Debug, Clone)]
pub struct StabilityArgs {
    /// Output folder.
    #[arg(long, default_value = "logs/stability")]
    pub out: PathBuf,
    /// Integrators to map, comma-separated (default: all).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub integrators: Vec<String>,
    /// A coarser grid (8 step sizes, 5 shapes) for a quick look; its derived limits are
    /// indicative only (the documented ones come from the full map).
    #[arg(long)]
    pub quick: bool,
    /// Replace stability.csv and stability.png (stability_scene.csv with --scene) if they exist.
    #[arg(long)]
    pub force: bool,
    /// Map this scene along the step size instead of the dimensionless free-body map
    /// (articulated models included: the variational family).
    #[arg(long, value_name = "SCENE.toml")]
    pub scene: Option<PathBuf>,
    /// With --scene: step sizes, s, comma-separated (default: the scene's dt times 0.5, 1, 2,
    /// 4, ..., 64).
    #[arg(long = "dt", value_delimiter = ',', num_args = 1.., requires = "scene")]
    pub dts: Vec<f64>,
    /// With --scene: the horizon of each run, s (default: the scene's duration).
    #[arg(long, requires = "scene")]
    pub duration: Option<f64>,
    /// With --scene: also read mesh files from DIR (repeatable). By default a mesh is read only
    /// when its real path (links resolved) is inside the URDF's folder (its parent for a folder
    /// named urdf, or the ROS package holding it), a package path, ROS_PACKAGE_PATH or the scene's
    /// folder; any other is refused (exit 2). Adds to every [[model]]'s allow_mesh_paths.
    #[arg(long = "allow-mesh-path", value_name = "DIR", requires = "scene")]
    pub allow_mesh_paths: Vec<PathBuf>,
}

fn run_scene(args: &StabilityArgs, path: &std::path::Path) -> anyhow::Result<()> {
    let kinds = parse_integrators(&args.integrators)?;
    if args.quick {
        anyhow::bail!("--quick is for the free-body map; with --scene choose the steps with --dt");
    }
    let mut scene = crate::scene::Scene::load(path)?;
    scene.allow_mesh_paths(&args.allow_mesh_paths)?;
    let dts: Vec<f64> = if args.dts.is_empty() {
        stability::scene::DT_FACTORS
            .iter()
            .map(|f| f * scene.sim.dt)
            .collect()
    } else {
        args.dts.clone()
    };
    for &dt in &dts {
        if !(dt.is_finite() && dt > 0.0) {
            anyhow::bail!("--dt: step sizes must be positive (got {dt})");
        }
    }
    let duration = args.duration.unwrap_or(scene.sim.duration);
    if !(duration.is_finite() && duration > 0.0) {
        anyhow::bail!("--duration must be a positive number of seconds (got {duration})");
    }
    let csv = args.out.join("stability_scene.csv");
    crate::fsutil::check_not_overwriting(&csv, args.force)?;
    println!(
        "stability of {} along dt: {} step sizes over {duration} s",
        path.display(),
        dts.len()
    );
    let map = stability::scene::sweep(
        &scene,
        &kinds,
        !args.integrators.is_empty(),
        &dts,
        duration,
        |row| eprintln!("  ran {} at dt = {} s", row.integrator.name(), row.dt),
    )?;
    for line in &map.skipped {
        println!("{line}");
    }
    print!("{}", stability::scene::summary(&map));
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    write_atomic(&csv, stability::scene::csv(&map.rows).as_bytes())?;
    println!("wrote");
    println!("  {}", csv.display());
    Ok(())
}

pub fn run(args: &StabilityArgs) -> anyhow::Result<()> {
    if let Some(path) = &args.scene {
        return run_scene(args, path);
    }
    let kinds = parse_integrators(&args.integrators)?;
    let csv = args.out.join("stability.csv");
    let png = args.out.join("stability.png");
    crate::fsutil::check_not_overwriting(&csv, args.force)?;
    crate::fsutil::check_not_overwriting(&png, args.force)?;
    let grid = if args.quick {
        Grid::quick()
    } else {
        Grid::full()
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let cells = grid.cells().len();
    println!(
        "stability map{}: {} integrators x {} cells ({} h|Ω| x {} shapes x {} spin axes), |Ω|max = 1 rad/s",
        if args.quick { " (quick grid)" } else { "" },
        kinds.len(),
        cells,
        grid.h_omegas.len(),
        grid.shapes.len(),
        grid.spin_axes.len()
    );
    let started = Instant::now();
    let rows = stability::sweep(&grid, &kinds, stability::default_threads());
    println!(
        "ran {} cells in {:.1} s",
        rows.len(),
        started.elapsed().as_secs_f64()
    );
    print!("{}", stability::output::summary(&rows, &kinds));
    if args.quick {
        println!(
            "(quick grid: fewer step sizes and shapes, so its derived limits are indicative only; \
             the documented ones come from the full map)"
        );
    }
    write_atomic(&csv, stability::output::csv(&rows).as_bytes())?;
    stability::plot::heat_map(&png, &grid, &rows, &kinds)?;
    println!("wrote");
    println!("  {}", csv.display());
    println!("  {}", png.display());
    Ok(())
}
