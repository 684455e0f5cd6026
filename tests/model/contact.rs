//! Contact, the scene side (issue 31): a scene's `[ground]` and its models' `collisions` built
//! into `World::contact` — each collider on the right body, at its pose in that body's
//! principal frame computed here by hand from the URDF numbers (not by the code under test),
//! in every body mode, with copies, groups and the pairs that never collide.

use crate::common;

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use std::f64::consts::FRAC_PI_2;
use tumble::scene::Scene;
use tumble::sim::contact::{Collider, ContactModel, Shape};
use tumble::world::World;

/// Two links: `base` (1 kg, centre of mass at its origin, inertia diag(0.03, 0.01, 0.025)) and
/// `arm` (3 kg, centre of mass at (0.05, 0, 0) of its frame, inertia diag(0.01, 0.02, 0.025)),
/// on a revolute `hinge` at (0.4, 0, 0) of `base`, axis z. `base` carries a sphere (r = 0.05)
/// at (0, 0, 0.1); `arm` a box 0.1 × 0.2 × 0.3 at (0, 0.1, 0), rpy (π/2, 0, 0); and a massless
/// `tip` (fixed at (0.3, 0, 0) of `arm`) a sphere (r = 0.02) at its origin. The visuals are
/// one sphere (r = 0.07) on `base`.
const TWO_LINKS: &str = r#"<?xml version="1.0"?>
<robot name="two">
  <link name="base">
    <inertial>
      <mass value="1.0"/>
      <inertia ixx="0.03" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.025"/>
    </inertial>
    <visual><geometry><sphere radius="0.07"/></geometry></visual>
    <collision name="ball">
      <origin xyz="0 0 0.1"/>
      <geometry><sphere radius="0.05"/></geometry>
    </collision>
  </link>
  <link name="arm">
    <inertial>
      <origin xyz="0.05 0 0"/>
      <mass value="3.0"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.025"/>
    </inertial>
    <collision>
      <origin xyz="0 0.1 0" rpy="1.5707963267948966 0 0"/>
      <geometry><box size="0.1 0.2 0.3"/></geometry>
    </collision>
  </link>
  <link name="tip">
    <collision><geometry><sphere radius="0.02"/></geometry></collision>
  </link>
  <joint name="hinge" type="revolute">
    <parent link="base"/><child link="arm"/>
    <origin xyz="0.4 0 0"/>
    <axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/>
  </joint>
  <joint name="tip_joint" type="fixed">
    <parent link="arm"/><child link="tip"/>
    <origin xyz="0.3 0 0"/>
  </joint>
</robot>
"#;

/// Builds `scene` (its text; `two.urdf` is [`TWO_LINKS`], more files in `files`) in a
/// temporary folder.
fn build_with(scene: &str, files: &[(&str, &str)]) -> anyhow::Result<World> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("two.urdf"), TWO_LINKS).unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    Scene::load(&path)?.build()
}

fn build(scene: &str) -> World {
    build_with(scene, &[]).unwrap_or_else(|e| panic!("{e:#}\n{scene}"))
}

fn rx(angle: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::x_axis(), angle)
}

/// `R` from its columns (the images of x, y, z), written out.
fn rotation(columns: [[f64; 3]; 3]) -> UnitQuaternion<f64> {
    let [a, b, c] = columns.map(Vector3::from);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(Matrix3::from_columns(
        &[a, b, c],
    )))
}

fn pose(t: [f64; 3], r: UnitQuaternion<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(Vector3::from(t)), r)
}

fn assert_pose(got: &Isometry3<f64>, want: &Isometry3<f64>, what: &str) {
    let dt = (got.translation.vector - want.translation.vector).norm();
    let dr = got.rotation.angle_to(&want.rotation);
    assert!(
        dt < 1e-12 && dr < 1e-12,
        "{what}: got {got:?}, want {want:?} (|dt| {dt:e}, angle {dr:e})"
    );
}

fn sphere(r: f64) -> Shape {
    Shape::Sphere { radius: r }
}

fn arm_box() -> Shape {
    Shape::Box {
        half_extents: Vector3::new(0.05, 0.1, 0.15),
    }
}

const SCENE: &str = "[sim]\nduration = 0.01\n[ground]\nheight = 0.0\n";

/// Links mode: each link its own body, its principal frame at its centre of mass with its
/// principal axes (moments ascending).
///
/// `base`: moments (0.01, 0.025, 0.03) lie along its y, z, x axes, so `link_from_principal` =
/// (0, Q) with Q's columns y, z, x: the ball at p = (0, 0, 0.1) is at Qᵀ p = (p_y, p_z, p_x)
/// = (0, 0.1, 0), turned by Qᵀ. `arm`: moments ascending along x, y, z (Q = E), centre of mass
/// c = (0.05, 0, 0): the box is at (0, 0.1, 0) − c = (−0.05, 0.1, 0), turned by Rx(π/2).
/// `tip` has no mass: no body, its sphere left out with a note.
#[test]
fn links_mode_places_each_collider_in_its_links_principal_frame() {
    let world = build(&format!(
        "{SCENE}[[model]]\nurdf = \"two.urdf\"\nposition = [1, 2, 3]\nrpy = [0.3, -0.2, 1.0]\n\
         collisions = \"urdf\"\nfriction = 0.4\nrestitution = 0.25\n"
    ));
    let c = &world.contact;
    assert_eq!(c.colliders.len(), 2, "{c:?}");
    let q_base = rotation([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);
    let ball = &c.colliders[0];
    assert_eq!((ball.body, &ball.shape), (0, &sphere(0.05)));
    assert_pose(
        &ball.body_from_shape,
        &pose([0.0, 0.1, 0.0], q_base.inverse()),
        "ball",
    );
    let arm = &c.colliders[1];
    assert_eq!((arm.body, &arm.shape), (1, &arm_box()));
    assert_pose(
        &arm.body_from_shape,
        &pose([-0.05, 0.1, 0.0], rx(FRAC_PI_2)),
        "arm box",
    );
    for collider in &c.colliders {
        assert_eq!(
            (
                collider.friction,
                collider.restitution,
                collider.group,
                collider.self_collision
            ),
            (0.4, 0.25, 0, false)
        );
    }
    // The hinge's parent and child never collide.
    assert_eq!(c.excluded_body_pairs, vec![(0, 1)]);
    assert!(
        world
            .notes
            .iter()
            .any(|n| n.contains("`tip` (no mass: with bodies = \"links\" it is no body)")),
        "{:?}",
        world.notes
    );
    // The ground: level, through the origin, the defaults.
    let ground = c.ground.as_ref().unwrap();
    assert_eq!(
        (
            ground.normal.into_inner(),
            ground.point,
            ground.friction,
            ground.restitution
        ),
        (Vector3::z(), Vector3::zeros(), 0.8, 0.0)
    );
    assert!(c.is_active());
    // Where the shape is in the world, two ways: through the body (the world's state) and
    // straight from the URDF (placement · link origin · collision origin).
    let world_from_model = pose(
        [1.0, 2.0, 3.0],
        UnitQuaternion::from_euler_angles(0.3, -0.2, 1.0),
    );
    let arm_from_box = pose([0.0, 0.1, 0.0], rx(FRAC_PI_2));
    let via_urdf =
        world_from_model * pose([0.4, 0.0, 0.0], UnitQuaternion::identity()) * arm_from_box;
    let via_body = world.bodies[1].world_from_body * arm.body_from_shape;
    assert_pose(&via_body, &via_urdf, "arm box in the world");
}

/// Rigid mode: one body, its principal frame the composite's. m = 1 + 3 = 4 kg; the arm's
/// centre of mass is at 0.4 + 0.05 = 0.45 in the model frame, so c = 3 · 0.45 / 4 = 0.3375
/// along x. The parallel-axis terms are along x only, so the composite inertia stays diagonal
/// with moments ascending along x, y, z (0.04, 0.181875, 0.201875): Q = E. The ball is at
/// (0, 0, 0.1) − c = (−0.3375, 0, 0.1); the box at (0.4, 0.1, 0) − c = (0.0625, 0.1, 0), turned
/// by Rx(π/2); the massless tip rides on the body: (0.4 + 0.3, 0, 0) − c = (0.3625, 0, 0).
#[test]
fn rigid_mode_places_every_links_collider_in_the_composites_principal_frame() {
    let world = build(&format!(
        "{SCENE}[[model]]\nurdf = \"two.urdf\"\nbodies = \"rigid\"\ncollisions = \"urdf\"\n"
    ));
    assert_eq!(world.bodies.len(), 1);
    let moments = world.bodies[0].principal_moments;
    assert!(
        (moments - Vector3::new(0.04, 0.181875, 0.201875)).norm() < 1e-12,
        "{moments}"
    );
    let c = &world.contact;
    let want = [
        (
            sphere(0.05),
            pose([-0.3375, 0.0, 0.1], UnitQuaternion::identity()),
        ),
        (arm_box(), pose([0.0625, 0.1, 0.0], rx(FRAC_PI_2))),
        (
            sphere(0.02),
            pose([0.3625, 0.0, 0.0], UnitQuaternion::identity()),
        ),
    ];
    assert_eq!(c.colliders.len(), want.len(), "{c:?}");
    for (collider, (shape, body_from_shape)) in c.colliders.iter().zip(&want) {
        assert_eq!((collider.body, &collider.shape), (0, shape));
        assert_pose(
            &collider.body_from_shape,
            body_from_shape,
            &format!("{shape:?}"),
        );
        // The defaults.
        assert_eq!((collider.friction, collider.restitution), (0.8, 0.0));
    }
    assert!(c.excluded_body_pairs.is_empty());
    assert!(
        world.notes.iter().all(|n| !n.contains("left out")),
        "{:?}",
        world.notes
    );
}

/// Articulated mode, floating: `base` and `arm` (with `tip` merged into it across the fixed
/// joint) are two bodies. `base`'s frame is links mode's; the arm group's composite is the
/// arm's own mass properties (the tip is massless), so the box is where links mode puts it,
/// and the tip's sphere at (0.3, 0, 0) − (0.05, 0, 0) = (0.25, 0, 0). Fixed base: `base` is
/// welded to the world, its ball left out with a note, the arm the only body.
#[test]
fn articulated_mode_places_colliders_on_the_groups_bodies() {
    let world = build(&format!(
        "{SCENE}[[model]]\nurdf = \"two.urdf\"\nbodies = \"articulated\"\n\
         collisions = \"urdf\"\nself_collision = true\n"
    ));
    let c = &world.contact;
    let q_base = rotation([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);
    let want = [
        (0, sphere(0.05), pose([0.0, 0.1, 0.0], q_base.inverse())),
        (1, arm_box(), pose([-0.05, 0.1, 0.0], rx(FRAC_PI_2))),
        (
            1,
            sphere(0.02),
            pose([0.25, 0.0, 0.0], UnitQuaternion::identity()),
        ),
    ];
    assert_eq!(c.colliders.len(), want.len(), "{c:?}");
    for (collider, (body, shape, body_from_shape)) in c.colliders.iter().zip(&want) {
        assert_eq!((collider.body, &collider.shape), (*body, shape));
        assert_pose(
            &collider.body_from_shape,
            body_from_shape,
            &format!("{shape:?}"),
        );
        assert!(collider.self_collision);
    }
    assert_eq!(c.excluded_body_pairs, vec![(0, 1)]);

    let world = build(&format!(
        "{SCENE}[[model]]\nurdf = \"two.urdf\"\nbodies = \"articulated\"\nbase = \"fixed\"\n\
         collisions = \"urdf\"\n"
    ));
    let c = &world.contact;
    assert_eq!(c.colliders.len(), 2, "{c:?}");
    assert!(c.colliders.iter().all(|k| k.body == 0));
    assert_pose(
        &c.colliders[0].body_from_shape,
        &pose([-0.05, 0.1, 0.0], rx(FRAC_PI_2)),
        "arm box",
    );
    // The hinge's parent is the world: no pair.
    assert!(c.excluded_body_pairs.is_empty());
    assert!(
        world
            .notes
            .iter()
            .any(|n| n.contains("`base` (welded to the world")),
        "{:?}",
        world.notes
    );
}

/// Copies (a table with `copies` and a drawn position) and tables: one group per copy, the
/// bodies' indices shifted, the colliders sorted by body, the pairs per copy; a table without
/// collisions adds bodies but no collider.
#[test]
fn copies_get_their_own_groups_and_pairs() {
    let world = build(&format!(
        "{SCENE}[[model]]\nurdf = \"two.urdf\"\nname = \"plain\"\n\
         [[model]]\nurdf = \"two.urdf\"\nname = \"many\"\ncopies = 3\nseed = 2\n\
         position = {{ uniform = [[-1, -1, 1], [1, 1, 2]] }}\ncollisions = \"urdf\"\n\
         [[model]]\nurdf = \"two.urdf\"\nname = \"stiff\"\nbodies = \"rigid\"\ncollisions = \"urdf\"\n"
    ));
    let c = &world.contact;
    // Bodies: plain 0-1, many_0 2-3, many_1 4-5, many_2 6-7, stiff 8.
    assert_eq!(world.bodies.len(), 9);
    let got: Vec<(usize, u32)> = c.colliders.iter().map(|k| (k.body, k.group)).collect();
    assert_eq!(
        got,
        vec![
            (2, 1),
            (3, 1),
            (4, 2),
            (5, 2),
            (6, 3),
            (7, 3),
            (8, 4),
            (8, 4),
            (8, 4)
        ]
    );
    assert_eq!(c.excluded_body_pairs, vec![(2, 3), (4, 5), (6, 7)]);
    // Every copy's colliders sit where the first copy's do in their bodies.
    for k in 0..3 {
        assert_eq!(
            c.colliders[2 * k].body_from_shape,
            c.colliders[0].body_from_shape
        );
        assert_eq!(
            c.colliders[2 * k + 1].body_from_shape,
            c.colliders[1].body_from_shape
        );
    }
}

/// The dataset path: `Scene::assemble` with another placement puts the same colliders on the
/// same bodies (the poses in the bodies do not depend on where a copy starts).
#[test]
fn assemble_with_any_placement_gives_the_same_colliders() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("two.urdf"), TWO_LINKS).unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(
        &path,
        format!("{SCENE}[[model]]\nurdf = \"two.urdf\"\nbodies = \"articulated\"\ncollisions = \"urdf\"\n"),
    )
    .unwrap();
    let scene = Scene::load(&path).unwrap();
    let loaded = scene.load_models().unwrap();
    let here = scene
        .assemble(&loaded, &|t, c| scene.models[t].placement(c))
        .unwrap();
    let mut moved = scene.models[0].clone();
    moved.position = [5.0, -1.0, 2.0];
    moved.rpy = [0.1, 0.2, 0.3];
    moved.angvel = [0.0, 0.0, 1.0];
    let there = scene.assemble(&loaded, &|_, c| moved.placement(c)).unwrap();
    assert_eq!(here.contact, there.contact);
    assert_eq!(here.contact.colliders.len(), 3);
}

/// `collisions = "visual"` takes the `<visual>` elements: `base`'s sphere of radius 0.07 at
/// its origin, so at the origin of its principal frame.
#[test]
fn visual_geometry_collides_when_asked() {
    let world = build(&format!(
        "{SCENE}[[model]]\nurdf = \"two.urdf\"\ncollisions = \"visual\"\n"
    ));
    let c = &world.contact;
    assert_eq!(c.colliders.len(), 1, "{c:?}");
    assert_eq!(
        (c.colliders[0].body, &c.colliders[0].shape),
        (0, &sphere(0.07))
    );
    let q_base = rotation([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);
    assert_pose(
        &c.colliders[0].body_from_shape,
        &pose([0.0; 3], q_base.inverse()),
        "visual sphere",
    );
}

/// A collision mesh becomes the hull of its vertices with `<mesh scale>` applied, placed like
/// any element; the same file used twice is one hull.
#[test]
fn a_collision_mesh_becomes_its_scaled_hull() {
    // A unit cube's 8 corners and its centre, as an OBJ (12 triangles; the centre is used by
    // no face and is not a vertex of the mesh).
    let mut obj = String::new();
    for k in 0..8 {
        obj += &format!("v {} {} {}\n", k & 1, (k >> 1) & 1, (k >> 2) & 1);
    }
    for f in [
        [1, 3, 4],
        [1, 4, 2],
        [5, 6, 8],
        [5, 8, 7],
        [1, 2, 6],
        [1, 6, 5],
        [3, 7, 8],
        [3, 8, 4],
        [1, 5, 7],
        [1, 7, 3],
        [2, 4, 8],
        [2, 8, 6],
    ] {
        obj += &format!("f {} {} {}\n", f[0], f[1], f[2]);
    }
    let urdf = r#"<robot name="m">
  <link name="m">
    <inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <collision>
      <origin xyz="0 0 0.5"/>
      <geometry><mesh filename="cube.obj" scale="0.2 0.4 -0.6"/></geometry>
    </collision>
    <collision><geometry><mesh filename="cube.obj" scale="0.2 0.4 -0.6"/></geometry></collision>
  </link>
</robot>"#;
    let world = build_with(
        &format!("{SCENE}[[model]]\nurdf = \"m.urdf\"\ncollisions = \"urdf\"\n"),
        &[("m.urdf", urdf), ("cube.obj", &obj)],
    )
    .unwrap();
    let c = &world.contact;
    assert_eq!(c.colliders.len(), 2);
    let Shape::ConvexHull { points } = &c.colliders[0].shape else {
        panic!("{:?}", c.colliders[0].shape)
    };
    let mut got: Vec<[f64; 3]> = points.iter().map(|p| [p.x, p.y, p.z]).collect();
    got.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let mut want: Vec<[f64; 3]> = (0..8)
        .map(|k| {
            [
                0.2 * (k & 1) as f64,
                0.4 * ((k >> 1) & 1) as f64,
                -0.6 * ((k >> 2) & 1) as f64,
            ]
        })
        .collect();
    want.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(got, want);
    // One hull, shared.
    let Shape::ConvexHull { points: second } = &c.colliders[1].shape else {
        panic!()
    };
    assert!(std::sync::Arc::ptr_eq(points, second));
    assert_pose(
        &c.colliders[0].body_from_shape,
        &pose([0.0, 0.0, 0.5], UnitQuaternion::identity()),
        "mesh",
    );
}

/// A scene without `[ground]` or `collisions` has an empty, inactive contact model (today's
/// behaviour), and the bundled contact scene builds the cube on the ground.
#[test]
fn no_contact_keys_no_contact_and_the_bundled_scene() {
    let world = build("[sim]\nduration = 0.01\n[[model]]\nurdf = \"two.urdf\"\n");
    assert_eq!(world.contact, ContactModel::default());
    assert!(!world.contact.is_active());

    let scene = Scene::load(&common::root().join("models/contact_box.toml")).unwrap();
    let world = scene.build().unwrap();
    let c = &world.contact;
    assert_eq!(
        c.colliders,
        vec![Collider {
            body: 0,
            body_from_shape: Isometry3::identity(),
            shape: Shape::Box {
                half_extents: Vector3::repeat(0.1)
            },
            friction: 0.8,
            restitution: 0.0,
            group: 0,
            self_collision: false,
        }]
    );
    let ground = c.ground.as_ref().unwrap();
    assert_eq!(
        (ground.normal.into_inner(), ground.point),
        (Vector3::z(), Vector3::zeros())
    );
    // Its bottom face starts 0.5 m above the ground.
    let bottom = world.bodies[0].world_from_body.translation.vector.z - 0.1;
    assert!((bottom - 0.5).abs() < 1e-15, "{bottom}");
    assert!(c.is_active());
}

/// Errors while building: a model asking for collisions without the geometry, naming the
/// scene, the model and its URDF.
#[test]
fn collisions_without_geometry_are_errors() {
    let no_visual = TWO_LINKS.replace(
        "<visual><geometry><sphere radius=\"0.07\"/></geometry></visual>",
        "",
    );
    let e = format!(
        "{:#}",
        build_with(
            &format!("{SCENE}[[model]]\nurdf = \"nv.urdf\"\ncollisions = \"visual\"\n"),
            &[("nv.urdf", &no_visual)],
        )
        .unwrap_err()
    );
    assert!(
        e.contains("scene.toml: model[0]: collisions = \"visual\": model `two`")
            && e.contains("nv.urdf")
            && e.contains("no link has <visual> geometry"),
        "{e}"
    );
}
