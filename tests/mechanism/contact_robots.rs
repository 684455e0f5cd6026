//! Articulated mechanisms in contact (issue 31): a body of a robot answers a contact impulse
//! through its joints (`sim::contact::robots`). Closed forms and conservation laws only.

use tumble::scene::Scene;
use tumble::simulation::Simulation;

/// Two 8 kg, 0.2 m cubes whose centres are 0.25 m apart along x, joined by a hinge about y
/// half-way between them (the joint frame at the child's centre: `origin` 0.25 m from the
/// parent's). Inertia `m a² / 6 = 0.0533…` kg m² about every axis.
pub const HINGE2: &str = r#"<?xml version="1.0"?>
<robot name="hinge2">
  <link name="a">
    <inertial><mass value="8.0"/><inertia ixx="0.0533333333333333" ixy="0" ixz="0" iyy="0.0533333333333333" iyz="0" izz="0.0533333333333333"/></inertial>
    <visual><geometry><box size="0.2 0.2 0.2"/></geometry></visual>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
  </link>
  <link name="b">
    <inertial><mass value="8.0"/><inertia ixx="0.0533333333333333" ixy="0" ixz="0" iyy="0.0533333333333333" iyz="0" izz="0.0533333333333333"/></inertial>
    <visual><geometry><box size="0.2 0.2 0.2"/></geometry></visual>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
  </link>
  <joint name="j" type="continuous">
    <parent link="a"/><child link="b"/>
    <origin xyz="0.25 0 0"/><axis xyz="0 1 0"/>
  </joint>
</robot>
"#;

/// A simulation of `scene` (TOML, in a directory holding `hinge2.urdf`) on one thread.
fn simulation(scene: &str, dir: &std::path::Path) -> Simulation {
    std::fs::write(dir.join("hinge2.urdf"), HINGE2).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    let scene = Scene::load(&path).unwrap();
    let world = scene.build().unwrap();
    Simulation::of_world(
        &world,
        scene.integrator(),
        scene.sim.dt,
        &scene.variational_settings(),
        1,
        &scene.run_settings(),
    )
    .unwrap()
}

/// The two cubes dropped flat from 0.2 m onto the ground land and rest: heights at the
/// half-size to the solver's tolerance, no penetration growing, no creep.
#[test]
fn a_hinged_pair_lands_and_rests_flat() {
    let dir = tempfile::tempdir().unwrap();
    let mut sim = simulation(
        "[sim]\ndt = 0.001\nduration = 10.0\ngravity = [0.0, 0.0, -9.81]\n\
         [ground]\nheight = 0.0\nfriction = 0.8\n\
         [[model]]\nurdf = \"hinge2.urdf\"\nbodies = \"articulated\"\n\
         position = [0.0, 0.0, 0.3]\ncollisions = \"urdf\"\n",
        dir.path(),
    );
    let mut worst_gap: f64 = 0.0;
    for step in 1..=3000u64 {
        sim.advance(1).unwrap();
        let parts = sim.partitions();
        if step % 100 == 0 || step > 2990 {
            let view = sim.view();
            let za = view.world_from_body(0).translation.vector;
            let zb = view.world_from_body(1).translation.vector;
            let gaps: Vec<f64> = parts.contacts().iter().map(|c| c.gap_m).collect();
            eprintln!(
                "{step}: a {:.3e} {:.3e} b {:.3e} {:.3e} sweeps {} gaps {:?}",
                za.x,
                za.z - 0.1,
                zb.x - 0.25,
                zb.z - 0.1,
                parts.contact_sweeps(),
                gaps
            );
        }
        if step > 1000 {
            for c in parts.contacts() {
                worst_gap = worst_gap.max(-c.gap_m);
            }
        }
    }
    assert!(worst_gap < 1e-9, "{worst_gap:e}");
}
