//! `copies = N` of an articulated table: one shared mechanism model (an `Arc`) for every copy,
//! frame ids `<name>_<index>/<link>`, and each copy moving exactly as the same model run alone
//! at that copy's placement.

use crate::common::urdfs::models_scene as scene;

use nalgebra::Vector3;
use std::sync::Arc;
use tumble::scene::Scene;
use tumble::sim::Bodies;
use tumble::sim::Loads;
use tumble::simulation::FrameBuilder;
use tumble::world::World;

const SIM: &str = "[sim]\ndt = 0.002\nduration = 1.0\nintegrator = \"variational\"\n";

/// Pendulums welded at drawn positions, and floating chains drawn elsewhere (no gravity would
/// leave the pendulums still: the scene keeps gravity, the chains fall together with it).
fn copies_scene() -> String {
    format!(
        "{SIM}
[[model]]
urdf = \"double_pendulum.urdf\"
name = \"pend\"
bodies = \"articulated\"
base = \"fixed\"
copies = 12
seed = 7
position = {{ uniform = [[-5.0, -5.0, 1.0], [5.0, 5.0, 4.0]] }}
joints = {{ shoulder = 2.0, elbow = 0.5 }}
joint_velocities = {{ elbow = 1.0 }}

[[model]]
urdf = \"chain3_free.urdf\"
name = \"chain\"
bodies = \"articulated\"
copies = 3
seed = 8
position = {{ uniform = [[-5.0, -5.0, 5.0], [5.0, 5.0, 8.0]] }}
linvel = [0.1, 0.0, 0.05]
angvel = [0.0, 0.3, 0.5]
joints = {{ j1 = 0.4, j2 = -0.3 }}
joint_velocities = {{ j1 = 2.0, j2 = -3.0 }}
"
    )
}

/// The same model alone, welded (or placed) at `position`.
fn alone(urdf: &str, fixed: bool, position: &Vector3<f64>, rest: &str) -> String {
    format!(
        "{SIM}
[[model]]
urdf = \"{urdf}\"
bodies = \"articulated\"
base = \"{}\"
position = [{:?}, {:?}, {:?}]
{rest}
",
        if fixed { "fixed" } else { "floating" },
        position.x,
        position.y,
        position.z
    )
}

fn run(world: &World, scene: &Scene, steps: u64) -> Bodies {
    let mut bodies = Bodies::new(&world.bodies);
    let mut integrator = world
        .integrator(
            scene.integrator(),
            scene.sim.dt,
            &scene.variational_settings(),
        )
        .unwrap();
    integrator.init(&bodies);
    for _ in 0..steps {
        integrator.step(&mut bodies, &Loads::uniform_gravity(scene.gravity()));
    }
    bodies
}

#[test]
fn copies_share_one_mechanism_model_and_each_moves_as_the_model_alone() {
    let scene = copies_scene();
    let scene = scene_from(&scene);
    let world = scene.build().unwrap();
    assert_eq!(world.mechanisms.len(), 15);
    // One model per table, shared by its copies; an instance per copy (its name and bodies).
    for m in &world.mechanisms[1..12] {
        assert!(Arc::ptr_eq(&m.shared, &world.mechanisms[0].shared));
    }
    for m in &world.mechanisms[13..] {
        assert!(Arc::ptr_eq(&m.shared, &world.mechanisms[12].shared));
    }
    assert!(!Arc::ptr_eq(
        &world.mechanisms[0].shared,
        &world.mechanisms[12].shared
    ));
    let names: Vec<&str> = world.mechanisms.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names[..3], ["pend_00", "pend_01", "pend_02"]);
    assert_eq!(names[12..], ["chain_0", "chain_1", "chain_2"]);
    let ids: Vec<&str> = world
        .layout
        .frames
        .iter()
        .map(|f| f.frame_id.as_str())
        .collect();
    assert_eq!(ids[..3], ["pend_00/base", "pend_00/upper", "pend_00/lower"]);
    assert!(ids.contains(&"pend_11/lower") && ids.contains(&"chain_2/link2"));
    let joints: Vec<&str> = world
        .layout
        .joints
        .iter()
        .map(|j| j.name.as_str())
        .collect();
    assert_eq!(joints[..2], ["pend_00/shoulder", "pend_00/elbow"]);

    // Where each copy stands: its root link frame at step 0.
    let mut frames = FrameBuilder::new(&world);
    let roots: Vec<Vector3<f64>> = {
        let frame = frames.frame(
            &Bodies::new(&world.bodies),
            &Loads::uniform_gravity(scene.gravity()),
            0,
            0.002,
        );
        world
            .layout
            .frames
            .iter()
            .zip(frame.world_from_link)
            .filter(|(f, _)| f.link == "base" || f.link == "link0")
            .map(|(_, pose)| pose.translation.vector)
            .collect()
    };
    assert_eq!(roots.len(), 15);
    // The draws differ from copy to copy.
    assert!((roots[0] - roots[1]).norm() > 1e-3);

    let steps = 500;
    let together = run(&world, &scene, steps);
    let mut worst: f64 = 0.0;
    for (k, m) in world.mechanisms.iter().enumerate() {
        let text = if k < 12 {
            alone(
                "double_pendulum.urdf",
                true,
                &roots[k],
                "joints = { shoulder = 2.0, elbow = 0.5 }\njoint_velocities = { elbow = 1.0 }",
            )
        } else {
            alone(
                "chain3_free.urdf",
                false,
                &roots[k],
                "linvel = [0.1, 0.0, 0.05]\nangvel = [0.0, 0.3, 0.5]\n\
                 joints = { j1 = 0.4, j2 = -0.3 }\njoint_velocities = { j1 = 2.0, j2 = -3.0 }",
            )
        };
        let single = scene_from(&text);
        let single_world = single.build().unwrap();
        assert_eq!(single_world.bodies.len(), m.body_count);
        let solo = run(&single_world, &single, steps);
        for (i, gi) in m.bodies().enumerate() {
            worst = worst.max((together.com_world[gi] - solo.com_world[i]).norm());
            worst = worst.max(
                together.world_from_body[gi]
                    .angle_to(&solo.world_from_body[i])
                    .abs(),
            );
            worst = worst.max((together.angmom_body[gi] - solo.angmom_body[i]).norm());
        }
    }
    // Each copy is stepped by the same constrained step as the model alone; the copy's pose
    // is composed from its drawn placement rather than read from the text, so the two differ
    // by round-off, which the chaotic swing amplifies: measured 6.5e-14 (m, rad, kg m²/s)
    // over 500 steps. The bound allows round-off only.
    assert!(worst <= 1e-12, "largest difference {worst:e}");
}

fn scene_from(text: &str) -> Scene {
    scene(text)
}
