//! `tumble simulate [SCENE.toml | MODEL.urdf] [--out STEM] [--ros2]`: runs a scene and writes
//! `STEM.mcap` and `STEM.rrd` (and with `--ros2` `STEM.ros2.mcap`, docs/ros2.md).

use crate::budget::{Estimate, human_bytes, peak_memory_bytes};
use crate::fsutil::check_not_overwriting;
use crate::record::format::with_extension;
use crate::record::mcap::ChunkCompression;
use crate::record::rerun::RerunOptions;
use crate::record::{Format, FormatSet, OutputFile};
use crate::scene::{BaseMode, BodiesMode, Scene, SimOverrides};
use crate::sim::integrators::{Jacobian, Potential};
use crate::sim::{Bodies, limits};
use crate::simulation::{AccuracyReport, SimulateOptions, output_paths, simulate_world};
use crate::world::World;
use std::path::{Path, PathBuf};

/// The bundled default scene, relative to the repository root.
pub const DEFAULT_SCENE: &str = "models/default.toml";

#[derive(clap::Args, Debug, Clone, Default)]
pub struct SimulateArgs {
    /// A scene file (.toml) or a URDF (.urdf, simulated alone at the origin with the default
    /// [sim] settings). Without it, the bundled default scene `models/default.toml` runs.
    pub input: Option<PathBuf>,
    /// Output stem: writes STEM.mcap and STEM.rrd. Default: logs/<input file stem>.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Step size, s (overrides sim.dt).
    #[arg(long)]
    pub dt: Option<f64>,
    /// Simulated time, s (overrides sim.duration).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Gravity x,y,z in m/s^2, world frame (overrides sim.gravity); 0,0,0 switches it off.
    #[arg(long, value_parser = super::parse_vec3, allow_hyphen_values = true)]
    pub gravity: Option<[f64; 3]>,
    /// Integrator (overrides sim.integrator): variational, moser-veselov, variational4,
    /// variational6, euler, semi-implicit, rk4.
    #[arg(long)]
    pub integrator: Option<String>,
    /// Record every Nth step (overrides sim.log_every).
    #[arg(long)]
    pub log_every: Option<u64>,
    /// Relative Newton residual tolerance (overrides sim.newton_tol).
    #[arg(long)]
    pub newton_tol: Option<f64>,
    /// Newton iteration cap (overrides sim.newton_max_iters).
    #[arg(long)]
    pub newton_max_iters: Option<u32>,
    /// Newton Jacobian of the variational integrator (overrides sim.jacobian).
    #[arg(long, value_parser = parse_jacobian)]
    pub jacobian: Option<Jacobian>,
    /// Potential quadrature of the variational integrator (overrides sim.potential).
    #[arg(long, value_parser = parse_potential)]
    pub potential: Option<Potential>,
    /// Switch automatic substepping off (sim.substep = false): a Newton solve that does not
    /// converge is used as is and counted.
    #[arg(long)]
    pub no_substep: bool,
    /// Largest substep split factor (overrides sim.max_substeps).
    #[arg(long)]
    pub max_substeps: Option<u32>,
    /// Stop when a body's rotational energy exceeds this multiple of its initial value
    /// (overrides sim.divergence_energy_ratio).
    #[arg(long)]
    pub divergence_energy_ratio: Option<f64>,
    /// With a URDF input: accept inertia that breaks the triangle inequality (a non-physical
    /// body, e.g. Hairer-Lubich-Wanner's test body); in a scene, set
    /// allow_non_physical_inertia = true on the [[model]].
    #[arg(long)]
    pub allow_non_physical_inertia: bool,
    /// With a URDF input: initial angular velocity x,y,z of every body, world frame, rad/s.
    #[arg(long, value_parser = super::parse_vec3, allow_hyphen_values = true)]
    pub angvel: Option<[f64; 3]>,
    /// With a URDF input: initial velocity x,y,z of every centre of mass, world frame, m/s.
    #[arg(long, value_parser = super::parse_vec3, allow_hyphen_values = true)]
    pub linvel: Option<[f64; 3]>,
    /// With a URDF input: world position x,y,z of the root link, m.
    #[arg(long, value_parser = super::parse_vec3, allow_hyphen_values = true)]
    pub position: Option<[f64; 3]>,
    /// With a URDF input: keep its joints (a scene's bodies = "articulated"): revolute,
    /// continuous and prismatic joints as constraints, fixed joints merged. Without it, every
    /// link with mass is a free body and the links fall apart.
    #[arg(long)]
    pub articulated: bool,
    /// With --articulated: floating (default, the root link moves freely) or fixed (the root
    /// link welded to the world at --position), as a scene's base.
    #[arg(long, value_parser = parse_base)]
    pub base: Option<BaseMode>,
    /// With a URDF input: extra folders searched for package:// meshes.
    #[arg(long = "package-path")]
    pub package_paths: Vec<PathBuf>,
    /// Also read mesh files from DIR (repeatable). By default a mesh is read only when its real
    /// path (links resolved) is inside the URDF's folder (its parent for a folder named urdf, or
    /// the ROS package holding it), a package path, ROS_PACKAGE_PATH or the scene's folder; any
    /// other is refused (exit 2). Adds to every [[model]]'s allow_mesh_paths.
    #[arg(long = "allow-mesh-path", value_name = "DIR")]
    pub allow_mesh_paths: Vec<PathBuf>,
    /// Also write STEM.ros2.mcap, a ROS 2 recording (`ros2 bag play`, RViz2): /tf,
    /// /robot_description, /bodies in CDR (docs/ros2.md).
    #[arg(long)]
    pub ros2: bool,
    /// Leave the inertia ellipsoids out of both files (the .rrd's ellipsoid entities and the
    /// MCAP's /inertia topic). The default for a recording with mesh geometry.
    #[arg(long, conflicts_with = "ellipsoids")]
    pub no_ellipsoids: bool,
    /// Write the inertia ellipsoids even though a model has meshes (by default they are
    /// written only when no model has mesh geometry: they would hide the meshes).
    #[arg(long)]
    pub ellipsoids: bool,
    /// Replace STEM.mcap and STEM.rrd (and STEM.ros2.mcap) if they exist (without it, an existing output is an error).
    #[arg(long)]
    pub force: bool,
    /// Run even when the estimated recordings exceed 64 GiB or the computing time 7 days (the
    /// estimate is checked before anything runs; see docs/reliability.md).
    #[arg(long)]
    pub allow_huge: bool,
    /// --inertia, --density, --geometry: replace the scene's [mass] values ([[model]] and
    /// per-link keys of a scene still refine them).
    #[command(flatten)]
    pub mass: super::MassArgs,
    /// Which files to write, comma-separated: mcap (STEM.mcap), rrd (STEM.rrd), parquet
    /// (STEM.trajectories.parquet and STEM.bodies.parquet, the dataset's tables for this run),
    /// ros2 (STEM.ros2.mcap, as --ros2).
    #[arg(long, default_value = "mcap,rrd", value_parser = FormatSet::parse)]
    pub format: FormatSet,
    /// MCAP chunk compression: auto (default: lz4 from 1000 bodies up, else zstd), zstd
    /// (smallest), lz4 (faster, a few per cent larger) or none.
    #[arg(long, default_value = "auto", value_parser = ChunkCompression::parse)]
    pub mcap_compression: ChunkCompression,
    /// Orientation error (rad) allowed over the run for every free body (overrides
    /// sim.accuracy): each body takes the substeps of dt its error model needs (the recording
    /// keeps dt); the summary prints the factors and an a posteriori check (docs/accuracy.md).
    #[arg(long, value_name = "TOL")]
    pub accuracy: Option<f64>,
    /// With --accuracy: also print one line per body (its substep factor, predicted and checked
    /// error), as in STEM.accuracy.json.
    #[arg(long, short)]
    pub verbose: bool,
    /// Test-only: scales the error model's predictions (a scale below 1 makes it too
    /// optimistic, so the a posteriori check must warn).
    #[arg(long, hide = true, default_value_t = 1.0)]
    pub accuracy_model_scale: f64,
    /// Threads stepping the bodies (default: all cores). The files do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Refuse the URDF oddities urdfdom loads (a misplaced XML declaration, unknown geometry,
    /// repeated elements, a 4-number mesh scale, a mimic of a missing joint) instead of loading
    /// them with a warning; sets strict = true on every [[model]] (docs/urdf.md).
    #[arg(long)]
    pub strict: bool,
}

/// The number of stepping threads: `requested`, else every core.
pub fn thread_count(requested: Option<usize>) -> anyhow::Result<usize> {
    match requested {
        Some(0) => anyhow::bail!("--threads must be at least 1"),
        Some(n) => Ok(n),
        None => Ok(std::thread::available_parallelism().map_or(1, |n| n.get())),
    }
}

fn parse_base(s: &str) -> Result<BaseMode, String> {
    match s {
        "floating" => Ok(BaseMode::Floating),
        "fixed" => Ok(BaseMode::Fixed),
        _ => Err(format!("expected floating or fixed, got {s:?}")),
    }
}

fn parse_jacobian(s: &str) -> Result<Jacobian, String> {
    match s {
        "analytic" => Ok(Jacobian::Analytic),
        "approximate" => Ok(Jacobian::Approximate),
        _ => Err(format!("expected analytic or approximate, got {s:?}")),
    }
}

fn parse_potential(s: &str) -> Result<Potential, String> {
    match s {
        "symmetric" => Ok(Potential::Symmetric),
        "end-point" => Ok(Potential::EndPoint),
        _ => Err(format!("expected symmetric or end-point, got {s:?}")),
    }
}

/// The user's choice of inertia ellipsoids: `--ellipsoids` on, `--no-ellipsoids` off, neither
/// `None` (then [`crate::record::RecordingLayout::default_ellipsoids`]: off when a model has
/// meshes).
pub fn ellipsoids_choice(on: bool, off: bool) -> Option<bool> {
    match (on, off) {
        (true, _) => Some(true),
        (false, true) => Some(false),
        (false, false) => None,
    }
}

/// Extension of a robot's Foxglove layout, written beside the MCAP (`STEM.foxglove.json`).
pub const FOXGLOVE_LAYOUT_EXTENSION: &str = "foxglove.json";

/// The shipped Foxglove layout with its 3D panel following the robot of `world`
/// ([`crate::record::foxglove_layout`]); `None` without a robot, or when the shipped layout
/// cannot be read (then a warning).
pub fn robot_foxglove_layout(world: &crate::world::World) -> Option<serde_json::Value> {
    use crate::record::foxglove_layout::{robot_camera, robot_layout};
    let camera = robot_camera(&world.layout, &world.initial_world_from_link())?;
    let path = foxglove_layout_path();
    let base = std::fs::read_to_string(&path)
        .map_err(|e| e.to_string())
        .and_then(|text| {
            serde_json::from_str::<serde_json::Value>(&text).map_err(|e| e.to_string())
        });
    match base {
        Ok(base) => robot_layout(&base, &camera),
        Err(e) => {
            eprintln!(
                "warning: cannot read the Foxglove layout {}: {e}; no robot layout written",
                path.display()
            );
            None
        }
    }
}

/// The Foxglove layout shipped with tumble, relative to the repository root.
pub const FOXGLOVE_LAYOUT: &str = "docs/foxglove/tumble-layout.json";

/// Where the Foxglove layout is: `./docs/foxglove/tumble-layout.json` if present, else the copy
/// in the source tree the binary was built from.
pub fn foxglove_layout_path() -> PathBuf {
    repository_file(FOXGLOVE_LAYOUT)
}

/// `relative` in the working directory if it is there, else in the source tree the binary was
/// built from.
fn repository_file(relative: &str) -> PathBuf {
    let local = PathBuf::from(relative);
    if local.is_file() {
        local
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join(relative)
    }
}

/// Where the default scene is: `./models/default.toml` if present, else the copy in the
/// source tree the binary was built from.
pub fn default_scene_path() -> PathBuf {
    repository_file(DEFAULT_SCENE)
}

/// Reads the scene the arguments name and applies the overrides.
pub fn scene_from_args(args: &SimulateArgs) -> anyhow::Result<Scene> {
    let input = args.input.clone().unwrap_or_else(default_scene_path);
    let is_urdf = input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("urdf"));
    let mut scene = if is_urdf {
        let mut scene = Scene::from_urdf(&input);
        let model = &mut scene.models[0];
        model.angvel = args.angvel.unwrap_or_default();
        model.linvel = args.linvel.unwrap_or_default();
        model.position = args.position.unwrap_or_default();
        model.package_paths = args.package_paths.clone();
        model.allow_non_physical_inertia = args.allow_non_physical_inertia;
        if args.base.is_some() && !args.articulated {
            anyhow::bail!(
                "--base applies to an articulated model: add --articulated (without it every link \
                 is a free body and there is no base to fix)"
            );
        }
        if args.articulated {
            model.bodies = BodiesMode::Articulated;
            model.base = args.base;
        }
        scene
    } else {
        if args.angvel.is_some()
            || args.linvel.is_some()
            || args.position.is_some()
            || args.allow_non_physical_inertia
            || args.articulated
            || args.base.is_some()
        {
            anyhow::bail!(
                "--angvel, --linvel, --position, --allow-non-physical-inertia, --articulated and \
                 --base apply to a URDF input; set them per [[model]] in {} (bodies = \"articulated\", \
                 base = \"fixed\")",
                input.display()
            );
        }
        Scene::load(&input)?
    };
    if args.strict {
        scene.set_strict();
    }
    scene.allow_mesh_paths(&args.allow_mesh_paths)?;
    scene.apply(&SimOverrides {
        dt: args.dt,
        duration: args.duration,
        gravity: args.gravity,
        integrator: args.integrator.clone(),
        log_every: args.log_every,
        newton_tol: args.newton_tol,
        newton_max_iters: args.newton_max_iters,
        jacobian: args.jacobian,
        potential: args.potential,
        substep: args.no_substep.then_some(false),
        max_substeps: args.max_substeps,
        divergence_energy_ratio: args.divergence_energy_ratio,
        accuracy: args.accuracy,
        mass: args.mass.settings(),
    })?;
    Ok(scene)
}

/// A bare URDF simulated as free links (no `--articulated`) whose joints move: the note saying
/// that its links fall apart, naming the flag. `None` for a scene, an articulated or rigid
/// model, or a URDF whose joints are all fixed.
pub fn free_links_note(scene: &Scene, loaded: &crate::scene::LoadedModels) -> Option<String> {
    let from_urdf = scene.text.is_empty()
        && scene
            .source
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("urdf"));
    let (entry, table) = (scene.models.first()?, loaded.tables.first()?);
    if !from_urdf || entry.bodies != BodiesMode::Links {
        return None;
    }
    let moving: Vec<&str> = table
        .model
        .joints
        .iter()
        .filter(|j| j.kind != crate::model::kinematics::JointKind::Fixed)
        .map(|j| j.name.as_str())
        .collect();
    if moving.is_empty() {
        return None;
    }
    let shown = moving
        .iter()
        .take(5)
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>();
    let more = if moving.len() > 5 {
        format!(" and {} more", moving.len() - 5)
    } else {
        String::new()
    };
    Some(format!(
        "note: {} has {} moving joint{} ({}{more}), but its links move as free bodies: nothing \
         holds them together and they fall apart. Add --articulated to keep the joints \
         (--base fixed welds the root link to the world)",
        scene.source.display(),
        moving.len(),
        if moving.len() == 1 { "" } else { "s" },
        shown.join(", ")
    ))
}

/// The warning for a step too large for some body's spin ([`crate::sim::limits`]), if any.
pub fn step_warning(scene: &Scene, world: &World) -> Option<String> {
    let bodies = Bodies::new(&world.bodies);
    let w = limits::check_step(&bodies, scene.integrator(), scene.sim.dt)?;
    let others = match w.bodies_over {
        1 => String::new(),
        n => format!(" (and {} other bodies)", n - 1),
    };
    Some(format!(
        "warning: dt = {} s is too large for body {:?}{others}: it turns at up to |Ω| = {:.4e} rad/s, \
         h|Ω| = {} rad per step, over the {} limit of {} rad for its inertia ratio {:.3e} (docs/limits.md; {}). \
         Largest safe step: dt <= {:.3e} s",
        crate::budget::readable(scene.sim.dt),
        world.layout.bodies[w.body].name,
        w.spin_rate_max,
        if w.h_omega < 1e6 {
            format!("{:.3}", w.h_omega)
        } else {
            format!("{:.3e}", w.h_omega)
        },
        scene.sim.integrator,
        w.limit,
        w.inertia_ratio,
        if scene.integrator().is_variational() {
            "past it Newton substeps where needed and the energy error grows"
        } else {
            "past it the energy error grows fast and the run may diverge"
        },
        w.dt_safe
    ))
}

/// `STEM.accuracy.json`: `--accuracy`'s per-body factors, predictions and checks.
pub const ACCURACY_EXTENSION: &str = "accuracy.json";

/// Prints `--accuracy`'s summary (factors as a histogram, predicted and checked errors, a
/// warning when the check exceeds the tolerance) and writes the per-body JSON.
fn print_accuracy(
    report: &AccuracyReport,
    world: &World,
    json_path: &Path,
    verbose: bool,
) -> anyhow::Result<()> {
    let plan = &report.plan;
    let n = plan.factors.len().max(1) as f64;
    println!(
        "accuracy {:e} rad: substep factors chosen per body from the error model (docs/accuracy.md); \
         {} substeps per step for {} bodies ({:.2} per body); predicted error max {:.2e} rad",
        plan.tol_rad,
        plan.cost(),
        plan.factors.len(),
        plan.cost() as f64 / n,
        plan.predicted_max()
    );
    let bins: Vec<String> = plan
        .histogram()
        .iter()
        .map(|&(lo, hi, c)| {
            if lo == hi {
                format!("k={lo}: {c}")
            } else {
                format!("k={lo}-{hi}: {c}")
            }
        })
        .collect();
    println!("  bodies per substep factor: {}", bins.join(", "));
    let est = report.estimated_max();
    println!(
        "  a posteriori check (Richardson, k vs 2k) on {} bod{}: achieved error max {:.2e} rad",
        report.checked.len(),
        if report.checked.len() == 1 {
            "y"
        } else {
            "ies"
        },
        est
    );
    if est > plan.tol_rad {
        let worst = report
            .checked
            .iter()
            .max_by(|a, b| a.estimated_rad.total_cmp(&b.estimated_rad))
            .map(|c| c.body)
            .unwrap_or(0);
        eprintln!(
            "warning: the a posteriori check estimates {est:.2e} rad for body {:?} (index {worst}, k = {}), \
             above --accuracy {:e}: the error model underestimated it; rerun with a smaller dt or tolerance",
            world.layout.bodies[worst].name, plan.factors[worst].k, plan.tol_rad
        );
    }
    let checked: std::collections::HashMap<usize, f64> = report
        .checked
        .iter()
        .map(|c| (c.body, c.estimated_rad))
        .collect();
    if verbose {
        for (i, f) in plan.factors.iter().enumerate() {
            let checked = checked
                .get(&i)
                .map_or_else(|| "-".to_string(), |e| format!("{e:.2e} rad"));
            println!(
                "  body {} (index {i}): k = {}, predicted {:.2e} rad, checked {checked}",
                world.layout.bodies[i].name, f.k, f.predicted_rad
            );
        }
    }
    let bodies: Vec<serde_json::Value> = plan
        .factors
        .iter()
        .enumerate()
        .map(|(i, f)| {
            serde_json::json!({
                "body": world.layout.bodies[i].name,
                "index": i,
                "substeps": f.k,
                "spin_rate_max": plan.calibrations[i].spin_rate_max,
                "predicted_error_rad": f.predicted_rad,
                "checked_error_rad": checked.get(&i),
            })
        })
        .collect();
    let json = serde_json::json!({
        "tolerance_rad": plan.tol_rad,
        "integrator": plan.kind.name(),
        "dt": plan.dt_secs,
        "duration": plan.duration_secs,
        "substeps_per_step": plan.cost(),
        "predicted_error_max_rad": plan.predicted_max(),
        "checked_error_max_rad": est,
        "bodies": bodies,
    });
    crate::fsutil::write_atomic(json_path, serde_json::to_string_pretty(&json)?.as_bytes())?;
    println!("  per body: {}", json_path.display());
    Ok(())
}

pub fn run(args: &SimulateArgs) -> anyhow::Result<()> {
    let scene = scene_from_args(args)?;
    let stem = args.out.clone().unwrap_or_else(|| {
        let name = scene.source.file_stem().unwrap_or_default();
        Path::new("logs").join(name)
    });
    let mut formats = args.format;
    if args.ros2 {
        formats.insert(Format::Ros2);
    }
    for path in output_paths(&stem, &formats) {
        check_not_overwriting(&path, args.force)?;
    }
    let accuracy_json = with_extension(&stem, ACCURACY_EXTENSION);
    if scene.sim.accuracy.is_some() {
        check_not_overwriting(&accuracy_json, args.force)?;
    }
    let threads = thread_count(args.threads)?;
    // `Scene::build`, in its steps: the loaded model says whether a bare URDF has joints.
    let loaded = scene.load_models()?;
    let mut world = scene.assemble(&loaded, &|table, copy| scene.models[table].placement(copy))?;
    scene.describe(&loaded, &mut world);
    if let Some(note) = free_links_note(&scene, &loaded) {
        eprintln!("{note}");
    }
    // The files only some scenes write (the contacts table), once the scene says.
    for path in formats.paths_of(&stem, &world.layout) {
        check_not_overwriting(&path, args.force)?;
    }
    // A robot's Foxglove layout (STEM.foxglove.json), beside the MCAP.
    let robot_layout = if formats.contains(Format::Mcap) {
        robot_foxglove_layout(&world)
    } else {
        None
    };
    let robot_layout_path = with_extension(&stem, FOXGLOVE_LAYOUT_EXTENSION);
    if robot_layout.is_some() {
        check_not_overwriting(&robot_layout_path, args.force)?;
    }
    for warning in &world.warnings {
        eprintln!("warning: {warning}");
    }
    for note in &world.notes {
        eprintln!("warning: {note}");
    }
    let estimate = Estimate::run(
        world.bodies.len() as f64,
        world.layout.frames.len() as f64,
        scene.steps() as f64,
        Some(scene.sim.log_every as f64),
    )
    .with_population(&world.population());
    estimate.check(args.allow_huge)?;
    crate::scene::bounds::check_end_time(
        &scene.source.display().to_string(),
        scene.sim.dt,
        scene.sim.duration,
        scene.steps(),
    )?;
    if let Some(warning) = step_warning(&scene, &world) {
        eprintln!("{warning}");
    }
    crate::interrupt::install()?;
    let ellipsoids = ellipsoids_choice(args.ellipsoids, args.no_ellipsoids)
        .unwrap_or_else(|| world.layout.default_ellipsoids());
    let started = std::time::Instant::now();
    let out = simulate_world(
        &scene,
        &mut world,
        &stem,
        &SimulateOptions {
            rerun: RerunOptions { ellipsoids },
            formats,
            threads,
            mcap_compression: args.mcap_compression,
            accuracy_model: crate::sim::accuracy::ErrorModel {
                scale: args.accuracy_model_scale,
            },
        },
    )?;
    let wall = started.elapsed().as_secs_f64();
    let s = &out.summary;
    let threads = out.stepping_threads;
    println!(
        "simulated {} bodies for {} steps of {} s ({} s) with {} on {threads} thread{} in {wall:.2} s wall time",
        out.bodies,
        s.steps,
        scene.sim.dt,
        scene.sim.duration,
        scene.sim.integrator,
        if threads == 1 { "" } else { "s" }
    );
    // A scene at rest without gravity starts with no energy: its change is only absolute.
    let energy_change = if s.energy_initial == 0.0 {
        format!(
            "absolute change {:.2e} J",
            s.energy_final - s.energy_initial
        )
    } else {
        format!(
            "relative change {:.2e}",
            (s.energy_final - s.energy_initial) / s.energy_initial.abs()
        )
    };
    println!(
        "energy {:.9e} J -> {:.9e} J ({energy_change}); {}",
        s.energy_initial,
        s.energy_final,
        s.momentum_text()
    );
    if let Some([gap, angle]) = s.constraint_residual {
        println!(
            "constraint residual max: joint gap {gap:.2e} m, axis misalignment {angle:.2e} rad"
        );
    }
    if let Some(b) = s.energy_balance() {
        let flow = b.flow;
        // The contact term only where there is contact (the line of runs without is unchanged).
        let contact = if flow.contact_work != 0.0 {
            format!(" + contact {:.6e} J", flow.contact_work)
        } else {
            String::new()
        };
        println!(
            "energy balance: change {:.6e} J = input work {:.6e} J - dissipated {:.6e} J\
             {contact} + not closed {:.3e} J ({:.2e} of the largest term)",
            b.change,
            flow.input_work,
            flow.dissipated,
            b.open,
            b.relative_open()
        );
    }
    if let Some(warning) = s.balance_warning() {
        eprintln!("warning: {warning}");
    }
    println!(
        "Newton: at most {} iterations per solve, {} non-converged solves; {} body-steps substepped (largest split {}x)",
        s.stats.newton_iters_max,
        s.stats.newton_failures,
        s.stats.substepped,
        s.stats.substep_factor_max.max(1)
    );
    if s.stats.substepped > 0 {
        eprintln!(
            "warning: {} body-steps did not converge at dt = {} s and were split into up to {} substeps \
             (sim.substep; the recording keeps dt); a smaller dt avoids it",
            s.stats.substepped,
            crate::budget::readable(scene.sim.dt),
            s.stats.substep_factor_max
        );
    }
    if s.stats.newton_failures > 0 {
        eprintln!(
            "warning: {} Newton solves did not reach sim.newton_tol within sim.newton_max_iters and were used as is \
             (substepping is off); reduce dt, raise the cap, or leave sim.substep on",
            s.stats.newton_failures
        );
    }
    if let Some(report) = &out.accuracy {
        print_accuracy(report, &world, &accuracy_json, args.verbose)?;
    }
    if let Some(peak) = peak_memory_bytes() {
        println!(
            "peak memory (VmHWM) {} (estimated {})",
            human_bytes(peak as f64),
            human_bytes(estimate.memory_bytes)
        );
    }
    if let Some(layout) = &robot_layout {
        crate::fsutil::write_atomic(
            &robot_layout_path,
            format!("{}\n", serde_json::to_string_pretty(layout)?).as_bytes(),
        )?;
    }
    println!("wrote {} frames to", s.frames_recorded);
    for path in &out.written {
        println!("  {}", path.display());
    }
    if robot_layout.is_some() {
        println!("  {}", robot_layout_path.display());
    }
    println!("view them with:");
    if formats.contains(Format::Rrd) {
        println!(
            "  rerun {}        (Rerun viewer 0.36/0.37: pip install rerun-sdk==0.36.3)",
            out.rrd.display()
        );
    }
    if formats.contains(Format::Mcap) {
        if robot_layout.is_some() {
            println!(
                "  Foxglove: open {}, then import the layout {} (Layouts > Import): a 3D panel following the robot, energy and momentum plots",
                out.mcap.display(),
                robot_layout_path.display()
            );
        } else {
            println!(
                "  Foxglove: open {}, then import the layout {} (Layouts > Import): a 3D panel on \"world\" showing /scene, energy and momentum plots",
                out.mcap.display(),
                foxglove_layout_path().display()
            );
        }
    }
    if formats.contains(Format::Parquet) {
        println!(
            "  pandas: pd.read_parquet(\"{}\")   (columns: docs/scale.md, the dataset's trajectories table)",
            OutputFile::Trajectories.path(&stem).display()
        );
        let contacts = OutputFile::Contacts.path(&stem);
        if out.written.contains(&contacts) {
            println!(
                "  pandas: pd.read_parquet(\"{}\")   (one row per contact and recorded step: docs/datasets.md)",
                contacts.display()
            );
        }
    }
    if let Some(ros2) = &out.ros2 {
        println!(
            "  ROS 2: ros2 bag play {} --clock   (RViz2 with use_sim_time:=true, fixed frame \"world\"; docs/ros2.md)",
            ros2.display()
        );
    }
    Ok(())
}
