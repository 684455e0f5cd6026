//! A run on one thread stays on that thread: loading, stepping and building the recorded
//! frames (free bodies and an articulated model's reports) never start rayon's global pool,
//! whose idle workers spin (`sched_yield`) after every task and took 0.19 s of the two cores'
//! CPU in a 1 s, 10 000-body `--threads 1` run while the frames were built there (docs/scale.md,
//! sixth session). Its own test binary: the global pool is per process, and this test must be
//! the only one that could start it.

mod common;

use nalgebra::Vector3;
use tumble::scene::Scene;

/// Checks the recorded frames: finite poses, and at step 0 (when `initial` is given) every
/// body's velocities as the scene set them. The latter catches a frame builder that fills a
/// body's state from another body (a frame task's offset: the swarm below has more bodies
/// than one task holds).
struct Check {
    /// Per body: the initial linear and angular velocity, world frame.
    initial: Option<Vec<(Vector3<f64>, Vector3<f64>)>>,
}

impl tumble::record::Sink for Check {
    fn write(&mut self, frame: &tumble::record::Frame<'_>) -> anyhow::Result<()> {
        assert!(
            frame
                .world_from_link
                .iter()
                .all(|p| p.translation.x.is_finite())
        );
        if let (0, Some(initial)) = (frame.step, &self.initial) {
            assert_eq!(frame.bodies.len(), initial.len());
            for (i, (state, (v, w))) in frame.bodies.iter().zip(initial).enumerate() {
                // The state at step 0 is the initial one up to the rounding of `J Ω` and back
                // (measured over the 3000 bodies: linear velocities exact, angular within
                // 1.95e-15 relative); another body's is off by order 1.
                assert!(
                    (state.linvel_world - v).norm() <= 1e-12 * v.norm(),
                    "body {i}"
                );
                assert!(
                    (state.angvel_world - w).norm() <= 1e-12 * w.norm(),
                    "body {i}"
                );
            }
        }
        Ok(())
    }
    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        Ok(())
    }
}

fn run_on_one_thread(scene: &std::path::Path, check_initial: bool) -> u64 {
    let scene = Scene::load(scene).unwrap();
    let world = scene.build().unwrap();
    let mut run = scene.run_settings();
    run.steps = run.steps.min(50);
    let initial = check_initial.then(|| {
        world
            .bodies
            .iter()
            .map(|b| (b.linvel_world, b.angvel_world))
            .collect()
    });
    let sinks: Vec<Box<dyn tumble::record::Sink>> = vec![Box::new(Check { initial })];
    let summary = common::run_scene_parts(&scene, &world, 1, &run, sinks);
    summary.frames_recorded
}

#[test]
fn a_one_thread_run_never_starts_the_global_pool() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["box", "t_handle", "disc"] {
        std::fs::copy(
            common::root().join(format!("models/{name}.urdf")),
            dir.path().join(format!("{name}.urdf")),
        )
        .unwrap();
    }
    // The swarm's shapes at 3000 bodies: more than one frame task (2048 items) per array.
    let swarm = std::fs::read_to_string(common::root().join("models/swarm.toml"))
        .unwrap()
        .replace("copies = 4000", "copies = 1000")
        .replace("copies = 3000", "copies = 1000");
    std::fs::write(dir.path().join("swarm.toml"), swarm).unwrap();
    let frames = run_on_one_thread(&dir.path().join("swarm.toml"), true);
    assert!(frames >= 2, "{frames} frames");
    // An articulated model: the mechanism reports of the frame builder.
    let frames = run_on_one_thread(&common::root().join("models/double_pendulum.toml"), false);
    assert!(frames >= 2, "{frames} frames");
    // `build_global` fails once the global pool exists (it was started by a parallel
    // iterator outside any pool).
    assert!(
        rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build_global()
            .is_ok(),
        "a one-thread run started rayon's global pool"
    );
}
