//! Whole-model bodies (`bodies = "rigid"`) and joint configurations (`joints`): the composite of
//! `models/arm.urdf` against an independent computation, a simulated rigid arm keeping its shape,
//! links and rigid modes placing every link frame alike, scene errors, and (interoperability)
//! the composite of real robots against Pinocchio's `ccrba`.

use crate::common;

use nalgebra::{Isometry3, Matrix3, Vector3};
use std::collections::BTreeMap;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_6};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use tumble::record::{Frame, Sink};
use tumble::scene::Scene;
use tumble::world::World;

// ---------------------------------------------------------------------------------------------
// An independent reading of models/arm.urdf: its numbers copied from the file (our own file, the
// derivations are in its header comment), rotations written out element by element, forward
// kinematics composed by hand. Nothing here calls tumble.
// ---------------------------------------------------------------------------------------------

fn rx(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

fn ry(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

fn rz(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// A rigid transform `x -> r x + p`.
#[derive(Clone, Copy)]
struct Pose {
    r: Matrix3<f64>,
    p: Vector3<f64>,
}

impl Pose {
    fn new(r: Matrix3<f64>, p: [f64; 3]) -> Self {
        Self {
            r,
            p: Vector3::from(p),
        }
    }
    fn rot(r: Matrix3<f64>) -> Self {
        Self::new(r, [0.0; 3])
    }
    fn then(&self, b: &Pose) -> Pose {
        Pose {
            r: self.r * b.r,
            p: self.r * b.p + self.p,
        }
    }
}

/// `(name, mass, com in the link frame, inertia about the com in link axes)`.
type Inertial = (&'static str, f64, [f64; 3], Matrix3<f64>);

/// The arm's joint origins and axes as written in models/arm.urdf:
/// shoulder: origin xyz (0, 0, 0.1), axis z;  elbow: origin xyz (0, 0, 0.3) rpy (0, 0, pi/2),
/// axis y;  wrist_mount (fixed): xyz (0.25, 0, 0) rpy (pi/2, 0, 0);  tool_mount (fixed):
/// xyz (0, 0, 0.08). Returns `model_from_link` of base, upper_arm, forearm, hand, tool0.
fn arm_link_poses(shoulder: f64, elbow: f64) -> Vec<(&'static str, Pose)> {
    // The file writes 1.5707963267948966, which parses to exactly FRAC_PI_2.
    let half_pi = FRAC_PI_2;
    let base = Pose::rot(Matrix3::identity());
    let upper_arm = base
        .then(&Pose::new(Matrix3::identity(), [0.0, 0.0, 0.1]))
        .then(&Pose::rot(rz(shoulder)));
    let forearm = upper_arm
        .then(&Pose::new(rz(half_pi), [0.0, 0.0, 0.3]))
        .then(&Pose::rot(ry(elbow)));
    let hand = forearm.then(&Pose::new(rx(half_pi), [0.25, 0.0, 0.0]));
    let tool0 = hand.then(&Pose::new(Matrix3::identity(), [0.0, 0.0, 0.08]));
    vec![
        ("base", base),
        ("upper_arm", upper_arm),
        ("forearm", forearm),
        ("hand", hand),
        ("tool0", tool0),
    ]
}

/// The arm's `<inertial>` elements (tool0 has none). Rotated inertial frames applied by hand:
/// forearm `Ry(pi/2) diag(...) Ry(pi/2)ᵀ`, hand `Rz(pi/6) diag(...) Rz(pi/6)ᵀ` (the file's
/// 1.5707963267948966 and 0.5235987755982988 parse to exactly FRAC_PI_2 and FRAC_PI_6).
fn arm_inertials() -> Vec<Inertial> {
    let rot = |r: Matrix3<f64>, d: [f64; 3]| {
        r * Matrix3::from_diagonal(&Vector3::from(d)) * r.transpose()
    };
    vec![
        (
            "base",
            2.0,
            [0.0, 0.0, 0.05],
            rot(
                Matrix3::identity(),
                [0.004866666666666667, 0.004866666666666667, 0.0064],
            ),
        ),
        (
            "upper_arm",
            1.5,
            [0.0, 0.0, 0.15],
            rot(Matrix3::identity(), [0.0115625, 0.0115625, 0.000625]),
        ),
        (
            "forearm",
            1.0,
            [0.125, 0.0, 0.0],
            rot(
                ry(FRAC_PI_2),
                [0.005433333333333333, 0.005433333333333333, 0.00045],
            ),
        ),
        (
            "hand",
            0.3,
            [0.0, 0.0, 0.04],
            rot(rz(FRAC_PI_6), [5e-05, 1.7e-04, 2e-04]),
        ),
    ]
}

/// Composite by the textbook formulas, in the model frame:
/// `m = Σ m_i`, `c = Σ m_i c_i / m` with `c_i = p_i + R_i com_i`,
/// `I = Σ R_i I_i R_iᵀ + m_i (|d_i|² E − d_i d_iᵀ)`, `d_i = c_i − c`.
fn arm_composite(shoulder: f64, elbow: f64) -> (f64, Vector3<f64>, Matrix3<f64>) {
    let poses: BTreeMap<_, _> = arm_link_poses(shoulder, elbow).into_iter().collect();
    let parts: Vec<(f64, Vector3<f64>, Matrix3<f64>)> = arm_inertials()
        .into_iter()
        .map(|(name, m, com, i)| {
            let pose = poses[name];
            (
                m,
                pose.p + pose.r * Vector3::from(com),
                pose.r * i * pose.r.transpose(),
            )
        })
        .collect();
    let mass: f64 = parts.iter().map(|p| p.0).sum();
    let com = parts
        .iter()
        .fold(Vector3::zeros(), |acc, (m, c, _)| acc + c * *m)
        / mass;
    let inertia = parts.iter().fold(Matrix3::zeros(), |acc, (m, c, i)| {
        let d = c - com;
        acc + i + (Matrix3::identity() * d.dot(&d) - d * d.transpose()) * *m
    });
    (mass, com, inertia)
}

// ---------------------------------------------------------------------------------------------
// Scenes and runs.
// ---------------------------------------------------------------------------------------------

/// A scene of models/arm.urdf (the scene "file" sits in models/, it is parsed from `text`).
fn arm_scene(model_keys: &str, sim: &str) -> anyhow::Result<Scene> {
    let text = format!("[sim]\n{sim}\n[[model]]\nurdf = \"arm.urdf\"\n{model_keys}\n");
    Scene::parse(&text, &common::root().join("models/rigid_test.toml"))
}

/// The composite the built world holds for its body `b`, in the world frame:
/// mass, centre of mass and `I = Q diag(moments) Qᵀ`.
fn body_composite(world: &World, b: usize) -> (f64, Vector3<f64>, Matrix3<f64>) {
    let body = &world.bodies[b];
    let q = body
        .world_from_body
        .rotation
        .to_rotation_matrix()
        .into_inner();
    let inertia = q * Matrix3::from_diagonal(&body.principal_moments) * q.transpose();
    (body.mass, body.world_from_body.translation.vector, inertia)
}

/// Everything a run records: link poses and the bodies' angular momenta per recorded frame.
#[derive(Default, Clone)]
struct Recorded {
    poses: Vec<Vec<Isometry3<f64>>>,
    angmom: Vec<Vec<Vector3<f64>>>,
}

struct MemorySink(Arc<Mutex<Recorded>>);

impl Sink for MemorySink {
    fn write(&mut self, frame: &Frame<'_>) -> anyhow::Result<()> {
        let mut r = self.0.lock().unwrap();
        r.poses.push(frame.world_from_link.to_vec());
        r.angmom
            .push(frame.bodies.iter().map(|b| b.angmom_world).collect());
        Ok(())
    }
    fn finish(self: Box<Self>) -> anyhow::Result<()> {
        Ok(())
    }
}

fn run(scene: &Scene) -> (World, Recorded, tumble::simulation::RunSummary) {
    let world = scene.build().unwrap_or_else(|e| panic!("{e:#}"));
    let recorded = Arc::new(Mutex::new(Recorded::default()));
    let sinks: Vec<Box<dyn Sink>> = vec![Box::new(MemorySink(recorded.clone()))];
    let integ = scene
        .integrator()
        .build(scene.sim.dt, &scene.variational_settings());
    let summary = common::run_world(&world, integ, &scene.run_settings(), sinks);
    let recorded = recorded.lock().unwrap().clone();
    (world, recorded, summary)
}

fn frame_ids(world: &World) -> Vec<String> {
    world
        .layout
        .frames
        .iter()
        .map(|f| f.frame_id.clone())
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Tests.
// ---------------------------------------------------------------------------------------------

/// The rigid body of the arm at shoulder = 0.7, elbow = -1.1 rad has the mass, centre of mass
/// and inertia of the independent computation above (four links with mass, two of them with
/// offset and rotated inertial frames, the massless tool0 contributing nothing).
#[test]
fn arm_composite_matches_an_independent_computation() {
    let (shoulder, elbow) = (0.7, -1.1);
    let scene = arm_scene(
        "bodies = \"rigid\"\njoints = { shoulder = 0.7, elbow = -1.1 }",
        "duration = 0.0\ngravity = [0.0, 0.0, 0.0]",
    )
    .unwrap();
    let world = scene.build().unwrap();
    assert_eq!(world.bodies.len(), 1);
    let (mass, com, inertia) = body_composite(&world, 0);
    let (mass_ref, com_ref, inertia_ref) = arm_composite(shoulder, elbow);
    assert_eq!(mass_ref, 4.8);
    // 2 + 1.5 + 1 + 0.3 summed in another order: measured 0 kg, bound 1e-14 kg.
    assert!((mass - mass_ref).abs() < 1e-14, "{mass} vs {mass_ref}");
    // Coordinates ~0.3 m: a few ulps of round-off. Measured 5.6e-17 m; bound 1e-15 m.
    let com_err = (com - com_ref).amax();
    assert!(com_err < 1e-15, "com {com} vs {com_ref}: {com_err:e}");
    // The body stores principal moments and axes; Q diag Qᵀ reproduces the tensor to the eigen
    // solver's accuracy, a few eps |I|. Measured 5.1e-16 relative to the largest entry (0.22
    // kg m²); bound 1e-14.
    let inertia_err = (inertia - inertia_ref).amax() / inertia_ref.amax();
    assert!(
        inertia_err < 1e-14,
        "inertia {inertia} vs {inertia_ref}: {inertia_err:e}"
    );
    // The configuration matters: at zero joints the composite is elsewhere.
    let (_, com_zero, _) = arm_composite(0.0, 0.0);
    let moved = (com_zero - com_ref).norm();
    assert!(moved > 0.01, "the centre of mass moved by {moved} m only");
    eprintln!(
        "arm composite: mass error {:e} kg, com error {com_err:e} m, inertia error {inertia_err:e} (relative)",
        (mass - mass_ref).abs()
    );
}

/// A rigid arm spun without gravity keeps its shape: the distances between link origins and the
/// relative orientations of the link frames stay those of t = 0 to round-off; the one body's
/// angular momentum is conserved. One body, one recorded frame per link (massless tool0
/// included), the body named after the model.
#[test]
fn rigid_arm_keeps_its_shape_and_momentum() {
    let scene = arm_scene(
        "bodies = \"rigid\"\njoints = { shoulder = 0.4, elbow = 0.9 }\n\
         position = [0.5, -0.2, 1.0]\nrpy = [0.3, -0.2, 1.0]\n\
         linvel = [0.1, 0.2, -0.3]\nangvel = [0.4, -1.5, 2.5]",
        "dt = 0.001\nduration = 3.0\ngravity = [0.0, 0.0, 0.0]\nlog_every = 10",
    )
    .unwrap();
    let (world, recorded, summary) = run(&scene);
    assert_eq!(world.bodies.len(), 1);
    assert_eq!(world.layout.bodies.len(), 1);
    assert_eq!(world.layout.bodies[0].name, "arm");
    assert_eq!(
        frame_ids(&world),
        ["base", "upper_arm", "forearm", "hand", "tool0"]
    );
    assert!(world.attachments.iter().all(|a| a.body == 0));
    assert_eq!(recorded.poses.len(), 301);
    assert_eq!(summary.stats.newton_failures, 0);

    let first = &recorded.poses[0];
    let n = first.len();
    let mut distance_err = 0.0_f64;
    let mut rotation_err = 0.0_f64;
    let mut turned = 0.0_f64;
    for poses in &recorded.poses {
        turned = turned.max(poses[0].rotation.angle_to(&first[0].rotation));
        for a in 0..n {
            for b in a + 1..n {
                let d0 = (first[a].translation.vector - first[b].translation.vector).norm();
                let d = (poses[a].translation.vector - poses[b].translation.vector).norm();
                distance_err = distance_err.max((d - d0).abs());
                let rel0 = first[a].rotation.inverse() * first[b].rotation;
                let rel = poses[a].rotation.inverse() * poses[b].rotation;
                rotation_err = rotation_err.max(rel.angle_to(&rel0));
            }
        }
    }
    // The body really turns (by up to pi over 3 s at |w| ~ 3 rad/s).
    assert!(turned > 1.0, "turned only {turned} rad");
    // All frames ride on one body through constant attachments: only the round-off of composing
    // poses (distances ~0.5 m, 1e-16 each) remains; the unit quaternion is renormalised each
    // step. Measured 3.9e-16 m and 8.5e-16 rad over 300 recorded frames; bounds 1e-13.
    assert!(
        distance_err < 1e-13,
        "distances drift by {distance_err:e} m"
    );
    assert!(
        rotation_err < 1e-13,
        "relative orientations drift by {rotation_err:e} rad"
    );
    // Torque-free: angular momentum about the centre of mass is conserved by the variational
    // scheme to round-off. Measured 6.5e-15 relative over 3000 steps; bound 1e-12.
    let l0 = recorded.angmom[0][0];
    let l_err = recorded
        .angmom
        .iter()
        .map(|l| (l[0] - l0).norm() / l0.norm())
        .fold(0.0, f64::max);
    assert!(l_err < 1e-12, "angular momentum changes by {l_err:e}");
    assert!(summary.angmom_rel_change_max < 1e-12);
    eprintln!(
        "rigid arm over 3 s: distance drift {distance_err:e} m, relative orientation drift \
         {rotation_err:e} rad, |dL|/|L| {l_err:e}, turned {turned:.3} rad"
    );

    // With a `name`, the body takes the name and frame ids are prefixed as in links mode.
    let named = arm_scene(
        "bodies = \"rigid\"\nname = \"left\"",
        "duration = 0.0\ngravity = [0.0, 0.0, 0.0]",
    )
    .unwrap()
    .build()
    .unwrap();
    assert_eq!(named.layout.bodies[0].name, "left");
    assert_eq!(named.layout.frames[0].frame_id, "left/base");
    assert_eq!(named.layout.frames[4].frame_id, "left/tool0");
}

/// Same joints and placement, `bodies = "links"` and `bodies = "rigid"`: at t = 0 every link
/// frame the two recordings share is at the same pose, and that pose is the independent forward
/// kinematics placed by the scene's position and rpy. (Links mode does not record the massless
/// tool0; rigid mode does.) So `joints` places the links in links mode too.
#[test]
fn links_and_rigid_modes_place_link_frames_alike() {
    let keys = "joints = { shoulder = -0.6, elbow = 1.3 }\n\
                position = [1.0, 2.0, 3.0]\nrpy = [0.1, 0.2, -0.7]\nangvel = [0.0, 0.0, 1.0]";
    let sim = "duration = 0.0\ngravity = [0.0, 0.0, -9.81]";
    let links = arm_scene(&format!("bodies = \"links\"\n{keys}"), sim).unwrap();
    let rigid = arm_scene(&format!("bodies = \"rigid\"\n{keys}"), sim).unwrap();
    let (links_world, links_rec, _) = run(&links);
    let (rigid_world, rigid_rec, _) = run(&rigid);
    assert_eq!(links_world.bodies.len(), 4);
    assert_eq!(rigid_world.bodies.len(), 1);
    let links_ids = frame_ids(&links_world);
    let rigid_ids = frame_ids(&rigid_world);
    assert_eq!(links_ids, ["base", "upper_arm", "forearm", "hand"]);
    assert_eq!(rigid_ids, ["base", "upper_arm", "forearm", "hand", "tool0"]);

    let world_from_model = Pose::new(rz(-0.7) * ry(0.2) * rx(0.1), [1.0, 2.0, 3.0]);
    let fk: BTreeMap<_, _> = arm_link_poses(-0.6, 1.3).into_iter().collect();
    let mut between_modes = 0.0_f64;
    let mut against_fk = 0.0_f64;
    let pose_err = |a: &Isometry3<f64>, r: &Matrix3<f64>, p: &Vector3<f64>| {
        let ra = a.rotation.to_rotation_matrix().into_inner();
        (ra - r).amax().max((a.translation.vector - p).amax())
    };
    for (j, id) in rigid_ids.iter().enumerate() {
        let rigid_pose = &rigid_rec.poses[0][j];
        let expected = world_from_model.then(&fk[id.as_str()]);
        against_fk = against_fk.max(pose_err(rigid_pose, &expected.r, &expected.p));
        if let Some(i) = links_ids.iter().position(|x| x == id) {
            let links_pose = &links_rec.poses[0][i];
            against_fk = against_fk.max(pose_err(links_pose, &expected.r, &expected.p));
            let r = rigid_pose.rotation.to_rotation_matrix().into_inner();
            between_modes =
                between_modes.max(pose_err(links_pose, &r, &rigid_pose.translation.vector));
        }
    }
    // Both go through their body's principal frame and back (link_from_principal and its
    // inverse, differently composed): round-off only. Measured 4.4e-16; bound 1e-14.
    assert!(between_modes < 1e-14, "modes differ by {between_modes:e}");
    // Against hand-composed kinematics (coordinates ~3 m): measured 7.8e-16; bound 1e-14.
    assert!(
        against_fk < 1e-14,
        "poses off the forward kinematics by {against_fk:e}"
    );
    eprintln!(
        "t = 0 link frames: links vs rigid {between_modes:e}, vs independent FK {against_fk:e}"
    );
}

/// A URDF written to `dir` with one `<link>` per `(name, mass, x)`: a 0.1 m cube at x (or no
/// `<inertial>` when the mass is 0), chained by fixed joints.
fn chain_urdf(dir: &Path, robot: &str, links: &[(&str, f64, f64)]) -> PathBuf {
    let mut xml = format!("<?xml version=\"1.0\"?>\n<robot name=\"{robot}\">\n");
    for (name, mass, _) in links {
        if *mass > 0.0 {
            let i = mass * 0.02 / 12.0;
            xml.push_str(&format!(
                "<link name=\"{name}\"><inertial><mass value=\"{mass:e}\"/>\
                 <inertia ixx=\"{i:e}\" ixy=\"0\" ixz=\"0\" iyy=\"{i:e}\" iyz=\"0\" izz=\"{i:e}\"/>\
                 </inertial></link>\n"
            ));
        } else {
            xml.push_str(&format!("<link name=\"{name}\"/>\n"));
        }
    }
    for w in links.windows(2) {
        xml.push_str(&format!(
            "<joint name=\"{}_{}\" type=\"fixed\"><parent link=\"{}\"/><child link=\"{}\"/>\
             <origin xyz=\"{:e} 0 0\"/></joint>\n",
            w[0].0,
            w[1].0,
            w[0].0,
            w[1].0,
            w[1].2 - w[0].2
        ));
    }
    xml.push_str("</robot>\n");
    let path = dir.join(format!("{robot}.urdf"));
    std::fs::write(&path, xml).unwrap();
    path
}

fn build_err(scene: anyhow::Result<Scene>) -> String {
    let message = match scene {
        Err(e) => format!("{e:#}"),
        Ok(s) => format!("{:#}", s.build().expect_err("the scene should be refused")),
    };
    assert!(
        message.contains("rigid_test.toml") || message.contains("scene.toml"),
        "error does not name the scene file: {message}"
    );
    message
}

fn assert_contains(message: &str, needles: &[&str]) {
    for needle in needles {
        assert!(message.contains(needle), "{needle:?} not in {message:?}");
    }
}

#[test]
fn joint_and_rigid_errors_name_file_model_and_cause() {
    let sim = "duration = 0.0";
    // A position that is not a number, in either mode.
    for mode in ["links", "rigid"] {
        let m = build_err(arm_scene(
            &format!("bodies = \"{mode}\"\njoints = {{ elbow = nan }}"),
            sim,
        ));
        assert_contains(&m, &["model[0].joints.elbow", "finite"]);
        let m = build_err(arm_scene(
            &format!("bodies = \"{mode}\"\njoints = {{ elbow = inf }}"),
            sim,
        ));
        assert_contains(&m, &["model[0].joints.elbow"]);
        // A joint the URDF does not have: scene file, model, URDF and joint named.
        let m = build_err(arm_scene(
            &format!("bodies = \"{mode}\"\njoints = {{ wrist = 0.3 }}"),
            sim,
        ));
        assert_contains(&m, &["model[0]", "arm.urdf", "wrist"]);
        // A fixed joint cannot be set.
        let m = build_err(arm_scene(
            &format!("bodies = \"{mode}\"\njoints = {{ wrist_mount = 0.3 }}"),
            sim,
        ));
        assert_contains(&m, &["model[0]", "wrist_mount", "fixed"]);
    }
    let m = build_err(arm_scene("bodies = \"solid\"", sim));
    assert_contains(&m, &["solid", "rigid"]);

    let dir = tempfile::tempdir().unwrap();
    let scene = |urdf: &Path, keys: &str| {
        let text = format!(
            "[sim]\n{sim}\n[[model]]\nurdf = \"{}\"\nbodies = \"rigid\"\n{keys}\n",
            urdf.display()
        );
        Scene::parse(&text, &dir.path().join("scene.toml"))
    };
    // No link with mass: nothing to simulate, in rigid mode as in links mode.
    let frames = chain_urdf(dir.path(), "frames", &[("a", 0.0, 0.0), ("b", 0.0, 1.0)]);
    let m = build_err(scene(&frames, ""));
    assert_contains(&m, &["model[0]", "frames.urdf", "nothing to simulate"]);
    // Every link fine, but the composite overflows: 1e300 kg at 1e5 m from the centre gives a
    // parallel-axis term of 1e310 kg m², beyond f64. The composite is refused, the model named.
    let huge = chain_urdf(dir.path(), "huge", &[("a", 1e300, 0.0), ("b", 1e300, 2e5)]);
    let m = build_err(scene(&huge, ""));
    assert_contains(&m, &["model[0]", "composite of model `huge`", "not finite"]);
    // Total mass overflowing to infinity.
    let heavy = chain_urdf(dir.path(), "heavy", &[("a", 1e308, 0.0), ("b", 1e308, 0.1)]);
    let m = build_err(scene(&heavy, "name = \"heavy_one\""));
    assert_contains(
        &m,
        &["model[0]", "composite of model `heavy_one`", "total mass"],
    );

    // Two rigid models whose bodies would share a name: one named "arm", the other unnamed
    // (robot "arm"); their frame ids differ ("arm/base" and "base"), their body names would not.
    let arm = common::root().join("models/arm.urdf");
    let text = format!(
        "[sim]\n{sim}\n[[model]]\nurdf = \"{0}\"\nbodies = \"rigid\"\nname = \"arm\"\n\
         [[model]]\nurdf = \"{0}\"\nbodies = \"rigid\"\n",
        arm.display()
    );
    let m = build_err(Scene::parse(&text, &dir.path().join("scene.toml")));
    assert_contains(&m, &["model[1]", "body name \"arm\""]);
}

/// A base with 1e-3 kg m² moments and, fixed to it, a part whose moments are `head`.
fn part_urdf(dir: &Path, robot: &str, head: [f64; 3]) -> PathBuf {
    let [a, b, c] = head;
    let xml = format!(
        "<?xml version=\"1.0\"?>\n<robot name=\"{robot}\">\n\
         <link name=\"base\"><inertial><mass value=\"1\"/>\
         <inertia ixx=\"1e-3\" ixy=\"0\" ixz=\"0\" iyy=\"1e-3\" iyz=\"0\" izz=\"1e-3\"/>\
         </inertial></link>\n\
         <link name=\"head\"><inertial><mass value=\"0.1\"/>\
         <inertia ixx=\"{a:e}\" ixy=\"0\" ixz=\"0\" iyy=\"{b:e}\" iyz=\"0\" izz=\"{c:e}\"/>\
         </inertial></link>\n\
         <joint name=\"neck\" type=\"fixed\"><parent link=\"base\"/><child link=\"head\"/>\
         <origin xyz=\"0 0 0.1\"/></joint>\n</robot>\n"
    );
    let path = dir.join(format!("{robot}.urdf"));
    std::fs::write(&path, xml).unwrap();
    path
}

/// A part's inertia is judged to round-off of the model's scale: iCub's `head` (principal
/// moments -2.4e-35, 0, 2.4e-35 kg m², zero to round-off) next to a 1e-3 kg m² link loads in
/// rigid and articulated modes (it was refused as "not positive semi-definite"); a real defect
/// (a moment of -1e-4 kg m²) is refused with the keys that accept it, and accepted with them.
#[test]
fn part_inertia_is_judged_to_the_models_round_off() {
    let dir = tempfile::tempdir().unwrap();
    let scene = |urdf: &Path, mode: &str, keys: &str| {
        let text = format!(
            "[sim]\nduration = 0.0\n[[model]]\nurdf = \"{}\"\nbodies = \"{mode}\"\n{keys}\n",
            urdf.display()
        );
        Scene::parse(&text, &dir.path().join("scene.toml"))
    };
    let round_off = part_urdf(dir.path(), "round_off", [-2.4e-35, 0.0, 2.4e-35]);
    for mode in ["rigid", "articulated"] {
        let world = scene(&round_off, mode, "").unwrap().build();
        assert!(world.is_ok(), "{mode}: {:#}", world.err().unwrap());
    }
    let negative = part_urdf(dir.path(), "negative", [-1e-4, 1e-3, 1e-3]);
    for mode in ["rigid", "articulated"] {
        let m = build_err(scene(&negative, mode, ""));
        assert_contains(
            &m,
            &[
                "negative.urdf",
                "head",
                "not positive semi-definite",
                "allow_non_physical_inertia = true",
                "--allow-non-physical-inertia",
            ],
        );
        // With the opt-in the composite (positive definite: the base's 1e-3 and the part's
        // offset outweigh -1e-4) is simulated.
        let world = scene(&negative, mode, "allow_non_physical_inertia = true")
            .unwrap()
            .build();
        assert!(world.is_ok(), "{mode}: {:#}", world.err().unwrap());
    }
}

// ---------------------------------------------------------------------------------------------
// Interoperability: Pinocchio's composite rigid-body inertia of real robots.
// ---------------------------------------------------------------------------------------------

fn json_vec3(v: &serde_json::Value) -> Vector3<f64> {
    Vector3::from_iterator(v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()))
}

fn json_mat3(v: &serde_json::Value) -> Matrix3<f64> {
    let rows: Vec<Vector3<f64>> = v.as_array().unwrap().iter().map(json_vec3).collect();
    Matrix3::from_rows(&[
        rows[0].transpose(),
        rows[1].transpose(),
        rows[2].transpose(),
    ])
}

/// tumble's rigid composite of example-robot-data robots (model frame = root link frame) against
/// Pinocchio's `ccrba` (`data.Ig`: centroidal inertia in world axes, with the free-flyer at the
/// identity so that world = root link frame; see tests/py/pin_composite.py for why not the
/// fixed-base build), at the zero configuration and at one with every joint moved. Pinocchio
/// reads the same URDF numbers and composes in another order (and merges links on fixed
/// joints first), so only round-off separates the two.
#[test]
fn composite_matches_pinocchio_ccrba_on_real_robots() {
    let robots = [
        "ur_description/urdf/ur5_robot.urdf",
        "panda_description/urdf/panda.urdf",
        "solo_description/robots/solo12.urdf",
        "pr2_description/urdf/pr2.urdf",
        "romeo_description/urdf/romeo.urdf",
        "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf",
    ];
    let dir = tempfile::tempdir().unwrap();
    let mut worst = (0.0_f64, 0.0_f64, 0.0_f64);
    for robot in robots {
        for config in ["zero", "nonzero"] {
            let pin = common::run_py("pin_composite.py", &[Path::new(robot), Path::new(config)]);
            let joints: BTreeMap<String, f64> =
                serde_json::from_value(pin["joints"].clone()).unwrap();
            if config == "nonzero" {
                assert!(!joints.is_empty(), "{robot}: no joint moved");
            }
            let joints_toml: Vec<String> = joints
                .iter()
                .map(|(name, q)| format!("{name:?} = {q:?}"))
                .collect();
            let text = format!(
                "[sim]\nduration = 0.0\n[[model]]\nurdf = {:?}\nbodies = \"rigid\"\n\
                 allow_non_physical_inertia = true\njoints = {{ {} }}\n",
                pin["urdf"].as_str().unwrap(),
                joints_toml.join(", ")
            );
            let scene = Scene::parse(&text, &dir.path().join("scene.toml")).unwrap();
            let world = scene
                .build()
                .unwrap_or_else(|e| panic!("{robot} {config}: {e:#}"));
            let (mass, com, inertia) = body_composite(&world, 0);
            let mass_pin = pin["mass"].as_f64().unwrap();
            let com_pin = json_vec3(&pin["com"]);
            let inertia_pin = json_mat3(&pin["inertia"]);
            assert_eq!(json_vec3(&pin["lever"]), Vector3::zeros());
            let mass_err = (mass - mass_pin).abs() / mass_pin;
            let com_err = (com - com_pin).amax();
            let inertia_err = (inertia - inertia_pin).amax() / inertia_pin.amax();
            eprintln!(
                "{robot:40} {config:8} links {:3} mass {mass:10.6} kg (rel err {mass_err:.1e})  \
                 com err {com_err:.1e} m  inertia rel err {inertia_err:.1e}  \
                 (Pinocchio fixed-base total {:.6} + universe {:.6})",
                world.layout.frames.len(),
                pin["fixed_base_mass"].as_f64().unwrap(),
                pin["universe_mass"].as_f64().unwrap(),
            );
            // Sums of up to 82 masses in another order: a few ulps. Measured at most 8.8e-16
            // (pr2); bound 1e-13.
            assert!(
                mass_err < 1e-13,
                "{robot} {config}: mass {mass} vs {mass_pin}"
            );
            // Robot-sized coordinates (~1 m) through two different kinematic chains (Pinocchio
            // builds its rotations from rpy itself): measured at most 3.3e-16 m (pr2); bound
            // 1e-12 m.
            assert!(com_err < 1e-12, "{robot} {config}: com {com} vs {com_pin}");
            // Parallel-axis sums plus the eigen round trip of the body's principal frame:
            // measured at most 1.3e-15 of the largest entry (panda); bound 1e-12.
            assert!(
                inertia_err < 1e-12,
                "{robot} {config}: inertia\n{inertia}\nvs Pinocchio\n{inertia_pin}"
            );
            worst = (
                worst.0.max(mass_err),
                worst.1.max(com_err),
                worst.2.max(inertia_err),
            );
        }
    }
    eprintln!(
        "worst: mass {:.1e} (rel), com {:.1e} m, inertia {:.1e} (rel)",
        worst.0, worst.1, worst.2
    );
}

/// A moving link with mass and zero inertia (iCub's `r_hip_1`: 0.754 kg, every moment 0) is a
/// body the articulated step cannot turn: refused, naming the link and the keys that run it
/// anyway (its mass properties from its geometry).
#[test]
fn a_point_mass_body_is_refused_with_the_keys_that_run_it() {
    let dir = tempfile::tempdir().unwrap();
    let xml = "<?xml version=\"1.0\"?>\n<robot name=\"hip\">\n\
         <link name=\"pelvis\"><inertial><mass value=\"1\"/>\
         <inertia ixx=\"1e-3\" ixy=\"0\" ixz=\"0\" iyy=\"1e-3\" iyz=\"0\" izz=\"1e-3\"/>\
         </inertial></link>\n\
         <link name=\"r_hip_1\"><inertial><mass value=\"0.754\"/>\
         <inertia ixx=\"0\" ixy=\"0\" ixz=\"0\" iyy=\"0\" iyz=\"0\" izz=\"0\"/>\
         </inertial><collision><geometry><box size=\"0.05 0.05 0.1\"/></geometry></collision></link>\n\
         <joint name=\"r_hip_pitch\" type=\"revolute\"><parent link=\"pelvis\"/><child link=\"r_hip_1\"/>\
         <axis xyz=\"0 1 0\"/><limit lower=\"-1\" upper=\"1\" effort=\"10\" velocity=\"1\"/></joint>\n</robot>\n";
    let urdf = dir.path().join("hip.urdf");
    std::fs::write(&urdf, xml).unwrap();
    let scene = |keys: &str| {
        let text = format!(
            "[sim]\nduration = 0.0\n[[model]]\nurdf = \"{}\"\nbodies = \"articulated\"\n{keys}\n",
            urdf.display()
        );
        Scene::parse(&text, &dir.path().join("scene.toml"))
    };
    let m = build_err(scene(""));
    assert_contains(
        &m,
        &[
            "hip.urdf",
            "r_hip_1",
            "not positive definite",
            "links = { r_hip_1 = { inertia = \"geometry\" } }",
            "--inertia geometry",
        ],
    );
    // The key it names runs it: the box gives the link its moments.
    let world = scene("links = { r_hip_1 = { inertia = \"geometry\" } }")
        .unwrap()
        .build();
    assert!(world.is_ok(), "{:#}", world.err().unwrap());
}
