//! The stepping contract of [`Simulation`]: how far each call goes changes nothing recorded.

use super::*;
use crate::record::Frame;
use crate::scene::Scene;
use nalgebra::Isometry3;
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
