//! `trade.rrd` and `trade.mcap`: every integrator's run of the scene side by side, stepped in
//! lockstep at one step size.
//!
//! Integrator `k`'s copy of the scene has frame ids `<k>/<frame id>` (e.g. `rk4/box`) and model
//! `<k>`, so in Rerun each integrator is one entity subtree (`/rk4/world_from_link/box`,
//! `/rk4/visual_geometries/...`, `/plots/energy/rk4/box`), and in MCAP one topic prefix
//! (`/rk4/tf`, `/rk4/bodies`). All copies start from the same state; where they part is what
//! the integrators disagree on.

use crate::record::rerun::RerunOptions;
use crate::record::{Frame, OutputFile, RecordingLayout, Sink, SinkOptions, TopicGroup};
use crate::scene::Scene;
use crate::sim::guard::Divergence;
use crate::sim::{IntegratorKind, RunSettings};
use crate::simulation::{Progress, Simulation};
use crate::world::World;
use std::path::Path;

/// Most frames recorded per run (`log_every` is chosen to stay below).
pub const MAX_FRAMES: u64 = 1000;

/// The combined layout: one prefixed copy of `world`'s layout per integrator.
pub fn layout(world: &World, kinds: &[IntegratorKind], dt: f64) -> RecordingLayout {
    let mut layout = RecordingLayout {
        name: format!("{}_trade", world.layout.name),
        metadata: world.layout.metadata.clone(),
        // Every run has the scene's ground; each run's contacts name its own bodies.
        ground: world.layout.ground,
        contacts: world.layout.contacts,
        ..Default::default()
    };
    layout
        .metadata
        .insert("integrator".into(), "(see integrators)".into());
    layout.metadata.insert(
        "integrators".into(),
        kinds.iter().map(|k| k.name()).collect::<Vec<_>>().join(","),
    );
    layout.metadata.insert("dt".into(), format!("{dt:?}"));
    for kind in kinds {
        let prefix = kind.name();
        let frames_start = layout.frames.len();
        let bodies_start = layout.bodies.len();
        let joints_start = layout.joints.len();
        let mechanisms_start = layout.mechanisms.len();
        for f in &world.layout.frames {
            let mut f = f.clone();
            f.frame_id = format!("{prefix}/{}", f.frame_id);
            f.model = prefix.to_string();
            layout.frames.push(f);
        }
        for b in &world.layout.bodies {
            let mut b = b.clone();
            b.name = format!("{prefix}/{}", b.name);
            b.frame += frames_start;
            layout.bodies.push(b);
        }
        for j in &world.layout.joints {
            let mut j = j.clone();
            j.name = format!("{prefix}/{}", j.name);
            j.model = prefix.to_string();
            layout.joints.push(j);
        }
        for m in &world.layout.mechanisms {
            let mut m = m.clone();
            m.name = format!("{prefix}/{}", m.name);
            m.bodies = m.bodies.start + bodies_start..m.bodies.end + bodies_start;
            m.joints = m.joints.start + joints_start..m.joints.end + joints_start;
            layout.mechanisms.push(m);
        }
        for d in &world.layout.drives {
            let mut d = d.clone();
            d.joint += joints_start;
            layout.drives.push(d);
        }
        layout.topic_groups.push(TopicGroup {
            prefix: format!("/{prefix}"),
            frames: frames_start..layout.frames.len(),
            bodies: bodies_start..layout.bodies.len(),
            joints: joints_start..layout.joints.len(),
            mechanisms: mechanisms_start..layout.mechanisms.len(),
        });
    }
    layout
}

/// Runs every integrator on `scene` for `duration_secs` at `dt` and records them side by side.
/// Every run is a [`Simulation`] on this thread, watched by its divergence guard (the scene's
/// `divergence_energy_ratio`, Newton failures stop it when substepping is on); the runs go from
/// one recorded step to the next in turn. When one run fails, the recording ends at the last
/// recorded step before it (nothing non-finite is written) and the failure is returned with
/// the integrator it happened to (the earliest step's, the first in `kinds` among those failing
/// at that step) and the body's name; the files are finished either way.
pub fn record(
    scene: &Scene,
    kinds: &[IntegratorKind],
    dt: f64,
    duration_secs: f64,
    rrd: &Path,
    mcap: &Path,
) -> anyhow::Result<Option<(IntegratorKind, Divergence, String)>> {
    let world = scene.build()?;
    crate::scene::triangles::check_recorded(&world, &scene.source)?;
    let layout = layout(&world, kinds, dt);
    let steps = super::measure::steps_in(duration_secs, dt);
    let log_every = steps.div_ceil(MAX_FRAMES).max(1);
    let settings = RunSettings {
        steps,
        log_every,
        quiet: true,
        ..scene.run_settings()
    };
    let variational = scene.variational_settings();
    // The runs first (an unsupported integrator is an error before any file exists).
    let mut runs: Vec<Simulation> = kinds
        .iter()
        .map(|&kind| Simulation::of_world(&world, kind, dt, &variational, 1, &settings))
        .collect::<anyhow::Result<_>>()?;
    // The MCAP file keeps its inertia ellipsoids (the default options); the Rerun one leaves
    // them out.
    let options = SinkOptions {
        rerun: RerunOptions { ellipsoids: false },
        ..SinkOptions::default()
    };
    let mut sinks: Vec<Box<dyn Sink>> = vec![
        crate::record::open_file(OutputFile::Mcap, mcap, &layout, &options)?,
        crate::record::open_file(OutputFile::Rrd, rrd, &layout, &options)?,
    ];
    let mut stopped = None;
    let mut poses = Vec::with_capacity(layout.frames.len());
    let mut states = Vec::with_capacity(layout.bodies.len());
    let mut joint_states = Vec::with_capacity(layout.joints.len());
    let mut mechanism_states = Vec::with_capacity(layout.mechanisms.len());
    let mut contacts = Vec::new();
    let mut result = Ok(());
    let mut step = 0;
    loop {
        poses.clear();
        states.clear();
        joint_states.clear();
        mechanism_states.clear();
        contacts.clear();
        let mut time_ns = 0;
        for sim in &mut runs {
            let frame = sim.frame();
            time_ns = frame.time_ns;
            // Run k's bodies follow those of the runs before it in the combined layout.
            let offset = states.len();
            contacts.extend(frame.contacts.iter().map(|c| crate::record::ContactState {
                body_a: c.body_a + offset,
                body_b: c.body_b.map(|b| b + offset),
                ..*c
            }));
            poses.extend_from_slice(&frame.world_from_link);
            states.extend_from_slice(&frame.bodies);
            joint_states.extend_from_slice(&frame.joints);
            mechanism_states.extend_from_slice(&frame.mechanisms);
        }
        let frame = Frame {
            step,
            time_ns,
            world_from_link: &poses,
            bodies: &states,
            joints: &joint_states,
            mechanisms: &mechanism_states,
            contacts: &contacts,
        };
        if let Some(e) = sinks.iter_mut().find_map(|s| s.write(&frame).err()) {
            result = Err(e);
            break;
        }
        if step == steps {
            break;
        }
        let next = ((step / log_every + 1) * log_every).min(steps);
        if let Err(e) = runs
            .iter_mut()
            .try_for_each(|sim| sim.advance(next - step).map(drop))
        {
            result = Err(e);
            break;
        }
        stopped = kinds
            .iter()
            .zip(&mut runs)
            .filter(|(_, sim)| sim.progress() == Progress::Stopped)
            .filter_map(|(&kind, sim)| sim.summary().stopped.map(|d| (kind, d)))
            .min_by_key(|(_, d)| d.step)
            .map(|(kind, d)| (kind, d, world.layout.bodies[d.body].name.clone()));
        if stopped.is_some() {
            break;
        }
        step = next;
    }
    crate::record::finish_all(sinks, result.map(|()| stopped), &[rrd, mcap])
}
