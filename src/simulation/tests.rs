//! The stepping contract of [`Simulation`]: how far each call goes changes nothing recorded.

use super::*;
use crate::record::Frame;
use crate::scene::Scene;
use nalgebra::{Isometry3, Vector3};
use std::sync::Mutex;

type Seen = Arc<Mutex<Vec<(u64, i64, Vec<Isometry3<f64>>)>>>;

/// Keeps every frame it is given (step, time, link poses).
struct Keep(Seen);

impl Sink for Keep {
    fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
        self.0
            .lock()
            .unwrap()
            .push((frame.step, frame.time_ns, frame.world_from_link.to_vec()));
        Ok(())
    }
    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        Ok(())
    }
}

/// The bundled default scene (a T-handle flipping beside a box, under gravity), 95 steps
/// recorded every 10th.
fn default_world() -> (Scene, World, RunSettings) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/default.toml");
    let scene = Scene::load(&path).unwrap();
    let world = scene.build().unwrap();
    let settings = RunSettings {
        steps: 95,
        log_every: 10,
        ..scene.run_settings()
    };
    (scene, world, settings)
}

fn simulation(scene: &Scene, world: &World, settings: &RunSettings) -> (Simulation, Seen) {
    let mut sim = Simulation::of_world(
        world,
        scene.integrator(),
        scene.sim.dt,
        &scene.variational_settings(),
        1,
        settings,
    )
    .unwrap();
    let seen = Seen::default();
    sim.attach_all(vec![Box::new(Keep(seen.clone()))]).unwrap();
    (sim, seen)
}

/// One `run` and many uneven `advance` calls record the same frames bit for bit: frame 0,
/// every 10th step and the last (95), and end in the same state.
#[test]
fn advancing_in_any_increments_records_what_one_run_records() {
    let (scene, world, settings) = default_world();
    let (mut whole, seen_whole) = simulation(&scene, &world, &settings);
    assert_eq!(whole.run().unwrap(), Progress::Done);
    let (mut pieces, seen_pieces) = simulation(&scene, &world, &settings);
    let mut calls = 0;
    for n in [1, 7, 13, 0, 2, 9, 40, 11].into_iter().cycle() {
        calls += 1;
        if pieces.advance(n).unwrap() == Progress::Done {
            break;
        }
        assert!(calls < 100, "advance never reached the end");
    }
    let steps: Vec<u64> = seen_whole.lock().unwrap().iter().map(|f| f.0).collect();
    assert_eq!(steps, [0, 10, 20, 30, 40, 50, 60, 70, 80, 90, 95]);
    assert_eq!(*seen_whole.lock().unwrap(), *seen_pieces.lock().unwrap());
    for i in 0..world.bodies.len() {
        assert_eq!(
            whole.view().world_from_body(i),
            pieces.view().world_from_body(i)
        );
    }
    let (a, b) = (whole.summary(), pieces.summary());
    assert_eq!(a, b);
    assert_eq!(a.frames_recorded, 11);
    assert_eq!(a.last_recorded_step, 95);
}

/// The clock: `advance` stops at the run's last step, `step` and `time_secs` say where the
/// run is (the recordings' integer nanoseconds), and a finished run takes no more steps and
/// records nothing more.
#[test]
fn advance_stops_at_the_last_step_and_the_clock_follows() {
    let (scene, world, settings) = default_world();
    let (mut sim, seen) = simulation(&scene, &world, &settings);
    assert_eq!((sim.step(), sim.progress()), (0, Progress::Running));
    assert_eq!(sim.advance(30).unwrap(), Progress::Running);
    assert_eq!(sim.step(), 30);
    assert_eq!(sim.time_secs(), 0.03);
    assert_eq!(sim.advance(1000).unwrap(), Progress::Done);
    assert_eq!(sim.step(), 95);
    assert_eq!(sim.time_secs(), time_ns(95, scene.sim.dt) as f64 / 1e9);
    let recorded = seen.lock().unwrap().len();
    assert_eq!(sim.advance(10).unwrap(), Progress::Done);
    assert_eq!(sim.step(), 95);
    assert_eq!(seen.lock().unwrap().len(), recorded);
    let summary = sim.finish(&[]).unwrap();
    assert_eq!(summary.steps, 95);
}

/// `frame()` between recorded steps is the current state, built on demand and not sent to
/// the sinks; at a recorded step it is the recorded frame.
#[test]
fn the_current_frame_is_built_on_demand_and_not_recorded() {
    let (scene, world, settings) = default_world();
    let (mut sim, seen) = simulation(&scene, &world, &settings);
    sim.advance(13).unwrap();
    let sent = seen.lock().unwrap().len();
    assert_eq!(sent, 2, "frames 0 and 10");
    let frame = sim.frame().clone();
    assert_eq!(frame.step, 13);
    assert_eq!(seen.lock().unwrap().len(), sent);
    // Link frame 0 rides on body 0: its pose follows the body's current pose.
    let a = world.attachments[0];
    assert_eq!(
        frame.world_from_link[0],
        sim.view().world_from_body(a.body) * a.body_from_link
    );
    sim.advance(7).unwrap();
    let recorded = seen.lock().unwrap().last().unwrap().clone();
    assert_eq!(recorded.0, 20);
    assert_eq!(sim.frame().world_from_link, recorded.2);
}

/// A sink attached after the first step would miss frames: refused, naming the step.
#[test]
fn a_sink_attached_after_the_first_step_is_refused() {
    let (scene, world, settings) = default_world();
    let (mut sim, _) = simulation(&scene, &world, &settings);
    sim.advance(3).unwrap();
    let e = sim
        .attach(Box::new(Keep(Seen::default())))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("before the first step") && e.contains("step 3"),
        "{e}"
    );
}

/// A run of no steps still records its initial frame when finished.
#[test]
fn a_run_of_no_steps_records_frame_zero() {
    let (scene, world, mut settings) = default_world();
    settings.steps = 0;
    let (sim, seen) = simulation(&scene, &world, &settings);
    assert_eq!(sim.progress(), Progress::Done);
    let summary = sim.finish(&[]).unwrap();
    assert_eq!(summary.frames_recorded, 1);
    assert_eq!(seen.lock().unwrap().len(), 1);
    assert_eq!(seen.lock().unwrap()[0].0, 0);
}

/// A run without sinks counts its record points and reports the same summary as one with a
/// sink (its final frame built when the summary asks), for free bodies and for a mechanism
/// (whose totals are the reported ones, read from the frames). The constraint residual is the
/// largest over the frames built: the recorded run's (frames 0, 10, …, 95) covers the bare
/// run's (frame 0 and the final one), so it is at least as large.
#[test]
fn a_run_without_sinks_reports_what_a_recorded_run_reports() {
    for scene_file in ["models/default.toml", "models/double_pendulum.toml"] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(scene_file);
        let scene = Scene::load(&path).unwrap();
        let world = scene.build().unwrap();
        let settings = RunSettings {
            steps: 95,
            log_every: 10,
            ..scene.run_settings()
        };
        let (mut recorded, _) = simulation(&scene, &world, &settings);
        recorded.run().unwrap();
        let mut bare = Simulation::of_world(
            &world,
            scene.integrator(),
            scene.sim.dt,
            &scene.variational_settings(),
            1,
            &settings,
        )
        .unwrap();
        bare.run().unwrap();
        let (mut a, mut b) = (recorded.summary(), bare.summary());
        match (a.constraint_residual.take(), b.constraint_residual.take()) {
            (None, None) => assert!(world.mechanisms.is_empty(), "{scene_file}"),
            (Some(ra), Some(rb)) => {
                assert!(
                    ra[0] >= rb[0] && ra[1] >= rb[1],
                    "{scene_file}: {ra:?} {rb:?}"
                )
            }
            other => panic!("{scene_file}: {other:?}"),
        }
        assert_eq!(a, b, "{scene_file}");
        assert_eq!(b.frames_recorded, 11, "{scene_file}");
        // The final totals are the final state's, not the initial ones.
        assert_ne!(b.energy_final, b.energy_initial, "{scene_file}");
    }
}

/// The summary's totals, recomputed here from the bodies: the energy at both ends (the
/// variational step keeps it within O(h²), no drift) and the largest relative change of a
/// body's angular momentum about its centre of mass (torque-free under uniform gravity, kept
/// to round-off).
#[test]
fn the_summary_measures_energy_and_momentum_of_the_bodies() {
    let (scene, world, settings) = default_world();
    let (sim, _) = simulation(&scene, &world, &settings);
    let loads = crate::sim::Loads::uniform_gravity(settings.gravity);
    let angmom = |sim: &Simulation| -> Vec<Vector3<f64>> {
        let view = sim.view();
        (0..world.bodies.len())
            .map(|i| {
                let (bodies, j) = view.body(i);
                bodies.angmom_world(j)
            })
            .collect()
    };
    let energy = |sim: &Simulation| -> f64 {
        let view = sim.view();
        (0..world.bodies.len())
            .map(|i| {
                let (bodies, j) = view.body(i);
                bodies.energy(j, &loads)
            })
            .sum()
    };
    let (l0, e0) = (angmom(&sim), energy(&sim));
    let mut sim = sim;
    sim.run().unwrap();
    let (l1, e1) = (angmom(&sim), energy(&sim));
    let summary = sim.finish(&[]).unwrap();
    assert_eq!(summary.energy_initial, e0);
    assert_eq!(summary.energy_final, e1);
    // Measured 1.0e-12 relative over the 95 steps (the scheme's energy error is O(h²) and
    // bounded; 1e-6 leaves room for any phase of the T-handle's flip at h = 1 ms).
    assert!((e1 - e0).abs() < 1e-6 * e0.abs(), "{e0} -> {e1}");
    let expected = l0
        .iter()
        .zip(&l1)
        .map(|(a, b)| (b - a).norm() / a.norm())
        .fold(0.0, f64::max);
    assert_eq!(summary.angmom_rel_change_max, expected);
    assert!(expected > 0.0 && expected < 1e-12, "{expected}");
}

/// `run_to_end` steps every remaining step and finishes: the summary of the whole run.
#[test]
fn run_to_end_runs_every_step_and_finishes() {
    let (scene, world, settings) = default_world();
    let (mut sim, seen) = simulation(&scene, &world, &settings);
    sim.advance(42).unwrap();
    let summary = sim.run_to_end(&[]).unwrap();
    assert_eq!((summary.steps, summary.frames_recorded), (95, 11));
    assert_eq!(seen.lock().unwrap().last().unwrap().0, 95);
}

/// A run of `steps` steps of the scene `text` (its files beside the bundled models).
fn run_scene(text: &str, steps: u64) -> RunSummary {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/summary_test.toml");
    let scene = Scene::parse(text, &path).unwrap();
    let world = scene.build().unwrap();
    let settings = RunSettings {
        steps,
        log_every: 10,
        ..scene.run_settings()
    };
    let (mut sim, _) = simulation(&scene, &world, &settings);
    sim.run().unwrap();
    sim.finish(&[]).unwrap()
}

/// A floating robot released at rest under gravity keeps a zero angular momentum (uniform
/// gravity has no moment about its centre of mass): the change is reported as an absolute
/// figure in kg m²/s, not divided by the zero initial momentum (which printed 1.5e294), and the
/// constraint residual over the run is reported.
#[test]
fn a_robot_released_at_rest_reports_an_absolute_momentum_change() {
    let s = run_scene(
        "[sim]\ndt = 0.001\nduration = 1.0\n[[model]]\nurdf = \"chain3_free.urdf\"\n\
         bodies = \"articulated\"\njoints = { j1 = 0.4, j2 = -0.3 }\n",
        200,
    );
    assert_eq!(s.angmom_checked, [0, 1], "{s:?}");
    assert_eq!(s.angmom_rel_change_max, 0.0);
    // Measured 1.1e-16 kg m²/s over the 200 steps (the old relative figure divided it by
    // |L0| = 0).
    assert!(s.angmom_abs_change_max < 1e-15, "{s:?}");
    assert!(!s.fixed_base);
    let [gap, angle] = s.constraint_residual.expect("an articulated run");
    // Measured 1.1e-16 m and 1.1e-16 rad.
    assert!(gap < 1e-9 && angle < 1e-9, "{gap:e} {angle:e}");
    let text = s.momentum_text();
    assert_eq!(
        text,
        format!(
            "angular momentum absolute change max {:.2e} kg m^2/s (starting at rest)",
            s.angmom_abs_change_max
        )
    );
}

/// A fixed-base robot's angular momentum is not conserved (the weld exchanges it with the
/// world): the summary says so instead of printing 0.00e0; a spinning chain keeps the
/// relative figure.
#[test]
fn a_fixed_base_run_says_its_momentum_is_not_conserved() {
    let s = run_scene(
        "[sim]\ndt = 0.001\nduration = 1.0\n[[model]]\nurdf = \"double_pendulum.urdf\"\n\
         bodies = \"articulated\"\nbase = \"fixed\"\njoints = { shoulder = 2.0, elbow = 0.5 }\n",
        100,
    );
    assert_eq!(s.angmom_checked, [0, 0], "{s:?}");
    assert!(s.fixed_base);
    assert_eq!(
        s.momentum_text(),
        "angular momentum not conserved: fixed base"
    );
    // Measured 5.0e-16 m and 1.9e-16 rad over the 100 steps.
    let [gap, angle] = s.constraint_residual.expect("an articulated run");
    assert!(gap < 1e-12 && angle < 1e-12, "{gap:e} {angle:e}");

    let s = run_scene(
        "[sim]\ndt = 0.001\nduration = 1.0\ngravity = [0, 0, 0]\n[[model]]\n\
         urdf = \"chain3_free.urdf\"\nbodies = \"articulated\"\nangvel = [0.0, 0.3, 0.5]\n\
         joint_velocities = { j1 = 2.0, j2 = -3.0 }\n",
        100,
    );
    assert_eq!(s.angmom_checked, [1, 0], "{s:?}");
    // Measured 9.6e-16 (exact discrete conservation).
    assert!(s.angmom_rel_change_max < 1e-12, "{s:?}");
    assert!(
        s.momentum_text()
            .starts_with("angular momentum relative change max ")
    );
}

/// The Rerun blueprint plots the scene's angular momentum change only where one is conserved:
/// not for a fixed-base robot alone (it would be a flat line at 0), but for a floating one.
#[test]
fn the_rerun_blueprint_omits_the_momentum_plot_of_fixed_base_runs() {
    let dir = tempfile::tempdir().unwrap();
    let views = |urdf: &str, base: &str| -> Vec<String> {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/views.toml");
        let text = format!(
            "[sim]\nduration = 0.01\n[[model]]\nurdf = \"{urdf}\"\nbodies = \"articulated\"\n{base}\n"
        );
        let world = Scene::parse(&text, &path).unwrap().build().unwrap();
        let out = dir.path().join(format!("{urdf}.rrd"));
        let sink =
            crate::record::rerun::RerunSink::create(&out, &world.layout, &Default::default())
                .unwrap();
        sink.plot_views().iter().map(|v| v.title.clone()).collect()
    };
    let has_momentum = |titles: &[String]| titles.iter().any(|t| t.starts_with("angular momentum"));
    let fixed = views("double_pendulum.urdf", "base = \"fixed\"");
    assert!(!has_momentum(&fixed), "{fixed:?}");
    assert!(
        fixed.iter().any(|t| t.starts_with("energy change")),
        "{fixed:?}"
    );
    let floating = views("chain3_free.urdf", "");
    assert!(has_momentum(&floating), "{floating:?}");
}
