//! Shared helpers of the integration tests.
#![allow(dead_code)]

pub mod bodies;
pub mod limited;
pub mod urdfs;

use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The interoperability venv's python (created on first use by `scripts/pyenv.sh`).
/// Panics with a clear message when it cannot be created: these tests never pass silently.
pub fn python() -> PathBuf {
    let out = Command::new("bash")
        .arg(root().join("scripts/pyenv.sh"))
        .output()
        .expect("cannot run bash scripts/pyenv.sh");
    assert!(
        out.status.success(),
        "scripts/pyenv.sh failed (the interoperability tests need Python 3 and PyPI):\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    PathBuf::from(String::from_utf8(out.stdout).unwrap().trim())
}

/// Runs `tests/py/<script>` with the venv's python and parses its JSON output.
pub fn run_py(script: &str, args: &[&Path]) -> serde_json::Value {
    let out = Command::new(python())
        .arg(root().join("tests/py").join(script))
        .args(args)
        .output()
        .expect("cannot run python");
    assert!(
        out.status.success(),
        "{script} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("script output is not JSON")
}

/// A program from the venv's bin folder (e.g. `rerun`).
pub fn venv_bin(name: &str) -> PathBuf {
    python().parent().unwrap().join(name)
}

/// Poses as `[tx, ty, tz, qx, qy, qz, qw]`, one per recorded frame, with the frame's time in ns.
pub type Recorded = Vec<(i64, Vec<[f64; 7]>)>;

/// A sink keeping every frame in memory: the reference recordings are compared with.
#[derive(Default)]
pub struct Memory {
    pub frames: std::sync::Arc<std::sync::Mutex<Recorded>>,
}

impl tumble::record::Sink for Memory {
    fn write(&mut self, frame: &tumble::record::Frame<'_>) -> anyhow::Result<()> {
        let poses = frame
            .world_from_link
            .iter()
            .map(|p| {
                let t = p.translation.vector;
                let q = p.rotation.quaternion().coords;
                [t.x, t.y, t.z, q.x, q.y, q.z, q.w]
            })
            .collect();
        self.frames.lock().unwrap().push((frame.time_ns, poses));
        Ok(())
    }
    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        Ok(())
    }
}

/// Runs `scene` into memory: the frame ids and every recorded frame.
pub fn reference_frames(scene: &tumble::scene::Scene) -> (Vec<String>, Recorded) {
    let world = scene.build().unwrap();
    let memory = Memory::default();
    let frames = memory.frames.clone();
    let sinks: Vec<Box<dyn tumble::record::Sink>> = vec![Box::new(memory)];
    let integ = scene
        .integrator()
        .build(scene.sim.dt, &scene.variational_settings());
    let settings = scene.run_settings();
    run_world(&world, integ, &settings, sinks);
    let ids = world
        .layout
        .frames
        .iter()
        .map(|f| f.frame_id.clone())
        .collect();
    let frames = frames.lock().unwrap().clone();
    (ids, frames)
}

/// Runs the `tumble` binary with `args` in the working directory `cwd`.
pub fn tumble(args: &[&str], cwd: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_tumble"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("cannot run tumble")
}

/// Process output as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Runs `world` with one `integrator` (one partition, this thread) into `sinks`, finished.
pub fn run_world(
    world: &tumble::world::World,
    integrator: Box<dyn tumble::sim::Integrator>,
    settings: &tumble::sim::RunSettings,
    sinks: Vec<Box<dyn tumble::record::Sink>>,
) -> tumble::simulation::RunSummary {
    let mut sim =
        tumble::simulation::Simulation::with_integrator(world, integrator, settings).unwrap();
    sim.attach_all(sinks).unwrap();
    sim.run_to_end(&[]).unwrap()
}

/// Runs `world` (built from `scene`) on `threads` threads, each partition stepped by the
/// scene's own integrator, into `sinks`, finished.
pub fn run_scene_parts(
    scene: &tumble::scene::Scene,
    world: &tumble::world::World,
    threads: usize,
    settings: &tumble::sim::RunSettings,
    sinks: Vec<Box<dyn tumble::record::Sink>>,
) -> tumble::simulation::RunSummary {
    let mut sim = tumble::simulation::Simulation::of_world(
        world,
        scene.integrator(),
        scene.sim.dt,
        &scene.variational_settings(),
        threads,
        settings,
    )
    .unwrap();
    sim.attach_all(sinks).unwrap();
    sim.run_to_end(&[]).unwrap()
}

/// A bundled scene of `models/`, as a path string.
pub fn scene(name: &str) -> String {
    root().join("models").join(name).display().to_string()
}

/// The release binary under test.
pub fn exe() -> &'static str {
    env!("CARGO_BIN_EXE_tumble")
}

/// Every name in `dir`, sorted.
pub fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}
