//! Scenes: URDF inertial frames, the rpy convention, scene validation, and the default scene.

use crate::common;

use nalgebra::{Matrix3, Point3, Vector3};
use std::path::Path;
use tumble::scene::Scene;

/// A one-link URDF with the given inertial origin and inertia tensor (about the centre of mass,
/// in the axes the `rpy` names).
fn one_link_urdf(xyz: [f64; 3], rpy: [f64; 3], mass: f64, i: &Matrix3<f64>) -> String {
    format!(
        r#"<?xml version="1.0"?>
<robot name="probe">
  <link name="probe">
    <inertial>
      <origin xyz="{} {} {}" rpy="{} {} {}"/>
      <mass value="{mass:?}"/>
      <inertia ixx="{:?}" ixy="{:?}" ixz="{:?}" iyy="{:?}" iyz="{:?}" izz="{:?}"/>
    </inertial>
  </link>
</robot>"#,
        xyz[0],
        xyz[1],
        xyz[2],
        rpy[0],
        rpy[1],
        rpy[2],
        i[(0, 0)],
        i[(0, 1)],
        i[(0, 2)],
        i[(1, 1)],
        i[(1, 2)],
        i[(2, 2)]
    )
}

/// `Rz(yaw) Ry(pitch) Rx(roll)` written out element by element (independent of nalgebra's
/// Euler-angle code and of tumble's).
fn rz_ry_rx(rpy: [f64; 3]) -> Matrix3<f64> {
    let (sr, cr) = rpy[0].sin_cos();
    let (sp, cp) = rpy[1].sin_cos();
    let (sy, cy) = rpy[2].sin_cos();
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, cr, -sr, 0.0, sr, cr);
    let ry = Matrix3::new(cp, 0.0, sp, 0.0, 1.0, 0.0, -sp, 0.0, cp);
    let rz = Matrix3::new(cy, -sy, 0.0, sy, cy, 0.0, 0.0, 0.0, 1.0);
    rz * ry * rx
}

fn scene_with(dir: &Path, urdf_text: &str, model_keys: &str, sim: &str) -> Scene {
    let urdf = dir.join("probe.urdf");
    std::fs::write(&urdf, urdf_text).unwrap();
    let text = format!("[sim]\n{sim}\n[[model]]\nurdf = \"probe.urdf\"\n{model_keys}\n");
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).unwrap()
}

fn pose_matrix(p: &[f64; 7]) -> (Vector3<f64>, Matrix3<f64>) {
    let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
        p[6], p[3], p[4], p[5],
    ));
    (
        Vector3::new(p[0], p[1], p[2]),
        q.to_rotation_matrix().into_inner(),
    )
}

/// A rotated, offset inertial frame (`<origin xyz rpy>` with a diagonal tensor) and the same
/// body written with an aligned inertial frame (the tensor pre-rotated by hand, `R I R^T`) move
/// identically; the centre of mass follows the closed-form parabola `c0 + v t + g t^2 / 2`,
/// which the symmetric potential reproduces to round-off.
#[test]
fn rotated_offset_inertial_frame_moves_like_an_aligned_one() {
    let com = [0.1, -0.05, 0.2];
    let rpy = [0.3, -0.4, 0.5];
    let diag = Matrix3::from_diagonal(&Vector3::new(0.02, 0.05, 0.06));
    let r = rz_ry_rx(rpy);
    let rotated_tensor = r * diag * r.transpose();
    let model = "position = [1.0, 2.0, 3.0]\nrpy = [0.2, 0.1, -0.3]\nlinvel = [0.5, 0.0, 3.0]\nangvel = [1.0, 2.0, 3.0]";
    let sim = "dt = 0.001\nduration = 1.0\ngravity = [0.0, 0.0, -9.81]\nlog_every = 50";
    let a_dir = tempfile::tempdir().unwrap();
    let b_dir = tempfile::tempdir().unwrap();
    let a = scene_with(
        a_dir.path(),
        &one_link_urdf(com, rpy, 2.0, &diag),
        model,
        sim,
    );
    let b = scene_with(
        b_dir.path(),
        &one_link_urdf(com, [0.0; 3], 2.0, &rotated_tensor),
        model,
        sim,
    );
    let (_, frames_a) = common::reference_frames(&a);
    let (_, frames_b) = common::reference_frames(&b);
    assert_eq!(frames_a.len(), 21);
    let world_from_model_rot = rz_ry_rx([0.2, 0.1, -0.3]);
    let c0 = Vector3::new(1.0, 2.0, 3.0) + world_from_model_rot * Vector3::from(com);
    let v0 = Vector3::new(0.5, 0.0, 3.0);
    let g = Vector3::new(0.0, 0.0, -9.81);
    let mut worst_pose = 0.0_f64;
    let mut worst_com = 0.0_f64;
    for ((t_a, poses_a), (t_b, poses_b)) in frames_a.iter().zip(&frames_b) {
        assert_eq!(t_a, t_b);
        let (pa, ra) = pose_matrix(&poses_a[0]);
        let (pb, rb) = pose_matrix(&poses_b[0]);
        worst_pose = worst_pose.max((pa - pb).norm()).max((ra - rb).norm());
        let t = *t_a as f64 * 1e-9;
        let com_world: Vector3<f64> = pa + ra * Vector3::from(com);
        let expected: Vector3<f64> = c0 + v0 * t + g * (0.5 * t * t);
        worst_com = worst_com.max((com_world - expected).norm());
    }
    // Both runs solve the same rotational problem in differently ordered principal frames, so
    // they agree to accumulated round-off (measured 2.2e-15 over 1000 steps).
    assert!(worst_pose < 1e-12, "poses differ by {worst_pose:e}");
    // The symmetric potential makes the centre-of-mass update exact; only round-off remains
    // (measured 5.7e-14 m).
    assert!(
        worst_com < 1e-12,
        "centre of mass off the parabola by {worst_com:e} m"
    );
}

/// The scene `rpy` is `R = Rz(yaw) Ry(pitch) Rx(roll)` (fixed axes x, y, z), as in URDF.
#[test]
fn scene_rpy_is_rz_ry_rx() {
    let dir = tempfile::tempdir().unwrap();
    let rpy = [0.7, -0.3, 1.9];
    let urdf = one_link_urdf(
        [0.0; 3],
        [0.0; 3],
        1.0,
        &Matrix3::from_diagonal(&Vector3::new(1.0, 2.0, 2.5)),
    );
    let scene = scene_with(
        dir.path(),
        &urdf,
        &format!(
            "position = [0.5, -1.0, 2.0]\nrpy = [{}, {}, {}]",
            rpy[0], rpy[1], rpy[2]
        ),
        "duration = 0.0\ngravity = [0.0, 0.0, 0.0]",
    );
    let (_, frames) = common::reference_frames(&scene);
    let (p, r) = pose_matrix(&frames[0].1[0]);
    // Quaternion -> matrix round trip: a few ulps.
    assert!(
        (r - rz_ry_rx(rpy)).norm() < 1e-14,
        "{r} vs {}",
        rz_ry_rx(rpy)
    );
    assert!((p - Vector3::new(0.5, -1.0, 2.0)).norm() < 1e-15);
    // A point on the link's x axis ends up along the first column.
    let x_world = Point3::from(p) + r * Vector3::x();
    assert!((x_world.coords - p - rz_ry_rx(rpy).column(0)).norm() < 1e-14);
}

fn load_err(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        common::root().join("models/box.urdf"),
        dir.path().join("box.urdf"),
    )
    .unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, text).unwrap();
    let result = Scene::load(&path).and_then(|s| s.build().map(|_| ()));
    let message = format!("{:#}", result.expect_err("scene should be rejected"));
    assert!(
        message.contains("bad.toml"),
        "error does not name the file: {message}"
    );
    message
}

#[test]
fn scene_errors_name_file_and_key() {
    let model = "[[model]]\nurdf = \"box.urdf\"\n";
    let cases: &[(String, &[&str])] = &[
        (
            format!("[sim]\ndtt = 0.1\n{model}"),
            &["dtt", "unknown field"],
        ),
        (
            format!("[sim]\ndt = -0.1\n{model}"),
            &["sim.dt", "positive"],
        ),
        (format!("[sim]\ndt = nan\n{model}"), &["sim.dt"]),
        (
            format!("[sim]\nduration = -1.0\n{model}"),
            &["sim.duration"],
        ),
        (format!("[sim]\nlog_every = 0\n{model}"), &["sim.log_every"]),
        (
            format!("[sim]\nintegrator = \"rk99\"\n{model}"),
            &["sim.integrator", "rk99", "variational"],
        ),
        (
            format!("[sim]\ngravity = [0.0, 9.81]\n{model}"),
            &["gravity"],
        ),
        (
            format!("[sim]\ngravity = [0.0, inf, 0.0]\n{model}"),
            &["sim.gravity"],
        ),
        (
            format!("{model}angvel = [nan, 0.0, 0.0]\n"),
            &["model[0].angvel"],
        ),
        (format!("{model}colour = \"red\"\n"), &["colour"]),
        ("[sim]\ndt = 0.01\n".to_string(), &["no [[model]]"]),
        (
            "[[model]]\nurdf = \"missing.urdf\"\n".to_string(),
            &["missing.urdf"],
        ),
        (format!("{model}{model}"), &["frame id", "box", "name"]),
        (format!("{model}name = \"a/b\"\n"), &["model[0].name"]),
    ];
    for (text, needles) in cases {
        let message = load_err(text);
        for needle in *needles {
            assert!(
                message.contains(needle),
                "{needle:?} not in error {message:?} for scene:\n{text}"
            );
        }
    }
}

/// Every bundled scene loads, builds and conserves what a torque-free, gravity-free or uniform
/// gravity scene must conserve.
#[test]
fn bundled_scenes_build_and_conserve() {
    for name in ["default", "box", "t_handle", "arm"] {
        let path = common::root().join(format!("models/{name}.toml"));
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{name}: {e:#}"));
        let world = scene.build().unwrap_or_else(|e| panic!("{name}: {e:#}"));
        assert!(!world.bodies.is_empty());
        let integ = scene
            .integrator()
            .build(scene.sim.dt, &scene.variational_settings());
        let settings = tumble::sim::RunSettings {
            steps: scene.steps().min(2000),
            ..scene.run_settings()
        };
        let summary = common::run_world(&world, integ, &settings, Vec::new());
        // Torque-free about each centre of mass: angular momentum is conserved to round-off by
        // the variational scheme (measured at most 2.0e-14, the arm, over 2000 steps).
        assert!(
            summary.angmom_rel_change_max < 1e-12,
            "{name}: {}",
            summary.angmom_rel_change_max
        );
        // Energy error of a second-order symplectic scheme oscillates with amplitude
        // O((omega dt)^2) <= 4e-4 for omega dt <= 0.02 here, much less for nearly steady spins
        // (measured at most 1.8e-8, the T-handle, over 2000 steps).
        let rel =
            (summary.energy_final - summary.energy_initial).abs() / summary.energy_initial.abs();
        assert!(rel < 1e-6, "{name}: relative energy change {rel:e}");
        assert_eq!(summary.stats.newton_failures, 0, "{name}");
    }
}

/// In the default scene the T-handle, spun about its intermediate axis, flips: the
/// link's y axis turns over (Dzhanibekov effect).
#[test]
fn default_scene_t_handle_flips() {
    let scene = Scene::load(&common::root().join("models/default.toml")).unwrap();
    let (ids, frames) = common::reference_frames(&scene);
    let handle = ids.iter().position(|id| id == "t_handle").unwrap();
    let (_, r0) = pose_matrix(&frames[0].1[handle]);
    let y0 = r0.column(1).into_owned();
    // The handle's y axis starts along world y; the angular momentum stays along world y. A flip
    // turns the link's y axis to point against it.
    let min_dot = frames
        .iter()
        .map(|(_, poses)| pose_matrix(&poses[handle]).1.column(1).dot(&y0))
        .fold(f64::INFINITY, f64::min);
    // Measured -0.99999999957: a full flip.
    assert!(
        min_dot < -0.9,
        "the handle never flipped: min y.y0 = {min_dot}"
    );
}
