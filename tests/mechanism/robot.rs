//! Real robots from example-robot-data (installed in the test venv, never committed) as
//! articulated mechanisms: welded at the base, released from their zero configuration, they
//! swing under gravity for 10 s at dt = 1 ms with no Newton failure, the energy bounded and
//! the joints closed to round-off. And the regression tests of issue 32's corpus
//! (docs/robot_corpus.md, example-robot-data and pybullet_data, the latter found through the
//! venv's `pybullet_data` module): each failure or refusal without its reason it found.

use crate::common;

use nalgebra::Vector3;
use std::path::Path;
use tumble::scene::Scene;
use tumble::sim::Bodies;
use tumble::sim::Loads;
use tumble::simulation::FrameBuilder;
use tumble::simulation::RunSummary;

struct Swing {
    joints: usize,
    bodies: usize,
    newton_failures: u64,
    substepped: u64,
    energy_err_rel: f64,
    kinetic_max: f64,
    residual_m: f64,
    residual_rad: f64,
}

/// `robot` (relative to example-robot-data's `robots/`) welded at 1 m, 10 s at 1 ms, passive:
/// `joint_damping = false` leaves out the URDF's `<dynamics damping>` (the panda's), and
/// `joint_limits = false`, `joint_friction = false` its limits (the panda's swing passes them:
/// each stop is inelastic) and friction, so the energy is conserved.
fn swing(robot: &str) -> Swing {
    swing_for(robot, 10)
}

/// [`swing`] for `seconds`.
fn swing_for(robot: &str, seconds: u32) -> Swing {
    let urdf = common::run_py("pin_composite.py", &[Path::new(robot), Path::new("zero")]);
    let urdf = urdf["urdf"].as_str().unwrap().to_string();
    let text = format!(
        "[sim]\ndt = 0.001\nduration = {seconds}.0\nintegrator = \"variational\"\n\
         [[model]]\nurdf = {urdf:?}\nbodies = \"articulated\"\nbase = \"fixed\"\n\
         position = [0.0, 0.0, 1.0]\nallow_non_physical_inertia = true\n\
         joint_damping = false\njoint_limits = false\njoint_friction = false\n"
    );
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::parse(&text, &dir.path().join("robot.toml")).unwrap();
    let world = scene.build().unwrap_or_else(|e| panic!("{robot}: {e:#}"));
    assert_eq!(world.mechanisms.len(), 1, "{robot}: one mechanism");
    let gravity: Vector3<f64> = scene.gravity();
    let dt = scene.sim.dt;
    let mut bodies = Bodies::new(&world.bodies);
    let mut integrator = world
        .integrator(scene.integrator(), dt, &scene.variational_settings())
        .unwrap();
    integrator.init(&bodies);
    let mut frames = FrameBuilder::new(&world);
    frames.frame(&bodies, &Loads::uniform_gravity(gravity), 0, dt);
    let e0 = frames.total_energy();
    let mut out = Swing {
        joints: world.layout.joints.len(),
        bodies: world.bodies.len(),
        newton_failures: 0,
        substepped: 0,
        energy_err_rel: 0.0,
        kinetic_max: 0.0,
        residual_m: 0.0,
        residual_rad: 0.0,
    };
    let mut de_max: f64 = 0.0;
    for step in 1..=u64::from(seconds) * 1000 {
        let stats = integrator.step(&mut bodies, &Loads::uniform_gravity(gravity));
        out.newton_failures += u64::from(stats.newton_failures);
        out.substepped += u64::from(stats.substepped);
        let frame = frames.frame(&bodies, &Loads::uniform_gravity(gravity), step, dt);
        let kinetic: f64 = frame.bodies.iter().map(|b| b.kinetic_energy).sum();
        out.kinetic_max = out.kinetic_max.max(kinetic);
        let m = &frame.mechanisms[0];
        out.residual_m = out.residual_m.max(m.residual_m);
        out.residual_rad = out.residual_rad.max(m.residual_rad);
        de_max = de_max.max((frames.total_energy() - e0).abs());
    }
    // Relative to the largest kinetic energy reached: the energy the swing exchanges
    // (independent of where the potential is zero).
    out.energy_err_rel = de_max / out.kinetic_max;
    eprintln!(
        "{robot}: {} joints, {} bodies, |dE|/Tmax {:.2e} (Tmax {:.2} J), gap {:.1e} m, axis {:.1e} rad, {} substepped",
        out.joints,
        out.bodies,
        out.energy_err_rel,
        out.kinetic_max,
        out.residual_m,
        out.residual_rad,
        out.substepped
    );
    out
}

#[test]
fn ur5_swings_under_gravity_for_ten_seconds() {
    let s = swing("ur_description/urdf/ur5_robot.urdf");
    assert_eq!(s.joints, 6);
    assert_eq!(s.newton_failures, 0);
    // It really swings: the arm starts horizontal, several joules of kinetic energy.
    assert!(s.kinetic_max > 1.0, "{}", s.kinetic_max);
    // Symplectic: bounded error, O(dt²). Measured 1.8e-5 (Tmax 59 J); bound 1e-3.
    assert!(s.energy_err_rel < 1e-3, "{}", s.energy_err_rel);
    // Joints closed at the Newton tolerance (relative 1e-12). Measured gap 3.2e-14 m, axis
    // 2.2e-13 rad; bounds 1e-10 m and 1e-11 rad.
    assert!(s.residual_m < 1e-10, "{}", s.residual_m);
    assert!(s.residual_rad < 1e-11, "{}", s.residual_rad);
}

#[test]
fn panda_swings_under_gravity_for_ten_seconds() {
    let s = swing("panda_description/urdf/panda.urdf");
    // 7 arm joints and the two finger sliders (one mimics the other).
    assert!(s.joints >= 7, "{}", s.joints);
    assert_eq!(s.newton_failures, 0);
    assert!(s.kinetic_max > 1.0, "{}", s.kinetic_max);
    // The light fingers and wrist whip faster than the UR5's links: measured 6.1e-4 (Tmax
    // 107 J); bound 5e-3 (an O(dt²) error, a drift would grow past it).
    assert!(s.energy_err_rel < 5e-3, "{}", s.energy_err_rel);
    // Measured gap 9.1e-13 m, axis 6.4e-13 rad; bounds 1e-10 m and 1e-11 rad.
    assert!(s.residual_m < 1e-10, "{}", s.residual_m);
    assert!(s.residual_rad < 1e-11, "{}", s.residual_rad);
}

/// Issue 32: the Allegro hands and Alexander's legs failed at step 1 ("not even split into 1024
/// substeps"). Their zero configuration holds bodies at rest in equilibrium (the three fingers
/// standing straight up while the thumb falls; the pelvis between two symmetric legs): the
/// joint rows' torques on such a body cancel, its `M⁺` is round-off of terms ~1e-5 N m s, and
/// the free-body residual's tolerance, relative to that cancelled sum (~1e-17), lay below the
/// round-off floor (~1e-21) Newton can reach. The floor is now part of the tolerance.
fn swings_one_second(robot: &str) {
    let s = swing_for(robot, 1);
    assert_eq!(s.newton_failures, 0, "{robot}");
    assert_eq!(s.substepped, 0, "{robot}");
    assert!(s.kinetic_max > 0.0, "{robot}: {}", s.kinetic_max);
    // Measured (1 s): right hand 3.8e-5, left hand 8.2e-5, Alexander 7.8e-5; bound 1e-3.
    assert!(s.energy_err_rel < 1e-3, "{robot}: {}", s.energy_err_rel);
    assert!(s.residual_m < 1e-10, "{robot}: {}", s.residual_m);
    assert!(s.residual_rad < 1e-10, "{robot}: {}", s.residual_rad);
}

#[test]
fn allegro_right_hand_swings_with_its_fingers_at_rest() {
    swings_one_second("allegro_hand_description/urdf/allegro_right_hand.urdf");
}

#[test]
fn allegro_left_hand_swings_with_its_fingers_at_rest() {
    swings_one_second("allegro_hand_description/urdf/allegro_left_hand.urdf");
}

#[test]
fn alexander_lower_body_swings_from_its_symmetric_start() {
    swings_one_second("alexander_description/urdf/alexander_v1.lowerBodyOnly.urdf");
}

/// example-robot-data's human.urdf, fixed base, its URDF limits on: the hip's stage reached
/// its limit at 0.451 s (at any dt) and the step's Newton solve failed there (the stops on a
/// compound joint's stages); those stages' limits are left out with a note now
/// (docs/mechanisms.md), and the 1 s runs with no Newton failure and its joints closed.
#[test]
fn the_human_model_runs_with_its_limits_on() {
    let info = common::run_py(
        "pin_composite.py",
        &[
            Path::new("human_description/robots/human.urdf"),
            Path::new("zero"),
        ],
    );
    let urdf = std::path::PathBuf::from(info["urdf"].as_str().unwrap());
    let share = urdf.ancestors().nth(5).unwrap().to_path_buf();
    let text = format!(
        "[sim]\ndt = 0.001\nduration = 1.0\n[[model]]\nurdf = {:?}\npackage_paths = [{:?}]\n\
         allow_mesh_paths = [\"/\"]\nbodies = \"articulated\"\nbase = \"fixed\"\n",
        urdf.display().to_string(),
        share.display().to_string()
    );
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::parse(&text, &dir.path().join("human.toml")).unwrap();
    let world = scene.build().unwrap();
    let mut sim = tumble::simulation::Simulation::of_world(
        &world,
        scene.integrator(),
        scene.sim.dt,
        &scene.variational_settings(),
        1,
        &scene.run_settings(),
    )
    .unwrap();
    sim.run().unwrap();
    let s = sim.summary();
    eprintln!("human, fixed base, limits on: {s:?}");
    assert_eq!(s.stopped, None, "{s:?}");
    assert_eq!(s.stats.newton_failures, 0);
    assert_eq!(s.steps, 1000);
}

/// pybullet_data's folder in the test venv (the `pybullet` pip package).
fn pybullet_data() -> std::path::PathBuf {
    let out = std::process::Command::new(common::python())
        .args([
            "-c",
            "import pybullet_data; print(pybullet_data.getDataPath())",
        ])
        .output()
        .expect("cannot run python");
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    std::path::PathBuf::from(common::text(&out.stdout).trim())
}

/// `tumble simulate` on pybullet_data's `file`, articulated, 1 s at 1 ms, with `extra` flags;
/// (exit code, stdout and stderr).
fn simulate_pybullet(file: &str, extra: &[&str]) -> (Option<i32>, String) {
    let data = pybullet_data();
    let dir = tempfile::tempdir().unwrap();
    let urdf = data.join(file).display().to_string();
    let stem = dir.path().join("o").display().to_string();
    let pkg = data.display().to_string();
    let mut args = vec![
        "simulate",
        &urdf,
        "--articulated",
        "--duration",
        "1",
        "--dt",
        "0.001",
        "--package-path",
        &pkg,
        "--allow-mesh-path",
        "/",
        "--format",
        "parquet",
        "--out",
        &stem,
    ];
    args.extend_from_slice(extra);
    let out = common::tumble(&args, dir.path());
    let text = common::text(&out.stdout) + &common::text(&out.stderr);
    (out.status.code(), text)
}

/// Issue 32, pybullet_data's static objects: every link of `plane.urdf` has mass 0 (pybullet's
/// mark of a static object), and a one-link `cube.urdf` welded to the world has nothing to
/// move. Both were refused without a way out; the messages now name the defect and the key that
/// runs the file anyway, and that key does run it.
#[test]
fn pybullet_static_objects_are_refused_with_the_key_that_runs_them() {
    // `file` with `refused_with` is refused naming `parts`; with `runs_with` it runs.
    let check = |file: &str, refused_with: &[&str], parts: &[&str], runs_with: &[&str]| {
        let (code, text) = simulate_pybullet(file, refused_with);
        assert_eq!(code, Some(2), "{text}");
        for part in parts.iter().chain([&file]) {
            assert!(text.contains(part), "{part}: {text}");
        }
        let (code, text) = simulate_pybullet(file, runs_with);
        assert_eq!(code, Some(0), "{text}");
        assert!(text.contains(" 0 non-converged solves"), "{text}");
    };
    check(
        "plane.urdf",
        &["--base", "floating"],
        &[
            "has no link with positive mass",
            "mass 0 or is missing",
            "`inertia = \"geometry\"` on the model (`--inertia geometry`)",
        ],
        &["--inertia", "geometry"],
    );
    check(
        "cube.urdf",
        &["--base", "fixed"],
        &[
            "no moving joint left",
            "base = \"floating\" (`--base floating`) lets it fall as one rigid body",
        ],
        &["--base", "floating"],
    );
}

/// A pybullet_data robot's scene (`extra`: more `[[model]]` keys), 1 s at 1 ms, fixed base:
/// its summary after checking it ran every step with no Newton failure, its body count, and
/// what its energy balance `ΔE = W − D + C` leaves open with the energy's scale (the largest
/// of |E(0)|, |E(1 s)|, |ΔE|, |W|, D).
fn balance_of_one_second(file: &str, extra: &str) -> (usize, RunSummary, f64, f64) {
    let urdf = pybullet_data().join(file);
    let text = format!(
        "[sim]\ndt = 0.001\nduration = 1.0\n[[model]]\nurdf = {:?}\nbodies = \"articulated\"\n\
         base = \"fixed\"\nallow_mesh_paths = [\"/\"]\n{extra}",
        urdf.display().to_string()
    );
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::parse(&text, &dir.path().join("robot.toml")).unwrap();
    let world = scene.build().unwrap_or_else(|e| panic!("{file}: {e:#}"));
    let mut sim = tumble::simulation::Simulation::of_world(
        &world,
        scene.integrator(),
        scene.sim.dt,
        &scene.variational_settings(),
        1,
        &scene.run_settings(),
    )
    .unwrap();
    sim.run().unwrap();
    let s = sim.summary();
    assert_eq!(s.stopped, None, "{file}: {s:?}");
    assert_eq!(s.stats.newton_failures, 0, "{file}");
    assert_eq!(s.steps, 1000, "{file}");
    let flow = s.energy_flow;
    let change = s.energy_final - s.energy_initial;
    let open = change - (flow.input_work - flow.dissipated + flow.contact_work);
    let scale = [
        s.energy_initial.abs(),
        s.energy_final.abs(),
        change.abs(),
        flow.input_work.abs(),
        flow.dissipated,
    ]
    .into_iter()
    .fold(0.0, f64::max);
    (world.bodies.len(), s, open, scale)
}

/// Issue 32's energy check at its tightest: pybullet_data's vision60 (12 bodies, its URDF limits
/// on), fixed base, 1 s at 1 ms, folds its legs into their stops. The stops remove 5.04 J, and
/// the energy balance `ΔE = W − D` leaves 5.5e-3 J open, 1.0e-3 of the energy's scale (|E(1 s)|
/// = 5.3 J); it halves with the step (2.3e-3 J at 0.5 ms, 1.1e-3 J at 0.25 ms): the O(h) ledger
/// of a stop (docs/mechanisms.md, "Energy"), not a leak. Bound 1e-2 (scripts/robot_corpus.py).
#[test]
fn vision60_closes_its_energy_balance_through_its_stops() {
    let (_, s, open, scale) = balance_of_one_second("quadruped/vision60.urdf", "");
    let flow = s.energy_flow;
    eprintln!(
        "vision60: dissipated {:.4e} J, open {open:.3e} J ({:.2e} of {scale:.3e} J)",
        flow.dissipated,
        open.abs() / scale
    );
    // The stops did dissipate (measured 5.04 J), and nothing was made.
    assert!(flow.dissipated > 1.0, "{}", flow.dissipated);
    assert_eq!(flow.input_work, 0.0);
    assert!(open.abs() / scale < 1e-2, "{open} of {scale}");
}

/// Issue 32: pybullet_data's laikago writes every link's inertia as zero; its refusal names
/// `inertia = "geometry"`, which then failed on the chassis' collision mesh, a V-HACD
/// decomposition whose hulls touch along an edge and share a face ("non-manifold mesh: 5
/// edges shared by more than two triangles", once welding joined the hulls' vertices). The
/// file's own indexing closes every hull and is kept now (`mesh_io::weld_indexed`): the robot
/// builds (12 bodies) and runs 1 s, fixed base, with no Newton failure and its energy kept
/// (measured: what the balance leaves open 2.9e-5 of the energy; bound 1e-2).
#[test]
fn laikago_runs_with_its_mass_from_its_vhacd_meshes() {
    let (bodies, s, open, scale) =
        balance_of_one_second("laikago/laikago.urdf", "inertia = \"geometry\"\n");
    eprintln!(
        "laikago: {bodies} bodies, E {:.4e} -> {:.4e} J, dissipated {:.3e} J, open {:.2e} of the scale",
        s.energy_initial,
        s.energy_final,
        s.energy_flow.dissipated,
        open.abs() / scale
    );
    assert!(bodies >= 12, "{bodies}");
    assert!(open.abs() / scale < 1e-2, "{open} of {scale}");
}

/// A welded solo12 with a 0.5 N m sine motor on each of its 12 joints (phases 0.7 rad apart),
/// its URDF limits on: 4 s at 2 ms with no Newton failure and no substep. Newton's start that
/// undamped motors keep (the previous steps' `ξ`, extrapolated: `step/newton.rs`) runs it; the
/// momenta's start, tried for issue 34 (docs/mechanisms.md), failed here at t = 0.85 s, not
/// converging even in 1024 substeps.
#[test]
fn solo12_with_a_sine_motor_on_every_joint_runs_four_seconds() {
    let info = common::run_py(
        "pin_composite.py",
        &[
            Path::new("solo_description/robots/solo12.urdf"),
            Path::new("zero"),
        ],
    );
    let urdf = std::path::PathBuf::from(info["urdf"].as_str().unwrap());
    // …/share/example-robot-data/robots/solo_description/robots/solo12.urdf
    let robots = urdf.ancestors().nth(3).unwrap().to_path_buf();
    let mut text = format!(
        "[sim]\ndt = 0.002\nduration = 4.0\nintegrator = \"variational\"\n\
         [[model]]\nurdf = {:?}\nbodies = \"articulated\"\nbase = \"fixed\"\npackage_paths = [{:?}]\n",
        urdf.display().to_string(),
        robots.display().to_string()
    );
    let mut k = 0;
    for leg in ["FL", "FR", "HL", "HR"] {
        for joint in ["HAA", "HFE", "KFE"] {
            text += &format!(
                "[[model.actuator]]\njoint = \"{leg}_{joint}\"\nkind = \"motor\"\n\
                 effort = {{ sine = {{ amplitude = 0.5, frequency_hz = 1.0, phase = {:.1} }} }}\n",
                0.7 * f64::from(k)
            );
            k += 1;
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::parse(&text, &dir.path().join("solo_motors.toml")).unwrap();
    let world = scene.build().unwrap();
    assert_eq!(world.mechanisms.len(), 1);
    let s = common::run_scene_parts(&scene, &world, 1, &scene.run_settings(), vec![]);
    let work = s.energy_flow.input_work;
    eprintln!(
        "solo12 with motors: {:?}, motors' work {work:.3} J",
        s.stats
    );
    assert_eq!(s.steps, 2000);
    assert_eq!((s.stats.newton_failures, s.stats.substepped), (0, 0));
    // The motors move the legs: measured input work 546.5 J (the limits take most of it).
    assert!(work.abs() > 10.0, "{work}");
}

/// The UR5 (limits on, as its URDF has them) released from a stretched pose, read through
/// [`tumble::simulation::Simulation::joint_state`] after every step, every 500 and every 1000
/// steps. A joint's angle is the stepper's state (issue 47): the three readings agree bit for
/// bit at the common steps, and every angle stays inside its URDF range. Before, each reader
/// unwrapped the angle near its own last sample plus rate times interval, and a sparse
/// reader landed 2π off (the issue measured shoulder_lift −2.939 read once after 1000 steps
/// where the recording held 3.344).
#[test]
fn ur5_joint_angles_are_the_same_at_every_sampling_rate() {
    use tumble::simulation::{Inits, Simulation};
    let urdf = common::run_py(
        "pin_composite.py",
        &[
            Path::new("ur_description/urdf/ur5_robot.urdf"),
            Path::new("zero"),
        ],
    );
    let urdf = urdf["urdf"].as_str().unwrap().to_string();
    let text = format!(
        "[sim]\ndt = 0.001\nduration = 3.0\nintegrator = \"variational\"\n\
         [[model]]\nurdf = {urdf:?}\nbodies = \"articulated\"\nbase = \"fixed\"\n\
         position = [0.0, 0.0, 1.0]\nallow_non_physical_inertia = true\n\
         joints = {{ shoulder_pan_joint = 0.3, shoulder_lift_joint = 0.2, elbow_joint = -0.4, \
         wrist_1_joint = 1.0 }}\n"
    );
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::parse(&text, &dir.path().join("ur5.toml")).unwrap();
    let sample = |every: u64| -> Vec<(u64, Vec<f64>)> {
        let mut world = scene.build().unwrap();
        let inits = std::mem::take(&mut world.bodies);
        let mut settings = scene.run_settings();
        settings.quiet = true;
        let mut sim =
            Simulation::of_scene(&scene, &world, Inits::Owned(inits), 1, &settings).unwrap();
        let n = world.layout.joints.len();
        let mut out = Vec::new();
        let (mut q, mut v) = (vec![0.0; n], vec![0.0; n]);
        while sim.step() < 3000 {
            sim.advance(every).unwrap();
            sim.joint_state(&mut q, &mut v);
            out.push((sim.step(), q.clone()));
        }
        out
    };
    let world = scene.build().unwrap();
    let every_step = sample(1);
    let mut travel = vec![0.0_f64; world.layout.joints.len()];
    for pair in every_step.windows(2) {
        for (t, (a, b)) in travel.iter_mut().zip(pair[0].1.iter().zip(&pair[1].1)) {
            *t = t.max((b - a).abs());
        }
    }
    for (step, q) in &every_step {
        for (j, (value, joint)) in q.iter().zip(&world.layout.joints).enumerate() {
            if let Some([lo, hi]) = joint.limits {
                // A stop holds a joint to round-off of its limit (1e-9 rad is far above it).
                assert!(
                    *value >= lo - 1e-9 && *value <= hi + 1e-9,
                    "step {step}: joint {j} {} at {value} outside [{lo}, {hi}]",
                    joint.name
                );
            }
        }
    }
    let (lo, hi) = every_step.iter().fold(
        (vec![f64::INFINITY; 6], vec![f64::NEG_INFINITY; 6]),
        |(mut lo, mut hi), (_, q)| {
            for j in 0..6 {
                lo[j] = lo[j].min(q[j]);
                hi[j] = hi[j].max(q[j]);
            }
            (lo, hi)
        },
    );
    eprintln!("UR5 joints: range lo {lo:?} hi {hi:?}, largest step change {travel:?}");
    // The arm really swings far: some joint covers more than π (where a nearest-branch reading
    // of a sparse sample can be 2π off). Measured: see the printed ranges.
    assert!(
        lo.iter()
            .zip(&hi)
            .any(|(l, h)| h - l > std::f64::consts::PI),
        "lo {lo:?} hi {hi:?}"
    );
    for every in [500, 1000] {
        for (step, q) in sample(every) {
            let (_, reference) = &every_step[(step - 1) as usize];
            assert_eq!(q, *reference, "every {every}: step {step}");
        }
    }
}
